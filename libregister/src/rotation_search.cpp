// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/rotation_search.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>
#include <utility>

#include "iires/detail/parallel.hpp"
#include "iires/register/hausdorff.hpp"
#include "iires/register/rotation_grid.hpp"

namespace iires::reg {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kBlock = 64;  // candidates evaluated against one fixed bound

/// fn(i) for i in [0, n) in parallel, one iteration at a time: a block has only 64 candidates (iires::parallelFor
/// hands out chunks of 256, i.e. the whole block to one thread). Each iteration writes only its own slot.
template <typename Fn>
void parallelEach(std::size_t n, int threads, Fn&& fn) {
  const long long count = static_cast<long long>(n);
#pragma omp parallel for schedule(dynamic, 1) num_threads(resolveThreads(threads))
  for (long long i = 0; i < count; ++i) fn(static_cast<std::size_t>(i));
}

/// Fisher–Yates with a seeded 64-bit engine: the order does not depend on the standard library.
std::vector<Eigen::Vector3d> shuffled(std::vector<Eigen::Vector3d> points, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  for (std::size_t i = points.size(); i > 1; --i) {
    const std::size_t j = static_cast<std::size_t>(rng() % i);
    std::swap(points[i - 1], points[j]);
  }
  return points;
}

struct Scored {
  double energy;
  std::size_t index;
  bool operator<(const Scored& o) const { return energy < o.energy || (energy == o.energy && index < o.index); }
};

Eigen::Matrix3d expMap(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

}  // namespace

void RotationSearchParams::validate() const {
  if (overlaps.empty() || overlaps.size() > 16)
    throw std::invalid_argument("rotation search: between 1 and 16 overlaps");
  for (double f : overlaps)
    if (!(f > 0.0 && f <= 1.0)) throw std::invalid_argument("rotation search: overlap must be in (0, 1]");
  if (!(overlapExponent >= 0.0)) throw std::invalid_argument("rotation search: overlapExponent must be >= 0");
  if (coarsePoints < 8) throw std::invalid_argument("rotation search: coarsePoints must be at least 8");
  if (coarseKeep < 1 || fullKeep < 1 || keep < 1)
    throw std::invalid_argument("rotation search: coarseKeep, fullKeep and keep must be at least 1");
  if (!(minSeparationDeg >= 0.0)) throw std::invalid_argument("rotation search: minSeparationDeg must be >= 0");
  if (refineLevels < 0) throw std::invalid_argument("rotation search: refineLevels must be >= 0");
  if (!(refineStepDeg > 0.0)) throw std::invalid_argument("rotation search: refineStepDeg must be positive");
}

struct RotationSearch::Impl {
  RotationSearchParams params;
  std::vector<Eigen::Vector3d> source, target;              // shuffled copies (visit order)
  std::vector<Eigen::Vector3d> sourceCoarse, targetCoarse;  // their first coarsePoints
  std::unique_ptr<KnnIndex> sourceTree, targetTree;
  std::vector<TrimLevel> sourceLevels, targetLevels, sourceCoarseLevels, targetCoarseLevels;
  mutable std::atomic<std::size_t> queries{0};

  // E(R) = max(h(R·S → T), h(Rᵀ·T → S)), eq. (11); Rᵀ·T → S has the same distances as T → R·S.
  // fs, ft (optional) receive the overlap level each direction chose.
  double eval(const std::vector<Eigen::Vector3d>& s, const std::vector<TrimLevel>& sl,
              const std::vector<Eigen::Vector3d>& t, const std::vector<TrimLevel>& tl, const Eigen::Matrix3d& r,
              double bound, double* fs = nullptr, double* ft = nullptr) const {
    thread_local std::vector<double> scratch;
    std::size_t visited = 0, visited2 = 0, ls = 0, lt = 0;
    const double a = boundedPartialHausdorff(s, r, *targetTree, sl, bound, scratch, &visited, &ls);
    if (!std::isfinite(a)) {
      queries.fetch_add(visited, std::memory_order_relaxed);
      return kInf;
    }
    const double b = boundedPartialHausdorff(t, r.transpose(), *sourceTree, tl, bound, scratch, &visited2, &lt);
    queries.fetch_add(visited + visited2, std::memory_order_relaxed);
    if (fs && std::isfinite(b)) *fs = sl[ls].overlap;
    if (ft && std::isfinite(b)) *ft = tl[lt].overlap;
    return std::max(a, b);
  }
  double full(const Eigen::Matrix3d& r, double bound, double* fs = nullptr, double* ft = nullptr) const {
    return eval(source, sourceLevels, target, targetLevels, r, bound, fs, ft);
  }
  double coarse(const Eigen::Matrix3d& r, double bound) const {
    return eval(sourceCoarse, sourceCoarseLevels, targetCoarse, targetCoarseLevels, r, bound);
  }

  /// The best @p keepCount of @p order (indices into @p rotations) by energy @p fn, with early exit against
  /// the keepCount-th best so far, block by block (deterministic for any thread count).
  /// @p onBlock(done) after each block (progress).
  template <typename Fn, typename OnBlock>
  std::vector<Scored> bestOf(const std::vector<Eigen::Matrix3d>& rotations, const std::vector<std::size_t>& order,
                             std::size_t keepCount, Fn&& fn, std::size_t* evaluations, OnBlock&& onBlock) const {
    std::vector<Scored> top;
    double bound = kInf;
    std::vector<double> e(std::max(kBlock, keepCount));
    // The first block is just big enough to set a bound; later blocks are fixed-size.
    for (std::size_t start = 0, block = std::min(keepCount, kBlock); start < order.size();
         start += block, block = kBlock) {
      const std::size_t count = std::min(block, order.size() - start);
      parallelEach(count, params.threads, [&](std::size_t j) { e[j] = fn(rotations[order[start + j]], bound); });
      if (evaluations) *evaluations += count;
      for (std::size_t j = 0; j < count; ++j)
        if (std::isfinite(e[j])) top.push_back({e[j], order[start + j]});
      std::sort(top.begin(), top.end());
      if (top.size() > keepCount) top.resize(keepCount);
      if (top.size() == keepCount) bound = top.back().energy;
      onBlock(start + count);
    }
    return top;
  }
};

RotationSearch::RotationSearch(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
                               const RotationSearchParams& params)
    : impl_(std::make_unique<Impl>()) {
  params.validate();
  if (source.size() < 3 || target.size() < 3)
    throw std::invalid_argument("rotation search needs at least 3 points per cloud");
  Impl& m = *impl_;
  m.params = params;
  m.source = shuffled(source, params.seed * 2 + 1);
  m.target = shuffled(target, params.seed * 2 + 2);
  m.sourceCoarse.assign(m.source.begin(), m.source.begin() + std::min(params.coarsePoints, m.source.size()));
  m.targetCoarse.assign(m.target.begin(), m.target.begin() + std::min(params.coarsePoints, m.target.size()));
  // Visit the points farthest from the centroid first: a wrong rotation moves them most, so early exits
  // come sooner. (Stable sort: ties keep the seeded order.)
  auto outerFirst = [](std::vector<Eigen::Vector3d>& p) {
    std::stable_sort(p.begin(), p.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
      return a.squaredNorm() > b.squaredNorm();
    });
  };
  outerFirst(m.sourceCoarse);
  outerFirst(m.targetCoarse);
  outerFirst(m.source);
  outerFirst(m.target);
  m.sourceTree = std::make_unique<KnnIndex>(m.source);
  m.targetTree = std::make_unique<KnnIndex>(m.target);
  m.sourceLevels = trimLevels(m.source.size(), params.overlaps, params.overlapExponent);
  m.targetLevels = trimLevels(m.target.size(), params.overlaps, params.overlapExponent);
  m.sourceCoarseLevels = trimLevels(m.sourceCoarse.size(), params.overlaps, params.overlapExponent);
  m.targetCoarseLevels = trimLevels(m.targetCoarse.size(), params.overlaps, params.overlapExponent);
}

RotationSearch::~RotationSearch() = default;

double RotationSearch::energy(const Eigen::Matrix3d& rotation, double bound, double* sourceOverlap,
                              double* targetOverlap) const {
  return impl_->full(rotation, bound, sourceOverlap, targetOverlap);
}

double RotationSearch::coarseEnergy(const Eigen::Matrix3d& rotation, double bound) const {
  return impl_->coarse(rotation, bound);
}

RotationSearchResult RotationSearch::search(const std::vector<Eigen::Matrix3d>& grid) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Impl& m = *impl_;
  const RotationSearchParams& p = m.params;
  m.queries = 0;
  RotationSearchResult result;
  result.gridSize = grid.size();
  if (grid.empty()) throw std::invalid_argument("rotation search: empty grid");

  // Coarse pass over the whole grid: a lower bound of E on point subsets.
  std::vector<std::size_t> all(grid.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  // Progress: the coarse pass is most of the work (≈ 90 %), the exact pass and the refinement the rest.
  auto report = [&](double fraction) {
    if (p.progress) p.progress(fraction);
  };
  report(0.0);
  const auto coarse = m.bestOf(
      grid, all, p.coarseKeep, [&](const Eigen::Matrix3d& r, double b) { return m.coarse(r, b); }, nullptr,
      [&](std::size_t done) { report(0.9 * static_cast<double>(done) / static_cast<double>(grid.size())); });

  // Exact energy of the survivors, best coarse first (so the bound tightens early).
  std::vector<std::size_t> survivors;
  for (const auto& s : coarse) survivors.push_back(s.index);
  const auto exact = m.bestOf(grid, survivors, p.fullKeep,
                              [&](const Eigen::Matrix3d& r, double b) { return m.full(r, b); },
                              &result.exactEvaluations, [](std::size_t) {});
  report(0.95);

  // Distinct candidates: greedy, lowest energy first, at least minSeparationDeg apart.
  const double minSep = p.minSeparationDeg * M_PI / 180.0;
  for (const auto& s : exact) {
    if (result.candidates.size() >= p.keep) break;
    bool distinct = true;
    for (const auto& c : result.candidates)
      if (rotationAngle(c.gridRotation, grid[s.index]) < minSep) distinct = false;
    if (!distinct) continue;
    RotationCandidate c;
    c.gridIndex = s.index;
    c.gridRotation = grid[s.index];
    c.gridEnergy = s.energy;
    c.rotation = c.gridRotation;
    c.energy = s.energy;
    result.candidates.push_back(c);
  }

  // Local refinement: pattern search over the 6 axis-angle steps ±h·eᵢ, left-multiplied, h halved whenever
  // no step improves E. Each candidate on its own; the 6 trials in parallel, bounded by E(current).
  std::vector<Eigen::Vector3d> steps;
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {-1, 1}) steps.push_back(sign * Eigen::Vector3d::Unit(axis));
  std::vector<double> e(steps.size());
  for (auto& c : result.candidates) {
    double h = p.refineStepDeg * M_PI / 180.0;
    int moves = 0;
    for (int level = 0; level < p.refineLevels && moves < 64;) {
      const Eigen::Matrix3d current = c.rotation;
      parallelEach(steps.size(), p.threads, [&](std::size_t j) {
        e[j] = m.full(expMap(h * steps[j].normalized()) * current, c.energy);
      });
      result.exactEvaluations += steps.size();
      std::size_t best = steps.size();
      for (std::size_t j = 0; j < steps.size(); ++j)
        if (e[j] < c.energy && (best == steps.size() || e[j] < e[best])) best = j;
      if (best == steps.size()) {
        h *= 0.5;
        ++level;
        continue;
      }
      ++moves;
      c.rotation = expMap(h * steps[best].normalized()) * current;
      c.energy = e[best];
    }
  }
  for (auto& c : result.candidates) m.full(c.rotation, kInf, &c.sourceOverlap, &c.targetOverlap);
  std::stable_sort(result.candidates.begin(), result.candidates.end(),
                   [](const RotationCandidate& a, const RotationCandidate& b) { return a.energy < b.energy; });
  report(1.0);
  result.pointQueries = m.queries.load();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace iires::reg
