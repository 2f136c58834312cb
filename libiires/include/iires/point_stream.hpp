// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file point_stream.hpp
/// @brief Reading a point cloud file in chunks, never holding it whole (out-of-core resampling, DESIGN §9).

#include <cstddef>
#include <memory>
#include <string>

#include "iires/types.hpp"

namespace iires {

/// @brief A point cloud file read chunk by chunk: .ply (ascii, binary little- or big-endian, with the vertex
/// element first), .xyz (x y z, or x y z nx ny nz on every line) and .xyzn.
///
/// Positions and normals only: other vertex properties are skipped. Strict like readPointCloud: a malformed
/// line, a truncated body or a non-finite coordinate is an InputError naming the file (and the line).
/// @note Memory: one chunk plus a read buffer of a few MB, whatever the file size.
class PointStream {
 public:
  /// Opens @p path and reads its header. @throws InputError for a missing file, an unsupported extension or
  /// a corrupted header.
  explicit PointStream(const std::string& path);
  ~PointStream();
  PointStream(const PointStream&) = delete;
  PointStream& operator=(const PointStream&) = delete;

  /// Whether the points come with normals.
  bool hasNormals() const;
  /// The point count the header declares (PLY), or an estimate from the file size and the first lines (text).
  std::size_t estimatedCount() const;
  /// Replaces @p chunk's points (and normals) with the next up to @p maxPoints points of the file.
  /// @return false when the file is exhausted (and @p chunk is empty).
  bool next(PointCloud& chunk, std::size_t maxPoints);
  /// Starts again at the first point.
  void rewind();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// @brief A binary PLY point cloud written chunk by chunk (scenes larger than memory), with a point count
/// declared up front. Atomic like writePointCloud: the file appears under its name only when finish() succeeds.
class PointStreamWriter {
 public:
  /// @throws InputError when @p path is not .ply or its directory is not writable.
  PointStreamWriter(const std::string& path, std::size_t count, bool normals);
  ~PointStreamWriter();  ///< removes the temporary file unless finish() succeeded
  PointStreamWriter(const PointStreamWriter&) = delete;
  PointStreamWriter& operator=(const PointStreamWriter&) = delete;

  /// Appends the points (and normals) of @p chunk. @throws InputError past the declared count or on a failed write.
  void write(const PointCloud& chunk);
  /// @throws InputError when fewer points than declared were written, or the file cannot be committed.
  void finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iires
