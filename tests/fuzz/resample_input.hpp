// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The input of fuzz_resample decoded into the resampler's cloud and parameters: shared by the harness and by the
// regression tests that replay the inputs it found (tests/fuzz_regression_test.cpp).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>

#include "iires/resample.hpp"

namespace iires::fuzz {

/// Byte layout: a 5-byte header, then points.
///  [0] N code: N = 1 + code % 48, or 1 + code · 499 / 255 (up to 500) when [2] bits 0-1 are both set.
///  [1] bit 0: raw doubles (24 bytes a point, anything goes) instead of int16 grid coordinates (6 bytes a point,
///      scaled by 1000^e / 1000 with e = bits 4-5); bit 1: intrinsic control; bit 2: pre-processing; bit 3: give
///      normals (int16 mode: from the next 3 int16 per point); bit 6: curvature mode; bit 7: sharp edges.
///  [2] bits 2-3: MLS k ∈ {3, 8, 16, 24}; bit 4: MLS degree 1; bit 5: one MLS iteration; bits 6-7: outliers
///      pull / remove / keep / keep without denoising.
///  [3] bits 0-1: passes ∈ {0, 1, 2, 4}; bits 2-3: final relaxation iterations ∈ {0, 4, 8, 12}; bit 4: two
///      relaxation iterations per pass (else one); bits 5-7: 1-ring candidates 6 + 2·v.
///  [4] bits 0-2: the first F points are also fixed samples; bits 3-7: seed.
constexpr std::size_t kHeader = 5;
constexpr std::size_t kMaxPoints = 2000;

struct ResampleInput {
  PointCloud cloud;
  ResampleParams params;
};

inline std::int16_t int16At(const std::uint8_t* p) {
  std::int16_t v;
  std::memcpy(&v, p, 2);
  return v;
}

/// The cloud and parameters @p data stands for; nothing for an input shorter than the header.
inline std::optional<ResampleInput> decodeResampleInput(const std::uint8_t* data, std::size_t size) {
  if (size < kHeader) return std::nullopt;
  ResampleInput in;
  ResampleParams& params = in.params;
  const std::uint8_t code = data[0], flags = data[1], a = data[2], b = data[3], c = data[4];
  params.targetCount = (a & 3) == 3 ? 1 + code * 499u / 255u : 1 + code % 48u;
  params.intrinsic = (flags & 2) != 0;
  params.preprocess = (flags & 4) != 0;
  if (flags & 64) params.mode = ResampleMode::kCurvature;
  params.sharpEdges = (flags & 128) != 0;
  static const int kMlsK[] = {3, 8, 16, 24};
  params.mls.k = kMlsK[(a >> 2) & 3];
  params.mls.degree = (a & 16) ? 1 : 2;
  params.mls.iterations = (a & 32) ? 1 : 2;
  static const OutlierMode kOutliers[] = {OutlierMode::kPull, OutlierMode::kRemove, OutlierMode::kKeep,
                                          OutlierMode::kKeep};
  params.preprocessing.outliers.mode = kOutliers[a >> 6];
  params.preprocessing.runDenoise = (a >> 6) != 3;
  static const int kPasses[] = {0, 1, 2, 4};
  params.maxPasses = kPasses[b & 3];
  params.maxRelaxIterations = 4 * ((b >> 2) & 3);
  params.relaxPerPass = (b & 16) ? 2 : 1;
  params.neighbours = 6 + 2 * (b >> 5);
  params.seed = c >> 3;
  const std::size_t fixedCount = c & 7;
  const bool raw = (flags & 1) != 0, normals = (flags & 8) != 0 && !raw;
  const double scale = std::pow(1000.0, static_cast<double>((flags >> 4) & 3)) / 1000.0;
  data += kHeader;
  size -= kHeader;
  PointCloud& cloud = in.cloud;
  const std::size_t stride = raw ? 24 : (normals ? 12 : 6);
  for (std::size_t i = 0; i + stride <= size && cloud.size() < kMaxPoints; i += stride) {
    if (raw) {
      double xyz[3];
      std::memcpy(xyz, data + i, 24);
      cloud.points.emplace_back(xyz[0], xyz[1], xyz[2]);
    } else {
      cloud.points.emplace_back(scale * int16At(data + i), scale * int16At(data + i + 2),
                                scale * int16At(data + i + 4));
      if (normals)
        cloud.normals.emplace_back(int16At(data + i + 6), int16At(data + i + 8), int16At(data + i + 10));
    }
  }
  // Fixed samples must be finite (they are parameters, not input); the cloud itself is passed as it is.
  for (std::size_t i = 0; i < std::min(fixedCount, cloud.size()); ++i)
    if (cloud.points[i].allFinite()) params.fixedSamples.push_back(cloud.points[i]);
  return in;
}

}  // namespace iires::fuzz
