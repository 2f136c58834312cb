// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file tile_grid.hpp
/// @brief TileGrid (internal): the cubic tiles of out-of-core resampling (DESIGN §9), their overlap margins,
/// colours and processing order.

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numeric>
#include <vector>

namespace iires::detail {

/// A grid of cubic tiles of edge `size` from `origin`, dims[a] tiles along axis a. The outer tiles reach to
/// infinity on their outer sides (every point has a tile). Tile t's region is its core plus `margin` on every
/// side that has a neighbour; margin < size, so a region meets only the 3×3×3 block around its tile.
struct TileGrid {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double size = 1, margin = 0;
  std::array<int, 3> dims{1, 1, 1};

  std::size_t count() const { return static_cast<std::size_t>(dims[0]) * dims[1] * dims[2]; }
  std::size_t index(const std::array<int, 3>& c) const {
    return (static_cast<std::size_t>(c[2]) * dims[1] + c[1]) * dims[0] + c[0];
  }
  std::array<int, 3> cell(std::size_t t) const {
    return {static_cast<int>(t % dims[0]), static_cast<int>(t / dims[0] % dims[1]),
            static_cast<int>(t / dims[0] / dims[1])};
  }
  int axisCell(const Eigen::Vector3d& p, int a) const {
    const double c = std::floor((p[a] - origin[a]) / size);
    return static_cast<int>(std::clamp(c, 0.0, static_cast<double>(dims[a] - 1)));
  }
  /// The tile whose core holds @p p.
  std::size_t tileOf(const Eigen::Vector3d& p) const {
    return index({axisCell(p, 0), axisCell(p, 1), axisCell(p, 2)});
  }
  /// Whether @p p lies in tile @p t's core plus margin.
  bool inRegion(std::size_t t, const Eigen::Vector3d& p) const {
    const std::array<int, 3> c = cell(t);
    for (int a = 0; a < 3; ++a) {
      const double lo = c[a] == 0 ? -std::numeric_limits<double>::infinity() : origin[a] + c[a] * size - margin;
      const double hi = c[a] == dims[a] - 1 ? std::numeric_limits<double>::infinity()
                                            : origin[a] + (c[a] + 1) * size + margin;
      if (!(p[a] >= lo && p[a] < hi)) return false;
    }
    return true;
  }
  /// Calls @p f(t) for every tile whose region holds @p p (its own tile first).
  template <class F>
  void forEachRegion(const Eigen::Vector3d& p, F&& f) const {
    const std::size_t own = tileOf(p);
    f(own);
    forEachNeighbour(own, [&](std::size_t t) {
      if (inRegion(t, p)) f(t);
    });
  }
  /// Calls @p f(t) for the (up to 26) tiles adjacent to @p t, in index order.
  template <class F>
  void forEachNeighbour(std::size_t t, F&& f) const {
    const std::array<int, 3> c = cell(t);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const std::array<int, 3> n{c[0] + dx, c[1] + dy, c[2] + dz};
          if ((dx || dy || dz) && n[0] >= 0 && n[1] >= 0 && n[2] >= 0 && n[0] < dims[0] && n[1] < dims[1] &&
              n[2] < dims[2])
            f(index(n));
        }
  }
  /// Adjacent tiles never share a colour: 4 colours on a one-layer grid, 8 in 3-D.
  int colour(std::size_t t) const {
    const std::array<int, 3> c = cell(t);
    return (c[0] & 1) | (c[1] & 1) << 1 | (c[2] & 1) << 2;
  }
  /// Tiles by (colour, index): the processing order.
  std::vector<std::size_t> order() const {
    std::vector<std::size_t> o(count());
    std::iota(o.begin(), o.end(), std::size_t{0});
    std::stable_sort(o.begin(), o.end(), [&](std::size_t a, std::size_t b) { return colour(a) < colour(b); });
    return o;
  }
};

}  // namespace iires::detail
