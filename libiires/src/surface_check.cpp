// SPDX-License-Identifier: GPL-3.0-or-later
// Whether a cloud samples a surface at all: a point set that fills a volume has no surface to resample.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "iires/detail/parallel.hpp"
#include "iires/knn.hpp"
#include "iires/validate.hpp"
#include "scan_lines.hpp"

namespace iires {
namespace {

constexpr std::size_t kMinPoints = 1000;    // fewer: a thin tube sampled that sparsely looks three-dimensional
constexpr std::size_t kMaxProbed = 20000;   // the test reads an even subsample of at most this many points
constexpr std::size_t kProbes = 256;        // neighbourhoods looked at
constexpr std::size_t kMaxScale = 2048;     // largest neighbourhood (points of the subsample)
// Surface variation λ₀/(λ₀ + λ₁ + λ₂) of a neighbourhood's covariance: 0 on a plane, 1/3 in a uniform ball.
// A noisy shell (σ = 12 % of a sphere's radius) stays under it at the largest scale, a solid over it at all.
constexpr double kFlatVariation = 0.1;
constexpr double kVolumeShare = 0.75;  // of the probes three-dimensional at every scale: the points fill a volume

/// Of point @p q and its neighbours @p idx (q itself first, as KnnIndex::knn returns them).
double variation(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& q,
                 const std::vector<std::uint32_t>& idx) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(detail::scatter(points, q, idx.data() + 1, idx.size() - 1), Eigen::EigenvaluesOnly);
  const Eigen::Vector3d l = eig.eigenvalues().cwiseMax(0.0);
  return l.sum() > 0 ? l[0] / l.sum() : 0.0;
}

}  // namespace

void checkSamplesASurface(const std::vector<Eigen::Vector3d>& points, const std::string& what, int threads) {
  const std::size_t n = points.size();
  if (n < kMinPoints) return;
  const std::size_t m = std::min(n, kMaxProbed);
  std::vector<Eigen::Vector3d> sub(m);
  for (std::size_t i = 0; i < m; ++i) sub[i] = points[i * n / m];
  const KnnIndex index(sub);
  // Neighbourhoods of 16, 64 and 256 points and a tenth of the cloud: a noisy surface is flat at one of them
  // (a thick shell at the largest), a volume at none.
  std::vector<std::size_t> scales;
  for (std::size_t k : {std::size_t{16}, std::size_t{64}, std::size_t{256}, std::min(m / 10, kMaxScale)})
    if (k >= 16 && k < m && (scales.empty() || k > scales.back())) scales.push_back(k);
  const std::size_t probes = std::min(m, kProbes);
  std::vector<char> solid(probes, 1);
  parallelFor(probes, threads, [&](std::size_t p) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    const Eigen::Vector3d& q = sub[p * m / probes];
    for (std::size_t k : scales) {
      index.knn(q, k, idx, d2);
      if (variation(sub, q, idx) <= kFlatVariation) {
        solid[p] = 0;
        return;
      }
    }
  });
  const double share = static_cast<double>(std::count(solid.begin(), solid.end(), 1)) / static_cast<double>(probes);
  if (scales.empty() || share < kVolumeShare) return;
  std::ostringstream os;
  os << what << ": the points fill a volume rather than sample a surface (" << std::lround(100 * share)
     << " % of the neighbourhoods probed are three-dimensional at every scale up to " << scales.back()
     << " points); there is no surface to resample";
  throw InputError(os.str());
}

}  // namespace iires
