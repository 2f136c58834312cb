// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Which samples to drop when a set holds too many: the most crowded first.
#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace iires::detail {

/// Per point of @p points, 1 for the @p excess to drop: those nearest another point first, sparing the partner
/// of each pair dropped (one of each close pair goes), then, while too many remain, the next most crowded
/// whatever their partners. Points with @p held set are never dropped but count as neighbours. Deterministic.
std::vector<char> mostCrowded(const std::vector<Eigen::Vector3d>& points, const std::vector<char>& held,
                              std::size_t excess);

}  // namespace iires::detail
