// SPDX-License-Identifier: GPL-3.0-or-later
// iires-reconstruct: a triangle mesh of near-equilateral triangles from a point cloud, with a quality report.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <stdexcept>

#include "common.hpp"
#include "progress.hpp"
#include "iires/io.hpp"
#include "iires/validate.hpp"
#include "iires/reconstruct/reconstruct.hpp"

namespace {

/// Memory one mesh vertex costs in the pipeline, generously (the resampler's share plus triangulation,
/// ~2 triangles per vertex, hole filling and the quality report): the memory guard's estimate.
constexpr std::size_t kBytesPerVertex = 4096;

}  // namespace

int main(int argc, char** argv) {
  return iires::tools::guardedMain("iires-reconstruct", [&]() -> int {
    CLI::App app{"Reconstruct a triangle mesh from a point cloud (isotropic resampling + local Delaunay) and "
                 "report its quality."};
    std::string input, output, reportPath, qualityOnly, uncoveredPath, method = "local";
    long long count = 10000;
    bool noResample = false, noHoles = false, noValidity = false, quiet = false, showProgress = false;
    iires::ReconstructParams params;
    iires::Execution exec;
    std::vector<std::string> columns;
    app.add_option("INPUT", input, "input cloud (.ply .pcd .xyz .xyzn .pts, or a mesh .obj .off .stl: its surface)")
        ->required();
    app.add_option("OUTPUT_MESH", output, "output mesh (.ply .obj .off by extension)");
    app.add_option("-n,--count", count,
                   "resample to exactly N points first and mesh them (>= 4; the report counts samples the mesh "
                   "leaves out and vertices hole filling adds)");
    app.add_flag("--no-resample", noResample, "triangulate the input points as they are");
    app.add_option("--method", method, "triangulation: local (default) or advancing-front")
        ->check(CLI::IsMember({"local", "advancing-front"}));
    app.add_flag("--no-hole-filling", noHoles, "leave small holes open");
    app.add_flag("--no-validity-repair", noValidity,
                 "keep self-intersecting faces and non-manifold edges/vertices (the report still counts them)");
    app.add_option("--max-hole-edges", params.holes.maxEdges, "close holes of at most this many edges (>= 3; up to 1.5x that when the fill is good, Q >= 0.4)");
    app.add_option("--max-hole-extent", params.holes.maxRefinedExtent,
                   "close longer holes with new vertices when their bounding box is at most this fraction of their "
                   "part's (0-1, default 0.6; 0 = off: keep every long loop open)")
        ->check(CLI::Range(0.0, 1.0));
    app.add_option("--quality-only", qualityOnly,
                   "report on this existing mesh (INPUT is the reference cloud); no OUTPUT_MESH");
    app.add_option("--columns", columns,
                   "names of a .xyz file's columns, e.g. x,y,z,red,green,blue,intensity,label:int (attributes carried to the mesh's .ply vertices)")
        ->delimiter(',');
    app.add_option("--report", reportPath, "write the report as JSON to this file");
    app.add_option("--uncovered", uncoveredPath,
                   "write the input points farther than 2 mesh spacings from the mesh (the parts it does not "
                   "cover) to this point cloud file");
    app.add_option("--threads", exec.threads, "threads (0 = all cores); the output does not depend on it")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--seed", params.seed, "seed; same seed -> same mesh")
        ->check(iires::tools::seedValidator());
    app.add_flag("-q,--quiet", quiet, "print nothing on success (no report, no progress)");
    app.add_flag("--progress", showProgress, "progress on stderr even when it is not a terminal");
    app.set_version_flag("--version", iires::tools::versionString());
    if (const int code = iires::tools::parseArgs(app, argc, argv); code != iires::tools::kContinue) return code;
    // Everything that can be checked before the work is checked here: no output is written on failure.
    iires::tools::checkOutputPaths(app, {{"OUTPUT_MESH", output}, {"--report", reportPath}, {"--uncovered", uncoveredPath}},
                                   {input, qualityOnly});
    if (!uncoveredPath.empty() && iires::extensionOf(uncoveredPath) != ".ply" &&
        iires::extensionOf(uncoveredPath) != ".xyz")
      throw iires::InputError("cannot write " + uncoveredPath + ": use .ply (with normals when the input has them) "
                              "or .xyz for --uncovered");
    iires::tools::Progress progress("iires-reconstruct", showProgress, quiet);
    exec.progress = progress.callback();  // resampling and meshing stages

    if (!qualityOnly.empty()) {
      if (!output.empty()) throw iires::InputError("--quality-only takes no OUTPUT_MESH (got " + output + ")");
      iires::tools::refuseFlags(app, {"-n", "--no-resample", "--method", "--no-hole-filling", "--no-validity-repair",
                                      "--max-hole-edges", "--max-hole-extent", "--columns"},
                                "--quality-only (it reports on the given mesh)");
      progress.update("read", 0.0);
      const iires::TriangleMesh mesh = iires::readMesh(qualityOnly);
      // NaN/Inf or overflowing coordinates would poison every distance: reject them, naming the file.
      for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        if (!mesh.vertices[i].allFinite())
          throw iires::InputError(qualityOnly + ": vertex " + std::to_string(i) +
                                  " has a non-finite coordinate (NaN or Inf)");
        if (mesh.vertices[i].cwiseAbs().maxCoeff() > iires::kMaxCoordinate)
          throw iires::InputError(qualityOnly + ": vertex " + std::to_string(i) +
                                  " has a coordinate beyond the supported magnitude");
      }
      iires::PointCloud reference = iires::readSurfacePoints(input);
      iires::validateCloud(reference, 1, input);
      progress.update("quality", 0.0);
      iires::MeshQualityParams qp;
      qp.seed = params.seed + 1;
      const iires::MeshQuality q = iires::evaluateMesh(mesh, &reference, qp, exec);
      progress.finish();
      iires::OutputBatch outputs;
      if (!reportPath.empty()) outputs.text(reportPath, q.toJson());
      if (!uncoveredPath.empty()) outputs.pointCloud(uncoveredPath, iires::uncoveredInput(reference, q));
      outputs.commit();
      if (!quiet) std::cout << "quality of " << qualityOnly << " (reference " << input << ")\n" << q.toTable();
      return iires::tools::kOk;
    }
    if (output.empty()) throw iires::InputError("OUTPUT_MESH is required (or use --quality-only MESH)");
    if (noResample) iires::tools::refuseFlags(app, {"-n"}, "--no-resample (the input's points are the vertices)");
    if (count < 4) throw iires::InputError("-n must be at least 4 (got " + std::to_string(count) + ")");
    if (!noResample) iires::tools::checkCount("-n", count, kBytesPerVertex);
    // Fail on a bad output extension before the work, not after it.
    const std::string ext = iires::extensionOf(output);
    if (ext != ".ply" && ext != ".obj" && ext != ".off")
      throw iires::InputError("cannot write " + output + ": unknown mesh format (use .ply, .obj or .off)");
    params.targetCount = static_cast<std::size_t>(count);
    params.resample = !noResample;
    params.fillHoles = !noHoles;
    params.repairValidity = !noValidity;
    params.method = iires::parseReconstructMethod(method);

    progress.update("read", 0.0);
    const iires::PointCloud cloud = iires::readSurfacePoints(input, columns);
    if (noResample) iires::tools::checkCount("the input's point count", static_cast<long long>(cloud.size()),
                                             kBytesPerVertex);
    iires::ReconstructResult result;
    try {
      result = iires::reconstruct(cloud, params, exec);
    } catch (const iires::InputError& e) {
      throw iires::InputError(input + ": " + e.what());
    }
    progress.update("write", 0.0);
    if (result.mesh.triangles.empty())  // the input or the count asked for, not a fault of the run
      throw iires::InputError(input + ": the reconstruction produced no triangles from " +
                              std::to_string(result.samples.size()) +
                              " samples: too few to mesh this surface (a larger -n), or the cloud is not a surface; "
                              "nothing was written");
    iires::OutputBatch outputs;  // the mesh, the report and the uncovered points, or none of them
    outputs.mesh(output, result.mesh);
    if (!reportPath.empty()) outputs.text(reportPath, result.toJson());
    if (!uncoveredPath.empty()) outputs.pointCloud(uncoveredPath, result.uncoveredInput);
    outputs.commit();
    progress.finish();
    if (!quiet) {
      std::cout << "mesh " << output << " (" << result.method << ", " << result.mesh.vertices.size()
                << " vertices from " << result.inputPoints << " input points)\n"
                << result.quality.toTable();
      std::cout << "  " << std::left << std::setw(30) << "left out of the mesh" << result.unusedVertices
                << " samples in no triangle, " << result.smallComponentFaces << " faces of small parts removed\n";
      std::cout << "  " << std::left << std::setw(30) << "small holes closed / kept" << result.holes.filled << " / "
                << result.holes.kept << "\n";
      std::cout << "  " << std::left << std::setw(30) << "thin rims closed by bands" << result.rimBands.bands << " ("
                << result.rimBands.facesAdded << " faces; " << result.rimBands.partsTurned << " parts turned over)\n";
      std::cout << "  " << std::left << std::setw(30) << "large holes closed / kept" << result.largeHoles.filled
                << " / " << result.largeHoles.kept << " (" << result.largeHoles.verticesAdded << " vertices added; "
                << result.largeHoles.unsupported << " kept open: the fill left the input)\n";
      std::cout << "  " << std::left << std::setw(30) << "Q<0.4 repairs moved / removed" << result.badTriangles.moved
                << " / " << result.badTriangles.removed << " (" << result.badTriangles.peeled << " rim faces peeled)\n";
      std::cout << "  " << std::left << std::setw(30) << "vertices relaxed" << result.verticesRelaxed << "\n";
      const iires::ValidityReport& v = result.validity;
      std::cout << "  " << std::left << std::setw(30) << "validity repairs" << v.intersectingPairs
                << " self-intersecting pairs, " << v.nonManifoldEdges << " non-manifold edges found; " << v.facesRemoved
                << " faces removed, " << v.facesAdded << " added";
      if (v.removedWithoutFill) std::cout << " (" << v.removedWithoutFill << " removed without a fill: holes left open)";
      std::cout << "\n";
      std::cout << "  " << std::left << std::setw(30) << "time (s)";
      for (const auto& s : result.timings) std::cout << s.name << " " << std::setprecision(3) << s.seconds << "  ";
      std::cout << "\n";
    }
    return iires::tools::kOk;
  });
}
