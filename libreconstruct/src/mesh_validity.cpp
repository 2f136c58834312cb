// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/reconstruct/mesh_validity.hpp"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <utility>

#include "iires/reconstruct/self_intersections.hpp"
#include "mesh_edges.hpp"

namespace iires {
namespace {

/// Remove the faces flagged in @p drop (keeping the others in order). Returns how many were removed.
std::size_t removeFaces(TriangleMesh& mesh, const std::vector<char>& drop) {
  auto& T = mesh.triangles;
  std::size_t w = 0;
  for (std::size_t f = 0; f < T.size(); ++f)
    if (!drop[f]) T[w++] = T[f];
  const std::size_t removed = T.size() - w;
  T.resize(w);
  return removed;
}

/// At every edge with more than two faces keep the lowest-index face and the lowest-index one using the edge in
/// the opposite direction (else the next one): the pair that can stay consistently oriented. With @p only, the
/// edges with an end it flags; the removed faces' vertices are flagged too (their removal can pinch them).
std::size_t removeNonManifoldEdgeFaces(TriangleMesh& mesh, std::size_t* edgesFound, std::vector<char>* only) {
  const std::vector<KeyedIndex> uses = detail::sortedEdgeUses(mesh, only);
  const auto face = [&](std::size_t k) { return uses[k].second / 2; };
  const auto forward = [&](std::size_t k) { return uses[k].second % 2; };
  std::vector<char> drop(mesh.triangles.size(), 0);
  std::size_t found = 0;
  detail::forEachEdge(uses, [&](std::size_t i, std::size_t j) {
    if (j - i <= 2) return;
    ++found;
    std::size_t second = i + 1;
    for (std::size_t k = i + 1; k < j; ++k)
      if (forward(k) != forward(i)) {
        second = k;
        break;
      }
    for (std::size_t k = i + 1; k < j; ++k)
      if (k != second) drop[face(k)] = 1;
  });
  if (edgesFound) *edgesFound = found;
  if (!found) return 0;
  if (only)
    for (std::size_t f = 0; f < drop.size(); ++f)
      if (drop[f])
        for (int c = 0; c < 3; ++c) (*only)[static_cast<std::size_t>(mesh.triangles[f][c])] = 1;
  return removeFaces(mesh, drop);
}

/// Flags the faces of @p pairs, grown by @p rings rings of faces through shared vertices.
std::vector<char> grownRegion(const TriangleMesh& mesh, const std::vector<std::pair<std::size_t, std::size_t>>& pairs,
                              int rings) {
  std::vector<char> in(mesh.triangles.size(), 0);
  for (const auto& [f, g] : pairs) in[f] = in[g] = 1;
  std::vector<char> vertexIn(mesh.vertices.size(), 0);
  for (int r = 0; r < rings; ++r) {
    for (std::size_t f = 0; f < in.size(); ++f)
      if (in[f])
        for (int c = 0; c < 3; ++c) vertexIn[static_cast<std::size_t>(mesh.triangles[f][c])] = 1;
    for (std::size_t f = 0; f < in.size(); ++f)
      for (int c = 0; c < 3; ++c)
        if (vertexIn[static_cast<std::size_t>(mesh.triangles[f][c])]) in[f] = 1;
  }
  return in;
}

/// Flags the vertices of the faces @p faces flags.
std::vector<char> verticesOf(const TriangleMesh& mesh, const std::vector<char>& faces) {
  std::vector<char> in(mesh.vertices.size(), 0);
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (faces[f])
      for (int c = 0; c < 3; ++c) in[static_cast<std::size_t>(mesh.triangles[f][c])] = 1;
  return in;
}

/// Make every edge and vertex manifold by removing faces; returns the faces removed. With @p only (a flag per
/// vertex), only its vertices and the edges they end are looked at: where a removal or a fill changed the faces.
std::size_t removeNonManifold(TriangleMesh& mesh, std::size_t minComponentFaces, int threads,
                              std::size_t* edgesFound = nullptr, std::vector<char>* only = nullptr) {
  std::size_t removed = removeNonManifoldEdgeFaces(mesh, edgesFound, only);
  if (const std::size_t fans = removeExtraFans(mesh, threads, only); fans > 0) {
    removed += fans;
    if (minComponentFaces > 1) removed += removeSmallComponents(mesh, minComponentFaces);
  }
  return removed;
}

/// Fill the holes a removal opened (their loops pass through a vertex @p opened flags) as the pipeline fills
/// holes: small loops, extra fans, large loops.
void refill(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, const std::vector<char>& opened,
            const ValidityParams& params, int threads, ValidityReport& report) {
  const std::size_t faces = mesh.triangles.size(), vertices = mesh.vertices.size();
  const std::vector<Eigen::Vector3i> before = mesh.triangles;
  const std::size_t open = fillSmallHoles(mesh, normals, params.holes).kept;
  // The fills append faces and change a few in place (zips): only their vertices can be pinched.
  std::vector<char> filled(mesh.triangles.size(), 1);
  for (std::size_t f = 0; f < faces; ++f) filled[f] = mesh.triangles[f] != before[f];
  std::vector<char> touched = verticesOf(mesh, filled);
  const std::size_t pinched = removeNonManifold(mesh, params.minComponentFaces, threads, nullptr, &touched);
  if (params.holes.maxRefinedExtent > 0 && (open > 0 || pinched > 0)) {  // else no loop is left for it
    orientConsistently(mesh, normals);  // fillLargeHoles needs an oriented 2-manifold
    std::vector<char> loops(mesh.vertices.size(), 0);  // the loops the removal and the pinched fans opened
    for (std::size_t v = 0; v < loops.size(); ++v)
      loops[v] = (v < opened.size() && opened[v]) || (v < touched.size() && touched[v]);
    for (std::uint32_t v : params.unseenLoops)
      if (v < loops.size()) loops[v] = 1;
    fillLargeHoles(mesh, normals, params.holes, params.onlyOpenedLoops ? &loops : nullptr);
  }
  report.facesRemoved += pinched;
  report.facesAdded += mesh.triangles.size() + pinched - faces;
  report.verticesAdded += mesh.vertices.size() - vertices;
}

}  // namespace

void ValidityParams::validate() const {
  if (rounds < 0) throw std::invalid_argument("validity repair: rounds must be non-negative");
  holes.validate();
}

ValidityReport repairValidity(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, const ValidityParams& params,
                              const Execution& exec, const TriangleMesh* clean) {
  params.validate();
  ValidityReport report;
  // Since a clean mesh, only what changed can be non-manifold or intersect (the changed faces with the rest).
  std::vector<char> changed, touched;
  if (clean) {  // the vertices of the faces that are new, moved or gone
    changed = facesChangedSince(*clean, mesh);
    touched = verticesOf(mesh, changed);
    const std::vector<char> gone = verticesOf(*clean, facesChangedSince(mesh, *clean));
    for (std::size_t v = 0; v < gone.size() && v < touched.size(); ++v) touched[v] |= gone[v];
  }
  const std::size_t dropped = removeNonManifold(mesh, params.minComponentFaces, exec.threads, &report.nonManifoldEdges,
                                                clean ? &touched : nullptr);
  report.facesRemoved += dropped;
  if (clean && dropped > 0) changed = facesChangedSince(*clean, mesh);  // removing faces creates no intersection
  std::vector<std::pair<std::size_t, std::size_t>> pairs =
      clean ? selfIntersections(mesh, changed, exec.threads) : selfIntersections(mesh, exec.threads);
  report.intersectingPairs = pairs.size();
  for (int round = 1; round <= params.rounds && !pairs.empty() && params.refill; ++round) {
    ++report.rounds;
    const std::vector<char> drop = grownRegion(mesh, pairs, round);
    std::vector<char> pinchable = verticesOf(mesh, drop);  // removing faces pinches only their vertices
    report.facesRemoved += removeFaces(mesh, drop);
    report.facesRemoved += removeNonManifold(mesh, params.minComponentFaces, exec.threads, nullptr, &pinchable);
    if (params.minComponentFaces > 1) report.facesRemoved += removeSmallComponents(mesh, params.minComponentFaces);
    const TriangleMesh removed = mesh;  // free of intersections: every face of a pair went
    refill(mesh, normals, pinchable, params, exec.threads, report);
    pairs = selfIntersections(mesh, facesChangedSince(removed, mesh), exec.threads);
  }
  // What still intersects goes without a fill: removing faces creates no intersection, and removeNonManifold
  // only removes faces too.
  if (!pairs.empty()) {
    const std::size_t removed = removeFaces(mesh, grownRegion(mesh, pairs, 0)) + removeNonManifold(mesh, 0, exec.threads);
    report.removedWithoutFill += removed;
    report.facesRemoved += removed;
  }
  return report;
}

}  // namespace iires
