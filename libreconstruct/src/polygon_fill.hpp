// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Closing one hole polygon of a triangle mesh with triangles of its own vertices. Internal to libreconstruct.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "iires/types.hpp"

namespace iires::detail {

inline std::uint32_t vtx(const Eigen::Vector3i& t, int c) { return static_cast<std::uint32_t>(t[c]); }

/// The (unnormalised) normal of triangle (a, b, c) of @p m.
inline Eigen::Vector3d faceNormal(const TriangleMesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  return (m.vertices[b] - m.vertices[a]).cross(m.vertices[c] - m.vertices[a]);
}

/// Optimal triangulation of one hole polygon (vertices in the order new faces must follow);
/// @p isEdge tells whether an undirected edge key (undirectedKey) is already an edge of the mesh.
/// Returns false when every triangulation contains a forbidden triangle. With @p acrossNormals (the unit normal of
/// the face at each boundary half-edge, keyed by that half-edge), faces folding back onto those are forbidden.
bool triangulatePolygon(const TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals,
                        const std::vector<std::uint32_t>& loop, const std::function<bool(std::uint64_t)>& isEdge,
                        bool useNormals, std::vector<Eigen::Vector3i>& out, double* minQuality = nullptr,
                        const std::unordered_map<std::uint64_t, Eigen::Vector3d>* acrossNormals = nullptr);

}  // namespace iires::detail
