#pragma once
/// @file io.hpp
/// @brief Reading and writing point clouds and meshes. All file access of iires goes through here.

#include <string>

#include "iires/types.hpp"

namespace iires {

/// @brief Read a point cloud. Formats by extension (case-insensitive): .ply (ascii/binary), .pcd, .xyz,
/// .xyzn, .pts for clouds; the vertices of .obj, .off, .stl meshes (and of a .ply with faces).
/// @throws InputError naming the file when it is missing, a directory, unreadable, of unknown extension,
/// truncated, has a corrupted header, or holds no points.
/// @note Non-finite coordinates are *not* rejected here (see validate.hpp); normals are kept when present.
PointCloud readPointCloud(const std::string& path);

/// @brief Read a triangle mesh (.ply, .obj, .off, .stl).
/// @throws InputError as readPointCloud, and when the file has no triangles.
TriangleMesh readMesh(const std::string& path);

/// @brief Write a point cloud: .ply (binary little-endian unless @p ascii, with normals when present),
/// .xyz (positions) or .xyzn (positions + normals).
/// @note Atomic: written to a temporary file in the same directory, then renamed over @p path; on any
/// failure no file is left behind. @throws InputError for an unknown extension or a missing directory.
void writePointCloud(const std::string& path, const PointCloud& cloud, bool ascii = false);

/// @brief Write a triangle mesh: .ply (binary), .obj or .off, atomically as writePointCloud.
void writeMesh(const std::string& path, const TriangleMesh& mesh);

/// @brief Write a text file (reports, transforms) atomically, as writePointCloud.
/// @throws InputError when the directory is missing or not writable.
void writeTextFile(const std::string& path, const std::string& text);

/// @brief Lower-case extension of @p path including the dot (".ply"), or "" when it has none.
std::string extensionOf(const std::string& path);

}  // namespace iires
