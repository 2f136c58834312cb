// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The faces around each vertex of a triangle mesh, as one flat (CSR) index. Internal to libreconstruct.
#include <cstdint>
#include <vector>

#include "iires/types.hpp"

namespace iires::detail {

/// Faces of vertex v: incident[start[v]] … incident[start[v + 1] − 1], in ascending face order.
struct VertexFaces {
  std::vector<std::uint32_t> start, incident;
};

inline VertexFaces vertexFaces(const TriangleMesh& mesh) {
  const std::size_t nv = mesh.vertices.size();
  VertexFaces vf;
  vf.start.assign(nv + 1, 0);
  for (const auto& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) ++vf.start[static_cast<std::size_t>(t[c]) + 1];
  for (std::size_t v = 0; v < nv; ++v) vf.start[v + 1] += vf.start[v];
  vf.incident.resize(vf.start[nv]);
  std::vector<std::uint32_t> fill(vf.start.begin(), vf.start.end() - 1);
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
    for (int c = 0; c < 3; ++c) vf.incident[fill[static_cast<std::size_t>(mesh.triangles[f][c])]++] = f;
  return vf;
}

}  // namespace iires::detail
