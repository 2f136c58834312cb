// SPDX-License-Identifier: GPL-3.0-or-later
// Tests of self_intersections.hpp: known pairs on small meshes (a piercing triangle, a fold over a common edge,
// a face through a neighbour's vertex), none on closed convex meshes, degenerate faces apart.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "iires/reconstruct/self_intersections.hpp"
#include "shapes.hpp"

namespace iires {
namespace {

using V = Eigen::Vector3d;
using F = Eigen::Vector3i;
using Pairs = std::vector<std::pair<std::size_t, std::size_t>>;
using test::uvSphereMesh;

TriangleMesh tetrahedron() {
  TriangleMesh m;
  m.vertices = {V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), V(0, 0, 1)};
  m.triangles = {F(0, 2, 1), F(0, 1, 3), F(0, 3, 2), F(1, 2, 3)};
  return m;
}

TEST(SelfIntersections, NoneOnClosedConvexMeshes) {
  EXPECT_TRUE(selfIntersections(tetrahedron()).empty());
  EXPECT_TRUE(selfIntersections(uvSphereMesh(12, 20)).empty());
}

TEST(SelfIntersections, TrianglePiercingOneFace) {
  TriangleMesh m = tetrahedron();
  // Crosses the bottom face (z = 0) and ends inside the tetrahedron: exactly one pair.
  m.vertices.insert(m.vertices.end(), {V(0.2, 0.2, -0.5), V(0.3, 0.2, -0.5), V(0.25, 0.25, 0.1)});
  m.triangles.emplace_back(4, 5, 6);
  EXPECT_EQ(selfIntersections(m), (Pairs{{0, 4}}));
  EXPECT_EQ(selfIntersectingFaces(m), (std::vector<std::size_t>{0, 4}));
}

TEST(SelfIntersections, CommonEdgeFoldedOntoItself) {
  // Two faces on edge 0–1, coplanar, apexes on the same side: they overlap.
  TriangleMesh m;
  m.vertices = {V(0, 0, 0), V(1, 0, 0), V(0.5, 1, 0), V(0.6, 0.5, 0)};
  m.triangles = {F(0, 1, 2), F(1, 0, 3)};
  EXPECT_EQ(selfIntersections(m), (Pairs{{0, 1}}));
  // Apexes on opposite sides (a flat pair): no intersection; out of the plane: none either.
  m.vertices[3] = V(0.6, -0.5, 0);
  EXPECT_TRUE(selfIntersections(m).empty());
  m.vertices[3] = V(0.6, 0.5, 0.01);
  EXPECT_TRUE(selfIntersections(m).empty());
}

TEST(SelfIntersections, CommonVertexWithCrossingEdge) {
  // Faces share vertex 0; the second one's far edge passes through the first triangle.
  TriangleMesh m;
  m.vertices = {V(0, 0, 0), V(2, 0, 0), V(0, 2, 0), V(0.5, 0.5, -1), V(0.5, 0.5, 1)};
  m.triangles = {F(0, 1, 2), F(0, 3, 4)};
  EXPECT_EQ(selfIntersections(m), (Pairs{{0, 1}}));
  // Move the far edge outside the first triangle: they meet in vertex 0 only.
  m.vertices[3] = V(-0.5, -0.5, -1);
  m.vertices[4] = V(-0.5, -0.5, 1);
  EXPECT_TRUE(selfIntersections(m).empty());
}

TEST(SelfIntersections, DuplicateFaceAndDegenerateFace) {
  TriangleMesh m = tetrahedron();
  m.triangles.push_back(m.triangles[3]);  // the same triangle twice
  EXPECT_EQ(selfIntersections(m), (Pairs{{3, 4}}));
  TriangleMesh d = tetrahedron();
  d.vertices.push_back(V(0.5, 0.5, 0));  // on edge 1–2: a collinear face takes part in no pair
  d.triangles.emplace_back(1, 2, 4);
  EXPECT_TRUE(selfIntersections(d).empty());
}

// The grid and the fan shortcut against testing every pair: a sphere whose vertices are pushed in and out at
// random (folds, fans that overlap, faces through neighbours) and two overlapping spheres.
TEST(SelfIntersections, MatchesBruteForceOnCrumpledMeshes) {
  for (double noise : {0.0, 0.02, 0.08, 0.3}) {
    TriangleMesh m = uvSphereMesh(10, 14);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> g(0.0, noise);
    for (auto& v : m.vertices) v += V(g(rng), g(rng), g(rng));
    const TriangleMesh s = uvSphereMesh(6, 8);
    const int off = static_cast<int>(m.vertices.size());
    for (const auto& v : s.vertices) m.vertices.push_back(0.6 * v + V(0.7, 0.1, 0.0));
    for (const auto& t : s.triangles) m.triangles.push_back(t + F(off, off, off));
    const Pairs fast = selfIntersections(m), slow = selfIntersectionsBruteForce(m);
    EXPECT_EQ(fast, slow) << "noise " << noise;
    EXPECT_FALSE(slow.empty());
  }
}

// A few faces much longer than the others (a fill's long faces) are paired outside the grid: long faces across
// a crumpled sphere's box, crossing each other, against testing every pair.
TEST(SelfIntersections, MatchesBruteForceWithAFewLongFaces) {
  TriangleMesh m = uvSphereMesh(16, 24);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 0.02);
  for (auto& v : m.vertices) v += V(g(rng), g(rng), g(rng));
  const std::size_t longFrom = m.triangles.size();
  auto addFace = [&](const V& a, const V& b, const V& c) {
    const int o = static_cast<int>(m.vertices.size());
    m.vertices.insert(m.vertices.end(), {a, b, c});
    m.triangles.emplace_back(o, o + 1, o + 2);
  };
  addFace(V(-1.5, -1.5, -1.5), V(1.5, 1.5, 1.5), V(0.1, 0, 0));
  addFace(V(-1.5, 1.5, -1.5), V(1.5, -1.5, 1.5), V(0, 0.1, 0));
  addFace(V(-1.5, 1.5, 1.5), V(1.5, -1.5, -1.5), V(0, 0, 0.8));
  const Pairs fast = selfIntersections(m), slow = selfIntersectionsBruteForce(m);
  EXPECT_EQ(fast, slow);
  EXPECT_EQ(fast, selfIntersections(m, 2));
  const auto longPairs = std::count_if(slow.begin(), slow.end(), [&](const auto& p) { return p.second >= longFrom; });
  EXPECT_GT(longPairs, 6);  // each long face cuts the sphere twice at least
  EXPECT_TRUE(std::find(slow.begin(), slow.end(), std::pair<std::size_t, std::size_t>{longFrom, longFrom + 1}) !=
              slow.end());
}

TEST(SelfIntersections, SameAnswerForAnyThreadCount) {
  TriangleMesh a = uvSphereMesh(16, 24), b = uvSphereMesh(16, 24);
  const int off = static_cast<int>(a.vertices.size());
  for (const auto& v : b.vertices) a.vertices.push_back(0.7 * v + V(0.5, 0.2, 0.1));
  for (const auto& t : b.triangles) a.triangles.push_back(t + F(off, off, off));
  const Pairs one = selfIntersections(a, 1);
  EXPECT_FALSE(one.empty());  // two spheres cut each other along a closed curve
  EXPECT_EQ(one, selfIntersections(a, 2));
  for (const auto& [f, g] : one) EXPECT_TRUE(f < b.triangles.size() && g >= b.triangles.size());
}

TEST(SelfIntersections, OnlyThePairsOfChangedFaces) {
  TriangleMesh a = uvSphereMesh(16, 24), b = uvSphereMesh(16, 24);
  const std::size_t first = a.triangles.size();
  const int off = static_cast<int>(a.vertices.size());
  for (const auto& v : b.vertices) a.vertices.push_back(0.7 * v + V(0.5, 0.2, 0.1));
  for (const auto& t : b.triangles) a.triangles.push_back(t + F(off, off, off));
  const Pairs all = selfIntersections(a, 1);
  ASSERT_FALSE(all.empty());
  // Every pair holds a face of each sphere; flag every third face of the second one.
  std::vector<char> changed(a.triangles.size(), 0);
  for (std::size_t f = first; f < changed.size(); f += 3) changed[f] = 1;
  Pairs expected;
  for (const auto& [f, g] : all)
    if (changed[f] || changed[g]) expected.emplace_back(f, g);
  ASSERT_FALSE(expected.empty());
  ASSERT_LT(expected.size(), all.size());
  EXPECT_EQ(selfIntersections(a, changed, 1), expected);
  EXPECT_EQ(selfIntersections(a, changed, 2), expected);
  EXPECT_TRUE(selfIntersections(a, std::vector<char>(a.triangles.size(), 0)).empty());
  EXPECT_EQ(selfIntersections(a, std::vector<char>(a.triangles.size(), 1)), all);
  EXPECT_THROW(selfIntersections(a, std::vector<char>(3, 1)), std::invalid_argument);
}

TEST(SelfIntersections, FacesChangedSinceFlagsAddedAndMovedFaces) {
  const TriangleMesh before = uvSphereMesh(8, 12);
  TriangleMesh after = before;
  EXPECT_EQ(facesChangedSince(before, after), std::vector<char>(after.triangles.size(), 0));
  // Reordered corners and faces are the same faces; a moved vertex changes its faces; a new face is changed.
  std::swap(after.triangles[0][1], after.triangles[0][2]);
  std::swap(after.triangles[1], after.triangles[2]);
  after.vertices[5] += V(0.01, 0, 0);
  after.vertices.push_back(V(2, 2, 2));
  after.triangles.emplace_back(0, 1, static_cast<int>(after.vertices.size()) - 1);
  const std::vector<char> changed = facesChangedSince(before, after);
  for (std::size_t f = 0; f < after.triangles.size(); ++f) {
    const auto& t = after.triangles[f];
    const bool expected = f + 1 == after.triangles.size() || t[0] == 5 || t[1] == 5 || t[2] == 5;
    EXPECT_EQ(changed[f] != 0, expected) << "face " << f;
  }
}

}  // namespace
}  // namespace iires
