// SPDX-License-Identifier: GPL-3.0-or-later
// scene_generator: a large test scene for out-of-core resampling (DESIGN §9), written in chunks so that its size
// is not bounded by memory: a ground plane with walls (open boxes standing on it, like buildings) and copies of
// corpus models scattered, rotated about the vertical and scaled over it, sampled uniformly by area.
//   scene_generator --points 50000000 --out scene.ply [--models bunny00,fandisk,...] [--copies 60] [--seed 1]
//                   [--sink F]
// --sink F sets each model F of its height into the ground and leaves out the points below it, as a scan sees an
// object standing on the ground; 0 (the default) stands the models on it, a flat base then lying on the ground
// (two coincident sheets, both sampled).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "bench_util.hpp"
#include "iires/io.hpp"
#include "iires/point_stream.hpp"

namespace {

using Eigen::Vector3d;

struct Triangle {
  Vector3d a, b, c;
};

constexpr double kGround = 100.0;  // side of the ground square

void addQuad(std::vector<Triangle>& t, const Vector3d& o, const Vector3d& u, const Vector3d& v) {
  t.push_back({o, o + u, o + u + v});
  t.push_back({o, o + u + v, o + v});
}

/// Ground and the four walls of each of @p buildings boxes.
void addGroundAndWalls(std::vector<Triangle>& t, int buildings, std::mt19937_64& rng) {
  addQuad(t, {0, 0, 0}, {kGround, 0, 0}, {0, kGround, 0});
  std::uniform_real_distribution<double> at(5, kGround - 20), side(4, 15), height(3, 12);
  for (int b = 0; b < buildings; ++b) {
    const Vector3d o(at(rng), at(rng), 0);
    const double w = side(rng), d = side(rng), h = height(rng);
    addQuad(t, o, {w, 0, 0}, {0, 0, h});
    addQuad(t, o + Vector3d(w, 0, 0), {0, d, 0}, {0, 0, h});
    addQuad(t, o + Vector3d(w, d, 0), {-w, 0, 0}, {0, 0, h});
    addQuad(t, o + Vector3d(0, d, 0), {0, -d, 0}, {0, 0, h});
  }
}

/// @p copies corpus models, each scaled to 2–8 units, rotated about z and set on the ground, @p sink of its height
/// below it.
void addModels(std::vector<Triangle>& t, const std::vector<std::string>& names, int copies, double sink,
               std::mt19937_64& rng) {
  std::vector<iires::TriangleMesh> meshes;
  for (const std::string& n : names) meshes.push_back(iires::readMesh(std::string(IIRES_BENCH_DATA_DIR) + "/meshes/" + n + ".off"));
  std::uniform_real_distribution<double> at(2, kGround - 2), size(2, 8), angle(0, 2 * M_PI);
  for (int c = 0; c < copies; ++c) {
    const iires::TriangleMesh& m = meshes[static_cast<std::size_t>(c) % meshes.size()];
    Eigen::AlignedBox3d box;
    for (const Vector3d& v : m.vertices) box.extend(v);
    const double scale = size(rng) / box.sizes().maxCoeff();
    const Eigen::Matrix3d r = Eigen::AngleAxisd(angle(rng), Vector3d::UnitZ()).toRotationMatrix();
    const Vector3d base(at(rng), at(rng), 0);
    auto place = [&](const Vector3d& v) {
      Vector3d p = r * ((v - box.center()) * scale);
      return Vector3d(p.x() + base.x(), p.y() + base.y(), p.z() + (0.5 - sink) * box.sizes().z() * scale);
    };
    for (const Eigen::Vector3i& f : m.triangles)
      t.push_back({place(m.vertices[f[0]]), place(m.vertices[f[1]]), place(m.vertices[f[2]])});
  }
}

}  // namespace

int generate(int argc, char** argv) {
  std::size_t points = 1000000;
  std::string out = "scene.ply", models = "bunny00,fandisk,armadillo,eight,anchor,knot1";
  int copies = 60, buildings = 25;
  std::uint64_t seed = 1;
  double sink = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--points") points = std::stoull(value);
    else if (key == "--out") out = value;
    else if (key == "--models") models = value;
    else if (key == "--copies") copies = std::stoi(value);
    else if (key == "--buildings") buildings = std::stoi(value);
    else if (key == "--seed") seed = std::stoull(value);
    else if (key == "--sink") sink = std::stod(value);
    else {
      std::fprintf(stderr, "scene_generator: unknown option %s\n", key.c_str());
      return 2;
    }
  }
  if (!(sink >= 0 && sink < 1)) {
    std::fprintf(stderr, "scene_generator: --sink must lie in [0, 1)\n");
    return 2;
  }
  std::mt19937_64 rng(seed);
  std::vector<Triangle> tris;
  addGroundAndWalls(tris, buildings, rng);
  addModels(tris, iires::bench::split(models), copies, sink, rng);
  std::vector<double> cdf;
  double total = 0;
  for (const Triangle& t : tris) cdf.push_back(total += 0.5 * (t.b - t.a).cross(t.c - t.a).norm());
  iires::PointStreamWriter writer(out, points, false);
  std::uniform_real_distribution<double> u(0, 1);
  iires::PointCloud chunk;
  for (std::size_t done = 0; done < points;) {
    chunk.points.clear();
    const std::size_t m = std::min<std::size_t>(1u << 20, points - done);
    while (chunk.points.size() < m) {
      const auto k = static_cast<std::size_t>(std::lower_bound(cdf.begin(), cdf.end(), u(rng) * total) - cdf.begin());
      const Triangle& t = tris[std::min(k, tris.size() - 1)];
      double a = u(rng), b = u(rng);
      if (a + b > 1) a = 1 - a, b = 1 - b;
      chunk.points.push_back(t.a + a * (t.b - t.a) + b * (t.c - t.a));
      if (sink > 0 && chunk.points.back().z() < 0) chunk.points.pop_back();  // below the ground: drawn again
    }
    writer.write(chunk);
    done += m;
  }
  writer.finish();
  std::printf("points=%zu triangles=%zu area=%.6g out=%s\n", points, tris.size(), total, out.c_str());
  return 0;
}

int main(int argc, char** argv) {
  try {
    return generate(argc, argv);
  } catch (const std::exception& e) {  // a corpus model not fetched, an unwritable output, a bad number
    std::fprintf(stderr, "scene_generator: error: %s\n", e.what());
    return 2;
  }
}
