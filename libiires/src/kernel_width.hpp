// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Robust kernel widths for the MLS surface and the denoiser (DESIGN §3.3).

#include <algorithm>
#include <cstdint>
#include <vector>

#include "iires/detail/parallel.hpp"
#include "sampling_scale.hpp"

namespace iires::detail {

/// Kernel widths @p h cut at @p cap (a high quantile of them), the cap scaled by the samplingScale() of the
/// point's neighbourhood (from the nearest-neighbour distances @p nearest). A lone outlier (its neighbours are
/// ordinary points), a point on an open boundary (its nearest neighbours are as near as anywhere) and every
/// point of a cloud sampled on one scale are cut to the cap, as with the quantile alone; a part sampled sparsely
/// — a separate object with under a tenth of the points, which the quantile alone gives the dense part's width,
/// too narrow to reach its neighbours — keeps a width of its own scale. @p neighbours(i, out) fills @p out with
/// point i's nearest points; it is called only for the widths over the cap. Deterministic (reads the old widths
/// only).
template <typename Neighbours>
void clampWidths(std::vector<double>& h, const std::vector<double>& nearest, double cap, Neighbours&& neighbours,
                 int threads) {
  const SpacingQuantiles q = spacingQuantiles(nearest);
  std::vector<double> out(h);
  parallelFor(h.size(), threads, [&](std::size_t i) {
    if (!(h[i] > cap)) return;
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> around;
    idx.clear();
    neighbours(i, idx);
    around.assign(1, nearest[i]);
    for (std::uint32_t j : idx)
      if (j != i) around.push_back(nearest[j]);
    out[i] = std::min(h[i], samplingScale(around, q) * cap);
  });
  h = std::move(out);
}

}  // namespace iires::detail
