// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/rotation_search.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "iires/detail/parallel.hpp"
#include "iires/register/distance_field.hpp"
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

/// The part of a pose besides the rotation: S is mapped to scale·R·S + translation.
struct Offset {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;
};

struct Scored {
  double energy;
  std::size_t index;
  bool operator<(const Scored& o) const { return energy < o.energy || (energy == o.energy && index < o.index); }
};

/// The points k·step of the cubic lattice with 0 < |k·step| ≤ radius, nearest first (ties in lattice order).
std::vector<Eigen::Vector3d> latticeWithin(double radius, double step) {
  std::vector<Eigen::Vector3d> lattice;
  const int reach = static_cast<int>(std::floor(radius / step + 1e-9));
  for (int x = -reach; x <= reach; ++x)
    for (int y = -reach; y <= reach; ++y)
      for (int z = -reach; z <= reach; ++z) {
        const Eigen::Vector3d t = step * Eigen::Vector3d(x, y, z);
        if ((x || y || z) && t.norm() <= radius + 1e-9) lattice.push_back(t);
      }
  std::stable_sort(lattice.begin(), lattice.end(),
                   [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.norm() < b.norm() - 1e-12; });
  return lattice;
}

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
  if (fieldCells == 1) throw std::invalid_argument("rotation search: fieldCells must be 0 (off) or at least 2");
  if (!(fieldMargin >= 0.0) || !std::isfinite(fieldMargin))
    throw std::invalid_argument("rotation search: fieldMargin must be finite and >= 0");
  if (!(coarseOffsetRadius >= 0.0) || !std::isfinite(coarseOffsetRadius))
    throw std::invalid_argument("rotation search: coarseOffsetRadius must be finite and >= 0");
  if (!(coarseOffsetStep > 0.0) || !std::isfinite(coarseOffsetStep))
    throw std::invalid_argument("rotation search: coarseOffsetStep must be finite and positive");
  if (coarseOffsetRefineLevels < 0)
    throw std::invalid_argument("rotation search: coarseOffsetRefineLevels must be >= 0");
  if (!(openSideShift >= 0.0) || !std::isfinite(openSideShift))
    throw std::invalid_argument("rotation search: openSideShift must be finite and >= 0");
  if (!(openSideScaleSlope >= 0.0) || !(openSideScaleSlope * openSideShift < 1.0))
    throw std::invalid_argument("rotation search: openSideScaleSlope must be >= 0 and below 1 / openSideShift");
  if (coarseKeep < 1 || fullKeep < 1 || keep < 1)
    throw std::invalid_argument("rotation search: coarseKeep, fullKeep and keep must be at least 1");
  if (!(minSeparationDeg >= 0.0)) throw std::invalid_argument("rotation search: minSeparationDeg must be >= 0");
  if (refineLevels < 0) throw std::invalid_argument("rotation search: refineLevels must be >= 0");
  if (!(refineStepDeg > 0.0)) throw std::invalid_argument("rotation search: refineStepDeg must be positive");
  if (!(translationRadius >= 0.0)) throw std::invalid_argument("rotation search: translationRadius must be >= 0");
  if (!(translationStep > 0.0)) throw std::invalid_argument("rotation search: translationStep must be positive");
  if (translationScales.empty()) throw std::invalid_argument("rotation search: translationScales is empty");
  for (double scale : translationScales)
    if (!(scale > 0.0)) throw std::invalid_argument("rotation search: translationScales must be positive");
  if (translationPoints < 8) throw std::invalid_argument("rotation search: translationPoints must be at least 8");
  if (translationRefineLevels < 0)
    throw std::invalid_argument("rotation search: translationRefineLevels must be >= 0");
}

struct RotationSearch::Impl {
  RotationSearchParams params;
  Execution exec;
  std::vector<Eigen::Vector3d> source, target;              // shuffled copies (visit order)
  std::vector<Eigen::Vector3d> sourceCoarse, targetCoarse;  // their first coarsePoints
  std::vector<Eigen::Vector3d> sourceShift, targetShift;    // their first translationPoints
  std::unique_ptr<KnnIndex> sourceTree, targetTree;
  std::unique_ptr<DistanceField> sourceField, targetField;  // of the whole clouds; null when fieldCells = 0
  std::vector<TrimLevel> sourceLevels, targetLevels, sourceCoarseLevels, targetCoarseLevels, sourceShiftLevels,
      targetShiftLevels;
  std::vector<Eigen::Vector3d> lattice;  // translation lattice, nearest to the origin first (origin excluded)
  std::vector<Eigen::Vector3d> coarseLattice;  // the coarse pass's offsets, likewise
  mutable std::atomic<std::size_t> queries{0}, fieldQueries{0};

  // E(R, t, s) = max(h(s·R·S + t → T), s·h(Rᵀ(T − t)/s → S)), eq. (11) with a translation and a scale;
  // the second term has the same distances as T → s·R·S + t. fs, ft (optional) receive the overlap level
  // each direction chose. Distances from sd (of the source) and td (of the target): k-d trees or fields.
  template <typename Distances>
  double eval(const std::vector<Eigen::Vector3d>& s, const std::vector<TrimLevel>& sl,
              const std::vector<Eigen::Vector3d>& t, const std::vector<TrimLevel>& tl, const Distances& sd,
              const Distances& td, const Eigen::Matrix3d& r, const Offset& o, double bound, double* fs = nullptr,
              double* ft = nullptr) const {
    thread_local std::vector<double> scratch;
    std::size_t visited = 0, visited2 = 0, ls = 0, lt = 0;
    auto& counter = std::is_same_v<Distances, DistanceField> ? fieldQueries : queries;
    const double a = boundedPartialHausdorff(s, o.scale * r, o.translation, td, sl, bound, scratch, &visited, &ls);
    if (!std::isfinite(a)) {
      counter.fetch_add(visited, std::memory_order_relaxed);
      return kInf;
    }
    const Eigen::Matrix3d inverse = r.transpose() / o.scale;
    const double b = o.scale * boundedPartialHausdorff(t, inverse, -(inverse * o.translation), sd, tl,
                                                       bound / o.scale, scratch, &visited2, &lt);
    counter.fetch_add(visited + visited2, std::memory_order_relaxed);
    if (fs && std::isfinite(b)) *fs = sl[ls].overlap;
    if (ft && std::isfinite(b)) *ft = tl[lt].overlap;
    return std::max(a, b);
  }
  double full(const Eigen::Matrix3d& r, const Offset& o, double bound, double* fs = nullptr,
              double* ft = nullptr) const {
    return eval(source, sourceLevels, target, targetLevels, *sourceTree, *targetTree, r, o, bound, fs, ft);
  }
  double coarse(const Eigen::Matrix3d& r, const Offset& o, double bound) const {
    if (!sourceField)
      return eval(sourceCoarse, sourceCoarseLevels, targetCoarse, targetCoarseLevels, *sourceTree, *targetTree, r,
                  o, bound);
    return eval(sourceCoarse, sourceCoarseLevels, targetCoarse, targetCoarseLevels, *sourceField, *targetField, r,
                o, bound);
  }
  double offsetEnergy(const Eigen::Matrix3d& r, const Offset& o, double bound) const {
    return eval(sourceShift, sourceShiftLevels, targetShift, targetShiftLevels, *sourceTree, *targetTree, r, o,
                bound);
  }

  /// The coarse energy of R minimised over the pose: t = 0 and the coarse lattice (scale 1), the open sides'
  /// poses, then coarseOffsetRefineLevels pattern moves of ±h along each axis around the best (its scale kept),
  /// h halved each time.
  /// Early exit against min(@p bound, the best so far); +∞ when every offset exceeds @p bound (then no
  /// pattern move is tried). @p chosen receives the minimising offset (t = 0 when none is finite). Serial.
  double bestCoarse(const Eigen::Matrix3d& r, double bound, Offset* chosen) const {
    Offset best;
    double e = coarse(r, best, bound);
    auto consider = [&](const Offset& o, Offset& into, double& energy) {
      const double v = coarse(r, o, std::min(energy, bound));
      if (v < energy) {
        energy = v;
        into = o;
      }
    };
    for (const auto& t : coarseLattice) consider(Offset{t, 1.0}, best, e);
    // The open sides' poses: a cut source shifted away from its rim and shrunk, a cut target likewise
    const Eigen::Vector3d us = r * params.sourceOpenSide, ut = params.targetOpenSide;
    const double shift = params.openSideShift, k = params.openSideScaleSlope;
    for (double a : {0.0, us.squaredNorm() > 0 ? shift : 0.0})
      for (double b : {0.0, ut.squaredNorm() > 0 ? shift : 0.0})
        if (a > 0 || b > 0) consider(Offset{-a * us + b * ut, (1.0 - k * a) / (1.0 - k * b)}, best, e);
    double h = params.coarseOffsetStep;
    for (int level = 0; level < params.coarseOffsetRefineLevels && !coarseLattice.empty() && std::isfinite(e);
         ++level) {
      h *= 0.5;
      Offset next = best;
      double en = e;
      for (int axis = 0; axis < 3; ++axis)
        for (double sign : {-1.0, 1.0})
          consider(Offset{best.translation + sign * h * Eigen::Vector3d::Unit(axis), best.scale}, next, en);
      best = next;
      e = en;
    }
    *chosen = best;
    return e;
  }

  /// The translation and scale minimising E(R, t, s) on the translationPoints subsets: from @p start (the
  /// coarse pass's offset), for each scale of translationScales t = 0 and the lattice (early exit against the
  /// best so far), then at the best scale a pattern search of ±h along each axis, h halved
  /// translationRefineLevels times. Serial.
  Offset bestOffset(const Eigen::Matrix3d& r, const Offset& start, double* energy) const {
    Offset best = start;
    double e = offsetEnergy(r, best, kInf);
    for (double scale : params.translationScales) {
      Offset o;
      o.scale = scale;
      auto consider = [&](const Offset& candidate) {
        if (candidate.scale == start.scale && candidate.translation == start.translation) return;
        const double v = offsetEnergy(r, candidate, e);
        if (v < e) {
          e = v;
          best = candidate;
        }
      };
      consider(o);
      for (const auto& t : lattice) {
        o.translation = t;
        consider(o);
      }
    }
    double h = params.translationStep;
    for (int level = 0; level < params.translationRefineLevels && !lattice.empty(); ++level) {
      h *= 0.5;
      for (int moves = 0; moves < 8; ++moves) {
        Offset next = best;
        for (int axis = 0; axis < 3; ++axis)
          for (double sign : {-1.0, 1.0}) {
            Offset o = best;
            o.translation += sign * h * Eigen::Vector3d::Unit(axis);
            const double v = offsetEnergy(r, o, e);
            if (v < e) {
              e = v;
              next = o;
            }
          }
        if (next.translation == best.translation) break;
        best = next;
      }
    }
    *energy = e;
    return best;
  }

  /// The best @p keepCount of @p order (candidate indices) by energy @p fn(index, bound), with early exit
  /// against the keepCount-th best so far, block by block (deterministic for any thread count).
  /// @p onBlock(done) after each block (progress).
  template <typename Fn, typename OnBlock>
  std::vector<Scored> bestOf(const std::vector<std::size_t>& order, std::size_t keepCount, Fn&& fn,
                             std::size_t* evaluations, OnBlock&& onBlock) const {
    std::vector<Scored> top;
    double bound = kInf;
    std::vector<double> e(std::max(kBlock, keepCount));
    // The first block is just big enough to set a bound; later blocks are fixed-size.
    for (std::size_t start = 0, block = std::min(keepCount, kBlock); start < order.size();
         start += block, block = kBlock) {
      const std::size_t count = std::min(block, order.size() - start);
      parallelEach(count, exec.threads, [&](std::size_t j) { e[j] = fn(order[start + j], bound); });
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
                               const RotationSearchParams& params, const Execution& exec)
    : impl_(std::make_unique<Impl>()) {
  params.validate();
  if (source.size() < 3 || target.size() < 3)
    throw std::invalid_argument("rotation search needs at least 3 points per cloud");
  Impl& m = *impl_;
  m.params = params;
  m.exec = exec;
  m.source = shuffled(source, params.seed * 2 + 1);
  m.target = shuffled(target, params.seed * 2 + 2);
  m.sourceCoarse.assign(m.source.begin(), m.source.begin() + std::min(params.coarsePoints, m.source.size()));
  m.targetCoarse.assign(m.target.begin(), m.target.begin() + std::min(params.coarsePoints, m.target.size()));
  m.sourceShift.assign(m.source.begin(), m.source.begin() + std::min(params.translationPoints, m.source.size()));
  m.targetShift.assign(m.target.begin(), m.target.begin() + std::min(params.translationPoints, m.target.size()));
  // Visit the points farthest from the centroid first: a wrong rotation moves them most, so early exits
  // come sooner. (Stable sort: ties keep the seeded order.)
  auto outerFirst = [](std::vector<Eigen::Vector3d>& p) {
    std::stable_sort(p.begin(), p.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
      return a.squaredNorm() > b.squaredNorm();
    });
  };
  outerFirst(m.sourceCoarse);
  outerFirst(m.targetCoarse);
  outerFirst(m.sourceShift);
  outerFirst(m.targetShift);
  outerFirst(m.source);
  outerFirst(m.target);
  m.sourceTree = std::make_unique<KnnIndex>(m.source);
  m.targetTree = std::make_unique<KnnIndex>(m.target);
  if (params.fieldCells > 0) {
    DistanceFieldParams fp;
    fp.cells = params.fieldCells;
    fp.margin = params.fieldMargin;
    fp.threads = exec.threads;
    m.sourceField = std::make_unique<DistanceField>(m.source, *m.sourceTree, fp);
    m.targetField = std::make_unique<DistanceField>(m.target, *m.targetTree, fp);
  }
  m.sourceLevels = trimLevels(m.source.size(), params.overlaps, params.overlapExponent);
  m.targetLevels = trimLevels(m.target.size(), params.overlaps, params.overlapExponent);
  m.sourceCoarseLevels = trimLevels(m.sourceCoarse.size(), params.overlaps, params.overlapExponent);
  m.targetCoarseLevels = trimLevels(m.targetCoarse.size(), params.overlaps, params.overlapExponent);
  m.sourceShiftLevels = trimLevels(m.sourceShift.size(), params.overlaps, params.overlapExponent);
  m.targetShiftLevels = trimLevels(m.targetShift.size(), params.overlaps, params.overlapExponent);
  m.lattice = latticeWithin(params.translationRadius, params.translationStep);
  m.coarseLattice = latticeWithin(params.coarseOffsetRadius, params.coarseOffsetStep);
}

RotationSearch::~RotationSearch() = default;

double RotationSearch::energy(const Eigen::Matrix3d& rotation, double bound, double* sourceOverlap,
                              double* targetOverlap) const {
  return impl_->full(rotation, Offset{}, bound, sourceOverlap, targetOverlap);
}

double RotationSearch::energy(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation, double scale,
                              double bound, double* sourceOverlap, double* targetOverlap) const {
  if (!(scale > 0.0)) throw std::invalid_argument("rotation search: the scale of a pose must be positive");
  return impl_->full(rotation, Offset{translation, scale}, bound, sourceOverlap, targetOverlap);
}

double RotationSearch::coarseEnergy(const Eigen::Matrix3d& rotation, double bound) const {
  return impl_->coarse(rotation, Offset{}, bound);
}

RotationSearchResult RotationSearch::search(const std::vector<Eigen::Matrix3d>& grid) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Impl& m = *impl_;
  const RotationSearchParams& p = m.params;
  m.queries = 0;
  m.fieldQueries = 0;
  RotationSearchResult result;
  result.gridSize = grid.size();
  if (grid.empty()) throw std::invalid_argument("rotation search: empty grid");

  // Coarse pass over the whole grid: a lower bound of E on point subsets.
  std::vector<std::size_t> all(grid.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  // Progress: the coarse pass is most of the work (≈ 90 %), the exact pass and the refinement the rest.
  auto report = [&](double fraction) { m.exec.report("search", fraction); };
  report(0.0);
  std::vector<Offset> offsetOf(grid.size());  // each candidate's coarse offset, then its searched offset
  const auto coarse = m.bestOf(
      all, p.coarseKeep, [&](std::size_t i, double b) { return m.bestCoarse(grid[i], b, &offsetOf[i]); },
      nullptr,
      [&](std::size_t done) { report(0.9 * static_cast<double>(done) / static_cast<double>(grid.size())); });

  // Translation (and scale) search around each survivor (one survivor per task: deterministic), then the
  // survivors ordered by that energy so that the exact pass's bound tightens early.
  std::vector<Scored> shifted(coarse.size());
  parallelEach(coarse.size(), m.exec.threads, [&](std::size_t j) {
    double e = kInf;
    const std::size_t i = coarse[j].index;
    offsetOf[i] = m.bestOffset(grid[i], p.translationRadius > 0 ? offsetOf[i] : Offset{}, &e);
    shifted[j] = {e, coarse[j].index};
  });
  std::sort(shifted.begin(), shifted.end());

  // Exact energy of the survivors at their offset.
  std::vector<std::size_t> survivors;
  for (const auto& s : shifted) survivors.push_back(s.index);
  const auto exact = m.bestOf(survivors, p.fullKeep,
                              [&](std::size_t i, double b) { return m.full(grid[i], offsetOf[i], b); },
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
    c.translation = offsetOf[s.index].translation;
    c.scale = offsetOf[s.index].scale;
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
      parallelEach(steps.size(), m.exec.threads, [&](std::size_t j) {
        e[j] = m.full(expMap(h * steps[j].normalized()) * current, Offset{c.translation, c.scale}, c.energy);
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
  for (auto& c : result.candidates)
    m.full(c.rotation, Offset{c.translation, c.scale}, kInf, &c.sourceOverlap, &c.targetOverlap);
  std::stable_sort(result.candidates.begin(), result.candidates.end(),
                   [](const RotationCandidate& a, const RotationCandidate& b) { return a.energy < b.energy; });
  report(1.0);
  result.pointQueries = m.queries.load();
  result.fieldQueries = m.fieldQueries.load();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace iires::reg
