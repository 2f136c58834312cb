// libFuzzer target: iires::resample on small adversarial clouds (duplicates, coplanar, collinear, huge and tiny
// coordinates, NaN) with N <= 200 and one thread. InputError and std::invalid_argument are the acceptable
// failures; on success the result must hold exactly N finite points with unit normals.
// Build and run with tests/fuzz/run.sh.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#include "iires/resample.hpp"

namespace {

/// Byte layout: [N-1] [flags] then points. flags bit 0: raw doubles (24 bytes a point, anything goes) instead
/// of int16 grid coordinates (6 bytes a point, scaled by 1/1000); bit 1: intrinsic control; bit 2: pre-
/// processing; bit 3: give normals (from the next 3 int16 per point); bits 4-5: scale exponent for int16 mode.
constexpr std::size_t kMaxPoints = 400;

std::int16_t int16At(const std::uint8_t* p) {
  std::int16_t v;
  std::memcpy(&v, p, 2);
  return v;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  iires::ResampleParams params;
  params.targetCount = 1 + data[0] % 200;
  const std::uint8_t flags = data[1];
  params.intrinsic = (flags & 2) != 0;
  params.preprocess = (flags & 4) != 0;
  params.threads = 1;
  params.maxPasses = 4;
  params.maxRelaxIterations = 8;
  const bool raw = (flags & 1) != 0, normals = (flags & 8) != 0;
  const double scale = std::pow(1000.0, static_cast<double>((flags >> 4) & 3)) / 1000.0;
  data += 2;
  size -= 2;

  iires::PointCloud cloud;
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
  try {
    const iires::ResampleResult result = iires::resample(cloud, params);
    if (result.cloud.size() != params.targetCount) __builtin_trap();  // exactly N
    if (!result.cloud.hasNormals()) __builtin_trap();
    for (std::size_t i = 0; i < result.cloud.size(); ++i) {
      if (!result.cloud.points[i].allFinite()) __builtin_trap();
      if (std::abs(result.cloud.normals[i].norm() - 1.0) > 1e-6) __builtin_trap();
    }
  } catch (const iires::InputError&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
