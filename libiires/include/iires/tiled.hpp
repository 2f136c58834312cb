// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file tiled.hpp
/// @brief Out-of-core resampling of clouds larger than memory: tiles with overlap margins, stitched by fixed
/// samples (DESIGN §9).

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "iires/resample.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief How resampleTiled() cuts the cloud and how much memory it may use.
struct TileParams {
  /// Peak memory per input point of resample() (positions, normals, neighbour tables, k-d trees, MLS).
  static constexpr double kBytesPerInputPoint = 560;

  double tileSize = 0;          ///< edge of the cubic tiles, input units; 0 = auto: the largest tiles that fit the budget
  double memoryBudgetGB = 4;    ///< memory for one tile's resampling and the output (`--memory`), GB (10⁹ bytes)
  std::string scratchDir;       ///< where the spill files go (`--scratch`); empty = the system's temporary directory
  double marginSpacings = 4;    ///< overlap margin around each tile, in output spacings l (≥ 2)
  std::size_t surveyPoints = 1000000;  ///< uniform sample kept by the first pass (tile areas, auto tile size), ≥ 1000
  std::size_t chunkPoints = 1u << 20;  ///< points per chunk read from the file

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
  /// Input points one tile may hold with @p outputPoints output points kept beside it.
  std::size_t tileCapacity(std::size_t outputPoints) const;
};

/// @brief One tile's part in a tiled run.
struct TileReport {
  std::size_t index = 0;              ///< position in the grid (x fastest)
  std::array<int, 3> cell{};          ///< grid cell
  int colour = 0;                     ///< colour class (processing round)
  int rank = 0;                       ///< the process that resampled it (0 in a single-process run)
  std::size_t points = 0;             ///< input points in its core and margin
  std::size_t loadedPoints = 0;       ///< of them resampled (a deterministic subset when over the capacity)
  std::size_t share = 0;              ///< N_t: its share of N by surface area
  long long quota = 0;                ///< N_t plus the count differences earlier neighbours handed on
  std::size_t requested = 0;          ///< samples requested (quota plus the margin not yet finished)
  std::size_t context = 0;            ///< finished neighbours' samples held fixed in its margin
  std::size_t produced = 0;           ///< samples it contributes to the output
  double seconds = 0;                 ///< wall time of its resampling
};

/// @brief What resampleTiled() produced, with diagnostics.
struct TiledResult {
  PointCloud cloud;                   ///< exactly N points with normals, tile by tile in tile order
  std::size_t inputPoints = 0;        ///< points read
  std::size_t requestedPoints = 0;    ///< N
  std::array<int, 3> grid{1, 1, 1};   ///< tiles along x, y, z
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< the grid's lowest corner (the input's bounds)
  double tileSize = 0;                ///< edge of the tiles used
  double margin = 0;                  ///< overlap margin, input units
  double spacing = 0;                 ///< the global target spacing l from the surveyed area
  double area = 0;                    ///< surface area estimated from the survey sample
  std::size_t tileCapacity = 0;       ///< input points a tile may hold in the memory budget
  SpacingStats spacingStats;          ///< nearest-neighbour spacing of the output
  std::vector<TileReport> tiles;      ///< per tile, in tile order
  std::vector<StageTime> timings;     ///< survey, spill, colour_0.., total

  /// @brief The report as a JSON object.
  std::string toJson() const;
};

/// @brief Resample the cloud in the file @p path to exactly params.targetCount points without loading it.
///
/// Pass 1 streams the file: bounds and a uniform sample, whose local k-NN areas give each tile's surface area,
/// the global target spacing l and (tileSize 0) the tile size. Pass 2 streams it again into per-tile spill
/// files (core plus a margin of marginSpacings·l) in a scratch directory. Tiles run in colour order (no two
/// neighbours share a colour); each resamples its core and margin with resample(), its finished neighbours'
/// samples in the margin held fixed as context, and keeps the samples not in a later tile's core. Shares N_t
/// by area sum to N (largest remainder); a tile's deviation from its quota goes to its largest later neighbour,
/// so the total is exactly N. The scratch directory is removed on success and on failure.
/// @throws InputError for an unreadable file or scratch directory; std::invalid_argument for bad parameters;
/// std::runtime_error when a tile fails or the count cannot be met.
/// @note Deterministic: same file, params and seed give the same output for any thread count. Attributes
/// (colours, labels) are not carried. Memory: one tile (at most tileCapacity() points) plus the output.
TiledResult resampleTiled(const std::string& path, const ResampleParams& params, const TileParams& tiles,
                          const Execution& exec = {});

}  // namespace iires
