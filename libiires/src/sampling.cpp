// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/sampling.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <string>

namespace iires {
namespace {

/// Independent random streams, so that e.g. adding noise does not move the underlying surface samples.
enum Stream : std::uint32_t { kSurface = 1, kNoise = 2, kOutliers = 3 };

std::mt19937_64 engine(std::uint64_t seed, Stream stream) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                    static_cast<std::uint32_t>(stream)};
  return std::mt19937_64(seq);
}

void validate(const TriangleMesh& mesh, const MeshSamplingParams& p) {
  auto fail = [](const std::string& what) { throw InputError("sampleMesh: " + what); };
  if (p.count == 0) fail("count must be at least 1");
  if (!(p.densityRatio >= 1.0) || !std::isfinite(p.densityRatio))
    fail("densityRatio must be a finite value >= 1");
  if (!(p.noise >= 0.0) || !std::isfinite(p.noise)) fail("noise must be a finite value >= 0");
  if (!(p.outlierFraction >= 0.0 && p.outlierFraction <= 1.0)) fail("outlierFraction must lie in [0, 1]");
  if (p.outlierFraction > 0 &&
      !(p.outlierMin >= 0 && p.outlierMin <= p.outlierMax && std::isfinite(p.outlierMax)))
    fail("outlier offsets need 0 <= outlierMin <= outlierMax < inf");
  const int n = static_cast<int>(mesh.vertices.size());
  for (const Eigen::Vector3i& t : mesh.triangles)
    if ((t.array() < 0).any() || (t.array() >= n).any()) fail("triangle refers to a missing vertex");
}

}  // namespace

PointCloud sampleMesh(const TriangleMesh& mesh, const MeshSamplingParams& params) {
  validate(mesh, params);
  const auto& V = mesh.vertices;
  const auto& T = mesh.triangles;

  // Area-weighted triangle choice: cumulative areas + binary search; zero-area triangles are never hit.
  std::vector<double> cumulative(T.size());
  std::vector<Eigen::Vector3d> faceNormals(T.size());
  double total = 0;
  Eigen::AlignedBox3d box;
  for (std::size_t i = 0; i < T.size(); ++i) {
    const Eigen::Vector3d cross = (V[T[i][1]] - V[T[i][0]]).cross(V[T[i][2]] - V[T[i][0]]);
    const double norm = cross.norm();
    if (norm > 0 && std::isfinite(norm)) {
      total += 0.5 * norm;
      faceNormals[i] = cross / norm;  // oriented by the winding
      for (int k = 0; k < 3; ++k) box.extend(V[T[i][k]]);
    }
    cumulative[i] = total;
  }
  if (!(total > 0)) throw InputError("sampleMesh: the mesh has no triangle of positive area");

  // Density modulation: w(t) = ratio^t along the longest box axis, accepted with probability w / ratio.
  int axis = 0;
  box.sizes().maxCoeff(&axis);
  const double lo = box.min()[axis], extent = box.sizes()[axis];
  const double logRatio = std::log(params.densityRatio);

  std::mt19937_64 rng = engine(params.seed, kSurface);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  PointCloud cloud;
  cloud.points.reserve(params.count);
  cloud.normals.reserve(params.count);
  while (cloud.points.size() < params.count) {
    const double r = unit(rng) * total;
    const std::size_t f = std::min<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), r) - cumulative.begin(), T.size() - 1);
    const double s = std::sqrt(unit(rng)), b = unit(rng);  // uniform barycentrics (1-s, s(1-b), sb)
    const Eigen::Vector3d p = (1 - s) * V[T[f][0]] + s * (1 - b) * V[T[f][1]] + s * b * V[T[f][2]];
    if (logRatio > 0) {
      const double t = extent > 0 ? std::clamp((p[axis] - lo) / extent, 0.0, 1.0) : 0.0;
      if (unit(rng) >= std::exp(logRatio * (t - 1))) continue;
    }
    cloud.points.push_back(p);
    cloud.normals.push_back(faceNormals[f]);
  }

  // Offsets along the normal: noise for every point, then outliers replace the noise of the points they hit.
  std::vector<double> offsets(cloud.size(), 0.0);
  if (params.noise > 0) {
    std::mt19937_64 noiseRng = engine(params.seed, kNoise);
    std::normal_distribution<double> gaussian(0.0, params.noise);
    std::uniform_real_distribution<double> uniform(0.0, params.noise);
    for (double& o : offsets) o = params.gaussianNoise ? gaussian(noiseRng) : uniform(noiseRng);
  }
  // Outliers: exactly round(fraction * count) distinct points (a partial Fisher–Yates shuffle picks them),
  // offset by ±uniform[outlierMin, outlierMax].
  const auto outliers = static_cast<std::size_t>(std::llround(params.outlierFraction * params.count));
  if (outliers > 0) {
    std::mt19937_64 outlierRng = engine(params.seed, kOutliers);
    std::uniform_real_distribution<double> magnitude(params.outlierMin, params.outlierMax);
    std::bernoulli_distribution positive(0.5);
    std::vector<std::size_t> order(cloud.size());
    std::iota(order.begin(), order.end(), 0);
    for (std::size_t k = 0; k < outliers; ++k) {
      std::swap(order[k], order[std::uniform_int_distribution<std::size_t>(k, order.size() - 1)(outlierRng)]);
      offsets[order[k]] = (positive(outlierRng) ? 1.0 : -1.0) * magnitude(outlierRng);
    }
  }
  for (std::size_t i = 0; i < cloud.size(); ++i) cloud.points[i] += offsets[i] * cloud.normals[i];
  return cloud;
}

}  // namespace iires
