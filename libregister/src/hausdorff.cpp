// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/hausdorff.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "iires/detail/parallel.hpp"

namespace iires::reg {

namespace {

double squaredDistanceTo(const KnnIndex& to, const Eigen::Vector3d& p) {
  double d2 = 0;
  to.nearest(p, &d2);
  return d2;
}

double squaredDistanceTo(const DistanceField& to, const Eigen::Vector3d& p) { return to.squaredDistance(p); }

/// The partial Hausdorff energy with squared distances from @p to (a KnnIndex or a DistanceField).
template <typename Distances>
double boundedPartial(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& linear,
                      const Eigen::Vector3d& translation, const Distances& to,
                      const std::vector<TrimLevel>& levels, double bound, std::vector<double>& scratch,
                      std::size_t* visited, std::size_t* level) {
  constexpr std::size_t kMaxLevels = 16;
  if (levels.empty() || levels.size() > kMaxLevels)
    throw std::invalid_argument("boundedPartialHausdorff: between 1 and 16 levels");
  // Level j is beaten once more than its outliers lie farther than bound / penalty_j.
  double limit2[kMaxLevels];
  std::size_t over[kMaxLevels] = {};
  for (std::size_t j = 0; j < levels.size(); ++j) {
    const double t = bound / levels[j].penalty;
    limit2[j] = std::isfinite(t) ? t * t : std::numeric_limits<double>::infinity();
  }
  const bool plainMax = levels.size() == 1 && levels[0].outliers == 0;
  std::size_t alive = levels.size();  // levels not beaten yet
  scratch.clear();
  double worst = 0;  // running maximum, enough for a single untrimmed level
  std::size_t i = 0;
  for (; i < from.size(); ++i) {
    const double d2 = squaredDistanceTo(to, linear * from[i] + translation);
    for (std::size_t j = 0; j < levels.size(); ++j)
      if (d2 > limit2[j] && over[j]++ == levels[j].outliers) --alive;
    if (alive == 0) {
      if (visited) *visited = i + 1;
      return std::numeric_limits<double>::infinity();
    }
    if (plainMax)
      worst = std::max(worst, d2);
    else
      scratch.push_back(d2);
  }
  if (visited) *visited = i;
  if (plainMax) {
    if (level) *level = 0;
    return std::sqrt(worst);
  }
  return penalisedQuantile(scratch, levels, level);
}

}  // namespace

std::size_t allowedOutliers(std::size_t n, double overlap) {
  if (!(overlap > 0.0 && overlap <= 1.0))
    throw std::invalid_argument("overlap must be in (0, 1], got " + std::to_string(overlap));
  const auto keep = static_cast<std::size_t>(std::ceil(overlap * static_cast<double>(n) - 1e-9));
  return n - std::max<std::size_t>(1, std::min(n, keep));
}

double directedHausdorff(const std::vector<Eigen::Vector3d>& from, const KnnIndex& to, double overlap,
                         int threads) {
  if (from.empty() || to.size() == 0) throw std::invalid_argument("Hausdorff distance of an empty point set");
  const std::size_t outliers = allowedOutliers(from.size(), overlap);
  std::vector<double> d2(from.size());
  parallelFor(from.size(), threads, [&](std::size_t i) { to.nearest(from[i], &d2[i]); });
  // The (outliers+1)-th largest = the (n − outliers)-th smallest.
  const std::size_t k = from.size() - 1 - outliers;
  std::nth_element(d2.begin(), d2.begin() + static_cast<std::ptrdiff_t>(k), d2.end());
  return std::sqrt(d2[k]);
}

double hausdorffDistance(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                         double overlap, int threads) {
  if (a.empty() || b.empty()) throw std::invalid_argument("Hausdorff distance of an empty point set");
  const KnnIndex ia(a), ib(b);
  return std::max(directedHausdorff(a, ib, overlap, threads), directedHausdorff(b, ia, overlap, threads));
}

double boundedDirectedHausdorff(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& rotation,
                                const KnnIndex& to, std::size_t outliers, double bound,
                                std::vector<double>& scratch, std::size_t* visited) {
  TrimLevel level;
  level.outliers = outliers;
  return boundedPartialHausdorff(from, rotation, to, {level}, bound, scratch, visited);
}

std::vector<TrimLevel> trimLevels(std::size_t n, const std::vector<double>& overlaps, double exponent) {
  if (overlaps.empty()) throw std::invalid_argument("trimLevels: no overlap given");
  if (!(exponent >= 0.0)) throw std::invalid_argument("trimLevels: the exponent must be >= 0");
  const double top = *std::max_element(overlaps.begin(), overlaps.end());
  std::vector<TrimLevel> levels;
  for (double f : overlaps) {
    TrimLevel l;
    l.overlap = f;
    l.outliers = allowedOutliers(n, f);  // validates f
    l.penalty = std::pow(top / f, exponent);
    levels.push_back(l);
  }
  return levels;
}

double penalisedQuantile(std::vector<double>& d2, const std::vector<TrimLevel>& levels, std::size_t* level) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t j = 0; j < levels.size(); ++j) {
    const std::size_t k = d2.size() - 1 - levels[j].outliers;
    std::nth_element(d2.begin(), d2.begin() + static_cast<std::ptrdiff_t>(k), d2.end());
    const double v = levels[j].penalty * std::sqrt(d2[k]);
    if (v < best) {
      best = v;
      if (level) *level = j;
    }
  }
  return best;
}

double boundedPartialHausdorff(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& rotation,
                               const KnnIndex& to, const std::vector<TrimLevel>& levels, double bound,
                               std::vector<double>& scratch, std::size_t* visited, std::size_t* level) {
  return boundedPartialHausdorff(from, rotation, Eigen::Vector3d::Zero(), to, levels, bound, scratch, visited, level);
}

double boundedPartialHausdorff(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& linear,
                               const Eigen::Vector3d& translation, const KnnIndex& to,
                               const std::vector<TrimLevel>& levels, double bound, std::vector<double>& scratch,
                               std::size_t* visited, std::size_t* level) {
  return boundedPartial(from, linear, translation, to, levels, bound, scratch, visited, level);
}

double boundedPartialHausdorff(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& linear,
                               const Eigen::Vector3d& translation, const DistanceField& to,
                               const std::vector<TrimLevel>& levels, double bound, std::vector<double>& scratch,
                               std::size_t* visited, std::size_t* level) {
  return boundedPartial(from, linear, translation, to, levels, bound, scratch, visited, level);
}

}  // namespace iires::reg
