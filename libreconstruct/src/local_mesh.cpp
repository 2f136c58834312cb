// SPDX-License-Identifier: GPL-3.0-or-later
#include "local_mesh.hpp"

#include <unordered_map>

#include "iires/detail/disjoint_sets.hpp"
#include "mesh_edges.hpp"

namespace iires::detail {

bool localSurfaceMesh(const std::vector<Eigen::Vector3i>& faces,
                      const std::function<Eigen::Vector3d(std::uint32_t)>& point, Mesh& sm,
                      std::vector<std::uint32_t>& global) {
  const std::size_t nc = 3 * faces.size();
  auto vertexAt = [&](std::size_t corner) {
    return static_cast<std::uint32_t>(faces[corner / 3][static_cast<int>(corner % 3)]);
  };
  auto nextCorner = [](std::size_t corner) { return corner - corner % 3 + (corner % 3 + 1) % 3; };
  std::unordered_map<std::uint64_t, std::uint32_t> from;  // half-edge a → b: the corner of a
  from.reserve(nc);
  for (std::size_t k = 0; k < nc; ++k) from.emplace(directedKey(vertexAt(k), vertexAt(nextCorner(k))), k);
  DisjointSets fans(nc);
  for (std::size_t k = 0; k < nc; ++k) {
    const auto it = from.find(directedKey(vertexAt(nextCorner(k)), vertexAt(k)));  // the twin, b → a
    if (it == from.end()) continue;
    fans.unite(static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(nextCorner(it->second)));  // a
    fans.unite(static_cast<std::uint32_t>(nextCorner(k)), it->second);                              // b
  }
  std::vector<std::uint32_t> local(nc), id(nc, ~0u);
  global.clear();
  for (std::size_t k = 0; k < nc; ++k) {
    std::uint32_t& root = id[fans.find(static_cast<std::uint32_t>(k))];
    if (root == ~0u) root = static_cast<std::uint32_t>(global.size()), global.push_back(vertexAt(k));
    local[k] = root;
  }
  sm.clear();
  for (std::uint32_t g : global) {
    const Eigen::Vector3d p = point(g);
    sm.add_vertex(Kernel::Point_3(p.x(), p.y(), p.z()));
  }
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (sm.add_face(VertexIndex(local[3 * f]), VertexIndex(local[3 * f + 1]), VertexIndex(local[3 * f + 2])) ==
        Mesh::null_face())
      return false;
  return true;
}

}  // namespace iires::detail
