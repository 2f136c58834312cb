// SPDX-License-Identifier: GPL-3.0-or-later
// Benchmark: geodesic coordinates (paper §3.2) of a 1M-point dense sampling of armadillo. Prints key=value.
// Usage: geodesic_bench [MESH.off] [POINTS] [THREADS]
#include <chrono>
#include <cstdio>
#include <string>

#include "iires/geodesic.hpp"
#include "iires/io.hpp"
#include "iires/sampling.hpp"

int main(int argc, char** argv) {
  const std::string mesh = argc > 1 && *argv[1] ? argv[1] : std::string(IIRES_DATA_DIR) + "/meshes/armadillo.off";
  const std::size_t count = argc > 2 ? std::stoul(argv[2]) : 1000000;
  const int threads = argc > 3 ? std::stoi(argv[3]) : 0;
  try {
    iires::MeshSamplingParams sp;
    sp.count = count;
    const iires::PointCloud cloud = iires::sampleMesh(iires::readMesh(mesh), sp);
    for (bool normals : {false, true}) {
      iires::PointCloud input = cloud;
      if (!normals) input.normals.clear();
      const auto start = std::chrono::steady_clock::now();
      const iires::GeodesicCoordinates geo(input, {}, iires::Execution{threads});
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const auto& r = geo.report();
      std::printf("bench=geodesic model=%s points=%zu normals=%d threads=%d time_s=%.3f graph_s=%.3f "
                  "components_s=%.3f seed_s=%.3f fields_s=%.3f edges=%zu components=%zu\n",
                  mesh.c_str(), input.size(), normals ? 1 : 0, threads, seconds, r.graphSeconds,
                  r.componentSeconds, r.satelliteSeconds, r.fieldSeconds, r.edges, r.components);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "geodesic_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
