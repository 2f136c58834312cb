// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiling.hpp"

#include <exception>
#include <iostream>
#include <stdexcept>

#include "common.hpp"
#include "iires/io.hpp"
#include "iires/point_stream.hpp"
#include "iires/preprocess.hpp"

namespace iires::tools {
namespace {

/// Memory one output point costs in the pipeline, generously (samples, 1-rings, ~3N candidates with their
/// elimination neighbour lists, k-d trees): the memory guard's estimate.
constexpr std::size_t kBytesPerOutputPoint = 2048;

}  // namespace

bool TilingOptions::wanted(const std::string& input) const {
  if (!tiles.empty()) return tiles != "off";
  if (const std::string ext = extensionOf(input); ext != ".ply" && ext != ".xyz" && ext != ".xyzn") return false;
  double points = 0;
  try {
    points = static_cast<double>(PointStream(input).estimatedCount());
  } catch (const InputError&) {
    return false;  // not streamable (or unreadable): the in-memory reader says why
  }
  return points * TileParams::kBytesPerInputPoint > memoryGB * 1e9;
}

TileParams TilingOptions::params(const std::string& output) const {
  TileParams tp;
  tp.memoryBudgetGB = memoryGB;
  tp.scratchDir = scratch;
  if (tp.scratchDir.empty()) {  // next to the output
    const std::size_t slash = output.find_last_of('/');
    tp.scratchDir = slash == std::string::npos ? "." : output.substr(0, slash + 1);
  }
  if (tiles != "auto" && !tiles.empty()) {
    std::size_t used = 0;
    try {
      tp.tileSize = std::stod(tiles, &used);
    } catch (const std::exception&) {
    }
    if (used != tiles.size() || !(tp.tileSize > 0))
      throw InputError("--tiles takes auto, off or a tile size > 0 (got \"" + tiles + "\")");
  }
  tp.validate();
  return tp;
}

void TilingOptions::defaultMemory() {
  if (memoryGB != 0) return;
  const std::size_t available = availableMemory();
  memoryGB = available > 0 ? static_cast<double>(available) / 1e9 : 4.0;
}

void ResampleOptions::addRunFlags(CLI::App& app) {
  app.add_option("INPUT", input, "input cloud (.ply .pcd .xyz .xyzn .pts, or a mesh .obj .off .stl: its surface)")
      ->required();
  app.add_option("OUTPUT", output, "output cloud (.ply binary with normals, .xyz, .xyzn)")->required();
  app.add_option("-n,--count", count, "exact number of output points N (>= 1); required unless --denoise-only");
  app.add_option("--outliers", outlierMode, "outliers: pull back onto the surface, remove, or keep")
      ->check(CLI::IsMember({"pull", "remove", "keep"}));
  app.add_flag("--no-denoise", noDenoise, "skip the MLS denoising of the input");
  app.add_option("--seed", params.seed, "seed of the initial candidates' grid; same seed -> same output")
        ->check(iires::tools::seedValidator());
  app.add_option("--input-per-sample", params.maxInputPerSample,
                 "thin inputs denser than this many points per output point first (default 6; 0 = never)");
  app.add_option("--threads", exec.threads, "threads (0 = all cores); the output does not depend on it")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--report", reportPath, "write the report as JSON to this file");
  app.add_flag("--no-intrinsic", noIntrinsic,
               "Euclidean neighbours only (default: intrinsic control, never across thin gaps or objects)");
}

void ResampleOptions::addTilingFlags(CLI::App& app) {
  app.add_flag("-q,--quiet", quiet, "print nothing on success (no report, no progress)");
  app.add_option("--tiles", tiling.tiles,
                 "out-of-core: tiles of this edge length, auto (sized to --memory) or off; default: tiled "
                 "(auto) only when the input would not fit --memory");
  app.add_option("--memory", tiling.memoryGB, "memory budget in GB for --tiles (default: the memory available)")
      ->check(CLI::PositiveNumber);
  app.add_option("--scratch", tiling.scratch, "directory for the tiles' spill files (default: the output's)");
  app.add_flag("--progress", showProgress, "progress on stderr even when it is not a terminal");
}

void ResampleOptions::checkOutputs(const CLI::App& app, std::vector<std::pair<std::string, std::string>> more) const {
  more.insert(more.begin(), {{"OUTPUT", output}, {"--report", reportPath}});
  checkOutputPaths(app, more, {input});
  if (const std::string ext = extensionOf(output); ext != ".ply" && ext != ".xyz" && ext != ".xyzn")
    throw InputError("cannot write " + output + ": unknown point cloud extension \"" + ext +
                     "\" (supported: .ply .xyz .xyzn)");
}

void ResampleOptions::applyToParams(bool needCount) {
  params.preprocessing.outliers.mode = parseOutlierMode(outlierMode);
  params.preprocessing.runDenoise = !noDenoise;
  params.intrinsic = !noIntrinsic;
  params.preprocessing.sheets = !noIntrinsic;  // the sheet rule, also for --denoise-only
  if (!needCount) return;
  if (count < 1) throw InputError("-n must be at least 1 (got " + std::to_string(count) + ")");
  checkCount("-n", count, kBytesPerOutputPoint);
  params.targetCount = static_cast<std::size_t>(count);
}

int runTiled(const ResampleOptions& options, Progress& progress, TileExecutor& executor) {
  if (options.params.mode != ResampleMode::kIsotropic || options.params.sharpEdges)
    throw InputError("--tiles supports the isotropic mode without --sharp-edges");
  const TileParams tp = options.tiling.params(options.output);
  // Errors name the input once: the stream reader's already start with its path.
  const auto named = [&](const char* what) {
    const std::string message = what, prefix = options.input + ": ";
    return message.rfind(prefix, 0) == 0 ? message : prefix + message;
  };
  TiledResult result;
  try {
    result = resampleTiled(options.input, options.params, tp, options.exec, executor);
  } catch (const InputError& e) {
    throw InputError(named(e.what()));
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(named(e.what()));
  }
  std::exception_ptr failure;
  if (executor.rank() == 0) {
    try {
      progress.update("write", 0.0);
      OutputBatch outputs;
      outputs.pointCloud(options.output, result.cloud);
      if (!options.reportPath.empty()) outputs.text(options.reportPath, result.toJson());
      outputs.commit();
    } catch (...) {
      failure = std::current_exception();
    }
  }
  executor.agree(failure);
  progress.finish();
  if (!options.quiet && executor.rank() == 0) std::cout << result.toJson();
  return kOk;
}

}  // namespace iires::tools
