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
#include "iires/parallel.hpp"

namespace iires {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
constexpr double kDeg = M_PI / 180.0;

/// The spacing the fits at @p y work with: the global spacing @p h, or the local one (mean distance to the 6
/// nearest points) where the sampling is sparser, so a neighbourhood of `radius` spacings always holds about
/// the same number of points (non-uniform scans: a fixed radius leaves the sparse parts with too few).
double localSpacing(const KnnIndex& index, const Eigen::Vector3d& y, double h) {
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  index.knn(y, 7, idx, d2);
  double sum = 0;
  int m = 0;
  for (std::size_t t = 0; t < idx.size() && m < 6; ++t)
    if (d2[t] > 0) sum += std::sqrt(d2[t]), ++m;
  return m > 0 ? std::max(h, sum / m) : h;
}

/// The crease at a point: the intersection line of two fitted planes.
struct Crease {
  bool valid = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< the query point projected onto the line
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  Eigen::Vector3d normalA = Eigen::Vector3d::Zero(), normalB = Eigen::Vector3d::Zero();  ///< the two planes
  double offsetA = 0, offsetB = 0;                                                      ///< normal·x = offset
};

/// Plane through the (weighted) centroid of @p pts (indices into @p points) by PCA; returns the (weighted) RMS
/// residual. @p sigma > 0: point q has weight exp(−|q − p|²/σ²); 0 = all weights 1.
double fitPlane(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                const Eigen::Vector3d& p, double sigma, const Eigen::Vector3d& hint, Eigen::Vector3d& normal,
                double& offset) {
  auto w = [&](std::uint32_t i) { return sigma > 0 ? std::exp(-(points[i] - p).squaredNorm() / (sigma * sigma)) : 1.0; };
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double sum = 0;
  for (std::uint32_t i : idx) c += w(i) * points[i], sum += w(i);
  c /= sum;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::uint32_t i : idx) {
    const Eigen::Vector3d d = points[i] - c;
    cov += w(i) * d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  normal = es.eigenvectors().col(0);
  if (normal.dot(hint) < 0) normal = -normal;
  offset = normal.dot(c);
  return std::sqrt(std::max(0.0, es.eigenvalues()(0)) / sum);
}

/// The point of the line {x : na·x = oa, nb·x = ob} (unit normals) nearest @p p: x = p + α na + β nb.
Eigen::Vector3d lineNearest(const Eigen::Vector3d& na, double oa, const Eigen::Vector3d& nb, double ob,
                            const Eigen::Vector3d& p) {
  Eigen::Matrix2d g;
  g << 1.0, na.dot(nb), na.dot(nb), 1.0;
  const Eigen::Vector2d ab = g.inverse() * Eigen::Vector2d(oa - na.dot(p), ob - nb.dot(p));
  return p + ab(0) * na + ab(1) * nb;
}

/// Two-plane fit of the neighbourhood @p nbr of the point @p p (the normal-variation test). Returns whether the
/// point is on a crease by the thresholds in @p prm; fills @p crease. @p sigma > 0: the plane fits weight each
/// point by exp(−d²/σ²), d its distance to p (local planes: less bias from curved sheets); 0 = unweighted.
bool twoPlaneTest(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                  const Eigen::Vector3d& p, const std::vector<std::uint32_t>& nbr, double h, const FeatureParams& prm,
                  Crease& crease, double sigma = 0) {
  crease = Crease{};
  const std::size_t m = nbr.size();
  if (m < 8) return false;
  // Seeds of the 2-means on normals: the normal farthest from the mean, then the one farthest from it.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::uint32_t j : nbr) mean += normals[j];
  mean.normalize();
  std::size_t a = 0, b = 0;
  for (std::size_t t = 1; t < m; ++t)
    if (normals[nbr[t]].dot(mean) < normals[nbr[a]].dot(mean)) a = t;
  for (std::size_t t = 1; t < m; ++t)
    if (normals[nbr[t]].dot(normals[nbr[a]]) < normals[nbr[b]].dot(normals[nbr[a]])) b = t;
  Eigen::Vector3d na = normals[nbr[a]], nb = normals[nbr[b]];
  if (na.dot(nb) > std::cos(prm.angle * kDeg)) return false;  // the neighbours' normals vary too little
  std::vector<char> side(m, 0);
  for (int it = 0; it < 5; ++it) {
    Eigen::Vector3d sa = Eigen::Vector3d::Zero(), sb = Eigen::Vector3d::Zero();
    for (std::size_t t = 0; t < m; ++t) {
      side[t] = normals[nbr[t]].dot(na) >= normals[nbr[t]].dot(nb) ? 0 : 1;
      (side[t] == 0 ? sa : sb) += normals[nbr[t]];
    }
    if (sa.squaredNorm() == 0 || sb.squaredNorm() == 0) return false;
    na = sa.normalized();
    nb = sb.normalized();
  }
  // Planes through each cluster's positions, refined by reassigning points to the nearer plane.
  std::vector<std::uint32_t> ca, cb;
  Eigen::Vector3d pa, pb;
  double oa = 0, ob = 0, ra = 0, rb = 0;
  const std::size_t minCount = std::max<std::size_t>(3, static_cast<std::size_t>(prm.minClusterShare * m));
  for (int it = 0; it < 3; ++it) {
    ca.clear();
    cb.clear();
    for (std::size_t t = 0; t < m; ++t) (side[t] == 0 ? ca : cb).push_back(nbr[t]);
    if (ca.size() < minCount || cb.size() < minCount) return false;
    ra = fitPlane(points, ca, p, sigma, na, pa, oa);
    rb = fitPlane(points, cb, p, sigma, nb, pb, ob);
    if (it == 2) break;
    for (std::size_t t = 0; t < m; ++t) {
      const double da = std::abs(pa.dot(points[nbr[t]]) - oa), db = std::abs(pb.dot(points[nbr[t]]) - ob);
      side[t] = da <= db ? 0 : 1;
    }
  }
  if (ra > prm.maxResidual * h || rb > prm.maxResidual * h) return false;
  const Eigen::Vector3d dir = pa.cross(pb);
  const double sinAngle = dir.norm();
  if (pa.dot(pb) > std::cos(prm.angle * kDeg) || sinAngle < 1e-6) return false;
  const Eigen::Vector3d x = lineNearest(pa, oa, pb, ob, p);
  if ((x - p).norm() > prm.maxLineDistance * h) return false;
  crease.valid = true;
  crease.point = x;
  crease.direction = dir / sinAngle;
  crease.normalA = pa;
  crease.normalB = pb;
  crease.offsetA = oa;
  crease.offsetB = ob;
  return true;
}

constexpr std::size_t kMaxFitPoints = 200;  // a snap fit uses at most this many input points, the nearest

/// The snap fit at @p y: twoPlaneTest() with thresholds @p prm on the input points within params.radius local
/// spacings @p hl of y (the kMaxFitPoints nearest), weighted at params.snapSigma·hl. @p idx keeps that
/// neighbourhood for a caller that refits part of it; @p d2 is scratch.
bool snapFit(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& y, double hl,
             const FeatureParams& params, const FeatureParams& prm, Crease& c, std::vector<std::uint32_t>& idx,
             std::vector<double>& d2) {
  index.radius(y, params.radius * hl, idx, d2);
  if (idx.size() > kMaxFitPoints) idx.resize(kMaxFitPoints);
  return twoPlaneTest(cloud.points, cloud.normals, y, idx, hl, prm, c, params.snapSigma * hl);
}

/// The looser thresholds of the VCM detector's lines, for a snap fit where a chain already says a crease is:
/// any angle over 1°, twice the residual, half the cluster share.
FeatureParams looseParams(const FeatureParams& params) {
  FeatureParams loose = params;
  loose.angle = 1.0;
  loose.maxResidual = 2.0 * params.maxResidual;
  loose.minClusterShare = 0.5 * params.minClusterShare;
  return loose;
}

/// The crease at @p y running along ±@p dir (within params.maxChainTurn): the snap fit, else two planes fitted
/// on the points behind y only (an end where the crease stops ahead, or another crease crowds the ball ahead);
/// @p oneSided says the second held. @p idx keeps the ball, @p d2 and @p behind are scratch.
bool creaseAlong(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& y,
                 const Eigen::Vector3d& dir, double hl, const FeatureParams& params, Crease& c,
                 std::vector<std::uint32_t>& idx, std::vector<double>& d2, std::vector<std::uint32_t>& behind,
                 bool& oneSided) {
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  oneSided = false;
  if (snapFit(cloud, index, y, hl, params, params, c, idx, d2) && std::abs(c.direction.dot(dir)) >= cosTurn)
    return true;
  behind.clear();
  for (std::uint32_t j : idx)
    if ((cloud.points[j] - y).dot(dir) <= 0) behind.push_back(j);
  oneSided = twoPlaneTest(cloud.points, cloud.normals, y, behind, hl, params, c, params.snapSigma * hl) &&
             std::abs(c.direction.dot(dir)) >= cosTurn;
  return oneSided;
}

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

// ---- chains ---------------------------------------------------------------------------------------------

struct Dsu {
  std::vector<std::uint32_t> parent;
  explicit Dsu(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
};

struct TreeEdge {
  std::uint32_t to;
  double w;
};

/// Farthest vertex from @p src within the alive part of a forest (weighted), with parent links.
std::uint32_t farthest(const std::vector<std::vector<TreeEdge>>& g, const std::vector<char>& alive,
                       std::uint32_t src, std::vector<double>& dist, std::vector<std::int64_t>& parent,
                       std::vector<std::uint32_t>& visited) {
  visited.clear();
  std::vector<std::uint32_t> stack{src};
  dist[src] = 0;
  parent[src] = -1;
  std::uint32_t best = src;
  while (!stack.empty()) {
    const std::uint32_t u = stack.back();
    stack.pop_back();
    visited.push_back(u);
    if (dist[u] > dist[best] || (dist[u] == dist[best] && u < best)) best = u;
    for (const TreeEdge& e : g[u])
      if (alive[e.to] && static_cast<std::int64_t>(e.to) != parent[u]) {
        parent[e.to] = u;
        dist[e.to] = dist[u] + e.w;
        stack.push_back(e.to);
      }
  }
  return best;
}

double arcLength(const FeatureChain& c) {
  double len = 0;
  for (std::size_t t = 1; t < c.points.size(); ++t) len += (c.points[t] - c.points[t - 1]).norm();
  return len;
}

/// Denoise a chain: every vertex is projected onto the line fitted (PCA) to the vertices within ±w of it;
/// directions become the fitted lines' directions, oriented along the chain. Removes the per-point jitter
/// of the crease estimates, also across the crease, without shrinking the ends.
void fitLocalLines(FeatureChain& c, int w) {
  const std::size_t n = c.points.size();
  if (n == 2)
    for (auto& dd : c.directions)
      if (dd.dot(c.points[1] - c.points[0]) < 0) dd = -dd;
  if (n < 3) return;
  std::vector<Eigen::Vector3d> p(n), d(n);
  for (std::size_t t = 0; t < n; ++t) {
    const std::size_t lo = t >= static_cast<std::size_t>(w) ? t - w : 0, hi = std::min(n - 1, t + w);
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (std::size_t u = lo; u <= hi; ++u) m += c.points[u];
    m /= static_cast<double>(hi - lo + 1);
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (std::size_t u = lo; u <= hi; ++u) cov += (c.points[u] - m) * (c.points[u] - m).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    Eigen::Vector3d dir = es.eigenvectors().col(2);
    if (dir.dot(c.points[hi] - c.points[lo]) < 0) dir = -dir;
    p[t] = m + dir * (c.points[t] - m).dot(dir);
    d[t] = dir;
  }
  c.points.swap(p);
  c.directions.swap(d);
}

/// An open chain end: its position and the unit direction pointing out of the chain.
struct ChainEnd {
  std::size_t chain;
  bool back;
  Eigen::Vector3d pos, out;
};

std::vector<ChainEnd> openEnds(const std::vector<FeatureChain>& chains) {
  std::vector<ChainEnd> ends;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const auto& ch = chains[c];
    if (ch.closed || ch.points.size() < 2) continue;
    ends.push_back({c, false, ch.points.front(), -ch.directions.front()});
    ends.push_back({c, true, ch.points.back(), ch.directions.back()});
  }
  return ends;
}

/// Post-processing of the raw chains (paths of crease points):
///  1. local line fits (denoising);
///  2. the ends (where a third surface or a fading crease biases the fit) are trimmed by one
///     neighbourhood radius and re-grown along the end line;
///  3. chains whose ends meet head-on are joined (and a chain meeting itself is closed);
///  4. an end whose line meets another end's line (a corner) or another chain (a T-junction) within reach is
///     extended to the meeting point, so the feature lines reach their corners;
///  5. deterministic orientation and order (longest first).
void finishChains(std::vector<FeatureChain>& chains, double h, const FeatureParams& prm) {
  const double link = prm.chainRadius * h, cosTurn = std::cos(prm.maxChainTurn * kDeg);
  const double trim = prm.radius * h, tol = 2.0 * prm.maxLineDistance * h;
  for (auto& c : chains) {
    fitLocalLines(c, 6);
    // 2. trim the biased ends, remember by how much, and grow back along the end lines.
    if (arcLength(c) > 4 * trim) {
      for (int side = 0; side < 2; ++side) {
        std::reverse(c.points.begin(), c.points.end());
        std::reverse(c.directions.begin(), c.directions.end());
        for (auto& dd : c.directions) dd = -dd;
        const Eigen::Vector3d end = c.points.back();
        while (c.points.size() > 2 && (c.points.back() - end).norm() < trim) {
          c.points.pop_back();
          c.directions.pop_back();
        }
        // End line: PCA of the last vertices (beyond the trimmed part).
        const std::size_t n = c.points.size(), lo = n > 12 ? n - 12 : 0;
        Eigen::Vector3d m = Eigen::Vector3d::Zero();
        for (std::size_t u = lo; u < n; ++u) m += c.points[u];
        m /= static_cast<double>(n - lo);
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (std::size_t u = lo; u < n; ++u) cov += (c.points[u] - m) * (c.points[u] - m).transpose();
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
        Eigen::Vector3d dir = es.eigenvectors().col(2);
        if (dir.dot(c.points.back() - c.points[lo]) < 0) dir = -dir;
        const Eigen::Vector3d tip = m + dir * (end - m).dot(dir);
        c.points.push_back(tip);
        c.directions.push_back(dir);
        c.directions[n - 1] = dir;
      }
    }
  }
  // 3. join head-on ends: candidate pairs of ends (anti-parallel end directions, each end on the other's end
  // line, gap up to 4 links: random samplings leave stretches of a crease with no point close enough to be
  // detected), accepted greedily nearest first, each end once; a group meeting itself is closed.
  {
    const std::size_t nc = chains.size();
    std::vector<Eigen::Vector3d> pos(2 * nc), out(2 * nc);
    for (std::size_t c = 0; c < nc; ++c) {
      pos[2 * c] = chains[c].points.front();
      out[2 * c] = -chains[c].directions.front();
      pos[2 * c + 1] = chains[c].points.back();
      out[2 * c + 1] = chains[c].directions.back();
    }
    std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> pairs;
    if (nc > 0) {
      KnnIndex endIndex(pos);
      std::vector<std::uint32_t> idx;
      std::vector<double> d2;
      for (std::uint32_t a = 0; a < 2 * nc; ++a) {
        endIndex.radius(pos[a], 4 * link, idx, d2);
        for (std::uint32_t b : idx) {
          if (b <= a) continue;
          const Eigen::Vector3d gap = pos[b] - pos[a];
          const double len = gap.norm();
          if (-out[a].dot(out[b]) < cosTurn) continue;
          if (len > tol && (out[a].dot(gap) < cosTurn * len || -out[b].dot(gap) < cosTurn * len)) continue;
          const double offA = (gap - out[a] * gap.dot(out[a])).norm();
          const double offB = (gap - out[b] * gap.dot(out[b])).norm();
          if (len > link && std::max(offA, offB) > tol) continue;
          pairs.emplace_back(len, a, b);
        }
      }
    }
    std::sort(pairs.begin(), pairs.end());
    std::vector<std::int64_t> partner(2 * nc, -1);
    Dsu groups(nc);
    std::vector<double> groupLength(nc);
    for (std::size_t c = 0; c < nc; ++c) groupLength[c] = arcLength(chains[c]);
    for (const auto& [len, a, b] : pairs) {
      if (partner[a] >= 0 || partner[b] >= 0) continue;
      const std::uint32_t ga = groups.find(a / 2), gb = groups.find(b / 2);
      if (ga == gb && groupLength[ga] < 3 * link) continue;  // closing a loop: only a long one
      partner[a] = b;
      partner[b] = a;
      if (ga != gb) {
        groups.parent[ga] = gb;
        groupLength[gb] += groupLength[ga] + len;
      }
    }
    // Assemble: walk each group from a free end (or anywhere, for a loop), appending chains in order.
    std::vector<FeatureChain> joined;
    std::vector<char> used(nc, 0);
    auto append = [](FeatureChain& dst, const FeatureChain& src, bool reversed) {
      if (!reversed) {
        dst.points.insert(dst.points.end(), src.points.begin(), src.points.end());
        dst.directions.insert(dst.directions.end(), src.directions.begin(), src.directions.end());
      } else {
        for (std::size_t t = src.points.size(); t-- > 0;) {
          dst.points.push_back(src.points[t]);
          dst.directions.push_back(-src.directions[t]);
        }
      }
    };
    for (std::size_t c0 = 0; c0 < nc; ++c0) {
      if (used[c0]) continue;
      // Find the start: go out through front ends until a free end or back to c0.
      std::uint32_t entry = static_cast<std::uint32_t>(2 * c0);  // the end through which we enter the chain
      bool loop = false;
      for (std::size_t guard = 0; guard <= nc; ++guard) {
        if (partner[entry] < 0) break;
        const std::uint32_t nextExit = static_cast<std::uint32_t>(partner[entry]);
        entry = nextExit ^ 1u;  // enter the neighbour through its other end when walking backwards
        if (entry / 2 == c0) {
          loop = true;
          entry = static_cast<std::uint32_t>(2 * c0);
          break;
        }
      }
      FeatureChain g;
      std::uint32_t e = entry;
      for (;;) {
        const std::uint32_t c = e / 2;
        if (used[c]) break;
        used[c] = 1;
        append(g, chains[c], (e & 1u) != 0);  // entering through the back end: traverse reversed
        const std::int64_t nxt = partner[e ^ 1u];
        if (nxt < 0) break;
        e = static_cast<std::uint32_t>(nxt);
      }
      g.closed = loop;
      joined.push_back(std::move(g));
    }
    // Drop what is still short after joining.
    chains.clear();
    for (auto& g : joined)
      if (g.points.size() >= 2 && arcLength(g) >= prm.minChainLength * h) chains.push_back(std::move(g));
  }
  // 4. corners and T-junctions: extend each open end to where its line meets another end's line or chain.
  const double reach = 2 * link + trim;
  const auto ends = openEnds(chains);
  std::vector<std::pair<std::size_t, Eigen::Vector3d>> extensions;  // (end index, new tip)
  for (std::size_t a = 0; a < ends.size(); ++a) {
    const ChainEnd& e = ends[a];
    double bestS = reach;
    Eigen::Vector3d tip;
    bool found = false;
    for (std::size_t b = 0; b < ends.size(); ++b) {  // line–line closest approach, both ahead of their ends
      const ChainEnd& f = ends[b];
      if (b == a || f.chain == e.chain || (f.pos - e.pos).norm() > 2 * reach) continue;
      const double bb = e.out.dot(f.out), denom = 1 - bb * bb;
      if (denom < 0.1) continue;  // near-parallel lines: a join, not a corner
      const Eigen::Vector3d w = e.pos - f.pos;
      const double dd = e.out.dot(w), ee = f.out.dot(w);
      const double s = (bb * ee - dd) / denom, t = (ee - bb * dd) / denom;
      if (s < -tol || t < -tol || s > reach || t > reach) continue;
      const Eigen::Vector3d pe = e.pos + s * e.out, pf = f.pos + t * f.out;
      if ((pe - pf).norm() > tol || s >= bestS) continue;
      bestS = s;
      tip = 0.5 * (pe + pf);
      found = true;
    }
    for (std::size_t c = 0; c < chains.size(); ++c) {  // T-junction: the ray hits another chain's vertex
      if (c == e.chain) continue;
      for (const auto& v : chains[c].points) {
        const double s = (v - e.pos).dot(e.out);
        if (s < 0 || s >= bestS || (v - e.pos - s * e.out).norm() > tol) continue;
        bestS = s;
        tip = v;
        found = true;
      }
    }
    if (found && bestS > 1e-9 * h) extensions.emplace_back(a, tip);
  }
  for (const auto& [a, tip] : extensions) {
    FeatureChain& c = chains[ends[a].chain];
    if (ends[a].back) {
      c.points.push_back(tip);
      c.directions.push_back(c.directions.back());
    } else {
      c.points.insert(c.points.begin(), tip);
      c.directions.insert(c.directions.begin(), c.directions.front());
    }
  }
  // 5. lengths, orientation, order.
  for (auto& c : chains) {
    c.length = arcLength(c);
    if (c.closed) c.length += (c.points.back() - c.points.front()).norm();
    auto lex = [](const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
      return std::tie(p.x(), p.y(), p.z()) < std::tie(q.x(), q.y(), q.z());
    };
    if (lex(c.points.back(), c.points.front())) {
      std::reverse(c.points.begin(), c.points.end());
      std::reverse(c.directions.begin(), c.directions.end());
      for (auto& dd : c.directions) dd = -dd;
    }
  }
  std::stable_sort(chains.begin(), chains.end(),
                   [](const FeatureChain& a, const FeatureChain& b) { return a.length > b.length; });
}

std::vector<FeatureChain> buildChains(const std::vector<Eigen::Vector3d>& x0,
                                      const std::vector<Eigen::Vector3d>& d0, double h, const FeatureParams& prm) {
  std::vector<FeatureChain> chains;
  std::vector<Eigen::Vector3d> x, d;
  const double link = prm.chainRadius * h, cosTurn = std::cos(prm.maxChainTurn * kDeg);
  // Thin the crease points to a minimum separation of h/2 (in index order, deterministic): on a line of
  // well-separated points the minimum spanning tree is a path, not a zigzag with parallel branches.
  {
    KnnIndex all(x0);
    std::vector<char> removed(x0.size(), 0);
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    for (std::size_t i = 0; i < x0.size(); ++i) {
      if (removed[i]) continue;
      all.radius(x0[i], 0.5 * h, idx, d2);
      for (std::uint32_t j : idx)
        if (j > i) removed[j] = 1;
    }
    for (std::size_t i = 0; i < x0.size(); ++i)
      if (!removed[i]) {
        x.push_back(x0[i]);
        d.push_back(d0[i]);
      }
  }
  const std::size_t n = x.size();
  if (n < 2) return chains;
  // Candidate links: within `link`, directions and the link itself along the crease.
  KnnIndex index(x);
  std::vector<std::vector<std::pair<std::uint32_t, double>>> cand(n);
  parallelFor(n, prm.threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.radius(x[i], link, idx, d2);
    for (std::size_t t = 0; t < idx.size(); ++t) {
      const std::uint32_t j = idx[t];
      if (j <= i) continue;
      if (std::abs(d[i].dot(d[j])) < cosTurn) continue;
      const double len = std::sqrt(d2[t]);
      if (len > 1e-12 * h && std::abs((x[j] - x[i]).dot(d[i])) < cosTurn * len) continue;
      cand[i].emplace_back(j, len);
    }
  });
  std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> edges;
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& [j, w] : cand[i]) edges.emplace_back(w, static_cast<std::uint32_t>(i), j);
  std::sort(edges.begin(), edges.end());
  // Minimum spanning forest (Kruskal; ties broken by indices → deterministic).
  Dsu dsu(n);
  std::vector<std::vector<TreeEdge>> g(n);
  for (const auto& [w, a, b] : edges) {
    const std::uint32_t ra = dsu.find(a), rb = dsu.find(b);
    if (ra == rb) continue;
    dsu.parent[ra] = rb;
    g[a].push_back({b, w});
    g[b].push_back({a, w});
  }
  // Peel each tree into longest paths (its diameter, then the diameters of what remains).
  std::vector<char> alive(n, 1);
  std::vector<double> dist(n, 0);
  std::vector<std::int64_t> parent(n, -1);
  std::vector<std::uint32_t> visited;
  std::vector<char> peeled(n, 0);
  const double minLen = prm.minChainLength * h;
  for (std::uint32_t s = 0; s < n; ++s) {
    while (alive[s]) {
      const std::uint32_t a = farthest(g, alive, s, dist, parent, visited);
      const std::uint32_t b = farthest(g, alive, a, dist, parent, visited);
      const double len = dist[b];
      std::vector<std::uint32_t> path;
      for (std::int64_t v = b; v >= 0; v = parent[v]) path.push_back(static_cast<std::uint32_t>(v));
      // A tree's first path (its diameter) is kept however short: chainsJoin may bridge it to others across a
      // sampling gap. Later paths are branches of an already peeled tree: spurs unless long.
      const std::uint32_t tree = dsu.find(s);
      const bool first = !peeled[tree];
      peeled[tree] = 1;
      if (!first && len < minLen) {  // a spur: drop what remains of this piece
        for (std::uint32_t v : visited) alive[v] = 0;
        break;
      }
      for (std::uint32_t v : path) alive[v] = 0;
      FeatureChain c;
      for (std::uint32_t v : path) {
        c.points.push_back(x[v]);
        c.directions.push_back(d[v]);
      }
      chains.push_back(std::move(c));
    }
  }
  finishChains(chains, h, prm);
  return chains;
}

struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    return static_cast<std::size_t>(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
  }
};

double segmentDistance(const Eigen::Vector3d& p, const Segment& s) {
  const Eigen::Vector3d e = s[1] - s[0];
  const double l2 = e.squaredNorm();
  const double t = l2 > 0 ? std::clamp((p - s[0]).dot(e) / l2, 0.0, 1.0) : 0.0;
  return (s[0] + t * e - p).norm();
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

/// Each of @p idx to the nearest of three planes (n·x = o), if within @p tol of it: @p part[k] for plane k.
void partitionByPlanes(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                       const Eigen::Vector3d (&n)[3], const double (&o)[3], double tol,
                       std::vector<std::uint32_t> (&part)[3]) {
  for (auto& pt : part) pt.clear();
  for (std::uint32_t j : idx) {
    int best = 0;
    double bd = 1e300;
    for (int k = 0; k < 3; ++k) {
      const double dk = std::abs(n[k].dot(points[j]) - o[k]);
      if (dk < bd) bd = dk, best = k;
    }
    if (bd <= tol) part[best].push_back(j);
  }
}

/// [first, last] of each run of consecutive samples with the same @p owner (one chain's samples), in order.
std::vector<std::pair<std::size_t, std::size_t>> ownerRuns(const std::vector<std::uint32_t>& owner) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t a = 0; a < owner.size();) {
    std::size_t b = a;
    while (b + 1 < owner.size() && owner[b + 1] == owner[a]) ++b;
    runs.emplace_back(a, b);
    a = b + 1;
  }
  return runs;
}

/// Continue every open run of chain samples (@p out, consecutive samples of one chain in @p owner) along its
/// crease: from the end sample, step forward by the run's end spacing, fit the two sheets' local planes there
/// (the snap fit) and put the next sample on their intersection, while the fit passes the detector's thresholds,
/// its crease runs along the run (within maxChainTurn) and the new sample is not within 0.75 steps of a sample
/// already placed (then the gap to another chain, or to the run's own other end, is bridged). Where the full
/// ball fails, the two sheets are fitted on the half-ball behind the prediction; if the points ahead that
/// neither plane explains fit a third plane, the crease ends at a corner on it: the gap to the corner is filled,
/// a corner sample placed, and the corner's two other creases (the third plane's intersections with the two
/// sheets, on the side where each sheet lies) are followed as new runs: along the known planes while the points
/// around stay explained by them, handing over to the stepped fit once it holds. Fills the stretches of a crease
/// the detector missed, brings the ends into their corners and recovers short creases between corners.
/// New runs get chain indices after the existing ones. Sequential in a fixed order (each trace sees the
/// samples placed before it): deterministic.
void traceChainEnds(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                    std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
  struct Run {
    std::uint32_t chain;
    std::vector<Eigen::Vector3d> front, pts;  // front: traced off the first sample, outward order
  };
  std::vector<Run> runs;
  std::uint32_t nextChain = 0;
  for (const auto& [a, b] : ownerRuns(owner)) {
    nextChain = std::max(nextChain, owner[a] + 1);
    // A chain's run is split where samples were dropped (a gap over 1.6 × its median spacing): the pieces'
    // ends are traced like the chain's, so the gap is filled from both sides.
    std::vector<double> gaps;
    for (std::size_t t = a; t < b; ++t) gaps.push_back((out[t + 1] - out[t]).norm());
    double median = 0;
    if (!gaps.empty()) {
      std::vector<double> sorted(gaps);
      std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
      median = sorted[sorted.size() / 2];
    }
    std::size_t first = a;
    for (std::size_t t = a; t <= b; ++t)
      if (t == b || gaps[t - a] > 1.6 * median) {
        runs.push_back({owner[a], {}, std::vector<Eigen::Vector3d>(out.begin() + static_cast<long>(first), out.begin() + static_cast<long>(t + 1))});
        first = t + 1;
      }
  }
  struct Job {
    std::size_t run;
    bool back;  // appends to the run's back (else to its front list)
    Eigen::Vector3d tip, dir;
    double step;
  };
  std::vector<Job> jobs;
  std::vector<double> steps;  // the runs' end spacings: a lone sample's runs get their median
  for (const Run& run : runs)
    if (run.pts.size() >= 2) steps.push_back((run.pts[1] - run.pts[0]).norm());
  double typicalStep = 0;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
    typicalStep = steps[steps.size() / 2];
  }
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const auto& p = runs[r].pts;
    if (p.size() == 1 && typicalStep > 0) {
      // A lone sample (a piece of a chain between two gaps): traced both ways along its own crease.
      std::vector<std::uint32_t> idx;
      std::vector<double> d2;
      const double hs = localSpacing(index, p[0], h);
      Crease c;
      if (snapFit(cloud, index, p[0], hs, params, params, c, idx, d2)) {
        jobs.push_back({r, false, p[0], -c.direction, typicalStep});
        jobs.push_back({r, true, p[0], c.direction, typicalStep});
      }
      continue;
    }
    if (p.size() < 2) continue;
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3d tip = side ? p.back() : p.front(), prev = side ? p[p.size() - 2] : p[1];
      const double step = (tip - prev).norm();
      if (step > 1e-9 * h) jobs.push_back({r, side == 1, tip, (tip - prev) / step, step});
    }
  }
  std::vector<Eigen::Vector3d> all(out);  // every sample placed so far (brute-force proximity: a few thousand)
  // Never more crease samples than input points (they are spaced at least a chain step apart): past that, no job
  // steps on. Bounds the work on degenerate input (a fuzzer find: branches spawning branches along a crease of
  // tiny steps ran for minutes) and nearPlaced()'s brute force.
  const std::size_t budget = out.size() + cloud.points.size() + 64;
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  std::vector<std::uint32_t> idx, behind, ahead;
  std::vector<double> d2;
  auto nearPlaced = [&](const Eigen::Vector3d& y, const Eigen::Vector3d& except, double step) {
    for (const auto& q : all)
      if ((q - y).squaredNorm() < 0.5625 * step * step && (q - except).squaredNorm() > 1e-24) return true;
    return false;
  };
  // The regular stepped fit at y (full ball, else the half-ball behind along dir).
  double hl = h;  // the local spacing at the last fit (localSpacing)
  auto fitAt = [&](Eigen::Vector3d& y, const Eigen::Vector3d& dir, Crease& c, bool& oneSided) {
    bool ok = true;
    oneSided = false;
    hl = localSpacing(index, y, h);
    for (int it = 0; it < 2 && ok; ++it) {  // fitted at the prediction, then re-centred on the crease
      ok = creaseAlong(cloud, index, y, dir, hl, params, c, idx, d2, behind, oneSided);
      if (ok) y = c.point;
    }
    return ok;
  };
  const std::size_t inputRuns = runs.size();     // the runs after it are corners' branches
  std::vector<char> tracedFrom(runs.size(), 0);  // a job of the run added a sample or a corner's branch
  for (std::size_t jb = 0; jb < jobs.size() && all.size() <= budget; ++jb) {
    const Job job = jobs[jb];
    const std::size_t runsBefore = runs.size();
    std::vector<Eigen::Vector3d> added;
    Eigen::Vector3d tip = job.tip, dir = job.dir;
    const double step = job.step;
    // A corner ahead of @p o on the crease of @p c: points ahead of o (in the ball half a step on, radius + half
    // a step) that neither plane explains belong to a third sheet (off both planes by 3·maxResidual, a normal
    // unlike both, off the rounded crease); its plane is fitted, the corner refined as the three planes'
    // intersection. On success the gap from the tip is filled, the corner placed and its two other creases
    // followed (1). A third plane within the detector's angle of one sheet but not of the other is no corner but
    // the crease bending on (a faceted or small cylinder beside a plane): @p bend gets the next sample, one step
    // on along the other sheet ∩ the third plane (2). Else 0.
    auto cornerAhead = [&](const Crease& c, const Eigen::Vector3d& o, std::vector<Eigen::Vector3d>& added,
                           Crease* bend) -> int {
      const Eigen::Vector3d y = o + 0.5 * step * dir;
      const double hc = localSpacing(index, y, h), tolc = 3.0 * params.maxResidual * hc;
      const double reachC = params.radius * hc + 0.5 * step;
      // A third sheet's point: off both planes, with a normal unlike both, and not on the (rounded) crease.
      const double cosSheet = std::cos(0.5 * params.angle * kDeg);
      auto unexplained = [&](std::uint32_t j) {
        const Eigen::Vector3d& q = cloud.points[j];
        const Eigen::Vector3d& nq = cloud.normals[j];
        const Eigen::Vector3d off = q - c.point - c.direction * (q - c.point).dot(c.direction);
        return std::abs(c.normalA.dot(q) - c.offsetA) > tolc && std::abs(c.normalB.dot(q) - c.offsetB) > tolc &&
               std::abs(nq.dot(c.normalA)) < cosSheet && std::abs(nq.dot(c.normalB)) < cosSheet && off.norm() > hc;
      };
      index.radius(y, reachC, idx, d2);
      if (idx.size() > 400) idx.resize(400);
      behind.clear();
      for (std::uint32_t j : idx)
        if ((cloud.points[j] - o).dot(dir) <= 0) behind.push_back(j);
      bool placed = false;
      ahead.clear();
      for (std::uint32_t j : idx)
        if ((cloud.points[j] - o).dot(dir) > 0 && unexplained(j)) ahead.push_back(j);  // ahead of the tip
      if (ahead.size() >= 6) {
        Eigen::Vector3d n3;
        double o3 = 0, r3 = 0, along = 0;
        Eigen::Vector3d corner = c.point;
        // The third sheet's plane, refitted to the unexplained points around the corner estimate.
        for (int it = 0; it < 3; ++it) {
          if (ahead.size() < 6) break;
          r3 = fitPlane(cloud.points, ahead, y, 0, dir, n3, o3);
          along = n3.dot(c.direction);
          if (std::abs(along) <= 0.3) break;
          corner = c.point + ((o3 - n3.dot(c.point)) / along) * c.direction;  // the crease line meets it
          if (it == 2) break;
          std::vector<std::uint32_t> around;
          std::vector<double> ad2;
          index.radius(corner, params.radius * hc, around, ad2);
          ahead.clear();
          for (std::uint32_t j : around)
            if (unexplained(j)) ahead.push_back(j);
        }
        if (r3 <= 2.0 * params.maxResidual * hc && std::abs(along) > 0.3) {
          // The corner as the three sheets' common point: the points around it go to the nearest of the three
          // planes, each plane is refitted to its points (twice), and the planes are intersected.
          Crease cc = c;
          {
            Eigen::Vector3d pn[3] = {c.normalA, c.normalB, n3};
            double po[3] = {c.offsetA, c.offsetB, o3};
            std::vector<std::uint32_t> around, part[3];
            std::vector<double> ad2;
            index.radius(corner, params.radius * hc, around, ad2);
            for (int it = 0; it < 2; ++it) {
              partitionByPlanes(cloud.points, around, pn, po, tolc, part);
              Eigen::Vector3d tn[3];
              double to[3];
              bool fitted = true;
              for (int k = 0; k < 3 && fitted; ++k)
                fitted = part[k].size() >= 5 &&
                         fitPlane(cloud.points, part[k], corner, 0, pn[k], tn[k], to[k]) <= 2.0 * params.maxResidual * hc;
              if (!fitted) break;
              Eigen::Matrix3d m;
              m << tn[0].transpose(), tn[1].transpose(), tn[2].transpose();
              if (std::abs(m.determinant()) < 0.1) break;
              const Eigen::Vector3d k3 = m.inverse() * Eigen::Vector3d(to[0], to[1], to[2]);
              if ((k3 - corner).norm() > hc) break;
              for (int k = 0; k < 3; ++k) pn[k] = tn[k], po[k] = to[k];
              corner = k3;
            }
            cc.normalA = pn[0];
            cc.normalB = pn[1];
            cc.offsetA = po[0];
            cc.offsetB = po[1];
            const Eigen::Vector3d d = pn[0].cross(pn[1]);
            if (d.norm() > 1e-6) cc.direction = d.normalized() * (d.dot(c.direction) < 0 ? -1.0 : 1.0);
            n3 = pn[2];
            o3 = po[2];
          }
          // A sheet curving on (a small cylinder beside a plane): its points ahead fit a "third plane" within
          // the detector's angle of it, while the other sheet meets that plane at a crease. No corner then: the
          // crease bends; the next sample goes one step on along the other sheet ∩ the third plane.
          const double cosSharp = std::cos(params.angle * kDeg);
          const bool smoothA = std::abs(cc.normalA.dot(n3)) > cosSharp, smoothB = std::abs(cc.normalB.dot(n3)) > cosSharp;
          if (smoothA != smoothB) {
            const Eigen::Vector3d nO = smoothA ? cc.normalB : cc.normalA;
            const double oO = smoothA ? cc.offsetB : cc.offsetA;
            Eigen::Vector3d d = nO.cross(n3);
            if (d.norm() < 0.3) return 0;
            d.normalize();
            if (d.dot(dir) < 0) d = -d;
            if (d.dot(dir) < cosTurn) return 0;
            // The line's point nearest the tip, then one step on along it.
            const Eigen::Vector3d foot = lineNearest(nO, oO, n3, o3, tip);
            if ((foot - tip).norm() > 0.5 * step) return 0;
            const Eigen::Vector3d yb = foot + (step - (foot - tip).dot(dir)) / d.dot(dir) * d;
            double nb = 0;
            index.nearest(yb, &nb);
            if (std::sqrt(nb) > params.maxOffCrease * localSpacing(index, yb, h)) return 0;
            bend->valid = true;
            bend->point = yb;
            bend->direction = d;
            bend->normalA = nO;
            bend->offsetA = oO;
            bend->normalB = n3;
            bend->offsetB = o3;
            return 2;
          }
          const double ahead3 = (corner - tip).dot(dir);
          double nearest = 0;
          index.nearest(corner, &nearest);
          if (ahead3 > 0 && ahead3 < step + params.radius * hc && std::sqrt(nearest) <= params.maxOffCrease * hc) {
            // Fill tip → corner at ≤ step spacing (the corner itself unless a placed sample is there). A traced
            // tip closer than half a step to the corner moves onto it; an original one stands for it.
            bool cornerTaken = false;
            if ((corner - tip).norm() < 0.5 * step) {
              if (!added.empty() && all.back() == added.back()) {
                added.back() = corner;
                all.back() = corner;
                tip = corner;
              }
              cornerTaken = true;
            }
            const bool takenByOther = nearPlaced(corner, tip, step);  // its branches are followed already
            cornerTaken = cornerTaken || takenByOther;
            const double gap = (corner - tip).norm();
            const int pieces = std::max(1, static_cast<int>(std::ceil(gap / step - 0.25)));
            for (int k = 1; k <= pieces; ++k) {
              const Eigen::Vector3d q = tip + (corner - tip) * (static_cast<double>(k) / pieces);
              if (k == pieces ? cornerTaken : nearPlaced(q, tip, step)) break;
              added.push_back(q);
              all.push_back(q);
            }
            placed = true;
            if (!takenByOther) {
              // The corner's other two creases: third plane ∩ each sheet, leaving on the side where the sheet
              // lies (its points' offset from the crease line, within its plane).
              const std::vector<std::uint32_t> halfBall = behind;  // fitAt below reuses `behind`
              for (int sheet = 0; sheet < 2; ++sheet) {
                const Eigen::Vector3d nS = sheet ? cc.normalB : cc.normalA;
                const double oS = sheet ? cc.offsetB : cc.offsetA;
                const Eigen::Vector3d nO = sheet ? cc.normalA : cc.normalB;
                const double oO = sheet ? cc.offsetA : cc.offsetB;
                Eigen::Vector3d u = nS.cross(n3);
                if (u.norm() < 0.3) continue;
                // No crease between the sheet and the third one by the detector's angle (a sheet curving on, as
                // a small cylinder beside a plane: its points ahead fit a "third plane" a few tens of degrees
                // off): no branch there.
                if (std::abs(nS.dot(n3)) > std::cos(params.angle * kDeg)) continue;
                u.normalize();
                Eigen::Vector3d side = Eigen::Vector3d::Zero();
                for (std::uint32_t j : halfBall) {
                  const Eigen::Vector3d& q = cloud.points[j];
                  const double dS = std::abs(nS.dot(q) - oS), dO = std::abs(nO.dot(q) - oO);
                  if (dS <= tolc && dS < dO) side += q - y;
                }
                const Eigen::Vector3d w = nS.cross(cc.direction);  // in the sheet, across the crease
                const double sgn = side.dot(w);
                if (std::abs(sgn) < 1e-12 * h) continue;
                if (u.dot(w) * sgn < 0) u = -u;
                // Follow the branch along the known planes while its neighbourhood stays explained.
                Run branch{nextChain++, {}, {}};
                Eigen::Vector3d bt = corner;
                bool handOver = false;
                Crease bc;
                for (int k = 1; k * step <= 3.0 * params.radius * hc && all.size() <= budget; ++k) {
                  Eigen::Vector3d by = corner + (k * step) * u;
                  if (nearPlaced(by, bt, step)) break;
                  double nb = 0;
                  index.nearest(by, &nb);
                  if (std::sqrt(nb) > 1.5 * hc) break;  // past the surface (a random sampling leaves ~h gaps)
                  std::vector<std::uint32_t> bidx;
                  std::vector<double> bd2;
                  index.radius(by, params.radius * hc, bidx, bd2);
                  std::size_t unexplained = 0;
                  for (std::uint32_t j : bidx) {
                    const Eigen::Vector3d& q = cloud.points[j];
                    if (std::abs(nS.dot(q) - oS) > tolc && std::abs(n3.dot(q) - o3) > tolc &&
                        std::abs(nO.dot(q) - oO) > tolc)
                      ++unexplained;
                  }
                  if (unexplained * 6 > bidx.size()) break;
                  Eigen::Vector3d fy = by;
                  bool bOne = false;
                  if (fitAt(fy, u, bc, bOne) && !bOne && (fy - by).norm() <= params.maxLineDistance * hc) {
                    handOver = !nearPlaced(fy, bt, step);
                    if (handOver) by = fy;
                  }
                  branch.pts.push_back(by);
                  all.push_back(by);
                  bt = by;
                  if (handOver) break;
                }
                if (branch.pts.empty()) continue;
                runs.push_back(std::move(branch));
                if (handOver) {
                  const Eigen::Vector3d bd = bc.direction.dot(u) < 0 ? -bc.direction : bc.direction;
                  jobs.push_back({runs.size() - 1, true, bt, bd, step});
                }
              }
            }
          }
        }
      }
      return placed ? 1 : 0;
    };
    Crease last;  // the planes at the tip (the last full fit)
    {
      Eigen::Vector3d y = tip;
      bool one = false;
      if (!fitAt(y, dir, last, one) || one) last.valid = false;
    }
    for (int guard = 0; guard < 100000 && all.size() <= budget; ++guard) {
      const Eigen::Vector3d predicted = tip + step * dir;
      Eigen::Vector3d y = predicted;
      Crease c;
      bool oneSided = false;
      // The prediction lies on the crease but for its bend over one step: a fit far off it found another line.
      bool ok = fitAt(y, dir, c, oneSided);
      if (ok) {
        // One step on along the fitted line (the nearest point of the line to the prediction slides along it
        // where the crease bends; a sample a few steps ahead would leave a gap behind it).
        const double cd = c.direction.dot(dir);
        const double t = (step - (y - tip).dot(dir)) / cd;
        if (std::abs(cd) > 0.95 && std::abs(t) <= step) y += t * c.direction;
        ok = (y - tip).dot(dir) >= 0.5 * step &&  // the crease leads on
             (y - predicted).norm() <= 0.5 * step + 0.25 * hl;  // far off the prediction: another line
      }
      if (ok && nearPlaced(y, tip, step)) break;  // bridged to a sample already placed
      if (!ok || oneSided) {
        // Near a corner: fitted on the half-ball behind, or not at all (then the tip's planes go on).
        Crease bent;
        const int found = ok ? cornerAhead(c, y - step * dir, added, &bent)
                             : (last.valid ? cornerAhead(last, tip, added, &bent) : 0);
        if (found == 1) break;
        if (found == 2) {
          if (nearPlaced(bent.point, tip, step)) break;  // bridged
          y = bent.point;
          c = bent;
          ok = true;
          oneSided = false;
        }
        if (!ok) {
          // A fit fails now and then on a random sampling (a lopsided neighbourhood): the crease goes on if the
          // full fit holds one or two steps further; the skipped samples go on the straight line to it.
          bool resumed = false;
          for (int skip = 2; skip <= 3 && !resumed; ++skip) {
            Eigen::Vector3d z = tip + (skip * step) * dir;
            Crease cz;
            bool one = false;
            if (!fitAt(z, dir, cz, one) || one || (z - tip).dot(dir) < (skip - 0.5) * step) continue;
            if (nearPlaced(z, tip, step)) break;
            for (int k = 1; k < skip; ++k) {
              const Eigen::Vector3d q = tip + (z - tip) * (static_cast<double>(k) / skip);
              added.push_back(q);
              all.push_back(q);
            }
            y = z;
            c = cz;
            oneSided = false;
            resumed = true;
          }
          if (!resumed) break;
        }
      }
      added.push_back(y);
      all.push_back(y);
      if (!oneSided) last = c;
      dir = (c.direction.dot(dir) < 0 ? -c.direction : c.direction);
      tip = y;
    }
    tracedFrom.resize(runs.size(), 0);
    if (!added.empty() || runs.size() > runsBefore) tracedFrom[job.run] = 1;
    Run& run = runs[job.run];
    (job.back ? run.pts : run.front).insert(job.back ? run.pts.end() : run.front.end(), added.begin(), added.end());
  }
  tracedFrom.resize(runs.size(), 0);
  // A lone sample of the input runs that nothing was traced from (its crease fit fails, or it leads at once
  // into samples placed already), within one chain step of another chain's sample and within maxLineDistance
  // (local) spacings of that chain's line there (the line through the sample's two neighbours), is a stray: a
  // chain piece on a crease another chain (or its trace) holds, snapped onto a fit biased by a nearby corner
  // (fandisk: 0.18 output spacings off the crease, 0.1–0.7 h off the other chain's line). It is dropped: the
  // crease is held without it. A lone sample off that line (on another crease leaving a corner) stays.
  std::vector<char> stray(runs.size(), 0);
  for (std::size_t r = 0; r < inputRuns && typicalStep > 0; ++r) {
    const Run& run = runs[r];
    if (run.pts.size() != 1 || !run.front.empty() || tracedFrom[r]) continue;
    double nearest = 1e300, lateral = 1e300;
    for (std::size_t s = 0; s < runs.size(); ++s) {
      // Against samples that stay: another chain's run of several samples or one traced from.
      if (runs[s].chain == run.chain || (runs[s].pts.size() + runs[s].front.size() < 2 && !tracedFrom[s]))
        continue;
      // The other run's samples in order (front reversed, then pts).
      std::vector<Eigen::Vector3d> seq(runs[s].front.rbegin(), runs[s].front.rend());
      seq.insert(seq.end(), runs[s].pts.begin(), runs[s].pts.end());
      for (std::size_t k = 0; k < seq.size(); ++k) {
        const double d = (seq[k] - run.pts[0]).norm();
        if (d >= nearest) continue;
        nearest = d;
        const Eigen::Vector3d dir =
            (seq[std::min(k + 1, seq.size() - 1)] - seq[k > 0 ? k - 1 : 0]).normalized();
        const Eigen::Vector3d off = run.pts[0] - seq[k];
        lateral = (off - dir * off.dot(dir)).norm();
      }
    }
    stray[r] =
        nearest < typicalStep && lateral <= params.maxLineDistance * localSpacing(index, run.pts[0], h);
  }
  out.clear();
  owner.clear();
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const Run& run = runs[r];
    if (stray[r]) continue;
    for (std::size_t t = run.front.size(); t-- > 0;) out.push_back(run.front[t]), owner.push_back(run.chain);
    for (const auto& q : run.pts) out.push_back(q), owner.push_back(run.chain);
  }
}

/// Step 5 of snapToCreases(): fill the gaps the tracing and the corners leave between neighbouring samples.
/// Two samples a, b more than 1.5 × the chains' median spacing (`step`) and at most 6 steps apart, with no other
/// sample within 0.45 × their distance of their midpoint and half a step of the line a–b (nothing lies between
/// them), get samples at ≤ step on the crease between them, each
///  - at the snap fit's crease point near its chord point (the fitted crease running along a→b within
///    maxChainTurn, its point within 0.3 step of the chord), else
///  - on the fitted crease line of a or b where that line runs along a→b and passes within 0.1 step of the
///    chord point, else
///  - on the chord itself where the samples run on in line through a and b: a sample 0.5–1.6 steps behind a
///    (and one behind b) lies within 20° (or 0.15 step) of the line a–b (both for gaps over 4.5 steps; one of
///    them suffices for shorter ones, as next to a corner, where the corner sample has no neighbour in line).
///    This fills the holes where no two-plane fit holds (a plane beside a small-radius cylinder, a corner's
///    neighbourhood), which the tracing cannot step through.
/// A gap where one new sample has none of these is left open (two creases meeting, not one). Each new sample
/// lies within 1.5·maxOffCrease (local) spacings of an input point (an edge point of a random sampling may have
/// none within one spacing). Sequential in sample order, each gap seeing the samples added before it:
/// deterministic. The new samples are appended, owned by a's chain.
void fillCreaseGaps(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                    std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
  std::vector<double> gaps;
  for (std::size_t t = 1; t < out.size(); ++t)
    if (owner[t] == owner[t - 1]) gaps.push_back((out[t] - out[t - 1]).norm());
  if (gaps.empty()) return;
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  const double step = gaps[gaps.size() / 2];
  if (!(step > 1e-9 * h)) return;
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  const std::size_t n0 = out.size();
  const KnnIndex placed(out);  // the samples before filling; the added ones are checked by brute force
  std::vector<Eigen::Vector3d> added;
  std::vector<std::uint32_t> addedOwner;
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  // The snap fit at y (re-centred once on the crease), as in tracing; false where it fails the thresholds.
  auto fit = [&](const Eigen::Vector3d& y0, Crease& c) {
    Eigen::Vector3d y = y0;
    const double hl = localSpacing(index, y, h);
    for (int it = 0; it < 2; ++it) {
      if (!snapFit(cloud, index, y, hl, params, params, c, idx, d2)) return false;
      y = c.point;
    }
    return true;
  };
  std::vector<signed char> fitted(n0, -1);  // lazily: the crease at each original sample
  std::vector<Crease> creaseAt(n0);
  auto creaseOf = [&](std::size_t i) -> const Crease* {
    if (fitted[i] < 0) fitted[i] = fit(out[i], creaseAt[i]) ? 1 : 0;
    return fitted[i] ? &creaseAt[i] : nullptr;
  };
  std::vector<std::uint32_t> near, ci;
  std::vector<double> nd2, cd2;
  // A sample within r of the midpoint m of a–b and within half a step of the line a–b splits the gap (one off
  // the line, e.g. an outlier of a biased fit, does not).
  auto covered = [&](const Eigen::Vector3d& m, double r, const Eigen::Vector3d& u) {
    auto blocks = [&](const Eigen::Vector3d& q) {
      const Eigen::Vector3d v = q - m;
      return v.squaredNorm() < r * r && (v - u * v.dot(u)).squaredNorm() <= 0.25 * step * step;
    };
    placed.radius(m, r, ci, cd2);
    for (std::uint32_t c : ci)
      if (blocks(out[c])) return true;
    for (const auto& q : added)
      if (blocks(q)) return true;
    return false;
  };
  // A sample 0.5–1.6 steps behind e (away from f) within 20° (or 0.15 step) of the line e–f: the samples run on in
  // line (up to the wobble of samples placed by biased fits).
  const double kInLine = std::tan(20.0 * kDeg);
  auto inLine = [&](const Eigen::Vector3d& e, const Eigen::Vector3d& f) {
    const Eigen::Vector3d u = (f - e).normalized();
    placed.radius(e, 1.6 * step, ci, cd2);
    for (std::uint32_t c : ci) {
      const Eigen::Vector3d v = out[c] - e;
      const double t = v.dot(u);
      if (-t >= 0.5 * step && (v - t * u).norm() <= std::max(0.15 * step, -t * kInLine)) return true;
    }
    return false;
  };
  std::vector<Eigen::Vector3d> fill;
  for (std::size_t i = 0; i < n0; ++i) {
    placed.radius(out[i], 6.0 * step, near, nd2);
    std::vector<std::uint32_t> later;
    for (std::uint32_t j : near)
      if (j > i) later.push_back(j);
    std::sort(later.begin(), later.end());
    for (std::uint32_t j : later) {
      const Eigen::Vector3d &a = out[i], &b = out[j];
      const double g = (b - a).norm();
      if (g <= 1.5 * step || g > 6.0 * step) continue;
      const Eigen::Vector3d m = 0.5 * (a + b), u = (b - a) / g;
      if (covered(m, 0.45 * g, u)) continue;
      const bool lineA = inLine(a, b), lineB = inLine(b, a);
      const bool chord = g <= 4.5 * step ? (lineA || lineB) : (lineA && lineB);
      const int pieces = static_cast<int>(std::ceil(g / step - 1e-9));
      fill.clear();
      bool ok = true;
      for (int k = 1; k < pieces && ok; ++k) {
        const Eigen::Vector3d q = a + (b - a) * (static_cast<double>(k) / pieces);
        Crease c;
        ok = false;
        if (fit(q, c) && std::abs(c.direction.dot(u)) >= cosTurn) {
          const Eigen::Vector3d off = c.point - a - u * (c.point - a).dot(u);  // off the chord
          if (off.norm() <= 0.3 * step && (c.point - q).norm() <= 0.5 * step) fill.push_back(c.point), ok = true;
        }
        for (std::size_t e : {static_cast<std::size_t>(i), static_cast<std::size_t>(j)}) {
          if (ok) break;
          const Crease* ce = creaseOf(e);
          if (!ce || std::abs(ce->direction.dot(u)) < cosTurn) continue;
          const Eigen::Vector3d onLine = ce->point + ce->direction * (q - ce->point).dot(ce->direction);
          if ((onLine - q).norm() <= 0.1 * step) fill.push_back(onLine), ok = true;
        }
        if (!ok && chord) fill.push_back(q), ok = true;
        if (ok) {
          double nearest = 0;
          index.nearest(fill.back(), &nearest);
          ok = std::sqrt(nearest) <= 1.5 * params.maxOffCrease * localSpacing(index, fill.back(), h);
        }
      }
      if (!ok) continue;
      for (const auto& q : fill) added.push_back(q), addedOwner.push_back(owner[i]);
    }
  }
  out.insert(out.end(), added.begin(), added.end());
  owner.insert(owner.end(), addedOwner.begin(), addedOwner.end());
}

/// The two planes of @p c refitted on @p nbr (the neighbourhood of @p y), robust to a third sheet: each point
/// goes to the plane it is nearer to, and only if within 3·maxResidual spacings of it (the points of another
/// sheet, as a second crease's far side, are left out), and each plane is refitted with weights exp(−d²/σ²);
/// twice. The line point is the line's point nearest y. Returns false (and leaves @p c) when a plane keeps
/// fewer than 5 points or fits worse than maxResidual.
bool refitPlanesRobust(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& y,
                       const std::vector<std::uint32_t>& nbr, double hl, const FeatureParams& prm,
                       double sigma, Crease& c) {
  Eigen::Vector3d na = c.normalA, nb = c.normalB;
  double oa = c.offsetA, ob = c.offsetB;
  const double tol = 3.0 * prm.maxResidual * hl;
  std::vector<std::uint32_t> pa, pb;
  for (int it = 0; it < 2; ++it) {
    pa.clear();
    pb.clear();
    for (std::uint32_t j : nbr) {
      const double da = std::abs(na.dot(points[j]) - oa), db = std::abs(nb.dot(points[j]) - ob);
      if (std::min(da, db) <= tol) (da <= db ? pa : pb).push_back(j);
    }
    if (pa.size() < 5 || pb.size() < 5) return false;
    Eigen::Vector3d ta, tb;
    double toa = 0, tob = 0;
    if (fitPlane(points, pa, y, sigma, na, ta, toa) > prm.maxResidual * hl ||
        fitPlane(points, pb, y, sigma, nb, tb, tob) > prm.maxResidual * hl)
      return false;
    na = ta, nb = tb, oa = toa, ob = tob;
  }
  const Eigen::Vector3d dir = na.cross(nb);
  if (dir.norm() < 1e-6) return false;
  c.point = lineNearest(na, oa, nb, ob, y);
  c.direction = dir.normalized();
  c.normalA = na, c.normalB = nb, c.offsetA = oa, c.offsetB = ob;
  return true;
}

/// A sheet curving along a crease, as a height field over its plane: the points x with n·(x − o) = h(u, v),
/// (u, v) = (e1·(x − o), e2·(x − o)), e1 along the crease, h = c0 + c1 u + c2 v + c3 u². The one curvature
/// term is the bend along the crease (a cylinder meeting a plate at its foot); terms across it would let a
/// sheet bend onto a stray point next to the crease.
struct CreaseSheet {
  Eigen::Vector3d o, e1, e2, n;
  Eigen::Vector4d c = Eigen::Vector4d::Zero();
  /// n·(x − o) − h(u, v) (about the signed distance near the sheet) and, if @p grad, its gradient.
  double value(const Eigen::Vector3d& x, Eigen::Vector3d* grad = nullptr) const {
    const Eigen::Vector3d d = x - o;
    const double u = e1.dot(d), v = e2.dot(d);
    if (grad) *grad = n - (c(1) + 2 * c(3) * u) * e1 - c(2) * e2;
    return n.dot(d) - (c(0) + c(1) * u + c(2) * v + c(3) * u * u);
  }
  /// Fitted by least squares to @p idx, idx[t] weighted rw[t]·exp(−|idx[t] − o|²/σ²); returns the weighted
  /// RMS residual (infinity with fewer than 10 points).
  double fit(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
             const std::vector<double>& rw, double sigma) {
    if (idx.size() < 10) return std::numeric_limits<double>::infinity();
    Eigen::Matrix4d ata = Eigen::Matrix4d::Zero();
    Eigen::Vector4d atb = Eigen::Vector4d::Zero();
    std::vector<double> w(idx.size());
    for (std::size_t t = 0; t < idx.size(); ++t) {
      const Eigen::Vector3d d = points[idx[t]] - o;
      w[t] = rw[t] * std::exp(-d.squaredNorm() / (sigma * sigma));
      const double u = e1.dot(d) / sigma, v = e2.dot(d) / sigma;  // in units of σ: well conditioned
      const Eigen::Vector4d a(1, u, v, u * u);
      ata += w[t] * a * a.transpose();
      atb += w[t] * a * n.dot(d);
    }
    c = ata.ldlt().solve(atb).cwiseQuotient(Eigen::Vector4d(1, sigma, sigma, sigma * sigma));
    if (!c.allFinite()) return std::numeric_limits<double>::infinity();
    double r2 = 0, sum = 0;
    for (std::size_t t = 0; t < idx.size(); ++t) r2 += w[t] * std::pow(value(points[idx[t]]), 2), sum += w[t];
    return std::sqrt(r2 / sum);
  }
};

constexpr std::size_t kSheetFitPoints = 40;  // the curved sheets are fitted on this many nearest points

/// The crease point near @p c.point on the intersection of its two sheets fitted as CreaseSheets (over the
/// planes of @p c, bending along c.direction): a plane fitted to a sheet that curves along the crease lies off
/// it, and so does the planes' line. The kSheetFitPoints input points nearest c.point, Gaussian weights of
/// width 0.6 × their radius; four rounds of: each point to the sheet it is nearer to (the planes, then the
/// fitted sheets), left out beyond 3·maxResidual local spacings @p hl of both and weighted 1/(1 + (d/τ)²),
/// τ = maxResidual·hl, by its distance d (a third sheet's points, stray points); then Gauss-Newton from
/// c.point onto both sheets. Returns false where a sheet keeps under 10 points, the last round leaves out 10 %
/// of the points or more (a third sheet: a corner) or its fits leave a residual over maxResidual·hl.
bool curvedCreasePoint(const PointCloud& cloud, const KnnIndex& index, double hl, const FeatureParams& prm,
                       const Crease& c, Eigen::Vector3d& x) {
  std::vector<std::uint32_t> nbr;
  std::vector<double> d2;
  const Eigen::Vector3d x0 = c.point;
  if (index.knn(x0, kSheetFitPoints, nbr, d2) < kSheetFitPoints) return false;
  const double sigma = 0.6 * std::sqrt(d2.back());
  CreaseSheet sheet[2];
  const Eigen::Vector3d normal[2] = {c.normalA, c.normalB};
  const double offset[2] = {c.offsetA, c.offsetB};
  for (int s = 0; s < 2; ++s) {  // start: the planes
    CreaseSheet& q = sheet[s];
    q.o = x0, q.n = normal[s];
    q.e1 = (c.direction - q.n * q.n.dot(c.direction)).normalized();
    q.e2 = q.n.cross(q.e1);
    q.c(0) = offset[s] - q.n.dot(x0);
  }
  std::vector<std::uint32_t> part[2];
  std::vector<double> rw[2];
  const double tau = prm.maxResidual * hl;
  for (int it = 0; it < 4; ++it) {
    for (int s = 0; s < 2; ++s) part[s].clear(), rw[s].clear();
    for (std::uint32_t j : nbr) {
      const double da = std::abs(sheet[0].value(cloud.points[j])), db = std::abs(sheet[1].value(cloud.points[j]));
      const double d = std::min(da, db);
      if (d > 3.0 * tau) continue;
      const int s = da <= db ? 0 : 1;
      part[s].push_back(j);
      rw[s].push_back(1.0 / (1.0 + (d / tau) * (d / tau)));
    }
    if (it == 3 && 10 * (part[0].size() + part[1].size()) < 9 * nbr.size()) return false;  // a third sheet
    for (int s = 0; s < 2; ++s) {
      const double r = sheet[s].fit(cloud.points, part[s], rw[s], sigma);
      if (!std::isfinite(r) || (it == 3 && r > tau)) return false;
    }
  }
  x = x0;
  for (int it = 0; it < 10; ++it) {  // the minimum-norm step onto both: x ← x − Jᵀ(JJᵀ)⁻¹f
    Eigen::Matrix<double, 2, 3> j;
    Eigen::Vector2d f;
    for (int s = 0; s < 2; ++s) {
      Eigen::Vector3d g;
      f(s) = sheet[s].value(x, &g);
      j.row(s) = g.transpose();
    }
    const Eigen::Vector3d dx = -j.transpose() * (j * j.transpose()).inverse() * f;
    if (!dx.allFinite()) return false;
    x += dx;
    if (dx.norm() < 1e-9 * hl) break;
  }
  return true;
}

/// Step 6 of snapToCreases(): each sample where the snap fit with the loose thresholds (looseParams; a sample
/// the tracing placed where the strict fit fails) puts the planes' line within maxLineDistance/2 local spacings
/// of it (the planes describe the crease the sample is on, not a corner or another crease near it) moves onto
/// the two sheets' curved crease (curvedCreasePoint), where that lies within maxLineDistance local spacings.
/// Each sample on its own: deterministic, in parallel.
void refineOnCurvedSheets(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                          std::vector<Eigen::Vector3d>& out) {
  const FeatureParams loose = looseParams(params);
  parallelFor(out.size(), params.threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    const double hl = localSpacing(index, out[i], h);
    Crease c;
    Eigen::Vector3d x;
    if (snapFit(cloud, index, out[i], hl, params, loose, c, idx, d2) &&
        (c.point - out[i]).norm() <= 0.5 * params.maxLineDistance * hl &&
        curvedCreasePoint(cloud, index, hl, params, c, x) && (x - out[i]).norm() <= params.maxLineDistance * hl)
      out[i] = x;
  });
}

/// Step 3b of snapToCreases(): tips. Two creases that share a sheet and run into one point at a small angle
/// (8°–maxChainTurn; a step in a surface fading out, as fandisk's wedge at (0.072 0.035 −0.046), 18°) end
/// there without a third crease. Within a few spacings of the tip both creases lie in every fit's
/// neighbourhood, so the traces stop about a neighbourhood apart, and step 4's end lines (through the last
/// two samples, bent by the other crease) meet short of the tip. Here each open end's crease is the last fit
/// that holds at the end sample or up to 3 samples back (the full ball, else the half-ball behind), its
/// planes refitted without the points off both (refitPlanesRobust: the other crease's far sheet). Two ends
/// whose lines converge, share a plane (each end within maxLineDistance of one of the other's planes) and
/// meet (within half a spacing) ahead of both (within 6·radius local spacings) have their tip there, refined
/// as the common point of the shared plane and the two other sheets' planes refitted (Gaussian-weighted) on
/// the points around it, up to 4 times while a refit moves it by 0.1–1 spacing. Both ends are continued to
/// the tip on the straight line at their step (the second one's samples within half a step of the first's
/// left out, close to the tip) unless a placed sample lies on the way (within half a step: another crease
/// between them) or the tip is farther than maxOffCrease from the input. The samples are inserted after their
/// ends, so the runs end at the tip and step 4 adds no corner there. Ends are paired greedily in order:
/// deterministic.
void placeCreaseTips(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                     std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
  struct TipEnd {
    std::size_t run;
    bool back;                         // the run's last sample (else its first)
    Eigen::Vector3d point, direction;  // on the fitted line, nearest the end sample; forward, off the end
    double step, hl;
    Crease crease;
  };
  const auto runs = ownerRuns(owner);
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  std::vector<TipEnd> ends;
  std::vector<std::uint32_t> idx, behind;
  std::vector<double> d2;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const auto [a, b] = runs[r];
    if (b == a) continue;
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3d& tip = side ? out[b] : out[a];
      const Eigen::Vector3d& prev = side ? out[b - 1] : out[a + 1];
      const double step = (tip - prev).norm();
      if (!(step > 1e-9 * h)) continue;
      const Eigen::Vector3d forward = (tip - prev) / step;
      Crease c;
      double hl = h;
      bool ok = false;
      for (std::size_t k = 0; k <= 3 && k <= b - a && !ok; ++k) {
        const Eigen::Vector3d& y = side ? out[b - k] : out[a + k];
        hl = localSpacing(index, y, h);
        bool oneSided = false;
        ok = creaseAlong(cloud, index, y, forward, hl, params, c, idx, d2, behind, oneSided);
        Crease robust = c;
        if (ok && refitPlanesRobust(cloud.points, y, idx, hl, params, params.snapSigma * hl, robust) &&
            std::abs(robust.direction.dot(forward)) >= cosTurn)
          c = robust;
      }
      if (!ok) continue;
      const Eigen::Vector3d dir = c.direction.dot(forward) < 0 ? -c.direction : c.direction;
      ends.push_back({r, side == 1, c.point + dir * (tip - c.point).dot(dir), dir, step, hl, c});
    }
  }
  const double cosMin = std::cos(8.0 * kDeg);  // closer to parallel: no tip within reach
  std::vector<char> used(ends.size(), 0);
  std::vector<std::vector<Eigen::Vector3d>> extension(ends.size());
  std::vector<Eigen::Vector3d> placed(out);
  auto nearPlaced = [&](const Eigen::Vector3d& y, double r) {
    for (const auto& q : placed)
      if ((q - y).squaredNorm() < r * r) return true;
    return false;
  };
  auto planeDistance = [](const Crease& k, const Eigen::Vector3d& q, bool& isA) {
    const double da = std::abs(k.normalA.dot(q) - k.offsetA), db = std::abs(k.normalB.dot(q) - k.offsetB);
    isA = da <= db;
    return std::min(da, db);
  };
  for (std::size_t a = 0; a < ends.size(); ++a)
    for (std::size_t b = a + 1; b < ends.size() && !used[a]; ++b) {
      if (used[b] || ends[a].run == ends[b].run) continue;
      const TipEnd &ea = ends[a], &eb = ends[b];
      const double hl = std::max(ea.hl, eb.hl), reach = 6.0 * params.radius * hl;
      if ((ea.point - eb.point).norm() > reach) continue;
      const double c = ea.direction.dot(eb.direction);
      if (c > cosMin || c < cosTurn) continue;  // not converging at a small angle
      bool sharedA = false, sharedB = false;    // which plane of each end is the shared sheet
      if (planeDistance(ea.crease, eb.point, sharedA) > params.maxLineDistance * hl ||
          planeDistance(eb.crease, ea.point, sharedB) > params.maxLineDistance * hl)
        continue;
      // Closest points of the two lines: ea.point + sa·da and eb.point + tb·db, both ahead.
      const Eigen::Vector3d w = ea.point - eb.point;
      const double d = ea.direction.dot(w), e = eb.direction.dot(w);
      const double sa = (c * e - d) / (1.0 - c * c), tb = (e - c * d) / (1.0 - c * c);
      if (sa <= 0 || tb <= 0 || sa > reach || tb > reach) continue;
      const Eigen::Vector3d pa = ea.point + sa * ea.direction, pb = eb.point + tb * eb.direction;
      if ((pa - pb).norm() > 0.5 * hl) continue;  // the two lines must (nearly) meet
      Eigen::Vector3d tip = 0.5 * (pa + pb);
      {
        // The tip as the three sheets' common point: the shared plane (from the ends' fits: the shared sheet
        // narrows to nothing at the tip) and the two other sheets' planes, refitted on the points around the
        // tip that lie nearest to them (within 3·maxResidual).
        Eigen::Vector3d pn[3] = {sharedA ? ea.crease.normalA : ea.crease.normalB,
                                 sharedA ? ea.crease.normalB : ea.crease.normalA,
                                 sharedB ? eb.crease.normalB : eb.crease.normalA};
        double po[3] = {sharedA ? ea.crease.offsetA : ea.crease.offsetB,
                        sharedA ? ea.crease.offsetB : ea.crease.offsetA,
                        sharedB ? eb.crease.offsetB : eb.crease.offsetA};
        const double tolc = 3.0 * params.maxResidual * hl;
        std::vector<std::uint32_t> part[3];
        for (int it = 0; it < 4; ++it) {
          index.radius(tip, params.radius * hl, idx, d2);
          partitionByPlanes(cloud.points, idx, pn, po, tolc, part);
          Eigen::Vector3d tn[3] = {pn[0], pn[1], pn[2]};
          double to[3] = {po[0], po[1], po[2]};
          bool fitted = true;
          for (int k = 1; k < 3 && fitted; ++k)
            fitted = part[k].size() >= 5 && fitPlane(cloud.points, part[k], tip, params.snapSigma * hl, pn[k],
                                                     tn[k], to[k]) <= 2.0 * params.maxResidual * hl;
          if (!fitted) break;
          Eigen::Matrix3d m;
          m << tn[0].transpose(), tn[1].transpose(), tn[2].transpose();
          if (std::abs(m.determinant()) < 0.1) break;
          const Eigen::Vector3d k3 = m.inverse() * Eigen::Vector3d(to[0], to[1], to[2]);
          const double moved = (k3 - tip).norm();
          if (moved > hl) break;
          for (int k = 1; k < 3; ++k) pn[k] = tn[k], po[k] = to[k];
          tip = k3;
          if (moved < 0.1 * hl) break;
        }
      }
      double nearest = 0;
      index.nearest(tip, &nearest);
      if (std::sqrt(nearest) > params.maxOffCrease * hl) continue;  // off the surface
      std::vector<Eigen::Vector3d> fill[2];
      bool clear = true;
      for (int side = 0; side < 2 && clear; ++side) {
        const TipEnd& ek = side ? eb : ea;
        const double gap = (tip - ek.point).norm();
        const int pieces = std::max(1, static_cast<int>(std::ceil(gap / ek.step - 0.25)));
        for (int t = 1; t <= pieces && clear; ++t) {
          const Eigen::Vector3d q = ek.point + (tip - ek.point) * (static_cast<double>(t) / pieces);
          clear = !nearPlaced(q, 0.5 * ek.step);
          fill[side].push_back(q);
        }
      }
      if (!clear) continue;
      used[a] = used[b] = 1;
      extension[a] = fill[0];
      for (const auto& q : fill[1]) {
        bool near = false;
        for (const auto& p : extension[a]) near = near || (p - q).norm() < 0.5 * eb.step;
        if (!near) extension[b].push_back(q);
      }
      placed.insert(placed.end(), extension[a].begin(), extension[a].end());
      placed.insert(placed.end(), extension[b].begin(), extension[b].end());
    }
  std::vector<const std::vector<Eigen::Vector3d>*> before(runs.size(), nullptr), after(runs.size(), nullptr);
  for (std::size_t k = 0; k < ends.size(); ++k)
    if (!extension[k].empty()) (ends[k].back ? after : before)[ends[k].run] = &extension[k];
  std::vector<Eigen::Vector3d> result;
  std::vector<std::uint32_t> resultOwner;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const auto [a, b] = runs[r];
    if (before[r])
      for (std::size_t t = before[r]->size(); t-- > 0;)
        result.push_back((*before[r])[t]), resultOwner.push_back(owner[a]);
    for (std::size_t t = a; t <= b; ++t) result.push_back(out[t]), resultOwner.push_back(owner[a]);
    if (after[r])
      for (const auto& q : *after[r]) result.push_back(q), resultOwner.push_back(owner[a]);
  }
  out = std::move(result);
  owner = std::move(resultOwner);
}

}  // namespace

std::vector<Eigen::Vector3d> snapToCreases(const PointCloud& cloud, const std::vector<Eigen::Vector3d>& samples,
                                           const std::vector<std::uint32_t>& chainOfSample, double spacing,
                                           const FeatureParams& params, std::vector<std::uint32_t>* chainOut) {
  params.validate();
  if (!(spacing > 0)) throw std::invalid_argument("snapToCreases: spacing must be > 0");
  if (!cloud.hasNormals()) throw std::invalid_argument("snapToCreases: the cloud needs one normal per point");
  if (chainOfSample.size() != samples.size())
    throw std::invalid_argument("snapToCreases: one chain index per sample is needed");
  const double h = spacing;
  const std::size_t n = samples.size();
  const KnnIndex index(cloud.points);
  // 1. Each sample onto the intersection of its two sheets' local planes (the detector's thresholds).
  std::vector<Eigen::Vector3d> moved(samples);
  std::vector<char> good(n, 0);
  std::vector<Eigen::Vector3d> creaseDir(n, Eigen::Vector3d::Zero());  // of the fit that placed each good sample
  parallelFor(n, params.threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    // A chain may run beside its crease (its points come from the detector's unweighted fits): when the crease
    // is not within maxLineDistance, the sample may jump to it from up to 0.8·radius away.
    FeatureParams far = params;
    far.maxLineDistance = std::max(params.maxLineDistance, 0.8 * params.radius);
    const std::size_t before = i > 0 && chainOfSample[i - 1] == chainOfSample[i] ? i - 1 : i;
    const std::size_t after = i + 1 < n && chainOfSample[i + 1] == chainOfSample[i] ? i + 1 : i;
    Eigen::Vector3d along = samples[after] - samples[before];
    if (along.norm() > 0) along.normalize();  // stays 0 for a lone sample: no jump then
    bool onCrease = false;
    const double hl = localSpacing(index, samples[i], h);
    for (const FeatureParams* prm : {&params, static_cast<const FeatureParams*>(&far)}) {
      moved[i] = samples[i];
      onCrease = true;
      for (int it = 0; it < 2 && onCrease; ++it) {  // re-centred once: the second fit is centred on the crease
        Crease c;
        onCrease = snapFit(cloud, index, moved[i], hl, params, it == 0 ? *prm : params, c, idx, d2);
        // A jump must land on a crease running along the chain (not on another crease meeting it at a corner).
        if (onCrease && prm == &far && std::abs(c.direction.dot(along)) < std::cos(params.maxChainTurn * kDeg))
          onCrease = false;
        if (onCrease) moved[i] = c.point, creaseDir[i] = c.direction;
      }
      if (onCrease) break;
    }
    if (!onCrease) moved[i] = samples[i];
    good[i] = onCrease ? 1 : 0;
    if (onCrease) return;
    // The looser thresholds of the VCM detector's lines (the chain already says a crease is here), trusted
    // only for a small correction: a sample extended past the feature would be pulled far.
    Crease c;
    if (snapFit(cloud, index, samples[i], hl, params, looseParams(params), c, idx, d2) &&
        (c.point - samples[i]).norm() <= 0.25 * hl) {
      moved[i] = c.point;
      creaseDir[i] = c.direction;
      good[i] = 1;
    }
  });
  // 2. A sample where no crease fits but whose chain neighbours (≤ 3 samples either way) do goes onto the
  // chord between them; the others (chain ends past the feature, corners where three sheets meet) are dropped.
  std::vector<char> keep(good);
  for (std::size_t i = 0; i < n; ++i) {
    if (good[i]) continue;
    std::size_t prev = n, next = n;
    for (std::size_t j = i; j-- > 0 && i - j <= 3 && chainOfSample[j] == chainOfSample[i];)
      if (good[j]) {
        prev = j;
        break;
      }
    for (std::size_t j = i + 1; j < n && j - i <= 3 && chainOfSample[j] == chainOfSample[i]; ++j)
      if (good[j]) {
        next = j;
        break;
      }
    if (prev == n || next == n) continue;
    const Eigen::Vector3d ab = moved[next] - moved[prev];
    // On a curved crease the chord cuts inside: its sagitta ≈ L·θ/8 (θ the turn between the two ends' crease
    // directions) must stay below the detector's residual bound.
    const double cosTurn = std::min(1.0, std::abs(creaseDir[prev].dot(creaseDir[next])));
    if (ab.norm() * std::acos(cosTurn) / 8.0 > params.maxResidual * h) continue;
    const double t = std::clamp((samples[i] - moved[prev]).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
    const Eigen::Vector3d onChord = moved[prev] + t * ab;
    if ((onChord - samples[i]).norm() > params.maxLineDistance * h) continue;  // the neighbours disagree
    moved[i] = onChord;
    keep[i] = 1;
  }
  std::vector<Eigen::Vector3d> out;
  std::vector<std::uint32_t> owner;
  for (std::size_t i = 0; i < n; ++i)
    if (keep[i]) out.push_back(moved[i]), owner.push_back(chainOfSample[i]);
  traceChainEnds(cloud, index, h, params, out, owner);
  placeCreaseTips(cloud, index, h, params, out, owner);
  // 3. Corners: two chain ends whose crease lines, continued forward, meet within a few spacings of both get
  // a sample where they meet (the end samples of chains stop short of a corner, where the two-plane fit fails).
  struct End {
    Eigen::Vector3d point, direction;  // direction: forward, off the end of the chain
    double step;                       // the chain's sample spacing there
    std::uint32_t chain;
    bool filled;                       // already linked to a corner
  };
  std::vector<End> ends;
  for (const auto& [a, b] : ownerRuns(owner))
    if (b > a) {
      ends.push_back({out[a], (out[a] - out[a + 1]).normalized(), (out[a] - out[a + 1]).norm(), owner[a], false});
      ends.push_back({out[b], (out[b] - out[b - 1]).normalized(), (out[b] - out[b - 1]).norm(), owner[a], false});
    }
  const double reach = 3.0 * params.radius * h;
  std::vector<Eigen::Vector3d> corners, cornerPoints;  // all added samples; the corners alone
  std::vector<std::uint32_t> cornerOwner;
  // The gap between a chain end and its corner gets samples at the chain's spacing, on the straight line.
  auto fill = [&](End& e, const Eigen::Vector3d& corner) {
    if (e.filled) return;
    e.filled = true;
    const double gap = (corner - e.point).norm();
    const int pieces = static_cast<int>(std::ceil(gap / std::max(e.step, 1e-300) - 0.25));
    for (int k = 1; k < pieces; ++k) {
      corners.push_back(e.point + (corner - e.point) * (static_cast<double>(k) / pieces));
      cornerOwner.push_back(e.chain);
    }
  };
  for (std::size_t a = 0; a < ends.size(); ++a)
    for (std::size_t b = a + 1; b < ends.size(); ++b) {
      End &ea = ends[a], &eb = ends[b];
      if (ea.chain == eb.chain || (ea.point - eb.point).norm() > reach) continue;
      // Closest points of the two lines: ea.point + s·da and eb.point + t·db.
      const double c = ea.direction.dot(eb.direction);
      if (1.0 - c * c < 0.05) continue;  // nearly parallel (under 13°): no corner between them
      const Eigen::Vector3d w = ea.point - eb.point;
      const double d = ea.direction.dot(w), e = eb.direction.dot(w);
      const double sa = (c * e - d) / (1.0 - c * c), tb = (e - c * d) / (1.0 - c * c);
      if (sa < -0.5 * h || tb < -0.5 * h || sa > reach || tb > reach) continue;
      const Eigen::Vector3d pa = ea.point + sa * ea.direction, pb = eb.point + tb * eb.direction;
      if ((pa - pb).norm() > 0.5 * h) continue;  // the two lines must (nearly) meet
      Eigen::Vector3d corner = 0.5 * (pa + pb);
      double nearest = 0;
      index.nearest(corner, &nearest);
      if (std::sqrt(nearest) > params.maxOffCrease * h) continue;  // the lines meet off the surface
      // A corner the tracing already placed (or any sample there): nothing to add.
      bool taken = false;
      for (const auto& q : out)
        if ((q - corner).norm() < 0.5 * std::min(ea.step, eb.step)) taken = true;
      if (taken) continue;
      bool dup = false;
      for (const auto& q : cornerPoints)
        if ((q - corner).norm() < h) dup = true, corner = q;
      if (!dup) {
        cornerPoints.push_back(corner);
        corners.push_back(corner);
        cornerOwner.push_back(ea.chain);
      }
      fill(ea, corner);
      fill(eb, corner);
    }
  owner.insert(owner.end(), cornerOwner.begin(), cornerOwner.end());
  out.insert(out.end(), corners.begin(), corners.end());
  fillCreaseGaps(cloud, index, h, params, out, owner);
  refineOnCurvedSheets(cloud, index, h, params, out);
  if (chainOut) *chainOut = std::move(owner);
  return out;
}

double estimateSpacing(const std::vector<Eigen::Vector3d>& points, int threads) {
  if (points.size() < 2) return 0.0;
  KnnIndex index(points);
  std::vector<double> local(points.size());
  parallelFor(points.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.knn(points[i], 7, idx, d2);
    double sum = 0;
    int m = 0;
    for (std::size_t t = 0; t < idx.size(); ++t)
      if (idx[t] != i) {
        sum += std::sqrt(d2[t]);
        ++m;
      }
    local[i] = m > 0 ? sum / m : 0.0;
  });
  auto mid = local.begin() + static_cast<std::ptrdiff_t>(local.size() / 2);
  std::nth_element(local.begin(), mid, local.end());
  return *mid;
}

FeatureResult detectFeatures(const PointCloud& cloud, const FeatureParams& params) {
  params.validate();
  if (cloud.size() < 8) throw InputError("feature detection needs at least 8 points, got " +
                                         std::to_string(cloud.size()));
  if (!cloud.hasNormals()) throw std::invalid_argument("detectFeatures: the cloud needs one normal per point");
  const auto& pts = cloud.points;
  const auto& nrm = cloud.normals;
  const std::size_t n = pts.size();
  FeatureResult r;
  auto t0 = Clock::now();
  r.spacing = params.spacing > 0 ? params.spacing : estimateSpacing(pts, params.threads);
  const double h = r.spacing;
  if (!(h > 0)) throw InputError("feature detection: the points have zero spacing (all duplicates?)");

  KnnIndex index(pts);
  std::vector<char> flag(n, 0);
  std::vector<Crease> creases(n);
  auto neighbourhood = [&](std::size_t i, std::vector<std::uint32_t>& idx, double hi) {
    std::vector<double> d2;
    index.radius(pts[i], params.radius * hi, idx, d2);
    if (idx.size() > kMaxFitPoints) idx.resize(kMaxFitPoints);  // nearest first; bounds the cost in dense clusters
  };
  if (params.detector == FeatureDetector::NormalVariation) {
    parallelFor(n, params.threads, [&](std::size_t i) {
      std::vector<std::uint32_t> idx;
      const double hi = localSpacing(index, pts[i], h);
      neighbourhood(i, idx, hi);
      flag[i] = twoPlaneTest(pts, nrm, pts[i], idx, hi, params, creases[i]) ? 1 : 0;
    });
  } else {
    const auto cov = computeVcm(pts, params.vcmOffset * h, params.vcmConvolution * h, params.threads);
    parallelFor(n, params.threads, [&](std::size_t i) {
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
  r.chains = buildChains(x, d, h, params);
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
      parallelFor(n, params.threads, [&](std::size_t i) {
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
    r.samples = snapToCreases(cloud, samples, owner, h, params, &r.sampleChain);
    r.sampleSeconds = since(t0);
  }
  return r;
}

std::vector<Eigen::Vector3d> sampleFeatureChains(const std::vector<FeatureChain>& chains, double spacing,
                                                 std::vector<std::uint32_t>* chainOfSample) {
  if (!(spacing > 0)) throw std::invalid_argument("sampleFeatureChains: spacing must be > 0");
  std::vector<Eigen::Vector3d> out;
  std::vector<std::uint32_t> owner;
  std::unordered_map<CellKey, std::vector<std::uint32_t>, CellHash> grid;
  auto key = [&](const Eigen::Vector3d& p) {
    return CellKey{static_cast<std::int64_t>(std::floor(p.x() / spacing)),
                   static_cast<std::int64_t>(std::floor(p.y() / spacing)),
                   static_cast<std::int64_t>(std::floor(p.z() / spacing))};
  };
  auto crowded = [&](const Eigen::Vector3d& p, std::uint32_t chain) {
    const CellKey k = key(p);
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          auto it = grid.find({k.x + dx, k.y + dy, k.z + dz});
          if (it == grid.end()) continue;
          for (std::uint32_t s : it->second)
            if (owner[s] != chain && (out[s] - p).norm() < 0.5 * spacing) return true;
        }
    return false;
  };
  for (std::uint32_t ci = 0; ci < chains.size(); ++ci) {
    const FeatureChain& c = chains[ci];
    const std::size_t nv = c.points.size();
    if (nv == 0) continue;
    std::vector<Eigen::Vector3d> poly = c.points, dirs = c.directions;
    if (c.closed) {
      poly.push_back(c.points.front());
      dirs.push_back(c.directions.front());
    }
    std::vector<double> arc(poly.size(), 0.0);
    for (std::size_t t = 1; t < poly.size(); ++t) arc[t] = arc[t - 1] + (poly[t] - poly[t - 1]).norm();
    const double len = arc.back();
    std::vector<double> at;  // arc-length positions of this chain's samples
    if (c.closed) {
      const std::size_t m = std::max<std::size_t>(3, static_cast<std::size_t>(std::lround(len / spacing)));
      for (std::size_t s = 0; s < m; ++s) at.push_back(len * static_cast<double>(s) / static_cast<double>(m));
    } else {
      const std::size_t m = static_cast<std::size_t>(std::lround(len / spacing));
      if (m == 0) {
        at.push_back(0.5 * len);
      } else {
        for (std::size_t s = 0; s <= m; ++s) at.push_back(len * static_cast<double>(s) / static_cast<double>(m));
      }
    }
    std::size_t seg = 0;
    for (double a : at) {
      while (seg + 2 < poly.size() && arc[seg + 1] < a) ++seg;
      const std::size_t nxt = std::min(seg + 1, poly.size() - 1);
      const double span = arc[nxt] - arc[seg];
      const double w = span > 0 ? std::clamp((a - arc[seg]) / span, 0.0, 1.0) : 0.0;
      Eigen::Vector3d p = (1 - w) * poly[seg] + w * poly[nxt];
      // Onto the crease line of the nearer vertex (the polyline chord cuts a curved crease slightly).
      const std::size_t v = w < 0.5 ? seg : nxt;
      p = poly[v] + dirs[v] * (p - poly[v]).dot(dirs[v]);
      if (crowded(p, ci)) continue;
      grid[key(p)].push_back(static_cast<std::uint32_t>(out.size()));
      out.push_back(p);
      owner.push_back(ci);
    }
  }
  if (chainOfSample) *chainOfSample = owner;
  return out;
}

std::vector<Segment> sharpMeshEdges(const TriangleMesh& mesh, double minAngleDegrees, bool includeBoundary) {
  std::map<std::pair<int, int>, std::vector<std::size_t>> faces;
  std::vector<Eigen::Vector3d> fn(mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    fn[f] = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    if (fn[f].norm() > 0) fn[f].normalize();
    for (int e = 0; e < 3; ++e) {
      const int a = t[e], b = t[(e + 1) % 3];
      faces[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  }
  std::vector<Segment> out;
  const double cosMin = std::cos(minAngleDegrees * kDeg);
  for (const auto& [e, fs] : faces) {
    bool sharp = fs.size() == 1 ? includeBoundary : false;
    for (std::size_t a = 0; a < fs.size() && !sharp; ++a)
      for (std::size_t b = a + 1; b < fs.size() && !sharp; ++b) sharp = fn[fs[a]].dot(fn[fs[b]]) < cosMin;
    if (sharp) out.push_back({mesh.vertices[e.first], mesh.vertices[e.second]});
  }
  return out;
}

std::vector<Eigen::Vector3d> sampleSegments(const std::vector<Segment>& edges, double step,
                                            std::vector<std::uint32_t>* owner) {
  if (!(step > 0)) throw std::invalid_argument("sampleSegments: step must be > 0");
  std::vector<Eigen::Vector3d> out;
  if (owner) owner->clear();
  for (std::uint32_t e = 0; e < edges.size(); ++e) {
    const double len = (edges[e][1] - edges[e][0]).norm();
    const int m = std::max(1, static_cast<int>(std::ceil(len / step)));
    for (int t = 0; t <= m; ++t) {
      out.push_back(edges[e][0] + (edges[e][1] - edges[e][0]) * (static_cast<double>(t) / m));
      if (owner) owner->push_back(e);
    }
  }
  return out;
}

double distanceToSegments(const Eigen::Vector3d& p, const std::vector<Segment>& edges) {
  double best = std::numeric_limits<double>::infinity();
  for (const Segment& s : edges) best = std::min(best, segmentDistance(p, s));
  return best;
}

FeatureScore scoreFeatures(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<std::uint32_t>& featureIndices, const std::vector<Segment>& edges,
                           double tolerance, double band, int threads) {
  FeatureScore s;
  s.detected = featureIndices.size();
  if (edges.empty() || points.empty()) return s;
  // Densify the edges at step δ; a point within r of an edge has a densified sample within r + δ/2.
  const double reach = std::max(tolerance, band);
  const double step = std::max(reach, 1e-12);
  std::vector<std::uint32_t> owner;
  const std::vector<Eigen::Vector3d> dense = sampleSegments(edges, step, &owner);
  KnnIndex index(dense);
  std::vector<double> dist(points.size());
  parallelFor(points.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.radius(points[i], reach + step, idx, d2);
    double best = std::numeric_limits<double>::infinity();
    for (std::uint32_t j : idx) best = std::min(best, segmentDistance(points[i], edges[owner[j]]));
    dist[i] = best;
  });
  std::vector<char> flagged(points.size(), 0);
  std::size_t tp = 0;
  for (std::uint32_t i : featureIndices) {
    flagged[i] = 1;
    if (dist[i] <= tolerance) ++tp;
  }
  std::size_t found = 0;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (dist[i] <= band) {
      ++s.nearEdge;
      found += flagged[i];
    }
  s.precision = s.detected > 0 ? static_cast<double>(tp) / static_cast<double>(s.detected) : 1.0;
  s.recall = s.nearEdge > 0 ? static_cast<double>(found) / static_cast<double>(s.nearEdge) : 1.0;
  return s;
}

}  // namespace iires
