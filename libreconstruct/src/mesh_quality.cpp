#include "iires/reconstruct/mesh_quality.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "iires/disjoint_sets.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/parallel.hpp"
#include "iires/sampling.hpp"

namespace iires {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

std::string num(double x) {
  if (!std::isfinite(x)) return "null";
  std::ostringstream os;
  os << std::setprecision(10) << x;
  return os.str();
}

/// One face's directed edge a→b, keyed by its undirected vertex pair.
struct HalfEdge {
  std::uint64_t key;  // (min << 32) | max
  std::uint32_t face;
  bool forward;  // a < b
};

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

/// Area-uniform samples of a mesh plus its referenced vertices (the mesh side of a two-sided distance).
std::vector<Eigen::Vector3d> meshSamplePoints(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed) {
  std::vector<Eigen::Vector3d> pts;
  std::vector<char> used(mesh.vertices.size(), 0);
  for (const auto& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) used[static_cast<std::size_t>(t[c])] = 1;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    if (used[v]) pts.push_back(mesh.vertices[v]);
  try {
    MeshSamplingParams sp;
    sp.count = count;
    sp.seed = seed;
    const PointCloud s = sampleMesh(mesh, sp);
    pts.insert(pts.end(), s.points.begin(), s.points.end());
  } catch (const InputError&) {
    // No face of positive area: the vertices are all there is to measure.
  }
  return pts;
}

void checkIndices(const TriangleMesh& mesh) {
  const auto n = static_cast<long long>(mesh.vertices.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    for (int c = 0; c < 3; ++c)
      if (mesh.triangles[f][c] < 0 || mesh.triangles[f][c] >= n)
        throw InputError("mesh face " + std::to_string(f) + " refers to vertex " +
                         std::to_string(mesh.triangles[f][c]) + " of " + std::to_string(n));
}

void shapeStats(const TriangleMesh& mesh, MeshQuality& q, int threads) {
  const std::size_t nf = mesh.triangles.size();
  std::vector<double> qual(nf), angle(nf), area(nf);
  parallelFor(nf, threads, [&](std::size_t f) {
    const auto& t = mesh.triangles[f];
    const Eigen::Vector3d &a = mesh.vertices[static_cast<std::size_t>(t[0])],
                          &b = mesh.vertices[static_cast<std::size_t>(t[1])],
                          &c = mesh.vertices[static_cast<std::size_t>(t[2])];
    qual[f] = triangleQuality(a, b, c);
    angle[f] = triangleMinAngle(a, b, c);
    area[f] = 0.5 * (b - a).cross(c - a).norm();
  });
  if (nf == 0) return;
  q.qualityMin = std::numeric_limits<double>::max();
  q.minAngleMin = std::numeric_limits<double>::max();
  double sumQ = 0, sumA = 0;
  std::size_t bad = 0;
  for (std::size_t f = 0; f < nf; ++f) {  // fixed order: independent of the thread count
    q.qualityMin = std::min(q.qualityMin, qual[f]);
    q.minAngleMin = std::min(q.minAngleMin, angle[f]);
    sumQ += qual[f];
    sumA += angle[f];
    q.area += area[f];
    if (angle[f] < 30.0) ++bad;
    if (qual[f] < 1e-9) ++q.degenerateFaces;
  }
  q.qualityMean = sumQ / static_cast<double>(nf);
  q.minAngleMean = sumA / static_cast<double>(nf);
  q.shareBelow30 = static_cast<double>(bad) / static_cast<double>(nf);
}

void topologyStats(const TriangleMesh& mesh, MeshQuality& q) {
  const std::size_t nv = mesh.vertices.size(), nf = mesh.triangles.size();
  q.faces = nf;
  std::vector<HalfEdge> he;
  he.reserve(3 * nf);
  for (std::uint32_t f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) {
      const auto a = static_cast<std::uint32_t>(mesh.triangles[f][c]);
      const auto b = static_cast<std::uint32_t>(mesh.triangles[f][(c + 1) % 3]);
      if (a == b) continue;  // degenerate face: no edge
      he.push_back({edgeKey(a, b), f, a < b});
    }
  std::sort(he.begin(), he.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  q.oriented = true;
  DisjointSets boundary(nv);
  std::vector<char> onBoundary(nv, 0);
  double edgeLength = 0;
  for (std::size_t i = 0; i < he.size();) {
    std::size_t j = i;
    std::size_t forward = 0;
    while (j < he.size() && he[j].key == he[i].key) forward += he[j++].forward ? 1 : 0;
    const std::size_t count = j - i, backward = count - forward;
    const auto a = static_cast<std::uint32_t>(he[i].key >> 32), b = static_cast<std::uint32_t>(he[i].key);
    ++q.edges;
    edgeLength += (mesh.vertices[a] - mesh.vertices[b]).norm();
    if (count == 1) {
      ++q.boundaryEdges;
      boundary.unite(a, b);
      onBoundary[a] = onBoundary[b] = 1;
    } else if (count > 2) {
      ++q.nonManifoldEdges;
    }
    if (forward > 1 || backward > 1) q.oriented = false;
    i = j;
  }
  if (q.edges) q.meanEdgeLength = edgeLength / static_cast<double>(q.edges);
  for (std::uint32_t v = 0; v < nv; ++v)
    if (onBoundary[v] && boundary.find(v) == v) ++q.boundaryLoops;

  // Vertex → faces (CSR), referenced vertices, components.
  std::vector<std::uint32_t> start(nv + 1, 0);
  for (const auto& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) ++start[static_cast<std::size_t>(t[c]) + 1];
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<std::uint32_t> incident(start[nv]);
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::uint32_t f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) incident[fill[static_cast<std::size_t>(mesh.triangles[f][c])]++] = f;
  }
  DisjointSets comp(nv);
  for (const auto& t : mesh.triangles) {
    comp.unite(static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[1]));
    comp.unite(static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[2]));
  }
  // A vertex is manifold when its link (the opposite edges of its faces) is one path or one cycle.
  std::vector<std::uint32_t> linkVerts;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> linkEdges;
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (start[v] == start[v + 1]) {
      ++q.isolatedVertices;
      continue;
    }
    ++q.vertices;
    if (comp.find(v) == v) ++q.components;
    linkVerts.clear();
    linkEdges.clear();
    bool degenerate = false;
    for (std::uint32_t s = start[v]; s < start[v + 1]; ++s) {
      const auto& t = mesh.triangles[incident[s]];
      int c = 0;
      while (static_cast<std::uint32_t>(t[c]) != v) ++c;
      const auto x = static_cast<std::uint32_t>(t[(c + 1) % 3]), y = static_cast<std::uint32_t>(t[(c + 2) % 3]);
      if (x == v || y == v || x == y) degenerate = true;
      linkEdges.emplace_back(x, y);
      linkVerts.push_back(x);
      linkVerts.push_back(y);
    }
    if (degenerate) {
      ++q.nonManifoldVertices;
      continue;
    }
    std::sort(linkVerts.begin(), linkVerts.end());
    linkVerts.erase(std::unique(linkVerts.begin(), linkVerts.end()), linkVerts.end());
    auto local = [&](std::uint32_t x) {
      return static_cast<std::uint32_t>(std::lower_bound(linkVerts.begin(), linkVerts.end(), x) - linkVerts.begin());
    };
    DisjointSets link(linkVerts.size());
    std::vector<int> degree(linkVerts.size(), 0);
    for (const auto& [x, y] : linkEdges) {
      const std::uint32_t lx = local(x), ly = local(y);
      ++degree[lx];
      ++degree[ly];
      link.unite(lx, ly);
    }
    std::size_t parts = 0;
    bool branch = false;
    for (std::uint32_t i = 0; i < linkVerts.size(); ++i) {
      if (link.find(i) == i) ++parts;
      if (degree[i] > 2) branch = true;
    }
    if (parts != 1 || branch) ++q.nonManifoldVertices;
  }
  q.euler = static_cast<long long>(q.vertices) - static_cast<long long>(q.edges) + static_cast<long long>(nf);
  q.closed = nf > 0 && q.boundaryEdges == 0 && q.nonManifoldEdges == 0;
  q.manifold = q.nonManifoldEdges == 0 && q.nonManifoldVertices == 0;
  if (q.closed && q.manifold && q.oriented) q.genus = (2 * static_cast<long long>(q.components) - q.euler) / 2;
}

}  // namespace

double triangleQuality(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double la = (b - c).norm(), lb = (c - a).norm(), lc = (a - b).norm();
  const double area = 0.5 * (b - a).cross(c - a).norm();
  const double p = 0.5 * (la + lb + lc), h = std::max({la, lb, lc});
  if (p * h <= 0) return 0.0;
  return std::clamp(2.0 * std::sqrt(3.0) * area / (p * h), 0.0, 1.0);
}

double triangleMinAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  auto angle = [](const Eigen::Vector3d& o, const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
    const Eigen::Vector3d u = x - o, v = y - o;
    if (u.squaredNorm() == 0 || v.squaredNorm() == 0) return 0.0;
    return std::atan2(u.cross(v).norm(), u.dot(v));
  };
  return kRadToDeg * std::min({angle(a, b, c), angle(b, c, a), angle(c, a, b)});
}

void MeshQualityParams::validate() const {
  if (meshSamples == 0) throw std::invalid_argument("meshSamples must be at least 1");
  if (referenceSamples == 0) throw std::invalid_argument("referenceSamples must be at least 1");
}

MeshQuality evaluateMesh(const TriangleMesh& mesh, const PointCloud* reference, const MeshQualityParams& params) {
  params.validate();
  checkIndices(mesh);
  MeshQuality q;
  shapeStats(mesh, q, params.threads);
  topologyStats(mesh, q);
  if (reference && !reference->empty() && !mesh.triangles.empty()) {
    SurfaceDistance& d = q.distance;
    d.computed = true;
    d.diagonal = bboxDiagonal(reference->points);
    const MeshDistance toMesh(mesh);
    const DistanceStats back = toMesh.distances(reference->points, params.threads);
    d.backwardMax = back.max;
    d.backwardMean = back.mean;
    const std::vector<Eigen::Vector3d> samples = meshSamplePoints(mesh, params.meshSamples, params.seed);
    const KnnIndex index(reference->points);
    std::vector<double> dist(samples.size());
    parallelFor(samples.size(), params.threads, [&](std::size_t i) {
      double sq = 0;
      index.nearest(samples[i], &sq);
      dist[i] = std::sqrt(sq);
    });
    double sum = 0;
    for (double x : dist) sum += x, d.forwardMax = std::max(d.forwardMax, x);
    d.forwardMean = dist.empty() ? 0.0 : sum / static_cast<double>(dist.size());
    d.hausdorff = std::max(d.forwardMax, d.backwardMax);
    d.mean = 0.5 * (d.forwardMean + d.backwardMean);
  }
  return q;
}

SurfaceDistance surfaceDistance(const TriangleMesh& mesh, const TriangleMesh& referenceMesh,
                                const MeshQualityParams& params) {
  params.validate();
  checkIndices(mesh);
  checkIndices(referenceMesh);
  SurfaceDistance d;
  if (mesh.triangles.empty() || referenceMesh.triangles.empty()) return d;
  d.computed = true;
  const MeshDistance toRef(referenceMesh), toMesh(mesh);
  d.diagonal = toRef.diagonal();
  const DistanceStats fwd = toRef.distances(meshSamplePoints(mesh, params.meshSamples, params.seed), params.threads);
  const DistanceStats bwd =
      toMesh.distances(meshSamplePoints(referenceMesh, params.referenceSamples, params.seed + 1), params.threads);
  d.forwardMax = fwd.max;
  d.forwardMean = fwd.mean;
  d.backwardMax = bwd.max;
  d.backwardMean = bwd.mean;
  d.hausdorff = std::max(d.forwardMax, d.backwardMax);
  d.mean = 0.5 * (d.forwardMean + d.backwardMean);
  return d;
}

std::string MeshQuality::toJson() const {
  std::ostringstream os;
  os << "{\n  \"quality\": {\"min\": " << num(qualityMin) << ", \"mean\": " << num(qualityMean) << "},\n"
     << "  \"min_angle_deg\": {\"min\": " << num(minAngleMin) << ", \"mean\": " << num(minAngleMean) << "},\n"
     << "  \"share_angle_below_30\": " << num(shareBelow30) << ",\n"
     << "  \"degenerate_faces\": " << degenerateFaces << ",\n"
     << "  \"vertices\": " << vertices << ",\n  \"isolated_vertices\": " << isolatedVertices << ",\n"
     << "  \"faces\": " << faces << ",\n  \"edges\": " << edges << ",\n"
     << "  \"boundary_edges\": " << boundaryEdges << ",\n  \"boundary_loops\": " << boundaryLoops << ",\n"
     << "  \"non_manifold_edges\": " << nonManifoldEdges << ",\n"
     << "  \"non_manifold_vertices\": " << nonManifoldVertices << ",\n"
     << "  \"components\": " << components << ",\n  \"euler\": " << euler << ",\n"
     << "  \"genus\": " << genus << ",\n"
     << "  \"closed\": " << (closed ? "true" : "false") << ",\n"
     << "  \"manifold\": " << (manifold ? "true" : "false") << ",\n"
     << "  \"oriented\": " << (oriented ? "true" : "false") << ",\n"
     << "  \"mean_edge_length\": " << num(meanEdgeLength) << ",\n  \"area\": " << num(area);
  if (distance.computed) {
    os << ",\n  \"distance\": {\"hausdorff\": " << num(distance.hausdorff) << ", \"mean\": " << num(distance.mean)
       << ", \"hausdorff_rel_diag\": " << num(distance.relativeHausdorff())
       << ", \"mean_rel_diag\": " << num(distance.relativeMean()) << ", \"mesh_to_reference_max\": "
       << num(distance.forwardMax) << ", \"mesh_to_reference_mean\": " << num(distance.forwardMean)
       << ", \"reference_to_mesh_max\": " << num(distance.backwardMax) << ", \"reference_to_mesh_mean\": "
       << num(distance.backwardMean) << ", \"diagonal\": " << num(distance.diagonal) << "}";
  }
  os << "\n}\n";
  return os.str();
}

std::string MeshQuality::toTable() const {
  std::ostringstream os;
  auto row = [&](const std::string& name, const std::string& value) {
    os << "  " << std::left << std::setw(30) << name << value << "\n";
  };
  auto fix = [](double x, int digits) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(digits) << x;
    return s.str();
  };
  row("triangle quality Q min/mean", fix(qualityMin, 3) + " / " + fix(qualityMean, 3));
  row("min angle (deg) min/mean", fix(minAngleMin, 1) + " / " + fix(minAngleMean, 1));
  row("triangles with angle < 30 deg", fix(100.0 * shareBelow30, 2) + " %");
  row("vertices / faces / edges",
      std::to_string(vertices) + " / " + std::to_string(faces) + " / " + std::to_string(edges));
  row("boundary edges / loops", std::to_string(boundaryEdges) + " / " + std::to_string(boundaryLoops));
  row("non-manifold edges / vertices",
      std::to_string(nonManifoldEdges) + " / " + std::to_string(nonManifoldVertices));
  row("components", std::to_string(components));
  row("Euler characteristic", std::to_string(euler) + (genus >= 0 ? " (genus " + std::to_string(genus) + ")" : ""));
  row("closed / manifold / oriented", std::string(closed ? "yes" : "no") + " / " + (manifold ? "yes" : "no") +
                                          " / " + (oriented ? "yes" : "no"));
  if (degenerateFaces) row("degenerate faces", std::to_string(degenerateFaces));
  if (distance.computed) {
    row("Hausdorff (abs / % diag)",
        num(distance.hausdorff) + " / " + fix(100.0 * distance.relativeHausdorff(), 3) + " %");
    row("mean distance (abs / % diag)", num(distance.mean) + " / " + fix(100.0 * distance.relativeMean(), 4) + " %");
  }
  return os.str();
}

}  // namespace iires
