// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file layers.hpp
/// @brief The layer test of the sheet rule (sheets.hpp): whether a set of heights off a plane holds two sheets.
/// The sheet rule reads it on a point's neighbour row; voxel thinning on the points around a cell, so that the
/// cloud it leaves still resolves every gap the rule resolves on the input.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>

namespace iires::detail {

constexpr std::size_t kLayerPoints = 3;  ///< a second sheet: at least this many heights across the gap
constexpr double kLayerSpread = 0.5;     ///< a layer: heights' standard deviation under this × the spacing
constexpr double kBandPerNoise = 2.0;    ///< the empty band between two layers: wider than this × their spread

/// Whether the sorted heights @p h[0, m) form two layers: cut at their widest empty band (at least kLayerPoints
/// heights on either side), the layers' mean heights lie at least @p gap apart, each layer is thin (its heights'
/// standard deviation within kLayerSpread × @p spacing: a sheet's own noise) and the band is empty over more
/// than kBandPerNoise × that spread. One sheet has no such band: noise fills the heights continuously, and noise
/// thick enough to leave a band between its tail and its bulk makes the bulk too thick to be a layer.
inline bool twoLayers(const double* h, std::size_t m, double gap, double spacing) {
  if (m < 2 * kLayerPoints) return false;
  std::size_t cut = kLayerPoints;  // the upper layer starts at h[cut]
  for (std::size_t x = kLayerPoints + 1; x + kLayerPoints <= m; ++x)
    if (h[x] - h[x - 1] > h[cut] - h[cut - 1]) cut = x;
  auto moments = [&](std::size_t begin, std::size_t end) {  // mean and standard deviation of h[begin, end)
    double sum = 0, sum2 = 0;
    for (std::size_t a = begin; a < end; ++a) sum += h[a], sum2 += h[a] * h[a];
    const double count = static_cast<double>(end - begin), mean = sum / count;
    return std::pair{mean, std::sqrt(std::max(0.0, sum2 / count - mean * mean))};
  };
  const auto [lowMean, lowSpread] = moments(0, cut);
  const auto [highMean, highSpread] = moments(cut, m);
  const double spread = std::max(lowSpread, highSpread);
  return highMean - lowMean >= gap && spread <= kLayerSpread * spacing && h[cut] - h[cut - 1] > kBandPerNoise * spread;
}

}  // namespace iires::detail
