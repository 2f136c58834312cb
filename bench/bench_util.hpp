#pragma once
/// @file bench_util.hpp
/// @brief Small helpers shared by the benchmark executables (not part of the library).

#include <sstream>
#include <string>
#include <vector>

#include "iires/sampling.hpp"
#include "iires/types.hpp"

namespace iires::bench {

/// @brief "a,b,c" → {"a", "b", "c"} (command-line lists).
inline std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) out.push_back(item);
  return out;
}

/// @brief The benchmarks' input: @p count points sampled on @p mesh with density ratio @p ratio along the
/// longest axis (seed 1), positions only, like a raw scan — every method gets the same points.
inline PointCloud scanLikeSampling(const TriangleMesh& mesh, std::size_t count, double ratio) {
  MeshSamplingParams sp;
  sp.count = count;
  sp.densityRatio = ratio;
  sp.seed = 1;
  PointCloud cloud = sampleMesh(mesh, sp);
  cloud.normals.clear();
  return cloud;
}

}  // namespace iires::bench
