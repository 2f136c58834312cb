// SPDX-License-Identifier: GPL-3.0-or-later
// Feature detection: the Voronoi covariance measure flags crease candidates, the two-plane fit confirms them.
#include "iires/features.hpp"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>
#include <CGAL/vcm_estimate_edges.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <list>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>

#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"


#include "features_internal.hpp"

namespace iires {
using namespace detail;
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// ---- Voronoi covariance measure (CGAL's compute_vcm, parallelised; see vcm_estimate_normals.h) ----------

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<std::uint32_t, K>;
using Tds = CGAL::Triangulation_data_structure_3<Vb>;
using Delaunay = CGAL::Delaunay_triangulation_3<K, Tds>;
using Covariance = std::array<double, 6>;

/// VCM of every point: covariance of its Voronoi cell ∩ ball(offset) (the ball discretised by CGAL's
/// 20-plane sphere), then summed over the points within @p convolution. The Delaunay neighbour lists are
/// gathered sequentially (CGAL's traversal marks cells), the cells are intersected in parallel.
std::vector<Covariance> computeVcm(const std::vector<Eigen::Vector3d>& pts, double offset, double convolution,
                                   int threads) {
  const std::size_t n = pts.size();
  std::vector<std::pair<K::Point_3, std::uint32_t>> input(n);
  for (std::size_t i = 0; i < n; ++i)
    input[i] = {K::Point_3(pts[i].x(), pts[i].y(), pts[i].z()), static_cast<std::uint32_t>(i)};
  Delaunay dt(input.begin(), input.end());
  // Each input point's vertex (exact duplicates share one), and its Delaunay neighbours, sorted.
  std::vector<Delaunay::Vertex_handle> vertexOf(n);
  for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v) vertexOf[v->info()] = v;
  for (std::size_t i = 0; i < n; ++i)
    if (vertexOf[i] == Delaunay::Vertex_handle() || vertexOf[i]->info() != i) vertexOf[i] = dt.nearest_vertex(input[i].first);
  std::vector<std::size_t> offsets(n + 1, 0);
  std::vector<std::uint32_t> adj;
  std::vector<Delaunay::Vertex_handle> tmp;
  for (std::size_t i = 0; i < n; ++i) {
    tmp.clear();
    dt.finite_adjacent_vertices(vertexOf[i], std::back_inserter(tmp));
    const std::size_t start = adj.size();
    for (const auto& v : tmp) adj.push_back(v->info());
    std::sort(adj.begin() + static_cast<std::ptrdiff_t>(start), adj.end());
    offsets[i + 1] = adj.size();
  }
  const CGAL::Voronoi_covariance_3::Sphere_discretization<K> sphere(offset, 20);
  std::vector<Covariance> cov(n);
  parallelFor(n, threads, [&](std::size_t i) {
    using Traits = CGAL::Convex_hull_traits_3<K, CGAL::HalfedgeDS_default<K, CGAL::HalfedgeDS_items_3>>;
    using Polyhedron = Traits::Polygon_mesh;
    std::list<K::Plane_3> planes;
    for (std::size_t e = offsets[i]; e < offsets[i + 1]; ++e) {
      const Eigen::Vector3d d = (pts[adj[e]] - pts[i]) / 2.0;
      const K::Vector_3 v(d.x(), d.y(), d.z());
      planes.emplace_back(CGAL::ORIGIN + v, v);
    }
    sphere(std::back_inserter(planes));
    Polyhedron poly;
    CGAL::halfspace_intersection_with_constructions_3(planes.begin(), planes.end(), poly,
                                                      boost::make_optional(K::Point_3(CGAL::ORIGIN)));
    CGAL::Voronoi_covariance_3::internal::Covariance_accumulator_3<double> acc;
    for (auto fd : faces(poly)) {
      CGAL::Halfedge_around_face_circulator<Polyhedron> h0(halfedge(fd, poly), poly), hf = h0--,
          hs = std::next(hf);
      while (hs != h0) {
        acc((*h0)->vertex()->point(), (*hf)->vertex()->point(), (*hs)->vertex()->point());
        ++hs;
        ++hf;
      }
    }
    cov[i] = acc.result();
  });
  if (convolution <= 0) return cov;
  KnnIndex index(pts);
  std::vector<Covariance> out(n);
  parallelFor(n, threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.radius(pts[i], convolution, idx, d2);
    std::sort(idx.begin(), idx.end());  // fixed summation order
    Covariance m{};
    for (std::uint32_t j : idx)
      for (int c = 0; c < 6; ++c) m[c] += cov[j][c];
    out[i] = m;
  });
  return out;
}

}  // namespace

void FeatureParams::validate() const {
  auto fail = [](const std::string& m) { throw std::invalid_argument("FeatureParams: " + m); };
  if (!(spacing >= 0.0)) fail("spacing must be >= 0 (0 = estimate)");
  if (!(radius >= 1.0)) fail("radius must be >= 1 spacing");
  if (!(angle > 0.0 && angle < 180.0)) fail("angle must be in (0, 180) degrees");
  if (!(maxResidual > 0.0)) fail("maxResidual must be > 0");
  if (!(maxLineDistance > 0.0)) fail("maxLineDistance must be > 0");
  if (!(minClusterShare > 0.0 && minClusterShare < 0.5)) fail("minClusterShare must be in (0, 0.5)");
  if (!(vcmOffset > 0.0)) fail("vcmOffset must be > 0");
  if (!(vcmConvolution >= 0.0)) fail("vcmConvolution must be >= 0");
  if (!(vcmThreshold > 0.0 && vcmThreshold < 1.0)) fail("vcmThreshold must be in (0, 1)");
  if (!(chainRadius > 0.0)) fail("chainRadius must be > 0");
  if (!(maxChainTurn > 0.0 && maxChainTurn < 90.0)) fail("maxChainTurn must be in (0, 90) degrees");
  if (!(minChainLength >= 0.0)) fail("minChainLength must be >= 0");
  if (!(sampleSpacing >= 0.0)) fail("sampleSpacing must be >= 0");
  if (!(snapSigma > 0.0)) fail("snapSigma must be > 0");
  if (!(maxOffCrease >= 0.0)) fail("maxOffCrease must be >= 0");
}

namespace {

/// From each point's 7 nearest in @p index: @p estimate, its mean distance to the others (estimateSpacing()'s
/// reading, a duplicate counted at 0), and @p local, the mean over those at a distance above 0 (localSpacing()'s,
/// before its floor), in one search per point.
void pointSpacings(const KnnIndex& index, const std::vector<Eigen::Vector3d>& points, int threads,
                   std::vector<double>& estimate, std::vector<double>& local) {
  estimate.assign(points.size(), 0.0);
  local.assign(points.size(), 0.0);
  parallelFor(points.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.knn(points[i], 7, idx, d2);
    double sum = 0;
    int m = 0;
    for (std::size_t t = 0; t < idx.size(); ++t)
      if (idx[t] != i) sum += std::sqrt(d2[t]), ++m;
    estimate[i] = m > 0 ? sum / m : 0.0;
    local[i] = meanNearestDistance(d2);
  });
}

/// A bound on how far the normals of the points in a ball turn: the points binned in cubes of edge @p cell, each
/// cube keeping its normals' mean direction and their widest angle from it. Every normal of a point in the cubes a
/// ball meets lies within max(angle(c, mean) + width) of the mean c of the cube around the centre, so any two of
/// them within twice that. Cheaper than gathering the ball: the detector skips the balls it bounds under the
/// crease angle (the two-plane test would find their normals too alike).
class NormalCones {
 public:
  NormalCones(const std::vector<Eigen::Vector3d>& pts, const std::vector<Eigen::Vector3d>& nrm, double cell)
      : cell_(cell) {
    for (const auto& p : pts) box_.extend(p);
    const Eigen::Vector3d extent = box_.sizes() / cell_;
    if (!(extent.maxCoeff() < static_cast<double>(kAxis - 2))) return;  // too many cubes to key: no bound
    for (std::size_t i = 0; i < pts.size(); ++i) cones_[key(pts[i])].mean += nrm[i];
    for (auto& [k, c] : cones_) c.mean = c.mean.norm() > 1e-12 ? Eigen::Vector3d(c.mean.normalized()) : Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < pts.size(); ++i) {
      Cone& c = cones_[key(pts[i])];
      c.width = c.mean.isZero() ? M_PI : std::max(c.width, std::acos(std::clamp(nrm[i].dot(c.mean), -1.0, 1.0)));
    }
  }
  /// An upper bound (radians, at most π) on the angle between the normals of any two points within @p radius of
  /// @p p, a point of the cloud.
  double spread(const Eigen::Vector3d& p, double radius) const {
    if (cones_.empty()) return M_PI;
    const auto own = cones_.find(key(p));
    if (own == cones_.end() || own->second.mean.isZero()) return M_PI;
    const Eigen::Vector3d& axis = own->second.mean;
    const Eigen::Array3i lo = cellOf(p - Eigen::Vector3d::Constant(radius)),
                         hi = cellOf(p + Eigen::Vector3d::Constant(radius));
    if ((hi - lo).maxCoeff() > 4) return M_PI;  // a point far sparser than the rest: not worth the cubes
    double widest = 0;
    for (int x = lo.x(); x <= hi.x(); ++x)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int z = lo.z(); z <= hi.z(); ++z) {
          const auto c = cones_.find(pack(x, y, z));
          if (c == cones_.end()) continue;
          if (c->second.mean.isZero()) return M_PI;
          widest = std::max(widest, std::acos(std::clamp(axis.dot(c->second.mean), -1.0, 1.0)) + c->second.width);
        }
    return std::min(M_PI, 2.0 * widest);
  }

 private:
  struct Cone {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    double width = 0;
  };
  static constexpr std::int64_t kAxis = std::int64_t{1} << 20;  // cubes per axis a key holds
  Eigen::Array3i cellOf(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d c = ((p - box_.min()) / cell_).array().floor().cwiseMax(-1.0).cwiseMin(kAxis - 2.0);
    return c.cast<int>().array();
  }
  static std::uint64_t pack(std::int64_t x, std::int64_t y, std::int64_t z) {
    return static_cast<std::uint64_t>(((x + 1) * kAxis + (y + 1)) * kAxis + (z + 1));
  }
  std::uint64_t key(const Eigen::Vector3d& p) const {
    const Eigen::Array3i c = cellOf(p);
    return pack(c.x(), c.y(), c.z());
  }
  double cell_;
  Eigen::AlignedBox3d box_;
  std::unordered_map<std::uint64_t, Cone> cones_;
};

double median(std::vector<double> v) {
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

double estimateSpacing(const std::vector<Eigen::Vector3d>& points, int threads) {
  if (points.size() < 2) return 0.0;
  std::vector<double> estimate, local;
  pointSpacings(KnnIndex(points), points, threads, estimate, local);
  return median(std::move(estimate));
}

FeatureResult detectFeatures(const PointCloud& cloud, const FeatureParams& params, const Execution& exec) {
  params.validate();
  if (cloud.size() < 8) throw InputError("feature detection needs at least 8 points, got " +
                                         std::to_string(cloud.size()));
  if (!cloud.hasNormals()) throw std::invalid_argument("detectFeatures: the cloud needs one normal per point");
  const auto& pts = cloud.points;
  const auto& nrm = cloud.normals;
  const std::size_t n = pts.size();
  FeatureResult r;
  auto t0 = Clock::now();
  KnnIndex index(pts);
  std::vector<double> estimate, local;  // each point's spacing: the median's reading and localSpacing()'s
  pointSpacings(index, pts, exec.threads, estimate, local);
  r.spacing = params.spacing > 0 ? params.spacing : median(std::move(estimate));
  const double h = r.spacing;
  if (!(h > 0)) throw InputError("feature detection: the points have zero spacing (all duplicates?)");

  std::vector<char> flag(n, 0);
  std::vector<Crease> creases(n);
  auto neighbourhood = [&](std::size_t i, std::vector<std::uint32_t>& idx, double hi) {
    std::vector<double> d2;
    index.radius(pts[i], params.radius * hi, idx, d2);
    if (idx.size() > kMaxFitPoints) idx.resize(kMaxFitPoints);  // nearest first; bounds the cost in dense clusters
  };
  if (params.detector == FeatureDetector::NormalVariation) {
    const NormalCones cones(pts, nrm, params.radius * h);
    const double skipBelow = params.angle * kDeg - 1e-4;  // a margin for the rounding of the bound
    parallelFor(n, exec.threads, [&](std::size_t i) {
      std::vector<std::uint32_t> idx;
      const double hi = std::max(h, local[i]);  // localSpacing(index, pts[i], h)
      if (cones.spread(pts[i], params.radius * hi) < skipBelow) return;  // no crease: the normals are too alike
      neighbourhood(i, idx, hi);
      flag[i] = twoPlaneTest(pts, nrm, pts[i], idx, hi, params, creases[i]) ? 1 : 0;
    });
  } else {
    const auto cov = computeVcm(pts, params.vcmOffset * h, params.vcmConvolution * h, exec.threads);
    parallelFor(n, exec.threads, [&](std::size_t i) {
      Covariance c = cov[i];
      flag[i] = CGAL::vcm_is_on_feature_edge(c, params.vcmThreshold) ? 1 : 0;
      if (!flag[i]) return;
      // The crease for the chains: the two-plane fit with the sharpness test relaxed to a 1° minimum and
      // no line-distance limit (the VCM decided; the fit only supplies the line).
      FeatureParams loose = params;
      loose.angle = 1.0;
      loose.maxLineDistance = params.radius;
      loose.maxResidual = 1e9;
      std::vector<std::uint32_t> idx;
      neighbourhood(i, idx, h);
      twoPlaneTest(pts, nrm, pts[i], idx, h, loose, creases[i]);
    });
  }
  std::vector<Eigen::Vector3d> x, d;
  for (std::size_t i = 0; i < n; ++i) {
    if (!flag[i]) continue;
    r.detectedIndices.push_back(static_cast<std::uint32_t>(i));
    if (!creases[i].valid) continue;
    x.push_back(creases[i].point);
    d.push_back(creases[i].direction);
  }
  r.creasePoints = x.size();
  r.detectSeconds = since(t0);

  t0 = Clock::now();
  r.chains = buildChains(x, d, h, params, exec.threads);
  // The final feature points: input points within maxLineDistance of a chain (densified at h/4).
  {
    std::vector<Eigen::Vector3d> dense;
    for (const auto& c : r.chains) {
      const std::size_t nv = c.points.size(), segs = c.closed ? nv : nv - 1;
      for (std::size_t t = 0; t < segs; ++t) {
        const Eigen::Vector3d &a = c.points[t], &b = c.points[(t + 1) % nv];
        const int m = std::max(1, static_cast<int>(std::ceil((b - a).norm() / (0.25 * h))));
        for (int u = 0; u < m; ++u) dense.push_back(a + (b - a) * (static_cast<double>(u) / m));
      }
      if (!c.closed && nv > 0) dense.push_back(c.points.back());
    }
    if (!dense.empty()) {
      KnnIndex chainIndex(dense);
      const double reach = params.maxLineDistance * h;
      std::vector<char> near(n, 0);
      parallelFor(n, exec.threads, [&](std::size_t i) {
        double d2 = 0;
        chainIndex.nearest(pts[i], &d2);
        near[i] = d2 <= (reach + 0.125 * h) * (reach + 0.125 * h) ? 1 : 0;
      });
      for (std::size_t i = 0; i < n; ++i)
        if (near[i]) r.featureIndices.push_back(static_cast<std::uint32_t>(i));
    }
  }
  r.chainSeconds = since(t0);
  if (params.sampleSpacing > 0) {
    t0 = Clock::now();
    std::vector<std::uint32_t> owner;
    const auto samples = sampleFeatureChains(r.chains, params.sampleSpacing, &owner);
    r.samples = snapToCreases(cloud, samples, owner, h, params, exec, &r.sampleChain);
    r.sampleSeconds = since(t0);
  }
  return r;
}

}  // namespace iires
