// SPDX-License-Identifier: GPL-3.0-or-later
#include "voxel_thin.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "iires/detail/parallel.hpp"
#include "iires/mls.hpp"
#include "iires/resample.hpp"
#include "iires/detail/radix_sort.hpp"
#include "cell_layers.hpp"
#include "resampler.hpp"

namespace iires::detail {
namespace {
constexpr double kCellSheetHeight = 1.25;  // voxel cells: another sheet lies this × the sheet height off a plane
}  // namespace

std::vector<std::uint32_t> voxelThin(const std::vector<Eigen::Vector3d>& pts, const std::vector<Eigen::Vector3d>& normals,
                                     std::size_t target, double cell, std::uint64_t seed, int threads,
                                     double sheetHeight, double layerGap) {
  Eigen::Vector3d lo = pts[0], hi = pts[0];
  for (const auto& p : pts) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  // A seed shifts the grid by a fraction of a cell in each axis (seed 0: no shift).
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  for (int a = 0; seed && a < 3; ++a) {
    std::uint64_t z = seed + 0x9e3779b97f4a7c15ull * static_cast<std::uint64_t>(a + 1);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    shift[a] = static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  }
  const std::size_t n = pts.size();
  auto normalClass = [&](std::size_t i) -> std::uint64_t {
    if (normals.empty()) return 0;
    Eigen::Index axis;
    normals[i].cwiseAbs().maxCoeff(&axis);
    return static_cast<std::uint64_t>(2 * axis + (normals[i][axis] < 0 ? 1 : 0));
  };
  // Cell key of every point (and its squared distance to the cell centre), computed in parallel; cells are
  // then found by radix-sorting the keys. Keys number the grid's cells densely (few radix passes) unless the
  // grid is too large for that, then they mix the three cell coordinates.
  std::vector<KeyedIndex> byCell(n);  // (cell key, point), sorted by key; equal keys keep index order
  std::vector<double> toCentre(n);
  double sortedFor = 0;  // the cell size byCell is sorted for
  auto sortCells = [&](double size) {
    if (size == sortedFor) return;
    sortedFor = size;
    const Eigen::Vector3d dims = (hi - lo) / size + Eigen::Vector3d::Constant(2.0);
    const bool dense = dims.prod() < 0x1.0p58;
    const auto ny = static_cast<std::uint64_t>(dims.y()), nz = static_cast<std::uint64_t>(dims.z());
    parallelFor(n, threads, [&](std::size_t i) {
      const Eigen::Vector3d q = (pts[i] - lo) / size + shift;
      const auto ix = static_cast<std::uint64_t>(q.x()), iy = static_cast<std::uint64_t>(q.y()),
                 iz = static_cast<std::uint64_t>(q.z());
      const std::uint64_t cellKey = dense ? (ix * ny + iy) * nz + iz : (ix << 42) ^ (iy << 21) ^ iz;
      byCell[i] = {cellKey * 8 + normalClass(i), static_cast<std::uint32_t>(i)};
      toCentre[i] = (q - Eigen::Vector3d(ix + 0.5, iy + 0.5, iz + 0.5)).squaredNorm();
    });
    radixSort(byCell, threads);
  };
  auto occupied = [&](double size) {
    sortCells(size);
    std::size_t cells = 0;
    for (std::size_t r = 0; r < n; ++r) cells += r == 0 || byCell[r].first != byCell[r - 1].first;
    return cells;
  };
  // Occupied cells scale like cell⁻² on a surface.
  for (int step = 0; step < 8; ++step) {
    const double ratio = static_cast<double>(occupied(cell)) / static_cast<double>(target);
    if (ratio > 0.85 && ratio < 1.2) break;
    cell *= std::sqrt(std::clamp(ratio, 0.25, 4.0));
  }
  sortCells(cell);  // (already sorted when the loop stopped on it)
  // Where each cell's run of byCell starts (and, past the last, n).
  std::vector<std::size_t> runs;
  for (std::size_t r = 0; r < n; ++r)
    if (r == 0 || byCell[r].first != byCell[r - 1].first) runs.push_back(r);
  runs.push_back(n);
  // Cells near two sheets keep all their points (twoSheetCells), so that the thinned cloud resolves every gap
  // the input does. The input spacing (mean nearest-neighbour distance ≈ half the grid spacing of a random
  // sampling) comes from the occupied cells: each holds about cell² of surface.
  const std::size_t cells = runs.size() - 1;
  std::vector<char> twoLayers;
  if (layerGap > 0) {
    const double spacing = 0.5 * cell / std::sqrt(static_cast<double>(n) / static_cast<double>(cells));
    twoLayers = twoSheetCells(pts, byCell, runs, lo, shift, cell, layerGap * spacing, spacing, threads);
  }
  // Per cell the point nearest its centre (ties: the lowest index, the first of its run), returned in index
  // order. With a sheet height, per cell one point per sheet: the points off the planes of the cell's points
  // picked so far by more than it are picked too, nearest the centre first.
  std::vector<char> picked(n, 0);
  std::vector<std::uint32_t> run, reps;
  for (std::size_t c = 0; c < cells; ++c) {
    const std::size_t first = runs[c], last = runs[c + 1] - 1;
    std::size_t best = byCell[first].second;
    for (std::size_t r = first + 1; r <= last; ++r)
      if (toCentre[byCell[r].second] < toCentre[best]) best = byCell[r].second;
    picked[best] = 1;
    if (!twoLayers.empty() && twoLayers[c]) {
      for (std::size_t x = first; x <= last; ++x) picked[byCell[x].second] = 1;  // two sheets: not thinned
      continue;
    }
    if (sheetHeight <= 0 || normals.empty() || last == first) continue;
    run.clear();
    for (std::size_t x = first; x <= last; ++x) run.push_back(byCell[x].second);
    std::sort(run.begin(), run.end(), [&](std::uint32_t a, std::uint32_t b) {
      return toCentre[a] != toCentre[b] ? toCentre[a] < toCentre[b] : a < b;
    });
    reps.assign(1, static_cast<std::uint32_t>(best));
    for (std::uint32_t j : run)
      if (std::all_of(reps.begin(), reps.end(), [&](std::uint32_t q) {
            return std::abs(normals[q].dot(pts[j] - pts[q])) > sheetHeight;
          }))
        reps.push_back(j), picked[j] = 1;
  }
  std::vector<std::uint32_t> chosen;
  for (std::size_t i = 0; i < n; ++i)
    if (picked[i]) chosen.push_back(static_cast<std::uint32_t>(i));
  return chosen;
}

std::vector<std::uint32_t> initialCandidates(const PointCloud& cloud, const MlsSurface& surface,
                                             const ResampleParams& params, int threads) {
  const std::size_t count =
      static_cast<std::size_t>(params.candidateFactor *
                               static_cast<double>(params.targetCount + params.contextSamples.size()));
  if (cloud.size() <= count) {
    std::vector<std::uint32_t> all(cloud.size());
    std::iota(all.begin(), all.end(), 0u);
    return all;
  }
  // Intrinsic control: one candidate per sheet in each cell (sheets.hpp's height, without the slope term:
  // a cell spans several spacings, and a curved sheet split in two only adds a candidate).
  const double sheetHeight = params.intrinsic ? kCellSheetHeight * params.preprocessing.sheet.heightSpacings *
                                                    surface.meanSpacing()
                                              : 0.0;
  return voxelThin(cloud.points, cloud.normals, count, std::sqrt(surface.area() / static_cast<double>(count)),
                   params.seed, threads, sheetHeight);
}

}  // namespace iires::detail
