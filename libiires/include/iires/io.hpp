// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file io.hpp
/// @brief Reading and writing point clouds and meshes. All file access of iires goes through here.

#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "iires/types.hpp"

namespace iires {

/// @brief Read a point cloud. Formats by extension (case-insensitive): .ply (ascii/binary), .pcd, .xyz,
/// .xyzn (or CGAL's .pwn), .pts for clouds; the vertices of .obj, .off, .stl meshes (and of a .ply with faces),
/// which get area-weighted face normals oriented by the faces' winding when the file has no normals of its own.
/// @throws InputError naming the file when it is missing, a directory, unreadable, of unknown extension,
/// truncated, has a corrupted header, or holds no points.
/// @note Non-finite coordinates are *not* rejected here (see validate.hpp); normals are kept when present
/// (PLY nx ny nz, PCD normal_x.., NOFF, .xyzn, and a .xyz with 6 columns: x y z nx ny nz as CGAL writes).
/// A .pts may start with a point count; columns after x y z are ignored. Readers are strict: a malformed
/// line, a count that does not match the data, a truncated binary body or trailing data is an error.
/// Messages read "<path>: <problem>", with "line N: " where a line is to blame.
/// Vertex properties other than positions and normals are kept as PointCloud::attributes (PLY properties,
/// PCD fields, a PCD packed rgb/rgba as red green blue): colour channels (red green blue alpha, r g b a,
/// diffuse_*) averaged when resampled, other integer properties labels (majority), the rest scalars.
PointCloud readPointCloud(const std::string& path);

/// @brief Read a .xyz file whose columns are named by @p columns (e.g. {"x","y","z","red","green","blue",
/// "intensity"}): x y z required, nx ny nz together or not at all, other names attributes; "name:type" gives
/// an attribute's storage type (a PLY type: uchar, int, float, ...; an integer type makes it a label).
/// Untyped colour columns are uchar when every value is a whole number in [0, 255], else float; others float.
/// Every line must hold exactly one value per column. With @p columns empty, as readPointCloud(path).
/// @throws InputError as readPointCloud, and for bad column names or a file that is not .xyz.
PointCloud readPointCloud(const std::string& path, const std::vector<std::string>& columns);

/// @brief Read a file as the points of a surface: a cloud as readPointCloud(); a mesh (.ply with faces, .obj, .off,
/// .stl) as its vertices and, on every face larger than its median edge length squared, points spread over it (a
/// CAD part's vertices lie on its faces' rims only; a cube's 8 sample nothing of it) — at least about 100,000
/// over the surface; a mesh finer than that reads as its vertices. Normals: the file's (blended onto the face
/// points), or none (the resampler estimates them from the points); the face points take their corners'
/// attributes (blended; a label the nearest corner's). What the tools read as INPUT.
/// @throws InputError as readPointCloud.
PointCloud readSurfacePoints(const std::string& path, const std::vector<std::string>& columns = {});

/// @brief Read a triangle mesh (.ply, .obj, .off, .stl).
/// @throws InputError as readPointCloud, and when the file has no triangles or a face index is out of range.
/// @note Polygons are fan-triangulated; STL corners at identical positions become one vertex.
TriangleMesh readMesh(const std::string& path);

/// @brief Write a point cloud: .ply (binary little-endian unless @p ascii, with normals when present and
/// the attributes in their storage types), .xyz (positions) or .xyzn (positions + normals).
/// @note Atomic: written to a temporary file in the same directory, then renamed over @p path; on any
/// failure no file is left behind. @throws InputError for an unknown extension, a missing directory, or
/// .xyzn for a cloud without normals; messages read "cannot write <path>: <problem>".
/// @note PLY properties are doubles; text formats use the shortest decimal form that reads back exactly.
void writePointCloud(const std::string& path, const PointCloud& cloud, bool ascii = false);

/// @brief Write a triangle mesh: .ply (binary, with the vertex attributes), .obj or .off, atomically as
/// writePointCloud.
/// @throws InputError as writePointCloud, and when a triangle refers to a vertex the mesh does not have.
void writeMesh(const std::string& path, const TriangleMesh& mesh);

/// @brief Write a text file (reports, transforms) atomically, as writePointCloud.
/// @throws InputError when the directory is missing or not writable.
void writeTextFile(const std::string& path, const std::string& text);

/// @brief The outputs of one run, committed together or not at all.
///
/// Each write goes to a temporary file in its target's directory as soon as it is staged, so a full disk or a
/// bad path fails before anything is committed; commit() then renames every temporary over its target (with
/// SIGINT/SIGTERM/SIGHUP held back until it is done). A batch destroyed without commit() — an exception, a
/// failed later write — removes its temporaries and leaves every target as it was. With
/// removeTemporariesOnSignal() installed, an interrupted run removes them too.
/// @throws InputError from the staging calls as the single-file writers do ("cannot write <path>: ...").
class OutputBatch {
 public:
  OutputBatch();
  ~OutputBatch();
  OutputBatch(const OutputBatch&) = delete;
  OutputBatch& operator=(const OutputBatch&) = delete;

  void pointCloud(const std::string& path, const PointCloud& cloud, bool ascii = false);  ///< as writePointCloud
  void mesh(const std::string& path, const TriangleMesh& mesh);                           ///< as writeMesh
  void text(const std::string& path, const std::string& text);                            ///< as writeTextFile
  /// Any other format: @p write fills the stream (opened in binary mode); a failed stream fails the write.
  void file(const std::string& path, const std::function<void(std::ostream&)>& write);
  /// Renames every staged file over its target. @throws InputError when a rename fails.
  void commit();

 private:
  struct Staged;
  std::vector<std::unique_ptr<Staged>> staged_;
};

/// @brief Install handlers for SIGINT, SIGTERM and SIGHUP that remove the temporary files of uncommitted
/// writes, then end the process as the signal would have (the tools call this first).
void removeTemporariesOnSignal();

/// @brief Lower-case extension of @p path including the dot (".ply"), or "" when it has none; the extension of
/// its format where two name one: CGAL's ".pwn" (x y z nx ny nz per line) is ".xyzn".
std::string extensionOf(const std::string& path);

}  // namespace iires
