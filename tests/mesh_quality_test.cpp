// SPDX-License-Identifier: GPL-3.0-or-later
// Tests of mesh_quality.hpp: the formulas on known triangles, topology counts on known meshes, distances.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "iires/reconstruct/mesh_quality.hpp"
#include "shapes.hpp"

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
  EXPECT_TRUE(q.orientable);  // one face flipped: the surface is still a sphere
  EXPECT_EQ(q.genus, 0);
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

/// An open k × k grid of the unit square in z = 0 (edge 1/k).
TriangleMesh gridSquare(int k) {
  TriangleMesh g;
  for (int i = 0; i <= k; ++i)
    for (int j = 0; j <= k; ++j) g.vertices.emplace_back(double(i) / k, double(j) / k, 0.0);
  auto at = [&](int i, int j) { return i * (k + 1) + j; };
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      g.triangles.emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      g.triangles.emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  return g;
}

void append(TriangleMesh& m, const TriangleMesh& other, const V& shift) {
  const int off = static_cast<int>(m.vertices.size());
  for (const auto& v : other.vertices) m.vertices.push_back(v + shift);
  for (const auto& t : other.triangles) m.triangles.push_back(t + F(off, off, off));
}

// Two closed tetrahedra that share one vertex (a pinch): every edge has two faces, so the mesh is "closed",
// but the shared vertex's link is two cycles. The component has no genus: none is printed.
TEST(MeshQuality, PinchedVertexIsReported) {
  TriangleMesh m = tetrahedron();
  TriangleMesh other = tetrahedron();
  for (auto& v : other.vertices) v = -v;  // mirrored through vertex 0, which both keep at the origin
  const int off = static_cast<int>(m.vertices.size()) - 1;
  for (std::size_t i = 1; i < other.vertices.size(); ++i) m.vertices.push_back(other.vertices[i]);
  for (auto t : other.triangles) {
    for (int c = 0; c < 3; ++c) t[c] = t[c] == 0 ? 0 : t[c] + off;
    m.triangles.push_back(t);
  }
  const MeshQuality q = evaluateMesh(m);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 1u);
  EXPECT_EQ(q.selfIntersections, 0u);
  EXPECT_FALSE(q.manifold);
  EXPECT_FALSE(q.valid());
  ASSERT_EQ(q.parts.size(), 1u);
  EXPECT_FALSE(q.parts[0].manifold);
  EXPECT_EQ(q.parts[0].genus, -1);
  EXPECT_EQ(q.genus, -1);
  EXPECT_NE(q.toJson().find("\"genus\": null"), std::string::npos);
  EXPECT_EQ(q.toTable().find("genus -"), std::string::npos) << q.toTable();
  EXPECT_NE(q.toTable().find("non-manifold, 8 faces"), std::string::npos) << q.toTable();
}

TEST(MeshQuality, GenusPerClosedComponent) {
  TriangleMesh m = test::torusMesh(1.0, 0.4, 24, 12);
  append(m, tetrahedron(), V(5, 0, 0));
  const MeshQuality q = evaluateMesh(m);
  ASSERT_EQ(q.parts.size(), 2u);
  EXPECT_TRUE(q.parts[0].closed);
  EXPECT_EQ(q.parts[0].genus, 1);  // the torus, most faces first
  EXPECT_EQ(q.parts[0].faces, 576u);
  EXPECT_EQ(q.parts[1].genus, 0);
  EXPECT_EQ(q.closedComponents, 2u);
  EXPECT_EQ(q.genus, 1);
  EXPECT_TRUE(q.valid());
  EXPECT_NE(q.toTable().find("closed, genus 1, 576 faces"), std::string::npos) << q.toTable();
  EXPECT_NE(q.toTable().find("closed, genus 0, 4 faces"), std::string::npos) << q.toTable();
}

// An open component: its boundary loops, and the genus of a surface with boundary (χ = 2 − 2g − b), never −1.
TEST(MeshQuality, OpenComponentsPrintBoundaryLoops) {
  TriangleMesh m = gridSquare(4);
  // A torus cut open along two meridians: a cylinder, b = 2.
  TriangleMesh annulus = test::torusMesh(1.0, 0.4, 24, 12);
  annulus.triangles.erase(annulus.triangles.begin(), annulus.triangles.begin() + 24);
  append(m, annulus, V(5, 0, 0));
  const MeshQuality q = evaluateMesh(m);
  ASSERT_EQ(q.parts.size(), 2u);
  EXPECT_EQ(q.parts[0].boundaryLoops, 2u);
  EXPECT_EQ(q.parts[0].genus, 0);
  EXPECT_EQ(q.parts[1].boundaryLoops, 1u);
  EXPECT_EQ(q.parts[1].genus, 0);
  EXPECT_EQ(q.closedComponents, 0u);
  EXPECT_EQ(q.genus, 0);
  EXPECT_NE(q.toTable().find("open, 2 boundary loops, genus 0"), std::string::npos) << q.toTable();
  EXPECT_NE(q.toTable().find("open, 1 boundary loop, genus 0, 32 faces"), std::string::npos) << q.toTable();
}

TEST(MeshQuality, MoebiusStripIsNotOrientable) {
  // A strip of 12 quads whose ends are glued with a half twist.
  TriangleMesh m;
  const int n = 12;
  for (int i = 0; i < n; ++i)
    for (int s : {-1, 1}) {
      const double u = 2 * M_PI * i / n, w = 0.3 * s;
      m.vertices.emplace_back((1 + w * std::cos(u / 2)) * std::cos(u), (1 + w * std::cos(u / 2)) * std::sin(u),
                              w * std::sin(u / 2));
    }
  for (int i = 0; i < n; ++i) {
    const int a = 2 * i, b = 2 * i + 1;
    const int c = i + 1 < n ? 2 * (i + 1) : 1, d = i + 1 < n ? 2 * (i + 1) + 1 : 0;  // the twist swaps the sides
    m.triangles.emplace_back(a, c, d);
    m.triangles.emplace_back(a, d, b);
  }
  const MeshQuality q = evaluateMesh(m);
  EXPECT_TRUE(q.manifold);
  EXPECT_FALSE(q.orientable);
  EXPECT_FALSE(q.oriented);
  EXPECT_EQ(q.boundaryLoops, 1u);
  EXPECT_EQ(q.genus, -1);
  EXPECT_NE(q.toTable().find("not orientable"), std::string::npos) << q.toTable();
}

TEST(MeshQuality, SelfIntersectionsAreCounted) {
  TriangleMesh m = tetrahedron();
  m.vertices.insert(m.vertices.end(), {V(0.2, 0.2, -0.5), V(0.3, 0.2, -0.5), V(0.25, 0.25, 0.1)});
  m.triangles.emplace_back(4, 5, 6);
  const MeshQuality q = evaluateMesh(m);
  EXPECT_EQ(q.selfIntersections, 1u);
  EXPECT_FALSE(q.valid());
  EXPECT_NE(q.toJson().find("\"self_intersecting_face_pairs\": 1"), std::string::npos);
  EXPECT_EQ(evaluateMesh(test::torusMesh(1.0, 0.4, 24, 12)).selfIntersections, 0u);
}

// Reference points farther than two output spacings (2 × mean edge length) from the mesh are uncovered.
TEST(MeshQuality, UncoveredReferencePoints) {
  const TriangleMesh m = gridSquare(10);
  PointCloud cloud;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 20; ++j) cloud.points.emplace_back(i / 20.0, j / 20.0, 0.0);
  cloud.points.emplace_back(0.5, 0.5, 0.3);   // 0.3 above: farther than 2 × 0.113
  cloud.points.emplace_back(0.5, 0.5, 0.15);  // 0.15 above: within two spacings
  cloud.points.emplace_back(3.0, 0.5, 0.0);   // a part the mesh misses
  MeshQualityParams p;
  p.meshSamples = 2000;
  const MeshQuality q = evaluateMesh(m, &cloud, p);
  EXPECT_NEAR(q.uncoveredDistance, 2.0 * q.meanEdgeLength, 1e-12);
  EXPECT_EQ(q.uncoveredPoints, (std::vector<std::size_t>{441, 443}));
  EXPECT_EQ(q.uncovered, 2u);
  EXPECT_NEAR(q.uncoveredShare, 2.0 / 444.0, 1e-12);
  const PointCloud out = uncoveredInput(cloud, q);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out.points[1], V(3.0, 0.5, 0.0));
  EXPECT_NE(q.toTable().find("2 points (0.45 %)"), std::string::npos) << q.toTable();
}

// The mesh's area farther than two output spacings from every reference point is unsupported: a square meshed
// whole against points on its left half only leaves the strip beyond x = 0.5 + 2 spacings without input.
TEST(MeshQuality, UnsupportedMeshArea) {
  const TriangleMesh m = gridSquare(10);
  PointCloud half, whole;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 20; ++j) {
      whole.points.emplace_back(i / 20.0, j / 20.0, 0.0);
      if (i <= 10) half.points.emplace_back(i / 20.0, j / 20.0, 0.0);
    }
  MeshQualityParams p;
  p.meshSamples = 20000;
  const MeshQuality q = evaluateMesh(m, &half, p);
  EXPECT_NEAR(q.unsupportedShare, 0.5 - q.uncoveredDistance, 0.02);
  EXPECT_GT(q.unsupportedShare, 0.2);
  EXPECT_NE(q.toJson().find("\"unsupported\""), std::string::npos);
  EXPECT_NE(q.toTable().find("mesh off input"), std::string::npos) << q.toTable();
  EXPECT_EQ(evaluateMesh(m, &whole, p).unsupportedShare, 0.0);
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
  EXPECT_EQ(evaluateMesh(cube(), &cloud, {}, Execution{1}).toJson(),
            evaluateMesh(cube(), &cloud, {}, Execution{2}).toJson());
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
