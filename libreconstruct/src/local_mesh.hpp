// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A few faces of a larger mesh as a Surface_mesh of their own, so that CGAL's remeshing (whose tangential
// relaxation visits every vertex of the mesh it is given) costs what the faces cost. Internal to libreconstruct.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "surface_mesh.hpp"

namespace iires::detail {

/// @p faces (vertex indices of the larger mesh, positions from @p point) as the Surface_mesh @p sm, face k as sm's
/// face k, with one local vertex per fan of faces around each vertex (corners joined across shared edges): a
/// vertex whose faces here meet only there becomes two, so @p sm is a 2-manifold. @p global gets each local
/// vertex's index in the larger mesh. False when CGAL cannot add a face (the faces are not consistently oriented).
bool localSurfaceMesh(const std::vector<Eigen::Vector3i>& faces,
                      const std::function<Eigen::Vector3d(std::uint32_t)>& point, Mesh& sm,
                      std::vector<std::uint32_t>& global);

}  // namespace iires::detail
