// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: the cloud and mesh readers on arbitrary bytes, under every supported extension.
// The only acceptable failure is iires::InputError; anything else (another exception, a crash, a sanitizer
// report) is a bug. Build and run with tests/fuzz/run.sh.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "iires/io.hpp"

namespace {

/// A per-process scratch path in a RAM-backed directory when there is one.
std::string scratchPath(const char* extension) {
  static const std::string base = [] {
    const char* dir = ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    return std::string(dir) + "/iires_fuzz_readers_" + std::to_string(::getpid());
  }();
  return base + extension;
}

void check(const iires::PointCloud& cloud) {
  if (cloud.empty()) __builtin_trap();  // readers promise at least one point
  if (!cloud.normals.empty() && cloud.normals.size() != cloud.points.size()) __builtin_trap();
}

void check(const iires::TriangleMesh& mesh) {
  if (mesh.triangles.empty()) __builtin_trap();
  const auto count = static_cast<int>(mesh.vertices.size());
  for (const auto& t : mesh.triangles)
    if (t.minCoeff() < 0 || t.maxCoeff() >= count) __builtin_trap();  // readers range-check indices
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const char* const kExtensions[] = {".ply", ".pcd", ".xyz", ".xyzn", ".pts", ".obj", ".off", ".stl"};
  // The first byte picks the extension so the fuzzer can steer; the rest is the file.
  if (size < 1) return 0;
  const char* extension = kExtensions[data[0] % (sizeof kExtensions / sizeof *kExtensions)];
  const std::string path = scratchPath(extension);
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return 0;
    std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);
  }
  try {
    check(iires::readPointCloud(path));
  } catch (const iires::InputError&) {
  }
  try {
    check(iires::readMesh(path));
  } catch (const iires::InputError&) {
  }
  std::remove(path.c_str());
  return 0;
}
