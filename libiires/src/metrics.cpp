// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/metrics.hpp"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"

namespace iires {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Triangle = Kernel::Triangle_3;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, std::vector<Triangle>::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

Kernel::Point_3 toCgal(const Eigen::Vector3d& p) { return {p.x(), p.y(), p.z()}; }

/// Summarise distances in a fixed order (independent of how they were computed). p99 is the nearest-rank
/// 99th percentile: the ceil(0.99 n)-th smallest value.
DistanceStats summarise(std::vector<double> d) {
  DistanceStats s;
  if (d.empty()) return s;
  double sum = 0;
  for (double x : d) {
    sum += x;
    s.max = std::max(s.max, x);
  }
  s.mean = sum / static_cast<double>(d.size());
  const std::size_t rank = (99 * d.size() + 99) / 100 - 1;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(rank), d.end());
  s.p99 = d[rank];
  return s;
}

}  // namespace

SpacingStats spacingStats(const std::vector<Eigen::Vector3d>& points, int threads) {
  const std::size_t n = points.size();
  if (n < 2) return {};
  std::vector<double> nn(n, std::numeric_limits<double>::infinity());
  if (n < 64) {
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < n; ++j)
        if (i != j) nn[i] = std::min(nn[i], (points[i] - points[j]).norm());
  } else {
    const KnnIndex index(points);
    parallelFor(n, threads, [&](std::size_t i) {
      std::vector<std::uint32_t> ids;
      std::vector<double> sq;
      // The two nearest are the point itself (or an exact duplicate of it) and its nearest other point.
      index.knn(points[i], 2, ids, sq);
      nn[i] = std::sqrt(sq[1]);
    });
  }
  return summariseSpacing(nn);
}

SpacingStats summariseSpacing(const std::vector<double>& nearest) {
  SpacingStats s;
  if (nearest.empty()) return s;
  const double n = static_cast<double>(nearest.size());
  double sum = 0;
  s.min = nearest[0];
  for (double d : nearest) {
    sum += d;
    s.min = std::min(s.min, d);
    s.max = std::max(s.max, d);
  }
  s.mean = sum / n;
  double squares = 0;
  for (double d : nearest) squares += (d - s.mean) * (d - s.mean);
  s.cv = s.mean > 0 ? std::sqrt(squares / n) / s.mean : 0.0;  // population std / mean
  return s;
}

std::vector<double> sheetNeighbourDistances(const std::vector<Eigen::Vector3d>& points,
                                            const std::vector<Eigen::Vector3d>& normals, int threads) {
  if (normals.size() != points.size())
    throw std::invalid_argument("sheetNeighbourDistances: one normal per point is needed");
  if (points.size() < 2) return std::vector<double>(points.size(), 0.0);
  // On one smooth sheet two points whose normals turn by under 25° have an offset within about 12.5° of the
  // tangent plane (half the turn, on an arc): more than 15° out of it, the neighbour lies on a facing sheet.
  const double parallelCos = std::cos(25.0 * M_PI / 180.0), outSin = std::sin(15.0 * M_PI / 180.0);
  const KnnIndex index(points);
  std::vector<double> out(points.size());
  parallelFor(points.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> ids;
    std::vector<double> sq;
    const std::size_t found = index.knn(points[i], 16, ids, sq);  // itself (or a duplicate) first
    out[i] = std::sqrt(sq[std::min<std::size_t>(1, found - 1)]);
    const Eigen::Vector3d& n = normals[i];
    for (std::size_t t = 1; t < found; ++t) {
      const double d = std::sqrt(sq[t]);
      const bool facing = std::abs(n.dot(normals[ids[t]])) > parallelCos &&
                          std::abs(n.dot(points[ids[t]] - points[i])) > outSin * d;
      if (!facing) {
        out[i] = d;
        break;
      }
    }
  });
  return out;
}

struct MeshDistance::Impl {
  std::vector<Triangle> triangles;
  Tree tree;
  double diagonal = 0;
};

MeshDistance::MeshDistance(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  if (mesh.triangles.empty()) throw InputError("MeshDistance: the mesh has no triangles");
  const int n = static_cast<int>(mesh.vertices.size());
  impl_->triangles.reserve(mesh.triangles.size());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= n).any())
      throw InputError("MeshDistance: triangle refers to a missing vertex");
    impl_->triangles.emplace_back(toCgal(mesh.vertices[t[0]]), toCgal(mesh.vertices[t[1]]),
                                  toCgal(mesh.vertices[t[2]]));
  }
  impl_->tree.insert(impl_->triangles.begin(), impl_->triangles.end());
  impl_->tree.build();
  impl_->tree.accelerate_distance_queries();  // build the search structure now: queries stay const
  impl_->diagonal = bboxDiagonal(mesh.vertices);
}

MeshDistance::~MeshDistance() = default;

double MeshDistance::distance(const Eigen::Vector3d& p) const {
  return std::sqrt(impl_->tree.squared_distance(toCgal(p)));
}

DistanceStats MeshDistance::distances(const std::vector<Eigen::Vector3d>& points, int threads) const {
  std::vector<double> d(points.size());
  parallelFor(points.size(), threads, [&](std::size_t i) { d[i] = distance(points[i]); });
  return summarise(std::move(d));
}

Eigen::Vector3d MeshDistance::normal(const Eigen::Vector3d& p) const {
  const Triangle& t = *impl_->tree.closest_point_and_primitive(toCgal(p)).second;
  const Kernel::Vector_3 n = CGAL::cross_product(t[1] - t[0], t[2] - t[0]);
  const Eigen::Vector3d e(n.x(), n.y(), n.z());
  return e.norm() > 0 ? Eigen::Vector3d(e.normalized()) : Eigen::Vector3d::UnitZ();
}

double MeshDistance::diagonal() const { return impl_->diagonal; }

DistanceStats coverage(const std::vector<Eigen::Vector3d>& reference,
                       const std::vector<Eigen::Vector3d>& points, int threads) {
  if (reference.empty()) return {};
  if (points.empty()) throw InputError("coverage: no points to measure against the reference");
  const KnnIndex index(points);
  std::vector<double> d(reference.size());
  parallelFor(reference.size(), threads, [&](std::size_t i) {
    double sq = 0;
    index.nearest(reference[i], &sq);
    d[i] = std::sqrt(sq);
  });
  return summarise(std::move(d));
}

double bboxDiagonal(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return 0;
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : points) box.extend(p);
  return box.diagonal().norm();
}

double meanNeighbourSpacing(const std::vector<Eigen::Vector3d>& points, int k, int threads) {
  if (points.size() < 2) return 0.0;
  const KnnIndex index(points);
  std::vector<double> perPoint(points.size(), 0.0);
  parallelFor(points.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> ids;
    std::vector<double> sq;
    const std::size_t found = index.knn(points[i], static_cast<std::size_t>(k) + 1, ids, sq);  // itself first
    for (std::size_t j = 1; j < found; ++j) perPoint[i] += std::sqrt(sq[j]) / static_cast<double>(found - 1);
  });
  double sum = 0;
  for (double d : perPoint) sum += d;
  return sum / static_cast<double>(points.size());
}

}  // namespace iires
