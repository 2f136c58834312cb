// SPDX-License-Identifier: GPL-3.0-or-later
// iires-resample: resample a point cloud to exactly N points, uniformly spaced on its surface.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <stdexcept>

#include "common.hpp"
#include "progress.hpp"
#include "iires/geodesic.hpp"
#include "iires/io.hpp"
#include "iires/preprocess.hpp"
#include "iires/point_stream.hpp"
#include "iires/resample.hpp"
#include "iires/tiled.hpp"

namespace {

/// Memory one output point costs in the pipeline, generously (samples, 1-rings, ~3N candidates with their
/// elimination neighbour lists, k-d trees): the memory guard's estimate.
constexpr std::size_t kBytesPerOutputPoint = 2048;

/// The tiling flags: `--tiles auto|SIZE`, `--memory GB`, `--scratch DIR`.
struct TilingOptions {
  std::string tiles;   // empty: tiled only when the input does not fit the memory budget
  double memoryGB = 0;  // 0: the memory available now
  std::string scratch;

  /// Whether to run tiled: asked for, or the input (estimated from its header or size) would not fit.
  bool wanted(const std::string& input) const {
    if (!tiles.empty()) return tiles != "off";
    if (const std::string ext = iires::extensionOf(input); ext != ".ply" && ext != ".xyz" && ext != ".xyzn")
      return false;
    double points = 0;
    try {
      points = static_cast<double>(iires::PointStream(input).estimatedCount());
    } catch (const iires::InputError&) {
      return false;  // not streamable (or unreadable): the in-memory reader says why
    }
    return points * iires::TileParams::kBytesPerInputPoint > memoryGB * 1e9;
  }

  iires::TileParams params(const std::string& output) const {
    iires::TileParams tp;
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
        throw iires::InputError("--tiles takes auto, off or a tile size > 0 (got \"" + tiles + "\")");
    }
    tp.validate();
    return tp;
  }
};

/// The out-of-core run: tiles from the file, the output written once, in tile order.
int runTiled(const std::string& input, const std::string& output, const std::string& reportPath,
             const iires::ResampleParams& params, const iires::Execution& exec, const TilingOptions& tiling,
             iires::tools::Progress& progress, bool quiet) {
  if (params.mode != iires::ResampleMode::kIsotropic || params.sharpEdges)
    throw iires::InputError("--tiles supports the isotropic mode without --sharp-edges");
  const iires::TileParams tp = tiling.params(output);
  iires::TiledResult result;
  try {
    result = iires::resampleTiled(input, params, tp, exec);
  } catch (const iires::InputError& e) {
    throw iires::InputError(input + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(input + ": " + e.what());
  }
  progress.update("write", 0.0);
  iires::OutputBatch outputs;
  outputs.pointCloud(output, result.cloud);
  if (!reportPath.empty()) outputs.text(reportPath, result.toJson());
  outputs.commit();
  progress.finish();
  if (!quiet) std::cout << result.toJson();
  return iires::tools::kOk;
}

}  // namespace

int main(int argc, char** argv) {
  return iires::tools::guardedMain("iires-resample", [&]() -> int {
    CLI::App app{"Resample a point cloud to exactly N points on its surface (isotropic)."};
    std::string input, output, reportPath;
    long long count = 0;
    iires::ResampleParams params;
    iires::Execution exec;
    bool quiet = false, noIntrinsic = false, noDenoise = false, denoiseOnly = false, showProgress = false;
    std::string outlierMode = "pull";
    std::string geodesicPath;
    std::vector<std::string> columns;
    TilingOptions tiling;
    app.add_option("INPUT", input, "input cloud (.ply .pcd .xyz .xyzn .pts, or mesh vertices .obj .off .stl)")
        ->required();
    app.add_option("OUTPUT", output, "output cloud (.ply binary with normals, .xyz, .xyzn)")->required();
    app.add_option("-n,--count", count, "exact number of output points N (>= 1); required unless --denoise-only");
    app.add_option("--outliers", outlierMode, "outliers: pull back onto the surface, remove, or keep")
        ->check(CLI::IsMember({"pull", "remove", "keep"}));
    app.add_flag("--no-denoise", noDenoise, "skip the MLS denoising of the input");
    app.add_flag("--denoise-only", denoiseOnly,
                 "only pre-process (outliers + denoising) and write the cleaned cloud at its own point count");
    app.add_option("--seed", params.seed, "seed of the initial candidates' grid; same seed -> same output");
    app.add_option("--input-per-sample", params.maxInputPerSample,
                   "thin inputs denser than this many points per output point first (default 6; 0 = never)");
    app.add_option("--threads", exec.threads, "threads (0 = all cores); the output does not depend on it")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--report", reportPath, "write the report as JSON to this file");
    app.add_flag("--no-intrinsic", noIntrinsic,
                 "Euclidean neighbours only (default: intrinsic control, never across thin gaps or objects)");
    app.add_option("--columns", columns,
                   "names of a .xyz file's columns, e.g. x,y,z,red,green,blue,intensity,label:int (attributes carried to the output .ply)")
        ->delimiter(',');
    app.add_option("--export-geodesic", geodesicPath,
                   "write the input with geodesic coordinates g1 g2 g3 and component id (.ply)");
    std::string mode = "isotropic";
    int levels = 0;
    std::vector<double> ratios;
    app.add_option("--mode", mode, "isotropic (uniform spacing) or curvature (denser where the surface bends)")
        ->check(CLI::IsMember({"isotropic", "curvature"}));
    app.add_option("--levels", levels, "curvature mode: number of levels t (default 5); ratios default to a ramp")
        ->check(CLI::Range(2, 16));
    app.add_option("--ratios", ratios, "curvature mode: length ratios flat -> curved, e.g. 2,1.5,1,0.8,0.6")
        ->delimiter(',');
    app.add_flag("--sharp-edges", params.sharpEdges, "keep samples on sharp feature lines");
    app.add_option("--edge-ratio", params.edgeRatio, "spacing on feature lines, in units of the target length (0.1-4, default 0.5)")
        ->check(CLI::Range(0.1, 4.0));
    app.add_flag("-q,--quiet", quiet, "print nothing on success (no report, no progress)");
    app.add_option("--tiles", tiling.tiles,
                   "out-of-core: tiles of this edge length, auto (sized to --memory) or off; default: tiled "
                   "(auto) only when the input would not fit --memory");
    app.add_option("--memory", tiling.memoryGB, "memory budget in GB for --tiles (default: the memory available)")
        ->check(CLI::PositiveNumber);
    app.add_option("--scratch", tiling.scratch, "directory for the tiles' spill files (default: the output's)");
    app.add_flag("--progress", showProgress, "progress on stderr even when it is not a terminal");
    app.set_version_flag("--version", iires::tools::versionString());
    if (const int code = iires::tools::parseArgs(app, argc, argv); code != iires::tools::kContinue) return code;
    // Everything that can be checked before the work is checked here: no output is written on failure.
    iires::tools::checkOutputPaths(app, {{"OUTPUT", output}, {"--report", reportPath}, {"--export-geodesic", geodesicPath}},
                                   {input});
    if (const std::string ext = iires::extensionOf(output); ext != ".ply" && ext != ".xyz" && ext != ".xyzn")
      throw iires::InputError("cannot write " + output + ": unknown point cloud extension \"" + ext +
                              "\" (supported: .ply .xyz .xyzn)");
    iires::tools::Progress progress("iires-resample", showProgress, quiet);
    exec.progress = progress.callback();
    params.preprocessing.outliers.mode = iires::parseOutlierMode(outlierMode);
    params.preprocessing.runDenoise = !noDenoise;
    params.preprocessing.sheets = !noIntrinsic;  // the sheet rule, also for --denoise-only
    if (denoiseOnly) {
      progress.update("read", 0.0);
      const iires::PointCloud cloud = iires::readPointCloud(input, columns);
      iires::PreprocessResult cleaned;
      try {
        cleaned = iires::preprocess(cloud, params.preprocessing, exec);
      } catch (const iires::InputError& e) {
        throw iires::InputError(input + ": " + e.what());
      }
      iires::OutputBatch outputs;
      outputs.pointCloud(output, cleaned.cloud);
      if (!reportPath.empty()) outputs.text(reportPath, cleaned.toJson() + "\n");
      outputs.commit();
      if (!quiet) std::cout << cleaned.toJson() << "\n";
      return iires::tools::kOk;
    }
    if (count < 1) throw iires::InputError("-n must be at least 1 (got " + std::to_string(count) + ")");
    iires::tools::checkCount("-n", count, kBytesPerOutputPoint);
    params.targetCount = static_cast<std::size_t>(count);
    params.intrinsic = !noIntrinsic;
    if (mode == "curvature") {
      params.mode = iires::ResampleMode::kCurvature;
      if (!ratios.empty()) {
        params.curvature.ratios = ratios;
      } else if (levels > 0) {  // a geometric ramp from 2 (flattest) to 0.6 (most curved)
        params.curvature.ratios.clear();
        for (int q = 0; q < levels; ++q) params.curvature.ratios.push_back(2.0 * std::pow(0.3, q / (levels - 1.0)));
      }
    } else if (levels > 0 || !ratios.empty()) {
      throw iires::InputError("--levels and --ratios need --mode curvature");
    }
    if (!geodesicPath.empty() && noIntrinsic)
      throw iires::InputError("--export-geodesic needs intrinsic control (drop --no-intrinsic)");
    if (!geodesicPath.empty() && iires::extensionOf(geodesicPath) != ".ply")
      throw iires::InputError(geodesicPath + ": --export-geodesic writes .ply only");
    params.validate();  // every range before the input is read
    if (tiling.memoryGB == 0) {
      const std::size_t available = iires::tools::availableMemory();
      tiling.memoryGB = available > 0 ? static_cast<double>(available) / 1e9 : 4.0;
    }
    if ((columns.empty() || !tiling.tiles.empty()) && tiling.wanted(input)) {
      if (!geodesicPath.empty() || !columns.empty())
        throw iires::InputError("--export-geodesic and --columns are not available with --tiles");
      return runTiled(input, output, reportPath, params, exec, tiling, progress, quiet);
    }
    progress.update("read", 0.0);
    iires::PointCloud cloud = iires::readPointCloud(input, columns);
    iires::ResampleResult result;
    try {
      result = iires::resample(std::move(cloud), params, exec);
    } catch (const iires::InputError& e) {
      throw iires::InputError(input + ": " + e.what());
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(input + ": " + e.what());
    }
    progress.update("write", 0.0);
    iires::OutputBatch outputs;  // all three files or none
    outputs.pointCloud(output, result.cloud);
    if (!geodesicPath.empty()) iires::writeGeodesicPly(outputs, geodesicPath, *result.geodesic);
    if (!reportPath.empty()) outputs.text(reportPath, result.toJson());
    outputs.commit();
    progress.finish();
    if (!quiet) std::cout << result.toJson();
    return iires::tools::kOk;
  });
}
