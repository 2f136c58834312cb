// SPDX-License-Identifier: GPL-3.0-or-later
// iires-register: align SOURCE to TARGET (any rotation, scale, translation, density) without features.
#include <CLI/CLI.hpp>
#include <iostream>

#include "common.hpp"
#include "progress.hpp"
#include "iires/io.hpp"
#include "iires/outliers.hpp"
#include "iires/register/registration.hpp"

namespace {
constexpr std::size_t kBytesPerSample = 4096;  // generous: two resampled clouds, k-d trees, the rotation search
}  // namespace

int main(int argc, char** argv) {
  return iires::tools::guardedMain("iires-register", [&]() -> int {
    CLI::App app{"Align SOURCE to TARGET: resample both, search a rotation grid for the minimum Hausdorff "
                 "distance, refine with ICP (with scale). Prints the similarity T_target_source."};
    std::string sourcePath, targetPath, alignedPath, transformPath, reportPath, grid = "so3";
    iires::reg::RegistrationParams params;
    iires::Execution exec;
    auto samples = static_cast<long long>(params.samples);
    bool noScale = false, quiet = false, showProgress = false, fullResample = false;
    app.add_option("SOURCE", sourcePath, "cloud to move (.ply .pcd .xyz .xyzn .pts, or a mesh: its surface)")
        ->required();
    app.add_option("TARGET", targetPath, "cloud to align to")->required();
    app.add_option("-o,--output", alignedPath, "write SOURCE mapped into TARGET coordinates (.ply .xyz .xyzn)");
    app.add_option("--transform", transformPath, "write the 4x4 matrix T_target_source, one row per line");
    app.add_option("--report", reportPath, "write the report as JSON to this file");
    app.add_option("-m,--samples", samples,
                   "points each cloud is resampled to (>= 50; above 1000 capped at the larger input's size)");
    app.add_option("--grid", grid, "rotation grid: so3 (uniform, default) or euler (the paper's 24^3)")
        ->check(CLI::IsMember({"so3", "euler"}));
    auto* overlapOption = app.add_option("--overlap", params.overlap,
                                         "share of each cloud that overlaps the other, (0, 1], if known for sure "
                                         "(default: estimated)");
    app.add_flag("--no-scale", noScale, "rigid registration: keep the scale at 1");
    std::string outlierMode = "pull";
    app.add_option("--outliers", outlierMode,
                   "outliers of both clouds (and of the -o output): pull back onto the surface, remove, or keep")
        ->check(CLI::IsMember({"pull", "remove", "keep"}));
    app.add_option("--seed", params.seed, "seed; same seed -> same result")
        ->check(iires::tools::seedValidator());
    app.add_option("--threads", exec.threads, "threads (0 = all cores); the result does not depend on it")
        ->check(CLI::NonNegativeNumber);
    app.add_flag("--full-resample", fullResample,
                 "resample with the full pipeline (denoising, outliers, relaxation): slower, for noisy scans");
    app.add_flag("-q,--quiet", quiet, "print nothing on success (no result, no progress)");
    app.add_flag("--progress", showProgress, "progress on stderr even when it is not a terminal");
    app.set_version_flag("--version", iires::tools::versionString());
    if (const int code = iires::tools::parseArgs(app, argc, argv); code != iires::tools::kContinue) return code;
    if (samples < 50) throw iires::InputError("-m/--samples must be at least 50 (got " + std::to_string(samples) + ")");
    iires::tools::checkCount("-m", samples, kBytesPerSample);
    if (overlapOption->count() > 0 && !(params.overlap > 0.0 && params.overlap <= 1.0))
      throw iires::InputError("--overlap must be in (0, 1] (got " + std::to_string(params.overlap) + ")");
    params.samples = static_cast<std::size_t>(samples);
    params.grid = iires::reg::parseRotationGridType(grid);
    params.estimateScale = !noScale;
    params.outliers.mode = iires::parseOutlierMode(outlierMode);
    // Before any work: no output name empty, none an input, no two the same file.
    iires::tools::checkOutputPaths(app, {{"--output", alignedPath}, {"--transform", transformPath}, {"--report", reportPath}},
                                   {sourcePath, targetPath});
    if (!alignedPath.empty() && iires::extensionOf(alignedPath) != ".ply" && iires::extensionOf(alignedPath) != ".xyz" &&
        iires::extensionOf(alignedPath) != ".xyzn")
      throw iires::InputError("cannot write " + alignedPath + ": unknown extension (use .ply, .xyz or .xyzn)");

    if (fullResample) params.resample = iires::ResampleParams{};
    iires::tools::Progress progress("iires-register", showProgress, quiet);
    exec.progress = progress.callback();
    progress.update("read", 0.0);
    const iires::PointCloud source = iires::readSurfacePoints(sourcePath);
    const iires::PointCloud target = iires::readSurfacePoints(targetPath);
    iires::reg::RegistrationResult result;
    try {
      result = iires::reg::registerClouds(source, target, params, exec);
    } catch (const iires::InputError& e) {
      // The library names the clouds "source"/"target"; name the files instead.
      std::string msg = e.what();
      if (msg.rfind("source", 0) == 0) msg = sourcePath + msg.substr(6);
      else if (msg.rfind("target", 0) == 0) msg = targetPath + msg.substr(6);
      throw iires::InputError(msg);
    }
    progress.update("write", 0.0);
    iires::OutputBatch outputs;  // all given files or none
    if (!alignedPath.empty()) {  // the source without its outliers (pulled or removed as the run's were)
      outputs.pointCloud(alignedPath, iires::reg::transformCloud(iires::cleanOutliers(source, params.outliers, exec),
                                                                 result.T_target_source));
    }
    if (!transformPath.empty()) outputs.text(transformPath, iires::reg::formatTransform(result.T_target_source));
    if (!reportPath.empty()) outputs.text(reportPath, result.toJson());
    outputs.commit();
    progress.finish();
    if (!quiet) {
      std::cout << iires::reg::formatTransform(result.T_target_source);
      std::cout << "scale " << result.scale << "  rotation " << result.rotationAngleDeg << " deg  rmse "
                << result.rmse << "  hausdorff " << result.hausdorff << "  overlap " << result.sourceOverlap << " / "
                << result.targetOverlap << "  runner-up x" << result.secondBestScoreRatio
                << (result.ambiguous ? "  AMBIGUOUS: " : "")
                << result.ambiguityReason << "\n";
    }
    return iires::tools::kOk;
  });
}
