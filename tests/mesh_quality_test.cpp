// Tests of mesh_quality.hpp: the formulas on known triangles, topology counts on known meshes, distances.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "iires/reconstruct/mesh_quality.hpp"

namespace iires {
namespace {

using V = Eigen::Vector3d;
using F = Eigen::Vector3i;

TriangleMesh tetrahedron() {
  TriangleMesh m;
  m.vertices = {V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), V(0, 0, 1)};
  m.triangles = {F(0, 2, 1), F(0, 1, 3), F(0, 3, 2), F(1, 2, 3)};  // outward
  return m;
}

TriangleMesh cube() {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  // Two outward triangles per face.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.emplace_back(q[0], q[1], q[2]);
    m.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}

TriangleMesh openSquare() {
  TriangleMesh m;
  m.vertices = {V(0, 0, 0), V(1, 0, 0), V(1, 1, 0), V(0, 1, 0)};
  m.triangles = {F(0, 1, 2), F(0, 2, 3)};
  return m;
}

TEST(TriangleQuality, EquilateralIsOne) {
  const V a(0, 0, 0), b(2, 0, 0), c(1, std::sqrt(3.0), 0);
  EXPECT_NEAR(triangleQuality(a, b, c), 1.0, 1e-12);
  EXPECT_NEAR(triangleMinAngle(a, b, c), 60.0, 1e-9);
}

TEST(TriangleQuality, RightIsosceles) {
  // S = 1/2, p = (2 + √2)/2, h = √2  →  Q = √3 / (1 + √2).
  const V a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_NEAR(triangleQuality(a, b, c), std::sqrt(3.0) / (1.0 + std::sqrt(2.0)), 1e-12);
  EXPECT_NEAR(triangleMinAngle(a, b, c), 45.0, 1e-9);
}

TEST(TriangleQuality, ScaleAndRotationInvariant) {
  const V a(0.3, 0.1, 0), b(1.7, 0.2, 0.4), c(0.5, 1.3, -0.2);
  const double q = triangleQuality(a, b, c);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, V(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_NEAR(triangleQuality(250.0 * r * a, 250.0 * r * b, 250.0 * r * c), q, 1e-12);
}

TEST(TriangleQuality, DegenerateIsZero) {
  EXPECT_EQ(triangleQuality(V(0, 0, 0), V(1, 0, 0), V(2, 0, 0)), 0.0);  // collinear
  EXPECT_EQ(triangleQuality(V(0, 0, 0), V(0, 0, 0), V(1, 1, 0)), 0.0);  // repeated vertex
  EXPECT_EQ(triangleQuality(V(1, 1, 1), V(1, 1, 1), V(1, 1, 1)), 0.0);  // a point
  EXPECT_NEAR(triangleMinAngle(V(0, 0, 0), V(1, 0, 0), V(2, 0, 0)), 0.0, 1e-12);
}

TEST(MeshQuality, Tetrahedron) {
  const MeshQuality q = evaluateMesh(tetrahedron());
  EXPECT_EQ(q.vertices, 4u);
  EXPECT_EQ(q.faces, 4u);
  EXPECT_EQ(q.edges, 6u);
  EXPECT_EQ(q.boundaryEdges, 0u);
  EXPECT_EQ(q.boundaryLoops, 0u);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 0u);
  EXPECT_EQ(q.components, 1u);
  EXPECT_EQ(q.euler, 2);
  EXPECT_EQ(q.genus, 0);
  EXPECT_TRUE(q.closed);
  EXPECT_TRUE(q.manifold);
  EXPECT_TRUE(q.oriented);
  // Three right isosceles faces and one equilateral.
  EXPECT_NEAR(q.qualityMin, std::sqrt(3.0) / (1.0 + std::sqrt(2.0)), 1e-12);
  EXPECT_NEAR(q.qualityMean, (3.0 * std::sqrt(3.0) / (1.0 + std::sqrt(2.0)) + 1.0) / 4.0, 1e-12);
  EXPECT_NEAR(q.minAngleMin, 45.0, 1e-9);
  EXPECT_EQ(q.shareBelow30, 0.0);
  EXPECT_FALSE(q.distance.computed);
}

TEST(MeshQuality, OneFlippedFaceIsNotOriented) {
  TriangleMesh m = tetrahedron();
  std::swap(m.triangles[2][1], m.triangles[2][2]);
  const MeshQuality q = evaluateMesh(m);
  EXPECT_TRUE(q.closed);
  EXPECT_FALSE(q.oriented);
  EXPECT_EQ(q.genus, -1);
}

TEST(MeshQuality, Cube) {
  const MeshQuality q = evaluateMesh(cube());
  EXPECT_EQ(q.vertices, 8u);
  EXPECT_EQ(q.faces, 12u);
  EXPECT_EQ(q.edges, 18u);
  EXPECT_EQ(q.euler, 2);
  EXPECT_TRUE(q.closed && q.manifold && q.oriented);
  EXPECT_NEAR(q.area, 6.0, 1e-12);
}

TEST(MeshQuality, OpenSquare) {
  const MeshQuality q = evaluateMesh(openSquare());
  EXPECT_EQ(q.boundaryEdges, 4u);
  EXPECT_EQ(q.boundaryLoops, 1u);
  EXPECT_EQ(q.edges, 5u);
  EXPECT_EQ(q.euler, 1);
  EXPECT_FALSE(q.closed);
  EXPECT_TRUE(q.manifold);
  EXPECT_TRUE(q.oriented);
}

TEST(MeshQuality, NonManifoldEdgeFan) {
  TriangleMesh m;
  m.vertices = {V(0, 0, 0), V(1, 0, 0), V(0.5, 1, 0), V(0.5, -1, 0), V(0.5, 0, 1)};
  m.triangles = {F(0, 1, 2), F(1, 0, 3), F(0, 1, 4)};  // three faces on edge 0–1
  const MeshQuality q = evaluateMesh(m);
  EXPECT_EQ(q.nonManifoldEdges, 1u);
  EXPECT_FALSE(q.manifold);
  EXPECT_FALSE(q.closed);
  EXPECT_FALSE(q.oriented);  // 0→1 is used twice
  EXPECT_EQ(q.boundaryEdges, 6u);
}

TEST(MeshQuality, BowtieVertexIsNonManifold) {
  TriangleMesh m;
  m.vertices = {V(0, 0, 0), V(1, 0.5, 0), V(1, -0.5, 0), V(-1, 0.5, 0), V(-1, -0.5, 0)};
  m.triangles = {F(0, 2, 1), F(0, 3, 4)};
  const MeshQuality q = evaluateMesh(m);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 1u);
  EXPECT_EQ(q.components, 1u);
  EXPECT_FALSE(q.manifold);
}

TEST(MeshQuality, IsolatedVerticesAndComponents) {
  TriangleMesh m = tetrahedron();
  TriangleMesh s = openSquare();
  const int off = static_cast<int>(m.vertices.size());
  for (const auto& v : s.vertices) m.vertices.push_back(v + V(5, 0, 0));
  for (const auto& t : s.triangles) m.triangles.push_back(t + F(off, off, off));
  m.vertices.push_back(V(9, 9, 9));  // referenced by no face
  const MeshQuality q = evaluateMesh(m);
  EXPECT_EQ(q.components, 2u);
  EXPECT_EQ(q.isolatedVertices, 1u);
  EXPECT_EQ(q.vertices, 8u);
  EXPECT_EQ(q.euler, 3);
}

TEST(MeshQuality, DistanceToCloudOracle) {
  // Unit square; the cloud lies on it except one point 0.5 above its centre.
  PointCloud cloud;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 20; ++j) cloud.points.emplace_back(i / 20.0, j / 20.0, 0.0);
  cloud.points.emplace_back(0.5, 0.5, 0.5);
  MeshQualityParams p;
  p.meshSamples = 20000;
  const MeshQuality q = evaluateMesh(openSquare(), &cloud, p);
  ASSERT_TRUE(q.distance.computed);
  EXPECT_NEAR(q.distance.backwardMax, 0.5, 1e-12);        // cloud → mesh, exact
  EXPECT_LE(q.distance.forwardMax, std::sqrt(2.0) / 40 + 1e-9);  // mesh → cloud: half a grid diagonal at most
  EXPECT_GT(q.distance.forwardMax, 0.02);
  EXPECT_NEAR(q.distance.hausdorff, 0.5, 1e-12);
  EXPECT_NEAR(q.distance.diagonal, std::sqrt(2.25), 1e-12);
  EXPECT_NEAR(q.distance.relativeHausdorff(), 0.5 / std::sqrt(2.25), 1e-12);
}

TEST(MeshQuality, SurfaceDistanceBetweenShiftedCubes) {
  TriangleMesh a = cube(), b = cube();
  for (auto& v : b.vertices) v.z() += 0.1;
  MeshQualityParams p;
  p.meshSamples = p.referenceSamples = 20000;
  const SurfaceDistance d = surfaceDistance(b, a, p);
  EXPECT_NEAR(d.hausdorff, 0.1, 1e-9);
  EXPECT_NEAR(surfaceDistance(a, a, p).hausdorff, 0.0, 1e-12);
}

TEST(MeshQuality, SameReportForAnyThreadCount) {
  PointCloud cloud;
  for (int i = 0; i < 500; ++i) cloud.points.emplace_back(std::sin(i) * 0.5 + 0.5, std::cos(3 * i) * 0.5 + 0.5, 0.01 * (i % 7));
  MeshQualityParams p1, p2;
  p1.threads = 1;
  p2.threads = 2;
  EXPECT_EQ(evaluateMesh(cube(), &cloud, p1).toJson(), evaluateMesh(cube(), &cloud, p2).toJson());
}

TEST(MeshQuality, BadInputs) {
  TriangleMesh m = tetrahedron();
  m.triangles.push_back(F(0, 1, 7));
  EXPECT_THROW(evaluateMesh(m), InputError);
  MeshQualityParams p;
  p.meshSamples = 0;
  EXPECT_THROW(evaluateMesh(tetrahedron(), nullptr, p), std::invalid_argument);
  const MeshQuality empty = evaluateMesh(TriangleMesh{});
  EXPECT_EQ(empty.faces, 0u);
  EXPECT_FALSE(empty.closed);
  EXPECT_NE(empty.toJson().find("\"faces\": 0"), std::string::npos);
}

}  // namespace
}  // namespace iires
