// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// CGAL's Surface_mesh as the CGAL-based repairs use it, and the conversion from a TriangleMesh. Internal to
// libreconstruct.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include <Eigen/Core>
#include <vector>

#include "iires/types.hpp"

namespace iires::detail {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
using VertexIndex = Mesh::Vertex_index;
using FaceIndex = Mesh::Face_index;
using HalfedgeIndex = Mesh::Halfedge_index;

inline Eigen::Vector3d toEigen(const Kernel::Point_3& p) { return {p.x(), p.y(), p.z()}; }
inline Eigen::Vector3d toEigen(const Kernel::Vector_3& v) { return {v.x(), v.y(), v.z()}; }

/// @p mesh as a Surface_mesh with the same vertex and face indices; false when it is not an oriented
/// 2-manifold (a face CGAL cannot add). With @p leftOut, such faces are left out of @p sm and listed there instead
/// (the faces after them then have other indices in @p sm), and the result is true.
inline bool toSurfaceMesh(const TriangleMesh& mesh, Mesh& sm, std::vector<std::size_t>* leftOut = nullptr) {
  sm.reserve(static_cast<Mesh::size_type>(mesh.vertices.size()),
             static_cast<Mesh::size_type>(3 * mesh.triangles.size() / 2),
             static_cast<Mesh::size_type>(mesh.triangles.size()));
  for (const auto& p : mesh.vertices) sm.add_vertex(Kernel::Point_3(p.x(), p.y(), p.z()));
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    if (sm.add_face(VertexIndex(static_cast<Mesh::size_type>(t[0])), VertexIndex(static_cast<Mesh::size_type>(t[1])),
                    VertexIndex(static_cast<Mesh::size_type>(t[2]))) != Mesh::null_face())
      continue;
    if (!leftOut) return false;
    leftOut->push_back(f);  // CGAL's add_face changes nothing when it fails
  }
  return true;
}

}  // namespace iires::detail
