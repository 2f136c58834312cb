// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_layers.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>

#include "iires/detail/parallel.hpp"
#include "layers.hpp"

namespace iires::detail {
namespace {

constexpr int kAxisRounds = 4;               // refinements of a block's axis (two-plane fit) from each start
constexpr std::size_t kBlockPoints = 48;     // a block's points read by the test: at most this many, strided
/// Two sheets across a block each cross it and hold a comparable share of its points; a few at its edge where
/// one curved sheet turns off the plane (a tail of the heights) are no second sheet.
constexpr double kMinLayerShare = 0.25;
constexpr double kSameAxisCos = 0.99999;     // a refinement that turns the axis by less has converged

/// Sum of (p − mean)(p − mean)ᵀ over @p count points from @p p, and their mean.
Eigen::Matrix3d scatter(const Eigen::Vector3d* p, std::size_t count, Eigen::Vector3d& mean) {
  mean.setZero();
  for (std::size_t a = 0; a < count; ++a) mean += p[a];
  mean /= static_cast<double>(count);
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  for (std::size_t a = 0; a < count; ++a) s.noalias() += (p[a] - mean) * (p[a] - mean).transpose();
  return s;
}

Eigen::Vector3d thinnest(const Eigen::Matrix3d& s) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(s);
  return eig.eigenvectors().col(0);
}

/// A cell's points: count, mean and scatter about the mean.
struct CellMoments {
  std::size_t count = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
};

/// Whether the block's points @p block form two layers (layers.hpp) along some axis. Two parallel sheets tilt a
/// block's principal axes wherever one sheet holds more points on one side, so the axis is fitted as two
/// planes: from a start axis, the heights split at their widest empty band and the axis becomes the thinnest
/// direction of the two parts' pooled scatter (each about its own mean), until it settles. Starts: the block's
/// thinnest direction (right where the gap is narrow against the block) and that of its cells' pooled scatter
/// (right where the cells hold one sheet each: a gap about a cell wide). @p block is reordered.
bool blockHasTwoLayers(std::vector<Eigen::Vector3d>& block, const Eigen::Vector3d& mean,
                       const Eigen::Vector3d& blockAxis, const Eigen::Vector3d& cellsAxis, double gap, double spacing) {
  const std::size_t m = block.size();
  thread_local std::vector<std::pair<double, std::uint32_t>> byHeight;
  thread_local std::vector<double> heights;
  thread_local std::vector<Eigen::Vector3d> sorted;
  for (const Eigen::Vector3d& start : {blockAxis, cellsAxis}) {
    Eigen::Vector3d axis = start;
    for (int round = 0; round < kAxisRounds; ++round) {
      byHeight.clear();
      double low = 0, high = 0;
      for (std::size_t a = 0; a < m; ++a) {
        const double h = axis.dot(block[a] - mean);
        byHeight.push_back({h, static_cast<std::uint32_t>(a)});
        low = std::min(low, h), high = std::max(high, h);
      }
      if (high - low < gap) break;  // two layers a gap apart span at least the gap
      std::sort(byHeight.begin(), byHeight.end());
      heights.clear();
      for (const auto& [h, a] : byHeight) heights.push_back(h);
      std::size_t cut = kLayerPoints;  // the widest band, as twoLayers cuts
      for (std::size_t x = kLayerPoints + 1; x + kLayerPoints <= m; ++x)
        if (heights[x] - heights[x - 1] > heights[cut] - heights[cut - 1]) cut = x;
      if (twoLayers(heights.data(), m, gap, spacing) && std::min(cut, m - cut) >= kMinLayerShare * static_cast<double>(m))
        return true;
      sorted.clear();
      for (const auto& [h, a] : byHeight) sorted.push_back(block[a]);
      block.swap(sorted);
      Eigen::Vector3d lowMean, highMean;
      const Eigen::Vector3d next =
          thinnest(scatter(block.data(), cut, lowMean) + scatter(block.data() + cut, m - cut, highMean));
      if (std::abs(next.dot(axis)) >= kSameAxisCos) break;
      axis = next;
    }
  }
  return false;
}

}  // namespace

std::vector<char> twoSheetCells(const std::vector<Eigen::Vector3d>& pts, const std::vector<KeyedIndex>& byCell,
                                const std::vector<std::size_t>& runs, const Eigen::Vector3d& lo,
                                const Eigen::Vector3d& shift, double cell, double gap, double spacing, int threads) {
  // Spatial cells: the runs of one cell (its normal classes) are consecutive in byCell; their points are copied
  // in that order (the blocks then read them contiguously).
  const std::size_t cells = runs.size() - 1, n = byCell.size();
  std::vector<std::size_t> first;  // per spatial cell its first run; then the run count
  std::vector<std::size_t> spatialOf(cells);
  for (std::size_t c = 0; c < cells; ++c) {
    if (c == 0 || byCell[runs[c]].first / 8 != byCell[runs[c - 1]].first / 8) first.push_back(c);
    spatialOf[c] = first.size() - 1;
  }
  const std::size_t spatial = first.size();
  first.push_back(cells);
  std::vector<Eigen::Vector3d> ordered(n);
  parallelFor(n, threads, [&](std::size_t x) { ordered[x] = pts[byCell[x].second]; });
  auto begin = [&](std::size_t s) { return runs[first[s]]; };
  auto end = [&](std::size_t s) { return runs[first[s + 1]]; };
  // Cells by grid coordinates, z fastest: a column's three cells (z − 1, z, z + 1) are consecutive.
  constexpr std::uint64_t kMask = (1ull << 21) - 1;
  auto code = [&](const Eigen::Vector3i& g) {
    return ((static_cast<std::uint64_t>(g.x()) & kMask) << 42) | ((static_cast<std::uint64_t>(g.y()) & kMask) << 21) |
           (static_cast<std::uint64_t>(g.z()) & kMask);
  };
  std::vector<Eigen::Vector3i> grid(spatial);
  std::vector<CellMoments> moments(spatial);
  std::vector<std::pair<std::uint64_t, std::uint32_t>> byCode(spatial);
  std::vector<std::uint64_t> codes(spatial);
  parallelFor(spatial, threads, [&](std::size_t s) {
    const Eigen::Vector3d q = (ordered[begin(s)] - lo) / cell + shift;
    grid[s] = Eigen::Vector3i(static_cast<int>(q.x()), static_cast<int>(q.y()), static_cast<int>(q.z()));
    byCode[s] = {code(grid[s]), static_cast<std::uint32_t>(s)};
    moments[s].count = end(s) - begin(s);
    moments[s].scatter = scatter(ordered.data() + begin(s), moments[s].count, moments[s].mean);
  });
  std::sort(byCode.begin(), byCode.end());
  for (std::size_t x = 0; x < spatial; ++x) codes[x] = byCode[x].first;
  // Blocks: 3 × 3 × 3 cells about the points of a lattice of every other cell, each cell in the block about its
  // nearest lattice point (and those on a block's face in two): every cell lies inside a block whose points
  // reach a cell beyond it on every side.
  auto home = [](int g) { return 2 * ((g + 1) / 2); };
  std::vector<std::uint64_t> centres(spatial);
  for (std::size_t s = 0; s < spatial; ++s) centres[s] = code(Eigen::Vector3i(home(grid[s].x()), home(grid[s].y()), home(grid[s].z())));
  std::sort(centres.begin(), centres.end());
  centres.erase(std::unique(centres.begin(), centres.end()), centres.end());
  auto decode = [](std::uint64_t c) {
    return Eigen::Vector3i(static_cast<int>(c >> 42), static_cast<int>((c >> 21) & ((1u << 21) - 1)),
                           static_cast<int>(c & ((1u << 21) - 1)));
  };
  auto cellsOfBlock = [&](const Eigen::Vector3i& centre, std::array<std::uint32_t, 27>& around) {
    std::size_t count = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy) {
        const Eigen::Vector3i column = centre + Eigen::Vector3i(dx, dy, -1);
        if (column.x() < 0 || column.y() < 0) continue;
        const std::uint64_t last = code(column + Eigen::Vector3i(0, 0, 2));
        for (auto x = static_cast<std::size_t>(std::lower_bound(codes.begin(), codes.end(), code(column.cwiseMax(0))) -
                                               codes.begin());
             x < spatial && codes[x] <= last; ++x) {
          const std::uint32_t c = byCode[x].second;
          if ((grid[c] - centre).cwiseAbs().maxCoeff() <= 1) around[count++] = c;  // (past the code's range: not)
        }
      }
    return count;
  };
  std::vector<char> positive(centres.size(), 0);
  parallelFor(centres.size(), threads, [&](std::size_t b) {
    std::array<std::uint32_t, 27> around;
    const std::size_t count = cellsOfBlock(decode(centres[b]), around);
    std::size_t points = 0;
    for (std::size_t a = 0; a < count; ++a) points += moments[around[a]].count;
    if (points < 2 * kLayerPoints) return;
    // The block's mean and scatter from its cells' moments; the cells' pooled scatter.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t a = 0; a < count; ++a) mean += static_cast<double>(moments[around[a]].count) * moments[around[a]].mean;
    mean /= static_cast<double>(points);
    Eigen::Matrix3d pooled = Eigen::Matrix3d::Zero(), all = Eigen::Matrix3d::Zero();
    for (std::size_t a = 0; a < count; ++a) {
      const CellMoments& c = moments[around[a]];
      pooled += c.scatter;
      all.noalias() += static_cast<double>(c.count) * (c.mean - mean) * (c.mean - mean).transpose();
    }
    all += pooled;
    thread_local std::vector<Eigen::Vector3d> block;
    block.clear();
    const std::size_t stride = (points + kBlockPoints - 1) / kBlockPoints;  // every stride-th point of the block
    std::size_t seen = 0;
    for (std::size_t a = 0; a < count; ++a)
      for (std::size_t x = begin(around[a]); x < end(around[a]); ++x, ++seen)
        if (seen % stride == 0) block.push_back(ordered[x]);
    positive[b] = block.size() >= 2 * kLayerPoints &&
                  blockHasTwoLayers(block, mean, thinnest(all), thinnest(pooled), gap, spacing);
  });
  std::vector<char> layered(spatial, 0);
  for (std::size_t b = 0; b < centres.size(); ++b) {
    if (!positive[b]) continue;
    std::array<std::uint32_t, 27> around;
    const std::size_t count = cellsOfBlock(decode(centres[b]), around);
    for (std::size_t a = 0; a < count; ++a) layered[around[a]] = 1;
  }
  std::vector<char> out(cells);
  for (std::size_t c = 0; c < cells; ++c) out[c] = layered[spatialOf[c]];
  return out;
}

}  // namespace iires::detail
