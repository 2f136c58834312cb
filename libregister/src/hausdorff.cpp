#include "iires/register/hausdorff.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "iires/parallel.hpp"

namespace iires::reg {

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
  const double bound2 = std::isfinite(bound) ? bound * bound : std::numeric_limits<double>::infinity();
  scratch.clear();
  std::size_t over = 0, i = 0;
  double worst = 0;  // running maximum, enough when no outliers are allowed
  for (; i < from.size(); ++i) {
    double d2 = 0;
    to.nearest(rotation * from[i], &d2);
    if (d2 > bound2 && ++over > outliers) {
      if (visited) *visited = i + 1;
      return std::numeric_limits<double>::infinity();
    }
    if (outliers == 0)
      worst = std::max(worst, d2);
    else
      scratch.push_back(d2);
  }
  if (visited) *visited = i;
  if (outliers == 0) return std::sqrt(worst);
  const std::size_t k = scratch.size() - 1 - outliers;
  std::nth_element(scratch.begin(), scratch.begin() + static_cast<std::ptrdiff_t>(k), scratch.end());
  return std::sqrt(scratch[k]);
}

}  // namespace iires::reg
