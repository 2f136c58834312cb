// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The tiled (out-of-core) resampling run of iires-resample and iires-resample-mpi: the flags they share, the
// tiling options, and the run itself up to the output written once.
#include <CLI/CLI.hpp>
#include <string>

#include "iires/resample.hpp"
#include "iires/tile_executor.hpp"
#include "progress.hpp"

namespace iires::tools {

/// The tiling flags: `--tiles auto|SIZE|off`, `--memory GB`, `--scratch DIR`.
struct TilingOptions {
  std::string tiles;    // empty: tiled only when the input does not fit the memory budget
  double memoryGB = 0;  // 0: the memory available now
  std::string scratch;

  /// Whether to run tiled: asked for, or the input (estimated from its header or size) would not fit.
  bool wanted(const std::string& input) const;
  /// The library's parameters; the scratch directory defaults to the output's directory.
  /// @throws InputError for a bad --tiles value.
  TileParams params(const std::string& output) const;
  /// memoryGB 0 becomes the memory available now (4 GB when unknown).
  void defaultMemory();
};

/// The options of an isotropic resampling run that both tools take (the tiled path's flags).
struct ResampleOptions {
  std::string input, output, reportPath;
  long long count = 0;
  ResampleParams params;
  Execution exec;
  bool quiet = false, noIntrinsic = false, noDenoise = false, showProgress = false;
  std::string outlierMode = "pull";
  TilingOptions tiling;

  /// INPUT OUTPUT -n --outliers --no-denoise --seed --input-per-sample --threads --report --no-intrinsic.
  void addRunFlags(CLI::App& app);
  /// --tiles --memory --scratch --progress -q.
  void addTilingFlags(CLI::App& app);
  /// The output paths (OUTPUT, --report and @p more) and OUTPUT's format, before any work.
  /// @throws InputError as checkOutputPaths(), or for an unknown output extension.
  void checkOutputs(const CLI::App& app, std::vector<std::pair<std::string, std::string>> more = {}) const;
  /// The flags into params (outliers, denoising, -n when @p needCount, intrinsic control).
  void applyToParams(bool needCount);
};

/// @brief The tiled run: resampleTiled() with @p executor, then (on rank 0 only) the output and the report
/// written once, atomically; the report printed unless quiet. Every rank learns whether the write failed.
/// @return kOk. @throws as resampleTiled(), with the input's name in front of the message.
int runTiled(const ResampleOptions& options, Progress& progress, TileExecutor& executor);

}  // namespace iires::tools
