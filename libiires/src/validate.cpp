// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/validate.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "iires/detail/parallel.hpp"
#include "iires/detail/radix_sort.hpp"

namespace iires {
namespace {

using Eigen::Vector3d;

/// Keeps the points (and their normals) with @p keep[i] set, in order. @return the number of points removed.
template <typename Mask>
std::size_t keepMarked(PointCloud& cloud, const Mask& keep) {
  const std::size_t n = cloud.size();
  std::size_t kept = 0;
  while (kept < n && keep[kept]) ++kept;  // points before the first one removed stay where they are
  for (std::size_t i = kept; i < n; ++i) {
    if (!keep[i]) continue;
    cloud.points[kept] = cloud.points[i];
    if (cloud.hasNormals()) cloud.normals[kept] = cloud.normals[i];
    ++kept;
  }
  cloud.points.resize(kept);
  if (!cloud.normals.empty()) cloud.normals.resize(kept);
  return n - kept;
}

/// Removes exact duplicate positions, keeping the first occurrence and the normals of the kept points.
/// @return the number of points removed. O(n): points are sorted by a 32-bit hash of their coordinates (radix
/// sort, stable), so duplicates share a run; within a run a point is a duplicate when an earlier one equals
/// it.
std::size_t mergeDuplicates(PointCloud& cloud, int threads) {
  const std::size_t n = cloud.size();
  std::vector<KeyedIndex> byHash(n);
  parallelFor(n, threads, [&](std::size_t i) {
    std::uint64_t h = 0x9e3779b97f4a7c15ull;
    for (int k = 0; k < 3; ++k) {
      const double c = cloud.points[i][k] + 0.0;  // −0 and +0 compare equal: hash them alike
      std::uint64_t bits;
      std::memcpy(&bits, &c, sizeof bits);
      h = (h ^ bits) * 0xbf58476d1ce4e5b9ull;
      h ^= h >> 31;
    }
    byHash[i] = {h >> 32, static_cast<std::uint32_t>(i)};  // 32 bits: three radix passes; runs check equality
  });
  radixSort(byHash, threads);
  std::vector<bool> keep(n, true);
  for (std::size_t begin = 0, end = 0; begin < n; begin = end) {
    while (end < n && byHash[end].first == byHash[begin].first) ++end;
    for (std::size_t a = begin + 1; a < end; ++a)  // indices ascend within a run
      for (std::size_t b = begin; b < a; ++b)
        if (keep[byHash[b].second] && cloud.points[byHash[a].second] == cloud.points[byHash[b].second]) {
          keep[byHash[a].second] = false;
          break;
        }
  }

  return keepMarked(cloud, keep);
}

/// True when the points span no more than a line: the second-largest eigenvalue of their covariance is
/// negligible against the largest (or all points coincide).
bool collinear(const std::vector<Vector3d>& points) {
  Vector3d centroid = Vector3d::Zero();
  for (const Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  // The six distinct entries (an Eigen outer product per point costs several times more at millions of points).
  double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
  for (const Vector3d& p : points) {
    const double x = p.x() - centroid.x(), y = p.y() - centroid.y(), z = p.z() - centroid.z();
    xx += x * x, xy += x * y, xz += x * z, yy += y * y, yz += y * z, zz += z * z;
  }
  Eigen::Matrix3d covariance;
  covariance << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  const Vector3d eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvalues();
  return eigenvalues[2] <= 0 || eigenvalues[1] <= 1e-12 * eigenvalues[2];
}

/// The points within ten times the median distance from the coordinate-wise median: a cloud looks collinear
/// to the covariance when one point lies 10⁸ sizes away (the outlier stage removes it), its core does not.
std::vector<Vector3d> core(const std::vector<Vector3d>& points) {
  const std::size_t half = points.size() / 2;
  auto median = [&](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(half), v.end());
    return v[half];
  };
  Vector3d centre;
  for (int k = 0; k < 3; ++k) {
    std::vector<double> c(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) c[i] = points[i][k];
    centre[k] = median(std::move(c));
  }
  std::vector<double> dist(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) dist[i] = (points[i] - centre).norm();
  const double reach = 10.0 * median(dist);
  std::vector<Vector3d> kept;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (dist[i] <= reach) kept.push_back(points[i]);
  return kept;
}

/// The lowest index i < n with bad(i), or n when there is none (in parallel; independent of the thread count).
template <typename Pred>
std::size_t firstWhere(std::size_t n, int threads, Pred bad) {
  const auto count = static_cast<long long>(n);
  long long first = count;
#pragma omp parallel for reduction(min : first) num_threads(resolveThreads(threads))
  for (long long i = 0; i < count; ++i)
    if (bad(static_cast<std::size_t>(i))) first = std::min(first, i);
  return static_cast<std::size_t>(first);
}

}  // namespace

ValidationReport validateCloud(PointCloud& cloud, std::size_t minPoints, const std::string& what, int threads) {
  ValidationReport report;
  report.inputPoints = cloud.size();
  if (cloud.empty()) throw InputError(what + ": the cloud is empty");
  // The first point that is non-finite, or finite but so large that squared distances, covariances and MLS
  // moments overflow to Inf/NaN (one point at 5e244 would turn the whole output into NaN).
  const std::size_t n = cloud.size();
  const std::size_t bad = firstWhere(n, threads, [&](std::size_t i) {
    return !cloud.points[i].allFinite() || cloud.points[i].cwiseAbs().maxCoeff() > kMaxCoordinate;
  });
  if (bad < n) {
    const Vector3d& p = cloud.points[bad];
    if (!p.allFinite())
      throw InputError(what + ": point " + std::to_string(bad) + " has a non-finite coordinate (NaN or Inf)");
    std::ostringstream os;
    os << what << ": point " << bad << " has a coordinate of magnitude " << p.cwiseAbs().maxCoeff()
       << ", beyond the supported " << kMaxCoordinate << " (squared distances would overflow)";
    throw InputError(os.str());
  }
  // A cloud whose whole extent is below kMinExtent would lose its shape to underflow below.
  Vector3d lo = cloud.points[0], hi = cloud.points[0];
  for (const Vector3d& p : cloud.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  if (const double extent = (hi - lo).maxCoeff(); extent < kMinExtent && extent > 0) {
    std::ostringstream os;
    os << what << ": the cloud spans only " << extent << " units, below the supported " << kMinExtent
       << " (squared distances would underflow): scale the coordinates up";
    throw InputError(os.str());
  }
  // Denormal-scale coordinates (e.g. a cluster of points ~1e-310 apart) make differences whose
  // squares underflow to 0, and normalising them gives NaN; below kTinyCoordinate a coordinate is 0.
  parallelFor(n, threads, [&](std::size_t i) {
    for (int k = 0; k < 3; ++k)
      if (std::abs(cloud.points[i][k]) < kTinyCoordinate) cloud.points[i][k] = 0.0;
  });
  const bool normalsUsable = cloud.hasNormals() && firstWhere(n, threads, [&](std::size_t i) {
                               return !cloud.normals[i].allFinite() || !(cloud.normals[i].squaredNorm() > 0.0);
                             }) == n;
  if (!normalsUsable) cloud.normals.clear();

  report.duplicatesMerged = mergeDuplicates(cloud, threads);
  report.outputPoints = cloud.size();
  if (cloud.size() < minPoints)
    throw InputError(what + ": needs at least " + std::to_string(minPoints) +
                     " distinct points, the cloud has " + std::to_string(cloud.size()));
  if (cloud.size() == 1) throw InputError(what + ": all points are collinear (they all coincide)");
  if (collinear(cloud.points) && collinear(core(cloud.points)))
    throw InputError(what + ": all points are collinear");
  return report;
}

std::vector<std::uint32_t> withoutNearDuplicates(const NeighbourTable& table, const std::vector<Eigen::Vector3d>& points,
                                                 int threads) {
  constexpr std::size_t kRef = 9;  // the point itself and its 8 nearest
  if (table.k() < kRef) throw std::invalid_argument("withoutNearDuplicates: the table needs 9 columns");
  std::vector<char> merged(points.size(), 0);
  parallelFor(points.size(), threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    if (table.get(i, kRef, idx, d2) < kRef) return;
    const double limit = kNearDuplicate * kNearDuplicate * d2[kRef - 1];
    for (std::size_t t = 0; t < kRef; ++t)
      if (idx[t] < i && d2[t] <= limit) merged[i] = 1;
  });
  std::vector<std::uint32_t> kept;
  kept.reserve(points.size());
  const auto twins = static_cast<std::size_t>(std::count(merged.begin(), merged.end(), 1));
  const bool doubled = static_cast<double>(twins) >= kDoubledShare * static_cast<double>(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!doubled || !merged[i]) kept.push_back(static_cast<std::uint32_t>(i));
  return kept;
}

std::size_t mergeNearDuplicates(PointCloud& cloud, int threads) {
  if (cloud.size() < 9) return 0;
  const KnnIndex index(cloud.points);
  const NeighbourTable table(index, cloud.points, 9, threads);
  std::vector<char> keep(cloud.size(), 0);
  for (std::uint32_t i : withoutNearDuplicates(table, cloud.points, threads)) keep[i] = 1;
  return keepMarked(cloud, keep);
}

}  // namespace iires
