#include "iires/validate.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <vector>

#include "iires/radix_sort.hpp"

namespace iires {
namespace {

using Eigen::Vector3d;

/// Removes exact duplicate positions, keeping the first occurrence and the normals of the kept points.
/// @return the number of points removed. O(n): points are sorted by a hash of their coordinates (radix sort,
/// stable), so duplicates share a run; within a run a point is a duplicate when an earlier one equals it.
std::size_t mergeDuplicates(PointCloud& cloud) {
  const std::size_t n = cloud.size();
  std::vector<KeyedIndex> byHash(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t h = 0x9e3779b97f4a7c15ull;
    for (int k = 0; k < 3; ++k) {
      const double c = cloud.points[i][k] + 0.0;  // −0 and +0 compare equal: hash them alike
      std::uint64_t bits;
      std::memcpy(&bits, &c, sizeof bits);
      h = (h ^ bits) * 0xbf58476d1ce4e5b9ull;
      h ^= h >> 31;
    }
    byHash[i] = {h, static_cast<std::uint32_t>(i)};
  }
  radixSort(byHash);
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

  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!keep[i]) continue;
    cloud.points[kept] = cloud.points[i];
    if (cloud.hasNormals()) cloud.normals[kept] = cloud.normals[i];
    ++kept;
  }
  cloud.points.resize(kept);
  if (!cloud.normals.empty()) cloud.normals.resize(kept);
  return n - kept;
}

/// True when the points span no more than a line: the second-largest eigenvalue of their covariance is
/// negligible against the largest (or all points coincide).
bool collinear(const std::vector<Vector3d>& points) {
  Vector3d centroid = Vector3d::Zero();
  for (const Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Vector3d& p : points) covariance += (p - centroid) * (p - centroid).transpose();
  const Vector3d eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvalues();
  return eigenvalues[2] <= 0 || eigenvalues[1] <= 1e-12 * eigenvalues[2];
}

}  // namespace

ValidationReport validateCloud(PointCloud& cloud, std::size_t minPoints, const std::string& what) {
  ValidationReport report;
  report.inputPoints = cloud.size();
  if (cloud.empty()) throw InputError(what + ": the cloud is empty");
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.points[i].allFinite())
      throw InputError(what + ": point " + std::to_string(i) + " has a non-finite coordinate (NaN or Inf)");
    // Finite but so large that squared distances, covariances and MLS moments overflow to Inf/NaN (a fuzzer
    // find: one point at 5e244 turned the whole output into NaN).
    if (cloud.points[i].cwiseAbs().maxCoeff() > kMaxCoordinate) {
      std::ostringstream os;
      os << what << ": point " << i << " has a coordinate of magnitude " << cloud.points[i].cwiseAbs().maxCoeff()
         << ", beyond the supported " << kMaxCoordinate << " (squared distances would overflow)";
      throw InputError(os.str());
    }
  }
  // Denormal-scale coordinates (a fuzzer find: a cluster of points ~1e-310 apart) make differences whose
  // squares underflow to 0, and normalising them gives NaN; below kTinyCoordinate a coordinate is 0.
  for (Vector3d& p : cloud.points)
    for (int k = 0; k < 3; ++k)
      if (std::abs(p[k]) < kTinyCoordinate) p[k] = 0.0;
  const bool normalsUsable =
      cloud.hasNormals() && std::all_of(cloud.normals.begin(), cloud.normals.end(),
                                        [](const Vector3d& n) { return n.allFinite() && n.squaredNorm() > 0.0; });
  if (!normalsUsable) cloud.normals.clear();

  report.duplicatesMerged = mergeDuplicates(cloud);
  report.outputPoints = cloud.size();
  if (cloud.size() < minPoints)
    throw InputError(what + ": needs at least " + std::to_string(minPoints) +
                     " distinct points, the cloud has " + std::to_string(cloud.size()));
  if (cloud.size() == 1) throw InputError(what + ": all points are collinear (they all coincide)");
  if (collinear(cloud.points)) throw InputError(what + ": all points are collinear");
  return report;
}

}  // namespace iires
