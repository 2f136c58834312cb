// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file bench_util.hpp
/// @brief Small helpers shared by the benchmark executables (not part of the library).

#include <cstdlib>
#include <functional>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "iires/io.hpp"
#include "iires/metrics.hpp"
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
/// longest axis (seed 1), positions only, like a raw scan — every method gets the same points. @p noiseSpacings > 0
/// moves each point along the mesh normal by Gaussian noise of σ = noiseSpacings mean input spacings (seed 2).
inline PointCloud scanLikeSampling(const TriangleMesh& mesh, std::size_t count, double ratio,
                                   double noiseSpacings = 0.0) {
  MeshSamplingParams sp;
  sp.count = count;
  sp.densityRatio = ratio;
  sp.seed = 1;
  PointCloud cloud = sampleMesh(mesh, sp);
  if (noiseSpacings > 0) {
    const double sigma = noiseSpacings * spacingStats(cloud.points).mean;
    std::mt19937_64 rng(2);
    std::normal_distribution<double> gauss(0.0, sigma);
    for (std::size_t i = 0; i < cloud.points.size(); ++i) cloud.points[i] += gauss(rng) * cloud.normals[i];
  }
  cloud.normals.clear();
  return cloud;
}

/// @brief The command line of the benchmarks that resample one mesh's sampling to several N:
/// `MESH INPUT_COUNT N [N ...] [--density-ratio R] [--threads T]` plus options of their own, which @p option
/// consumes (it gets the argument and may advance the index past a value; returns false for "not mine").
/// Exits with code 2 and @p usage on too few arguments.
struct GridArgs {
  std::string meshPath;
  std::size_t inputCount = 0;
  std::vector<std::size_t> counts;
  double ratio = 1.0;
  int threads = 0;
  /// The mesh file's name without its directory (the `model=` of the key=value lines).
  std::string name() const { return meshPath.substr(meshPath.find_last_of('/') + 1); }
};

inline GridArgs parseGridArgs(int argc, char** argv, double defaultRatio, const std::string& usage,
                              const std::function<bool(const std::string&, int&)>& option = {}) {
  if (argc < 4) {
    std::cerr << "usage: " << usage << "\n";
    std::exit(2);
  }
  GridArgs g;
  g.meshPath = argv[1];
  g.inputCount = std::stoul(argv[2]);
  g.ratio = defaultRatio;
  for (int a = 3; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--density-ratio" && a + 1 < argc) {
      g.ratio = std::stod(argv[++a]);
    } else if (arg == "--threads" && a + 1 < argc) {
      g.threads = std::stoi(argv[++a]);
    } else if (!option || !option(arg, a)) {
      g.counts.push_back(std::stoul(arg));
    }
  }
  return g;
}

}  // namespace iires::bench
