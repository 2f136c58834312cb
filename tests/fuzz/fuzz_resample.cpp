// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: iires::resample, the resampler's entry point, on small adversarial clouds (duplicates,
// coplanar, collinear, huge and tiny coordinates, NaN) with parameters decoded from the input: N ≤ 500, at most
// 2,000 points, one thread. The pipeline's iteration counts are decoded small (they only repeat the same code),
// so that an execution takes milliseconds, not seconds, under ASan+UBSan. InputError and
// std::invalid_argument are the acceptable failures; on success the result must hold exactly N finite points
// with unit normals, among them every fixed sample unchanged. Build and run with tests/fuzz/run.sh.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "resample_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto in = iires::fuzz::decodeResampleInput(data, size);
  if (!in) return 0;
  const iires::ResampleParams& params = in->params;
  try {
    const iires::ResampleResult result = iires::resample(in->cloud, params, iires::Execution{1});
    if (result.cloud.size() != params.targetCount) __builtin_trap();  // exactly N
    if (!result.cloud.hasNormals()) __builtin_trap();
    for (std::size_t i = 0; i < result.cloud.size(); ++i) {
      if (!result.cloud.points[i].allFinite()) __builtin_trap();
      if (std::abs(result.cloud.normals[i].norm() - 1.0) > 1e-6) __builtin_trap();
    }
    for (const auto& p : params.fixedSamples)  // kept exactly as given
      if (std::find(result.cloud.points.begin(), result.cloud.points.end(), p) == result.cloud.points.end())
        __builtin_trap();
  } catch (const iires::InputError&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
