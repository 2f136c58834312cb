// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/reconstruct/mesh_quality.hpp"

#include "mesh_edges.hpp"
#include "vertex_faces.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "iires/detail/json.hpp"
#include "iires/detail/disjoint_sets.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/reconstruct/self_intersections.hpp"
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

/// The undirected edges of a mesh from its sorted half-edges: per edge its vertices and its run in `he`.
struct EdgeRun {
  std::uint32_t a, b;          // a < b
  std::size_t begin, end;      // he[begin, end) are its half-edges
};

std::vector<HalfEdge> sortedHalfEdges(const TriangleMesh& mesh) {
  const std::vector<KeyedIndex> uses = detail::sortedEdgeUses(mesh);  // by edge, faces ascending within one
  std::vector<HalfEdge> he;
  he.reserve(uses.size());
  for (const auto& [key, use] : uses) he.push_back({key, use / 2, use % 2 == 1});
  return he;
}

/// Edge counts, boundary, orientation and mean edge length; the boundary-edge graph's union-find in @p boundary.
std::vector<EdgeRun> edgeStats(const TriangleMesh& mesh, const std::vector<HalfEdge>& he, DisjointSets& boundary,
                               std::vector<char>& onBoundary, MeshQuality& q) {
  std::vector<EdgeRun> edges;
  q.oriented = true;
  double edgeLength = 0;
  for (std::size_t i = 0; i < he.size();) {
    std::size_t j = i;
    std::size_t forward = 0;
    while (j < he.size() && he[j].key == he[i].key) forward += he[j++].forward ? 1 : 0;
    const std::size_t count = j - i, backward = count - forward;
    const auto a = static_cast<std::uint32_t>(he[i].key >> 32), b = static_cast<std::uint32_t>(he[i].key);
    edges.push_back({a, b, i, j});
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
  q.edges = edges.size();
  if (q.edges) q.meanEdgeLength = edgeLength / static_cast<double>(q.edges);
  for (std::uint32_t v = 0; v < mesh.vertices.size(); ++v)
    if (onBoundary[v] && boundary.find(v) == v) ++q.boundaryLoops;
  return edges;
}

/// Whether vertex v (its faces incident[begin, end)) is manifold: its link (the opposite edges of its faces) is
/// one path or one cycle, and none of its faces is degenerate at it.
bool manifoldVertex(const TriangleMesh& mesh, std::uint32_t v, const std::uint32_t* begin, const std::uint32_t* end) {
  std::vector<std::uint32_t> linkVerts;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> linkEdges;
  for (const std::uint32_t* s = begin; s != end; ++s) {
    const auto& t = mesh.triangles[*s];
    int c = 0;
    while (static_cast<std::uint32_t>(t[c]) != v) ++c;
    const auto x = static_cast<std::uint32_t>(t[(c + 1) % 3]), y = static_cast<std::uint32_t>(t[(c + 2) % 3]);
    if (x == v || y == v || x == y) return false;
    linkEdges.emplace_back(x, y);
    linkVerts.push_back(x);
    linkVerts.push_back(y);
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
  for (std::uint32_t i = 0; i < linkVerts.size(); ++i) {
    if (link.find(i) == i) ++parts;
    if (degree[i] > 2) return false;
  }
  return parts == 1;
}

/// Per face, whether it can be oriented consistently with its neighbours across manifold edges: 2-colouring
/// of the face graph where a neighbour sharing an edge in the same direction must be flipped. Returns, per face
/// component root (through vertices, @p comp), whether a conflict was found.
std::vector<char> orientationConflicts(const TriangleMesh& mesh, const std::vector<HalfEdge>& he,
                                       const std::vector<EdgeRun>& edges, DisjointSets& comp) {
  const std::size_t nf = mesh.triangles.size();
  std::vector<std::uint32_t> start(nf + 1, 0);
  for (const EdgeRun& e : edges)
    if (e.end - e.begin == 2) ++start[he[e.begin].face + 1], ++start[he[e.begin + 1].face + 1];
  for (std::size_t f = 0; f < nf; ++f) start[f + 1] += start[f];
  std::vector<std::pair<std::uint32_t, char>> adj(start[nf]);  // neighbour, must differ in flip
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (const EdgeRun& e : edges) {
      if (e.end - e.begin != 2) continue;
      const HalfEdge &x = he[e.begin], &y = he[e.begin + 1];
      const char flip = x.forward == y.forward ? 1 : 0;  // same direction: one of them must be reversed
      adj[fill[x.face]++] = {y.face, flip};
      adj[fill[y.face]++] = {x.face, flip};
    }
  }
  std::vector<char> conflict(mesh.vertices.size(), 0);
  std::vector<signed char> side(nf, -1);
  std::vector<std::uint32_t> queue;
  for (std::uint32_t f0 = 0; f0 < nf; ++f0) {
    if (side[f0] >= 0) continue;
    side[f0] = 0;
    queue.assign(1, f0);
    for (std::size_t qi = 0; qi < queue.size(); ++qi) {
      const std::uint32_t f = queue[qi];
      for (std::uint32_t s = start[f]; s < start[f + 1]; ++s) {
        const auto [g, flip] = adj[s];
        const signed char want = static_cast<signed char>(side[f] ^ flip);
        if (side[g] < 0) {
          side[g] = want;
          queue.push_back(g);
        } else if (side[g] != want) {
          conflict[comp.find(static_cast<std::uint32_t>(mesh.triangles[f][0]))] = 1;
        }
      }
    }
  }
  return conflict;
}

/// The per-component topology (q.parts) and the summary built from it (genus, closed components, orientable).
void componentStats(const TriangleMesh& mesh, const std::vector<HalfEdge>& he, const std::vector<EdgeRun>& edges,
                    DisjointSets& comp, DisjointSets& boundary, const std::vector<char>& onBoundary,
                    const std::vector<char>& badVertex, const std::vector<char>& referenced, MeshQuality& q) {
  const std::size_t nv = mesh.vertices.size();
  std::vector<std::size_t> index(nv, 0);  // component root → position in parts (roots in ascending order)
  std::vector<std::uint32_t> roots;
  for (std::uint32_t v = 0; v < nv; ++v)
    if (referenced[v] && comp.find(v) == v) index[v] = roots.size(), roots.push_back(v);
  std::vector<ComponentTopology> parts(roots.size());
  for (auto& p : parts) p.manifold = true;
  auto of = [&](std::uint32_t v) -> ComponentTopology& { return parts[index[comp.find(v)]]; };
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (!referenced[v]) continue;
    ComponentTopology& p = of(v);
    ++p.vertices;
    if (badVertex[v]) p.manifold = false;
    if (onBoundary[v] && boundary.find(v) == v) ++p.boundaryLoops;
  }
  for (const auto& t : mesh.triangles) ++of(static_cast<std::uint32_t>(t[0])).faces;
  for (const EdgeRun& e : edges) {
    ComponentTopology& p = of(e.a);
    ++p.edges;
    if (e.end - e.begin > 2) p.manifold = false;
  }
  const std::vector<char> conflict = orientationConflicts(mesh, he, edges, comp);
  q.orientable = true;
  long long genusSum = 0;
  bool allGenus = true;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    ComponentTopology& p = parts[i];
    p.euler = static_cast<long long>(p.vertices) - static_cast<long long>(p.edges) + static_cast<long long>(p.faces);
    p.orientable = p.manifold && !conflict[roots[i]];
    p.closed = p.manifold && p.boundaryLoops == 0;
    const long long twiceGenus = 2 - p.euler - static_cast<long long>(p.boundaryLoops);
    if (p.orientable && twiceGenus >= 0 && twiceGenus % 2 == 0) p.genus = twiceGenus / 2;
    if (p.closed) ++q.closedComponents;
    if (!p.orientable) q.orientable = false;
    if (p.genus < 0) allGenus = false;
    genusSum += std::max(p.genus, 0LL);
  }
  q.genus = allGenus && !parts.empty() ? genusSum : -1;
  std::vector<std::size_t> order(parts.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return parts[x].faces > parts[y].faces; });
  q.parts.clear();
  for (std::size_t i : order) q.parts.push_back(parts[i]);
}

/// One component in words: "closed, genus 1, 5000 faces" / "open, 2 boundary loops, genus 0, 120 faces".
std::string describePart(const ComponentTopology& p) {
  std::string s;
  if (!p.manifold) {
    s = "non-manifold";
  } else {
    s = p.closed ? "closed" : "open, " + std::to_string(p.boundaryLoops) + " boundary loop" + (p.boundaryLoops == 1 ? "" : "s");
    s += p.genus >= 0 ? ", genus " + std::to_string(p.genus) : ", not orientable";
  }
  return s + ", " + std::to_string(p.faces) + " faces";
}

void topologyStats(const TriangleMesh& mesh, MeshQuality& q) {
  const std::size_t nv = mesh.vertices.size(), nf = mesh.triangles.size();
  q.faces = nf;
  const std::vector<HalfEdge> he = sortedHalfEdges(mesh);
  DisjointSets boundary(nv);
  std::vector<char> onBoundary(nv, 0);
  const std::vector<EdgeRun> edges = edgeStats(mesh, he, boundary, onBoundary, q);

  // Vertex → faces (CSR), referenced vertices, components.
  const detail::VertexFaces vf = detail::vertexFaces(mesh);
  const std::vector<std::uint32_t>&start = vf.start, &incident = vf.incident;
  DisjointSets comp(nv);
  for (const auto& t : mesh.triangles) {
    comp.unite(static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[1]));
    comp.unite(static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[2]));
  }
  std::vector<char> referenced(nv, 0), badVertex(nv, 0);
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (start[v] == start[v + 1]) {
      ++q.isolatedVertices;
      continue;
    }
    referenced[v] = 1;
    ++q.vertices;
    if (comp.find(v) == v) ++q.components;
    if (!manifoldVertex(mesh, v, incident.data() + start[v], incident.data() + start[v + 1])) {
      badVertex[v] = 1;
      ++q.nonManifoldVertices;
    }
  }
  q.euler = static_cast<long long>(q.vertices) - static_cast<long long>(q.edges) + static_cast<long long>(nf);
  q.closed = nf > 0 && q.boundaryEdges == 0 && q.nonManifoldEdges == 0;
  q.manifold = q.nonManifoldEdges == 0 && q.nonManifoldVertices == 0;
  componentStats(mesh, he, edges, comp, boundary, onBoundary, badVertex, referenced, q);
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

MeshQuality evaluateMesh(const TriangleMesh& mesh, const PointCloud* reference, const MeshQualityParams& params,
                         const Execution& exec) {
  params.validate();
  checkIndices(mesh);
  MeshQuality q;
  shapeStats(mesh, q, exec.threads);
  topologyStats(mesh, q);
  q.selfIntersections = selfIntersections(mesh, exec.threads).size();
  if (reference && !reference->empty() && !mesh.triangles.empty()) {
    SurfaceDistance& d = q.distance;
    d.computed = true;
    d.diagonal = bboxDiagonal(reference->points);
    const MeshDistance toMesh(mesh);
    const std::size_t nr = reference->size();
    std::vector<double> back(nr);
    parallelFor(nr, exec.threads, [&](std::size_t i) { back[i] = toMesh.distance(reference->points[i]); });
    q.uncoveredDistance = 2.0 * q.meanEdgeLength;
    double backSum = 0;
    for (std::size_t i = 0; i < nr; ++i) {  // fixed order: independent of the thread count
      backSum += back[i];
      d.backwardMax = std::max(d.backwardMax, back[i]);
      if (back[i] > q.uncoveredDistance) q.uncoveredPoints.push_back(i);
    }
    d.backwardMean = backSum / static_cast<double>(nr);
    q.uncovered = q.uncoveredPoints.size();
    q.uncoveredShare = static_cast<double>(q.uncovered) / static_cast<double>(nr);
    const std::vector<Eigen::Vector3d> samples = meshSamplePoints(mesh, params.meshSamples, params.seed);
    const KnnIndex index(reference->points);
    std::vector<double> dist(samples.size());
    parallelFor(samples.size(), exec.threads, [&](std::size_t i) {
      double sq = 0;
      index.nearest(samples[i], &sq);
      dist[i] = std::sqrt(sq);
    });
    double sum = 0;
    for (double x : dist) sum += x, d.forwardMax = std::max(d.forwardMax, x);
    d.forwardMean = dist.empty() ? 0.0 : sum / static_cast<double>(dist.size());
    d.hausdorff = std::max(d.forwardMax, d.backwardMax);
    d.mean = 0.5 * (d.forwardMean + d.backwardMean);
    // The area samples follow the q.vertices vertex samples (meshSamplePoints).
    if (dist.size() > q.vertices) {
      const auto far = std::count_if(dist.begin() + static_cast<std::ptrdiff_t>(q.vertices), dist.end(),
                                     [&](double x) { return x > q.uncoveredDistance; });
      q.unsupportedShare = static_cast<double>(far) / static_cast<double>(dist.size() - q.vertices);
    }
  }
  return q;
}

PointCloud uncoveredInput(const PointCloud& reference, const MeshQuality& quality) {
  PointCloud out;
  for (std::size_t i : quality.uncoveredPoints) {
    if (i >= reference.size()) throw std::invalid_argument("uncoveredInput: not the cloud the report measured");
    out.points.push_back(reference.points[i]);
    if (reference.hasNormals()) out.normals.push_back(reference.normals[i]);
  }
  return out;
}

SurfaceDistance surfaceDistance(const TriangleMesh& mesh, const TriangleMesh& referenceMesh,
                                const MeshQualityParams& params, const Execution& exec) {
  params.validate();
  checkIndices(mesh);
  checkIndices(referenceMesh);
  SurfaceDistance d;
  if (mesh.triangles.empty() || referenceMesh.triangles.empty()) return d;
  d.computed = true;
  const MeshDistance toRef(referenceMesh), toMesh(mesh);
  d.diagonal = toRef.diagonal();
  const DistanceStats fwd = toRef.distances(meshSamplePoints(mesh, params.meshSamples, params.seed), exec.threads);
  const DistanceStats bwd =
      toMesh.distances(meshSamplePoints(referenceMesh, params.referenceSamples, params.seed + 1), exec.threads);
  d.forwardMax = fwd.max;
  d.forwardMean = fwd.mean;
  d.backwardMax = bwd.max;
  d.backwardMean = bwd.mean;
  d.hausdorff = std::max(d.forwardMax, d.backwardMax);
  d.mean = 0.5 * (d.forwardMean + d.backwardMean);
  return d;
}

std::string MeshQuality::toJson() const {
  detail::JsonWriter j;
  const auto genusMember = [&](int g) { g >= 0 ? j.member("genus", g) : j.key("genus").null(); };  // -1: none
  j.beginObject(true);
  j.key("quality").beginObject().member("min", qualityMin).member("mean", qualityMean).endObject();
  j.key("min_angle_deg").beginObject().member("min", minAngleMin).member("mean", minAngleMean).endObject();
  j.member("share_angle_below_30", shareBelow30).member("degenerate_faces", degenerateFaces);
  j.member("vertices", vertices).member("isolated_vertices", isolatedVertices);
  j.member("faces", faces).member("edges", edges);
  j.member("boundary_edges", boundaryEdges).member("boundary_loops", boundaryLoops);
  j.member("non_manifold_edges", nonManifoldEdges).member("non_manifold_vertices", nonManifoldVertices);
  j.member("self_intersecting_face_pairs", selfIntersections);
  j.member("components", components).member("closed_components", closedComponents).member("euler", euler);
  genusMember(genus);
  j.key("parts").beginArray();
  for (const ComponentTopology& p : parts) {
    j.beginObject().member("faces", p.faces).member("vertices", p.vertices).member("euler", p.euler);
    j.member("boundary_loops", p.boundaryLoops).member("closed", p.closed).member("manifold", p.manifold);
    j.member("orientable", p.orientable);
    genusMember(p.genus);
    j.endObject();
  }
  j.endArray().member("closed", closed).member("manifold", manifold).member("orientable", orientable);
  j.member("oriented", oriented).member("valid", valid());
  j.member("mean_edge_length", meanEdgeLength).member("area", area);
  if (distance.computed) {
    j.key("distance").beginObject().member("hausdorff", distance.hausdorff).member("mean", distance.mean);
    j.member("hausdorff_rel_diag", distance.relativeHausdorff()).member("mean_rel_diag", distance.relativeMean());
    j.member("mesh_to_reference_max", distance.forwardMax).member("mesh_to_reference_mean", distance.forwardMean);
    j.member("reference_to_mesh_max", distance.backwardMax);
    j.member("reference_to_mesh_mean", distance.backwardMean).member("diagonal", distance.diagonal).endObject();
    j.key("uncovered").beginObject().member("count", uncovered).member("share", uncoveredShare);
    j.member("distance", uncoveredDistance).endObject();
    j.key("unsupported").beginObject().member("share", unsupportedShare).member("distance", uncoveredDistance);
    j.endObject();
  }
  j.endObject();
  return j.str() + "\n";
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
  row("self-intersecting face pairs", std::to_string(selfIntersections));
  row("components", std::to_string(components) + " (" + std::to_string(closedComponents) + " closed)");
  constexpr std::size_t kListed = 8;  // the largest components, one line each
  for (std::size_t i = 0; i < parts.size() && i < kListed; ++i)
    row(i == 0 ? "  by size" : "", describePart(parts[i]));
  if (parts.size() > kListed) row("", "... " + std::to_string(parts.size() - kListed) + " smaller components");
  row("Euler characteristic", std::to_string(euler));
  row("closed / manifold / oriented", std::string(closed ? "yes" : "no") + " / " + (manifold ? "yes" : "no") +
                                          " / " + (oriented ? "yes" : "no"));
  if (degenerateFaces) row("degenerate faces", std::to_string(degenerateFaces));
  if (distance.computed) {
    row("Hausdorff (abs / % diag)",
        num(distance.hausdorff) + " / " + fix(100.0 * distance.relativeHausdorff(), 3) + " %");
    row("mean distance (abs / % diag)", num(distance.mean) + " / " + fix(100.0 * distance.relativeMean(), 4) + " %");
    row("mesh -> input max (% diag)", fix(100.0 * distance.forwardMax / distance.diagonal, 3) + " %");
    row("input -> mesh max (% diag)", fix(100.0 * distance.backwardMax / distance.diagonal, 3) + " %");
    row("uncovered input (>2 spacings)",
        std::to_string(uncovered) + " points (" + fix(100.0 * uncoveredShare, 2) + " %)");
    row("mesh off input (>2 spacings)", fix(100.0 * unsupportedShare, 2) + " % of its area");
  }
  return os.str();
}

}  // namespace iires
