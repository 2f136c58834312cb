// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file tile_spill.hpp
/// @brief Scratch storage of out-of-core resampling (internal): a scratch directory removed with its
/// contents when it goes out of scope, and one spill file of raw points per tile.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "iires/types.hpp"

namespace iires::detail {

/// A fresh directory "iires-tiles-XXXXXX" inside a parent directory, removed with everything in it by the
/// destructor: on success and when an exception unwinds past it.
class ScratchDirectory {
 public:
  /// @param parent existing directory; empty = the system's temporary directory.
  /// @throws InputError when the directory cannot be created.
  explicit ScratchDirectory(const std::string& parent);
  ~ScratchDirectory();
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// Per-tile spill files of raw points (x y z, then nx ny nz when the input has normals, as doubles), written
/// through bounded per-tile buffers.
class TileSpill {
 public:
  TileSpill(const std::string& directory, std::size_t tiles, bool normals, std::size_t bufferBytes);
  /// Appends point @p i of @p cloud to tile @p t's file.
  void add(std::size_t t, const PointCloud& cloud, std::size_t i);
  /// Writes every buffer out. @throws InputError when a write fails (a full disk).
  void flush();
  /// Points written to tile @p t (after flush()).
  std::size_t count(std::size_t t) const { return counts_[t]; }
  /// Tile @p t's points; at most @p cap of them (a deterministic subset, seeded by @p seed, when it holds more).
  PointCloud read(std::size_t t, std::size_t cap, std::uint64_t seed) const;
  /// Deletes tile @p t's file (its points are no longer needed).
  void release(std::size_t t);

 private:
  std::string file(std::size_t t) const;
  void flush(std::size_t t);

  std::string directory_;
  bool normals_;
  std::size_t bufferBytes_, recordBytes_;
  std::vector<std::string> buffers_;
  std::vector<std::size_t> counts_;
};

}  // namespace iires::detail
