// SPDX-License-Identifier: GPL-3.0-or-later
// Tests of mesh_repair.hpp's large-hole filling against the input it was made from (the fill must lie on the
// sampled surface unless the data ends at the loop). The other mesh_repair tests are in reconstruct_test.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "iires/reconstruct/triangulate.hpp"
#include "shapes.hpp"

namespace iires {
namespace {

/// The local triangulation of a 3,000-point Fibonacci unit sphere with the faces touching z < -0.8 removed: one
/// loop of about 50 edges round a cap 0.6 in radius (a gap small next to the ball: fillLargeHoles() closes it).
TriangleMesh sphereWithoutCap(std::vector<Eigen::Vector3d>& normals) {
  PointCloud c;
  c.points = test::fibonacciSphere(3000);
  c.normals = c.points;
  const TriangleMesh whole = triangulateLocal(c).mesh;
  TriangleMesh m =
      test::withoutFaces(whole, [&](const Eigen::Vector3i& t) { return test::hasCornerBelow(whole, t, -0.8); });
  normals = c.normals;
  return m;
}

/// The vertices of @p m's faces: a scan whose points are the mesh's vertices (no point inside the loop).
std::vector<Eigen::Vector3d> usedVertices(const TriangleMesh& m) {
  std::vector<char> used(m.vertices.size(), 0);
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) used[static_cast<std::size_t>(t[k])] = 1;
  std::vector<Eigen::Vector3d> points;
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v]) points.push_back(m.vertices[v]);
  return points;
}

// The loop round the cut cap is where the data of a ball goes on down a pipe (a tube leaving the ball, not
// meshed: samples the triangulation did not link, as along 3torus's narrow wedges). A flat cap over the pipe's
// mouth lies up to 0.58 (7.5 mean edges) from every input point while the input goes on beyond the loop: the fill
// is undone and the loop left open, the mesh unchanged. Where the data ends at the loop (a scan's gap: the points
// are the ball's only), the same fill is kept; without input points fillLargeHoles() closes both (no support test).
TEST(MeshRepair, FillLargeHolesStaysOnTheSampledSurface) {
  std::vector<Eigen::Vector3d> normals;
  const TriangleMesh cut = sphereWithoutCap(normals);
  ASSERT_EQ(evaluateMesh(cut).boundaryLoops, 1u);
  // The loop: its mean radius and height.
  std::map<std::pair<int, int>, int> uses;
  for (const auto& t : cut.triangles)
    for (int k = 0; k < 3; ++k) ++uses[std::minmax(t[k], t[(k + 1) % 3])];
  double radius = 0, z = 0, loopEdges = 0, edgeSum = 0;
  for (const auto& [e, n] : uses) {
    const Eigen::Vector3d& a = cut.vertices[static_cast<std::size_t>(e.first)];
    const Eigen::Vector3d& b = cut.vertices[static_cast<std::size_t>(e.second)];
    edgeSum += (a - b).norm();
    if (n != 1) continue;
    radius += a.head<2>().norm(), z += a.z(), ++loopEdges;
  }
  ASSERT_GT(loopEdges, 30);
  radius /= loopEdges, z /= loopEdges;
  const double l = edgeSum / static_cast<double>(uses.size());

  const std::vector<Eigen::Vector3d> ball = usedVertices(cut);
  std::vector<Eigen::Vector3d> ballAndPipe = ball;  // the pipe: rings l/2 apart down to 1.2 below the loop
  const int around = static_cast<int>(std::ceil(2 * M_PI * radius / (0.5 * l)));
  for (double depth = 0.5 * l; depth < 1.2; depth += 0.5 * l)
    for (int i = 0; i < around; ++i) {
      const double a = 2 * M_PI * i / around;
      ballAndPipe.emplace_back(radius * std::cos(a), radius * std::sin(a), z - depth);
    }

  for (const bool pipe : {false, true}) {
    TriangleMesh m = cut;
    std::vector<Eigen::Vector3d> n = normals;
    HoleFillingParams p;
    p.inputPoints = std::make_shared<const SampledPoints>(
        std::make_shared<const std::vector<Eigen::Vector3d>>(pipe ? ballAndPipe : ball));
    const LargeHoleReport r = fillLargeHoles(m, n, p);
    EXPECT_EQ(r.loops, 1u) << "pipe " << pipe;
    const MeshQuality q = evaluateMesh(m);
    if (pipe) {
      EXPECT_EQ(r.filled, 0u);
      EXPECT_EQ(r.kept, 1u);
      EXPECT_EQ(r.unsupported, 1u);
      EXPECT_EQ(r.verticesAdded, 0u);
      EXPECT_EQ(m.vertices, cut.vertices);  // undone: the mesh as it was
      EXPECT_EQ(m.triangles, cut.triangles);
      EXPECT_EQ(q.boundaryLoops, 1u);
    } else {
      EXPECT_EQ(r.filled, 1u);
      EXPECT_EQ(r.unsupported, 0u);
      EXPECT_GT(r.verticesAdded, 100u);
      EXPECT_TRUE(q.closed);
      EXPECT_EQ(q.euler, 2);
    }
  }
  // A cap of the ball's own samples: the fill lies on them, so it is kept although they go on beyond the loop.
  {
    TriangleMesh m = cut;
    std::vector<Eigen::Vector3d> n = normals;
    HoleFillingParams p;
    std::vector<Eigen::Vector3d> flat = ball;
    for (double x = -radius; x <= radius; x += 0.5 * l)
      for (double y = -radius; y <= radius; y += 0.5 * l)
        if (std::hypot(x, y) < radius + l) flat.emplace_back(x, y, z);
    p.inputPoints =
        std::make_shared<const SampledPoints>(std::make_shared<const std::vector<Eigen::Vector3d>>(flat));
    const LargeHoleReport r = fillLargeHoles(m, n, p);
    EXPECT_EQ(r.filled, 1u);
    EXPECT_EQ(r.unsupported, 0u);
    EXPECT_TRUE(evaluateMesh(m).closed);
  }
  HoleFillingParams bad;
  bad.supportDistance = 0;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = HoleFillingParams{};
  bad.maxContinuedShare = 1.5;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace iires
