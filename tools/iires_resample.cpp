// SPDX-License-Identifier: GPL-3.0-or-later
// iires-resample: resample a point cloud to exactly N points, uniformly spaced on its surface.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <stdexcept>

#include "common.hpp"
#include "progress.hpp"
#include "tiling.hpp"
#include "iires/attributes.hpp"
#include "iires/geodesic.hpp"
#include "iires/io.hpp"
#include "iires/preprocess.hpp"
#include "iires/resample.hpp"
#include "iires/tile_executor.hpp"

namespace {

void warnNormalsReplaced(const std::string& input) {
  std::cerr << "iires-resample: warning: " << input
            << ": its normals do not describe the points' surface (tangent to it, or random); they were estimated "
               "from the points instead\n";
}

}  // namespace

int main(int argc, char** argv) {
  return iires::tools::guardedMain("iires-resample", [&]() -> int {
    CLI::App app{"Resample a point cloud to exactly N points on its surface (isotropic)."};
    iires::tools::ResampleOptions options;
    options.addRunFlags(app);
    iires::ResampleParams& params = options.params;
    bool denoiseOnly = false;
    std::string geodesicPath;
    std::vector<std::string> columns;
    app.add_flag("--denoise-only", denoiseOnly,
                 "only pre-process (outliers + denoising) and write the cleaned cloud at its own point count");
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
    options.addTilingFlags(app);
    app.set_version_flag("--version", iires::tools::versionString());
    if (const int code = iires::tools::parseArgs(app, argc, argv); code != iires::tools::kContinue) return code;
    // Everything that can be checked before the work is checked here: no output is written on failure.
    options.checkOutputs(app, {{"--export-geodesic", geodesicPath}});
    const std::string& input = options.input;
    const std::string& output = options.output;
    iires::tools::Progress progress("iires-resample", options.showProgress, options.quiet);
    iires::Execution& exec = options.exec;
    exec.progress = progress.callback();
    options.applyToParams(!denoiseOnly);
    if (denoiseOnly) {
      iires::tools::refuseFlags(app, {"-n", "--mode", "--levels", "--ratios", "--sharp-edges", "--edge-ratio",
                                      "--export-geodesic", "--tiles"},
                                "--denoise-only (it keeps the cloud's points)");
      progress.update("read", 0.0);
      const iires::PointCloud cloud = iires::readSurfacePoints(input, columns);
      iires::PreprocessResult cleaned;
      try {
        cleaned = iires::preprocess(cloud, params.preprocessing, exec);
      } catch (const iires::InputError& e) {
        throw iires::InputError(input + ": " + e.what());
      }
      // The points keep their attributes: in order where none was removed, else each its nearest input point's.
      if (cleaned.cloud.size() == cloud.size()) {
        cleaned.cloud.attributes = cloud.attributes;
      } else if (!cloud.attributes.empty()) {
        iires::AttributeParams nearest;
        nearest.neighbours = 1;
        cleaned.cloud.attributes = iires::interpolateAttributes(cloud, cleaned.cloud.points, {}, {}, nearest, exec);
      }
      iires::OutputBatch outputs;
      outputs.pointCloud(output, cleaned.cloud);
      if (!options.reportPath.empty()) outputs.text(options.reportPath, cleaned.toJson() + "\n");
      outputs.commit();
      if (!options.quiet && cleaned.givenNormalsReplaced) warnNormalsReplaced(input);
      if (!options.quiet) std::cout << cleaned.toJson() << "\n";
      return iires::tools::kOk;
    }
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
    if (ratios.size() == 1) throw iires::InputError("--ratios needs one length ratio per level, two levels at least");
    if (levels > 0 && !ratios.empty() && static_cast<std::size_t>(levels) != ratios.size())
      throw iires::InputError("--levels " + std::to_string(levels) + " and " + std::to_string(ratios.size()) +
                              " --ratios disagree (give one of them, or as many ratios as levels)");
    if (!geodesicPath.empty() && options.noIntrinsic)
      throw iires::InputError("--export-geodesic needs intrinsic control (drop --no-intrinsic)");
    if (!geodesicPath.empty() && iires::extensionOf(geodesicPath) != ".ply")
      throw iires::InputError(geodesicPath + ": --export-geodesic writes .ply only");
    params.validate();  // every range before the input is read
    options.tiling.defaultMemory();
    if ((columns.empty() || !options.tiling.tiles.empty()) && options.tiling.wanted(input)) {
      if (!geodesicPath.empty() || !columns.empty())
        throw iires::InputError("--export-geodesic and --columns are not available with --tiles");
      iires::TileExecutor local;
      return iires::tools::runTiled(options, progress, local);
    }
    progress.update("read", 0.0);
    iires::PointCloud cloud = iires::readSurfacePoints(input, columns);
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
    if (!options.reportPath.empty()) outputs.text(options.reportPath, result.toJson());
    outputs.commit();
    progress.finish();
    if (!options.quiet && result.givenNormalsReplaced) warnNormalsReplaced(input);
    if (!options.quiet) std::cout << result.toJson();
    return iires::tools::kOk;
  });
}
