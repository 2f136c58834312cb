// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file tile_executor.hpp
/// @brief Where the tiles of a tiled run are resampled: all in this process (the default), or spread over the
/// processes of a distributed run (DESIGN §9), which then share what each tile produced.

#include <cstddef>
#include <exception>
#include <vector>

#include "iires/tiled.hpp"

namespace iires {

/// @brief What resampling one tile gives: its samples, its report and the shortfall it hands on.
struct TileOutcome {
  PointCloud samples;          ///< the samples the tile contributes to the output
  TileReport report;           ///< its report (quota at its start, produced, times)
  std::size_t heir = 0;        ///< the unfinished tile taking the shortfall (unused when rest is 0)
  long long rest = 0;          ///< quota minus produced (never negative: a tile keeps at most its quota)
};

/// @brief The processes of a tiled run and how they meet. resampleTiled() gives the k-th tile of each colour
/// (in tile order) to process k mod ranks(); tiles of one colour are independent, and before the next colour
/// starts every process holds every outcome of this one, so all of them continue from the same state.
///
/// The base class is the single-process engine: one rank, nothing to share. A distributed engine overrides the
/// three virtual functions; every process must call them in the same order (they are collective).
class TileExecutor {
 public:
  virtual ~TileExecutor() = default;
  /// This process's index, 0 ≤ rank() < ranks().
  virtual int rank() const { return 0; }
  /// How many processes share the tiles.
  virtual int ranks() const { return 1; }
  /// @brief A meeting point: when any process passes a failure, every process throws (the failing process its
  /// own exception, the others one of the same kind with its message). @p failure is null on success.
  virtual void agree(std::exception_ptr failure) {
    if (failure) std::rethrow_exception(failure);
  }
  /// @brief After a colour: @p outcomes[i] belongs to @p tiles[i], filled on its owner @p owners[i] (its rank).
  /// On return it is filled on every process, bit for bit as the owner made it. Calls agree(@p failure) first.
  virtual void share(const std::vector<std::size_t>& tiles, const std::vector<int>& owners,
                     std::vector<TileOutcome>& outcomes, std::exception_ptr failure) {
    (void)tiles, (void)owners, (void)outcomes;
    agree(failure);
  }
};

/// @brief resampleTiled() with the tiles spread by @p executor. Every process calls it with the same file,
/// parameters and seed; each spills and resamples only its own tiles, and each returns the whole result.
/// @note The output is byte-identical for any number of processes and threads.
TiledResult resampleTiled(const std::string& path, const ResampleParams& params, const TileParams& tiles,
                          const Execution& exec, TileExecutor& executor);

}  // namespace iires
