// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Parts of a cloud sampled on a coarser scale than the rest (a separate object scanned sparsely): where the
// robust kernel widths (kernel_width.hpp) and the intrinsic rule's tolerance (intrinsic.hpp) take their own scale.

#include <algorithm>
#include <vector>

namespace iires::detail {

/// A cloud's median and 90th percentile of the nearest-neighbour distance.
struct SpacingQuantiles {
  double typical = 0;
  double sparsest = 0;
};

inline SpacingQuantiles spacingQuantiles(std::vector<double> nearest) {
  SpacingQuantiles q;
  if (nearest.empty()) return q;
  const auto median = nearest.begin() + static_cast<long>(nearest.size() / 2);
  const auto tenth = nearest.begin() + static_cast<long>(std::min(nearest.size() - 1, 9 * nearest.size() / 10));
  std::nth_element(nearest.begin(), tenth, nearest.end());
  q.sparsest = *tenth;
  std::nth_element(nearest.begin(), median, tenth);
  q.typical = *median;
  return q;
}

/// 1, or — where the median nearest-neighbour distance of a point's neighbourhood (@p around, the point and its
/// nearest points; reordered) exceeds twice the cloud's 90th percentile, beyond a random sampling's own
/// variation — its ratio to the cloud's median: how much coarser than the rest the part is sampled.
inline double samplingScale(std::vector<double>& around, const SpacingQuantiles& q) {
  if (around.empty() || !(q.typical > 0)) return 1.0;
  const auto mid = around.begin() + static_cast<long>(around.size() / 2);
  std::nth_element(around.begin(), mid, around.end());
  return *mid > 2.0 * q.sparsest ? *mid / q.typical : 1.0;
}

}  // namespace iires::detail
