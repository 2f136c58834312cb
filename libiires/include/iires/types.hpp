// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file types.hpp
/// @brief Basic containers shared by every iires library: point clouds, triangle meshes, errors.

#include <Eigen/Core>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace iires {

/// @brief How a per-point attribute is carried to new points (attributes.hpp).
enum class AttributeKind {
  kScalar,  ///< a measurement (intensity, curvature, ...): averaged over the neighbours
  kColor,   ///< one colour channel (red, green, blue, alpha): averaged over the neighbours
  kLabel,   ///< an integer class or id: the neighbours' majority
};

/// @brief One per-point property of a cloud or of a mesh's vertices (a PLY vertex property, an XYZ column,
/// a PCD field), with the type it was stored as so that writers give it back in the same form.
struct PointAttribute {
  std::string name;                          ///< e.g. "red", "intensity", "label"
  AttributeKind kind = AttributeKind::kScalar;
  std::string type = "float";                ///< storage type, PLY names: char uchar short ushort int uint float double
  std::vector<double> values;                ///< one value per point

  /// @brief Whether the storage type is an integer type (values are whole numbers then).
  bool isInteger() const { return type != "float" && type != "double"; }
};

/// @brief A point cloud: positions, (optionally) one unit normal per point, and any per-point attributes.
struct PointCloud {
  std::vector<Eigen::Vector3d> points;   ///< positions, any units
  std::vector<Eigen::Vector3d> normals;  ///< empty, or one unit normal per point
  std::vector<PointAttribute> attributes;  ///< each with one value per point (colours, intensity, labels)

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool hasNormals() const { return !normals.empty() && normals.size() == points.size(); }
};

/// @brief An indexed triangle mesh.
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;   ///< vertex positions
  std::vector<Eigen::Vector3i> triangles;  ///< vertex indices, counter-clockwise seen from outside
  std::vector<PointAttribute> vertexAttributes;  ///< each with one value per vertex (empty: none)
};

/// @brief Thrown when the *input* is unusable (missing/unreadable file, unknown format, empty cloud,
/// NaN coordinates, too few points, bad parameters given by the user). Tools map it to exit code 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace iires
