// SPDX-License-Identifier: GPL-3.0-or-later
// Thin parts and near-contact surfaces (issue 19): two sheets joined by a fold, a thin closed plate, two
// spheres nearly touching, a sphere inside a sphere — generated with fixed seeds (tests/shapes.hpp),
// positions only (like a raw .xyz scan), resampled with the default parameters (the CLI's defaults).
// Prints one key=value line per (case, input, gap, noise, N) and per --denoise-only run.
// Usage: thin_parts_bench CASE INPUT_COUNT GAP_SPACINGS NOISE_SPACINGS [N ...] [--threads T] [--no-intrinsic] [--input-per-sample X] [--write-input FILE.xyz] [--seed S]
//   CASE: sheets | plate | spheres | nested
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/preprocess.hpp"
#include "iires/resample.hpp"
#include "shapes.hpp"

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

iires::test::ThinCase makeCase(const std::string& name, std::size_t count, double gap, double noise,
                               std::uint64_t seed) {
  if (name == "sheets") return iires::test::foldedSheets(count, gap, noise, seed);
  if (name == "plate") return iires::test::thinPlate(count, gap, noise, seed);
  if (name == "spheres") return iires::test::twoSpheres(count, gap, noise, seed);
  if (name == "nested") return iires::test::nestedSpheres(count, gap, noise, seed);
  std::fprintf(stderr, "thin_parts_bench: error: unknown case '%s'\n", name.c_str());
  std::exit(2);
}

/// Share of the near parts' points on side 1 expected from the areas.
double expectedShare(const iires::test::ThinCase& t) {
  if (t.kind == 3) return (1 + t.gap) * (1 + t.gap) / (1 + (1 + t.gap) * (1 + t.gap));
  return 0.5;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr,
                 "usage: thin_parts_bench CASE INPUT_COUNT GAP_SPACINGS NOISE_SPACINGS [N ...] [--threads T] "
                 "[--no-intrinsic] [--input-per-sample X] [--write-input FILE.xyz] [--seed S]\n");
    return 2;
  }
  const std::string name = argv[1];
  const std::size_t count = std::stoul(argv[2]);
  const double gapSpacings = std::stod(argv[3]), noise = std::stod(argv[4]);
  std::vector<std::size_t> ns;
  int threads = 0;
  bool intrinsic = true;
  long inputPerSample = -1;
  std::string writeInput;
  std::uint64_t seed = 19;
  for (int a = 5; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--threads" && a + 1 < argc) {
      threads = std::stoi(argv[++a]);
    } else if (arg == "--input-per-sample" && a + 1 < argc) {
      inputPerSample = std::stol(argv[++a]);
    } else if (arg == "--seed" && a + 1 < argc) {
      seed = std::stoull(argv[++a]);
    } else if (arg == "--write-input" && a + 1 < argc) {
      writeInput = argv[++a];
    } else if (arg == "--no-intrinsic") {
      intrinsic = false;
    } else {
      ns.push_back(std::stoul(arg));
    }
  }
  iires::test::ThinCase t = makeCase(name, count, gapSpacings, noise, seed);
  t.cloud.normals.clear();  // a raw scan: positions only
  if (!writeInput.empty()) iires::writePointCloud(writeInput, t.cloud);
  const std::string prefix = "case=" + t.name + " input=" + std::to_string(count) +
                             " gap_spacings=" + std::to_string(gapSpacings).substr(0, 4) +
                             " noise_spacings=" + std::to_string(noise).substr(0, 4);
  if (std::getenv("THIN_PARTS_NO_DENOISE_ONLY") == nullptr) {  // --denoise-only
    const iires::Execution exec{threads};
    const double t0 = now();
    const iires::PreprocessResult r = iires::preprocess(t.cloud, {}, exec);
    double sum = 0, before = 0;
    for (const auto& p : r.cloud.points) sum += t.distance(p);
    for (const auto& p : t.cloud.points) before += t.distance(p);
    std::printf("%s mode=denoise-only points=%zu time_s=%.3f mean_dist_per_gap=%.4f input_mean_dist_per_gap=%.4f "
                "clean=%d sweeps=%d outliers=%zu\n",
                prefix.c_str(), r.cloud.size(), now() - t0, sum / r.cloud.size() / t.gap,
                before / t.cloud.size() / t.gap, r.cleanInput ? 1 : 0, r.denoiseIterations, r.outliersFound);
    std::fflush(stdout);
  }
  for (std::size_t n : ns) {
    iires::ResampleParams p;
    p.targetCount = n;
    p.intrinsic = intrinsic;
    if (inputPerSample >= 0) p.maxInputPerSample = static_cast<std::size_t>(inputPerSample);
    const double t0 = now();
    iires::ResampleResult r;
    try {
      r = iires::resample(t.cloud, p, iires::Execution{threads});
    } catch (const std::exception& e) {  // a row that failed is a result too: say so and go on
      std::printf("%s N=%zu status=failed error=\"%s\"\n", prefix.c_str(), n, e.what());
      std::fflush(stdout);
      continue;
    }
    const double seconds = now() - t0;
    std::size_t off = 0, near = 0, sides[2] = {0, 0};
    double worst = 0, mean = 0;
    for (const auto& q : r.cloud.points) {
      const double d = t.distance(q);
      mean += d;
      const int s = t.side(q);
      if (s < 0) continue;
      ++near;
      ++sides[s];
      worst = std::max(worst, d);
      off += d > 0.1 * t.gap;
    }
    const double share = near ? static_cast<double>(sides[1]) / static_cast<double>(near) : 0.0;
    iires::SpacingStats spacing;  // uniformity along the surface: each near part's points among themselves
    spacing.cv = iires::test::sideSpacingCv(t, r.cloud.points);
    spacing.mean = r.spacing.mean;
    std::printf("%s N=%zu points=%zu time_s=%.3f working=%zu off_sheet=%zu of=%zu max_dist_per_gap=%.4f "
                "mean_dist_per_gap=%.4f side0=%zu side1=%zu share_err_pct=%.2f cv=%.4f components=%zu "
                "clean=%d sweeps=%d out_spacing_per_gap=%.2f sheets_near=%zu sheets_zones=%zu sheets_s=%.3f\n",
                prefix.c_str(), n, r.cloud.size(), seconds, r.thinnedPoints, off, near, worst / t.gap,
                mean / r.cloud.size() / t.gap, sides[0], sides[1], 100 * (share - expectedShare(t)) / expectedShare(t),
                spacing.cv, r.components, r.preprocessing.cleanInput ? 1 : 0, r.preprocessing.denoiseIterations,
                spacing.mean / t.gap, r.sheets.nearPoints, r.sheets.nearZones, r.sheets.seconds);
    std::fflush(stdout);
  }
  return 0;
}
