#pragma once
/// @file types.hpp
/// @brief Basic containers shared by every iires library: point clouds, triangle meshes, errors.

#include <Eigen/Core>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace iires {

/// @brief A point cloud: positions and (optionally) one unit normal per point.
struct PointCloud {
  std::vector<Eigen::Vector3d> points;   ///< positions, any units
  std::vector<Eigen::Vector3d> normals;  ///< empty, or one unit normal per point

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool hasNormals() const { return !normals.empty() && normals.size() == points.size(); }
};

/// @brief An indexed triangle mesh.
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;   ///< vertex positions
  std::vector<Eigen::Vector3i> triangles;  ///< vertex indices, counter-clockwise seen from outside
};

/// @brief Thrown when the *input* is unusable (missing/unreadable file, unknown format, empty cloud,
/// NaN coordinates, too few points, bad parameters given by the user). Tools map it to exit code 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace iires
