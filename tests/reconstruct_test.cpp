// SPDX-License-Identifier: GPL-3.0-or-later
// Tests of triangulate.hpp, mesh_repair.hpp, advancing_front.hpp and reconstruct.hpp (+ the CLI).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/reconstruct/advancing_front.hpp"
#include "iires/reconstruct/reconstruct.hpp"
#include "iires/reconstruct/self_intersections.hpp"
#include "iires/sampling.hpp"
#include "mesh_checks.hpp"
#include "shapes.hpp"
#include "test_util.hpp"

namespace iires {
namespace {

using test::expectClosedGenus;
using test::signedVolume;
using test::sphereMesh;

/// Random points on a torus (uniform by area), outward normals.
PointCloud torusCloud(std::size_t n, double major = 1.0, double minor = 0.4, std::uint64_t seed = 5) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud c;
  while (c.size() < n) {
    const double a = 2 * M_PI * u(rng), b = 2 * M_PI * u(rng);
    if (u(rng) * (major + minor) > major + minor * std::cos(b)) continue;  // area weight
    const Eigen::Vector3d centre(major * std::cos(a), major * std::sin(a), 0);
    const Eigen::Vector3d n(std::cos(b) * std::cos(a), std::cos(b) * std::sin(a), std::sin(b));
    c.points.push_back(centre + minor * n);
    c.normals.push_back(n);
  }
  return c;
}

TEST(Triangulate, FibonacciSphereIsClosedWithoutRepair) {
  PointCloud c;
  c.points = test::fibonacciSphere(3000);
  c.normals = c.points;
  const TriangulateResult r = triangulateLocal(c);
  const MeshQuality q = evaluateMesh(r.mesh);
  expectClosedGenus(q, 2);
  EXPECT_GT(q.qualityMean, 0.8);  // the Delaunay triangulation of a Fibonacci spiral is not hexagonal: ≈ 0.83
  EXPECT_GT(signedVolume(r.mesh), 0);  // outward, from the normals
}

TEST(Triangulate, SameMeshForAnyThreadCount) {
  PointCloud c;
  c.points = test::fibonacciSphere(2000);
  c.normals = c.points;
  const auto a = triangulateLocal(c, {}, Execution{1}).mesh, b = triangulateLocal(c, {}, Execution{2}).mesh;
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  for (std::size_t f = 0; f < a.triangles.size(); ++f) EXPECT_EQ(a.triangles[f], b.triangles[f]);
}

TEST(Triangulate, RejectsBadInput) {
  PointCloud two;
  two.points = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)};
  two.normals = {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, 1)};
  EXPECT_THROW(triangulateLocal(two), InputError);
  PointCloud noNormals;
  noNormals.points = test::fibonacciSphere(100);
  EXPECT_THROW(triangulateLocal(noNormals), InputError);
  TriangulateParams bad;
  bad.minVotes = 4;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

TriangleMesh twoSpheres(const Eigen::Vector3d& shift) {
  PointCloud c;
  TriangleMesh m = sphereMesh(c), other = m;
  const int off = static_cast<int>(m.vertices.size());
  for (const auto& v : other.vertices) m.vertices.push_back(v + shift);
  for (const auto& t : other.triangles) m.triangles.push_back(t + Eigen::Vector3i(off, off, off));
  return m;
}

// Validity repair (issue 20): self-intersections removed locally, the holes filled again where the fill does
// not intersect; the result has no self-intersection and is manifold whatever it takes.
TEST(MeshValidity, RemovesSelfIntersectionsOfCrossingSpheres) {
  TriangleMesh m = twoSpheres(Eigen::Vector3d(1.2, 0.3, 0.1));
  const std::size_t before = selfIntersections(m).size();
  ASSERT_GT(before, 20u);  // the spheres cut each other along a circle
  std::vector<Eigen::Vector3d> normals;
  const ValidityReport rep = repairValidity(m, normals);
  EXPECT_EQ(rep.intersectingPairs, before);
  EXPECT_GT(rep.facesRemoved, 0u);
  const MeshQuality q = evaluateMesh(m);
  EXPECT_EQ(q.selfIntersections, 0u);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 0u);
  // Local: far from the other sphere the faces are all still there (a sphere has ~6,000 faces).
  EXPECT_GT(q.faces, 8000u);
}

// The refill after a removal looks at the loops the removal opened (and, when asked, those the large-hole fill
// kept unlooked-at), not at every loop of the mesh again: a cut sphere far from two crossing ones keeps its cap
// open unless its loop is named.
TEST(MeshValidity, RefillLooksOnlyAtTheLoopsItOpened) {
  TriangleMesh m = twoSpheres(Eigen::Vector3d(1.2, 0.3, 0.1));
  PointCloud c;
  const TriangleMesh sphere = sphereMesh(c);
  const TriangleMesh cut =
      test::withoutFaces(sphere, [&](const Eigen::Vector3i& t) { return test::hasCornerBelow(sphere, t, -0.8); });
  const int off = static_cast<int>(m.vertices.size());
  for (const auto& v : cut.vertices) m.vertices.push_back(v + Eigen::Vector3d(10, 0, 0));
  for (const auto& t : cut.triangles) m.triangles.push_back(t + Eigen::Vector3i(off, off, off));
  ASSERT_EQ(evaluateMesh(m).boundaryLoops, 1u);
  std::vector<std::uint32_t> capLoop;  // the cut sphere's vertices below the cut's rim
  for (std::size_t v = 0; v < cut.vertices.size(); ++v)
    if (cut.vertices[v].z() < -0.7) capLoop.push_back(static_cast<std::uint32_t>(off + static_cast<int>(v)));
  auto loopsAfter = [&](bool onlyOpened, const std::vector<std::uint32_t>& unseen) {
    TriangleMesh r = m;
    std::vector<Eigen::Vector3d> normals;
    ValidityParams vp;
    vp.onlyOpenedLoops = onlyOpened;
    vp.unseenLoops = unseen;
    const ValidityReport rep = repairValidity(r, normals, vp);
    EXPECT_GT(rep.rounds, 0u);
    EXPECT_EQ(evaluateMesh(r).selfIntersections, 0u);
    TriangleMesh far;  // the cut sphere's part of the result
    far.vertices = r.vertices;
    for (const auto& t : r.triangles)
      if (t.minCoeff() >= off) far.triangles.push_back(t);
    return evaluateMesh(far).boundaryLoops;
  };
  EXPECT_EQ(loopsAfter(false, {}), 0u);
  EXPECT_EQ(loopsAfter(true, {}), 1u);
  EXPECT_EQ(loopsAfter(true, capLoop), 0u);
}

TEST(MeshValidity, SplitsNonManifoldEdgesAndVertices) {
  PointCloud c;
  TriangleMesh m = sphereMesh(c);
  const std::size_t faces = m.triangles.size();
  // A third face on an edge (pointing inward), and a fan touching the sphere at one vertex only.
  const Eigen::Vector3i t = m.triangles[0];
  m.vertices.push_back(0.5 * (m.vertices[t[0]] + m.vertices[t[1]]));
  m.triangles.emplace_back(t[0], t[1], static_cast<int>(m.vertices.size()) - 1);
  const int apex = t[2], base = static_cast<int>(m.vertices.size());
  for (int k = 0; k < 3; ++k)
    m.vertices.push_back(m.vertices[apex] * 1.5 + Eigen::Vector3d(0.1 * std::cos(2 * M_PI * k / 3), 0.1 * std::sin(2 * M_PI * k / 3), 0));
  m.triangles.emplace_back(apex, base, base + 1);
  m.triangles.emplace_back(apex, base + 1, base + 2);
  const MeshQuality bad = evaluateMesh(m);
  ASSERT_EQ(bad.nonManifoldEdges, 1u);
  ASSERT_GE(bad.nonManifoldVertices, 1u);
  std::vector<Eigen::Vector3d> normals;
  const ValidityReport rep = repairValidity(m, normals);
  EXPECT_EQ(rep.nonManifoldEdges, 1u);
  const MeshQuality q = evaluateMesh(m);
  EXPECT_TRUE(q.manifold);
  EXPECT_TRUE(q.closed);
  EXPECT_EQ(q.faces, faces);  // exactly the added faces went
  EXPECT_EQ(q.selfIntersections, 0u);
}

TEST(MeshValidity, ValidMeshIsUnchanged) {
  PointCloud c;
  TriangleMesh m = sphereMesh(c);
  const TriangleMesh copy = m;
  std::vector<Eigen::Vector3d> normals;
  EXPECT_FALSE(repairValidity(m, normals).changed());
  EXPECT_EQ(m.triangles, copy.triangles);
}

// A noisy scan of a sphere (radial noise of 0.05, about 0.7 mesh spacings at N = 3,000): the small-hole fill
// closes some loops through the neighbouring sheet. Found on CGAL's sphere_20k (σ ≈ 0.04); the repair removes
// those faces with a ring and fills again: closed, genus 0, no self-intersection. (The seed is one whose mesh
// needs the repair: with the sheet rule's neighbourhoods seed 2 no longer does.)
TEST(Reconstruct, NoisySphereHasNoSelfIntersections) {
  std::mt19937_64 rng(0);
  std::normal_distribution<double> g(0.0, 1.0);
  PointCloud noisy;
  // Radial noise of σ = 8 % of the radius: the denoising leaves enough of it that the triangulation
  // makes crossing faces somewhere (20–28 pairs on seeds 0–2; at 7 % some seeds have none), which the repair
  // removes.
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    noisy.points.push_back((1.0 + 0.08 * g(rng)) * d);
  }
  ReconstructParams p;
  p.targetCount = 5000;
  const ReconstructResult r = reconstruct(noisy, p, Execution{2});
  EXPECT_GT(r.validity.intersectingPairs, 0u) << "the case no longer needs the repair";
  EXPECT_EQ(r.quality.selfIntersections, 0u);
  expectClosedGenus(r.quality, 2);
  EXPECT_EQ(r.quality.genus, 0);
  EXPECT_TRUE(r.quality.valid());
  EXPECT_NE(r.toJson().find("\"validity_repair\": {\"intersecting_pairs_found\": "), std::string::npos);
}

TEST(Reconstruct, SphereCloudClosedGenus0) {
  ReconstructParams p;
  p.targetCount = 2000;
  const ReconstructResult r = reconstruct(test::sphereCloud(20000), p);
  ASSERT_NE(r.resampling.geodesic, nullptr);  // default: the resampler's intrinsic rule
  expectClosedGenus(r.quality, 2);
  EXPECT_GT(signedVolume(r.mesh), 0);
  EXPECT_GE(r.quality.qualityMean, 0.88);
  EXPECT_GE(r.quality.qualityMin, 0.4);
  // Distance to the true sphere: vertices on it, face centroids within the chord sagitta (the distance to the
  // random input cloud mostly measures that cloud's own gaps).
  for (const auto& v : r.mesh.vertices) EXPECT_NEAR(v.norm(), 1.0, 5e-3);
  for (const auto& t : r.mesh.triangles)
    EXPECT_GT(((r.mesh.vertices[t[0]] + r.mesh.vertices[t[1]] + r.mesh.vertices[t[2]]) / 3.0).norm(), 0.99);
  EXPECT_EQ(r.samples.size(), 2000u);
  EXPECT_NE(r.toJson().find("\"method\": \"local\""), std::string::npos);
}

// Every point given twice a hair apart (a scan exported twice, rounded differently), triangulated as it is: the
// twins are merged first. Before, every triangle between twins was degenerate and nothing was written ("the
// reconstruction produced no triangles").
TEST(Reconstruct, PointsGivenTwiceAHairApartAreMeshedAsOnce) {
  PointCloud cloud = test::sphereCloud(3000, 1.0, 9);
  cloud.normals.clear();
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1e-9, 1e-9);
  for (std::size_t i = 0; i < 3000; ++i)
    cloud.points.push_back(cloud.points[i] + Eigen::Vector3d(u(rng), u(rng), u(rng)));
  ReconstructParams asIs;
  asIs.resample = false;
  const ReconstructResult r = reconstruct(cloud, asIs);
  EXPECT_GE(r.nearDuplicatesMerged, 3000u);
  EXPECT_LE(r.samples.size(), 3000u);
  expectClosedGenus(r.quality, 2);
}

// A lidar's scan lines (positions only: 0.02 apart, points 0.002 apart along them) meshed at an edge length about
// the lines' distance: one piece of well-shaped triangles. With every stage's neighbours on one line the normals
// came out oriented line by line (two pieces) and the samples uneven (Q_avg 0.84).
TEST(Reconstruct, ScanLinesMeshedInOnePiece) {
  ReconstructParams p;
  p.targetCount = 5000;
  const ReconstructResult r = reconstruct(test::scanLineCloud(6), p);
  EXPECT_EQ(r.quality.components, 1u);
  EXPECT_GE(r.quality.qualityMean, 0.90);
  EXPECT_GE(r.quality.qualityMin, 0.4);
}

TEST(Reconstruct, TorusCloudClosedGenus1) {
  ReconstructParams p;
  p.targetCount = 3000;
  const ReconstructResult r = reconstruct(torusCloud(30000), p);
  ASSERT_NE(r.resampling.geodesic, nullptr);  // default: the intrinsic rule
  expectClosedGenus(r.quality, 0);
  EXPECT_EQ(r.quality.genus, 1);
  EXPECT_GE(r.quality.qualityMean, 0.88);
}

// A polyhedron with creases sharper than 90° (the triangular ring: 41° rims, normals 139° apart; 300° hole edges,
// 120° apart) sampled without normals, uniform and with a 4× density gradient: a closed mesh of genus 1 without
// self-intersections. The normals estimated for the samples come out turned over past such creases, and a 1-ring
// there used to see the far face folded back over its own: open strips along the creases, genus 9 and more.
TEST(Reconstruct, SharpCreasesClosedWithTheirGenus) {
  for (double ratio : {1.0, 4.0}) {
    MeshSamplingParams sp;
    sp.count = 20000;
    sp.densityRatio = ratio;
    sp.seed = 1;
    PointCloud cloud = sampleMesh(test::triangularRing(), sp);
    cloud.normals.clear();
    ReconstructParams p;
    p.targetCount = 2000;
    const ReconstructResult r = reconstruct(cloud, p);
    SCOPED_TRACE(ratio);
    expectClosedGenus(r.quality, 0);
    EXPECT_EQ(r.quality.genus, 1);
    EXPECT_EQ(r.quality.selfIntersections, 0u);
    EXPECT_GT(signedVolume(r.mesh), 0);
    EXPECT_GE(r.quality.qualityMin, 0.4);
  }
}

// The local triangulation alone, on blue-noise points of the triangular ring with exact per-face normals, the
// hole's faces turned inward (as a propagation over the normals' dot product leaves them past a crease sharper
// than 90°): the normals are turned back out, and the faces spanning the creases are proposed and kept — the
// 1-rings unfold the far face about the crease line instead of folding it back over their own.
TEST(Triangulate, LinksAcrossSharpCreases) {
  MeshSamplingParams sp;
  sp.count = 40000;
  sp.seed = 2;
  const PointCloud dense = sampleMesh(test::triangularRing(), sp);
  PointCloud truth;  // the dense points thinned to at least 0.04 apart, in order (blue noise, as resampled)
  for (std::size_t i = 0; i < dense.size(); ++i)
    if (std::none_of(truth.points.begin(), truth.points.end(),
                     [&](const Eigen::Vector3d& q) { return (q - dense.points[i]).squaredNorm() < 0.04 * 0.04; }))
      truth.points.push_back(dense.points[i]), truth.normals.push_back(dense.normals[i]);
  PointCloud cloud = truth;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.points[i].head<2>().norm() < 0.45 && cloud.normals[i].head<2>().norm() > 0.99)
      cloud.normals[i] = -cloud.normals[i];
  const TriangulateResult r = triangulateLocal(cloud);
  ASSERT_EQ(r.normals.size(), cloud.size());
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) wrong += r.normals[i].dot(truth.normals[i]) < 0;
  EXPECT_LE(wrong, cloud.size() / 1000) << "normals left turned over";
  const MeshQuality q = evaluateMesh(r.mesh, nullptr);
  // Measured: 78 boundary edges of 1,721 points, all within 4 spacings of the corners where three creases meet
  // (before the crease rules:
  // 215 with the normals all outward, 319 with the hole's turned over).
  EXPECT_LT(q.boundaryEdges, cloud.size() / 12) << "open strips along the creases (" << cloud.size() << " points)";
  EXPECT_EQ(r.mesh.triangles, triangulateLocal(truth).mesh.triangles) << "the same mesh as from outward normals";
  EXPECT_EQ(q.nonManifoldEdges, 0u);
}

TEST(Reconstruct, CroppedSphereKeepsItsBoundary) {
  PointCloud full = test::sphereCloud(20000), cropped;
  for (std::size_t i = 0; i < full.size(); ++i)
    if (full.points[i].z() < 0.5) cropped.points.push_back(full.points[i]), cropped.normals.push_back(full.normals[i]);
  ReconstructParams p;
  p.targetCount = 2000;
  const ReconstructResult r = reconstruct(cropped, p);
  EXPECT_FALSE(r.quality.closed);
  EXPECT_EQ(r.quality.boundaryLoops, 1u);
  EXPECT_GT(r.quality.boundaryEdges, 30u);  // the rim: circumference 2π·0.87 over an edge of ≈ 0.07
  EXPECT_EQ(r.quality.nonManifoldEdges, 0u);
  EXPECT_TRUE(r.quality.oriented);
  EXPECT_EQ(r.quality.euler, 1);  // a disc
  // The vertices are relaxed: better triangles, the rim itself where it was.
  EXPECT_GT(r.verticesRelaxed, 50u);
  ReconstructParams off = p;
  off.relaxSweeps = 0;
  const ReconstructResult o = reconstruct(cropped, off);
  EXPECT_EQ(o.verticesRelaxed, 0u);
  EXPECT_GT(r.quality.qualityMean, o.quality.qualityMean);
  EXPECT_GE(r.quality.qualityMin, o.quality.qualityMin);
  EXPECT_EQ(r.quality.boundaryEdges, o.quality.boundaryEdges);
  EXPECT_EQ(r.quality.selfIntersections, 0u);
}

TEST(Reconstruct, AdvancingFrontOnSphere) {
  ReconstructParams p;
  p.targetCount = 2000;
  p.method = ReconstructMethod::kAdvancingFront;
  const ReconstructResult r = reconstruct(test::sphereCloud(20000), p);
  EXPECT_EQ(r.method, "advancing-front");
  EXPECT_GT(r.mesh.triangles.size(), 3800u);
  EXPECT_TRUE(r.quality.oriented);
  EXPECT_GT(signedVolume(r.mesh), 0);
  EXPECT_LT(r.quality.distance.relativeHausdorff(), 0.02);
  // CGAL lists the facets in the order of its cells' addresses, which change with the heap (the output's file
  // name alone changed the bytes written): they come out in one order, each from its lowest vertex, sorted.
  const AdvancingFrontResult af = advancingFront(test::sphereCloud(3000, 1.0, 4));
  ASSERT_GT(af.mesh.triangles.size(), 5000u);
  for (const auto& t : af.mesh.triangles) EXPECT_TRUE(t[0] < t[1] && t[0] < t[2]) << t.transpose();
  EXPECT_TRUE(std::is_sorted(af.mesh.triangles.begin(), af.mesh.triangles.end(),
                             [](const Eigen::Vector3i& a, const Eigen::Vector3i& b) {
                               return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
                             }));
}

TEST(Reconstruct, DegenerateInputIsAnInputError) {
  PointCloud line;
  for (int i = 0; i < 100; ++i) line.points.emplace_back(i, 2.0 * i, -i);
  EXPECT_THROW(reconstruct(line), InputError);
  PointCloud few;
  few.points = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0)};
  EXPECT_THROW(reconstruct(few), InputError);
  EXPECT_THROW(reconstruct(PointCloud{}), InputError);
  PointCloud solid;  // points filling a cube: no surface, with or without resampling
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 5000; ++i) solid.points.emplace_back(u(rng), u(rng), u(rng));
  ReconstructParams asIs;
  asIs.resample = false;
  EXPECT_THROW(reconstruct(solid), InputError);
  EXPECT_THROW(reconstruct(solid, asIs), InputError);
  ReconstructParams p;
  p.targetCount = 2;
  EXPECT_THROW(reconstruct(test::sphereCloud(100), p), std::invalid_argument);
  EXPECT_THROW(parseReconstructMethod("poisson"), std::invalid_argument);
}

TEST(Reconstruct, SameMeshForAnyThreadCount) {
  ReconstructParams p1, p2;
  p1.targetCount = p2.targetCount = 1000;
  p1.evaluate = p2.evaluate = false;
  const PointCloud c = test::sphereCloud(8000);
  const auto a = reconstruct(c, p1, Execution{1}).mesh, b = reconstruct(c, p2, Execution{2}).mesh;
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  EXPECT_EQ(a.vertices, b.vertices);
  for (std::size_t f = 0; f < a.triangles.size(); ++f) EXPECT_EQ(a.triangles[f], b.triangles[f]);
}

// 3torus's planar faces meet in narrow wedges: its local triangulation leaves loops of 124-240 edges along them.
// Refined, faired fills spanned the empty space across the wedges (2,719 of 23,937 faces more than 2 edge lengths
// from the input, 713 self-intersecting pairs); such fills are undone now (the input goes on beyond the loops),
// so every face lies on the input. CGAL's hole search in a 3-D Delaunay triangulation filled them differently
// from run to run on two threads (4 of 10 runs differed from the one-thread mesh); each run must give the
// one-thread mesh.
TEST(ReconstructRealData, LargeHolesFilledTheSameForAnyThreadCount) {
  const TriangleMesh truth = readMesh(test::dataPath("meshes/3torus.off"));
  MeshSamplingParams sp;
  sp.count = 200000;
  sp.seed = 1;
  const std::string path = test::tempDir() + "/3torus.xyz";  // as iires-sample-mesh writes it for the CLI
  writePointCloud(path, sampleMesh(truth, sp));
  // Four holes cut into the input, each a disc of radius 0.15 (about 3 spacings of the mesh: loops too long for
  // fillSmallHoles).
  const PointCloud read = readPointCloud(path);
  const std::vector<Eigen::Vector3d> cuts = {read.points[1000], read.points[60000], read.points[120000],
                                             read.points[180000]};
  constexpr double kCut = 0.15;
  auto inCut = [&](const Eigen::Vector3d& q, double margin) {
    return std::any_of(cuts.begin(), cuts.end(), [&](const Eigen::Vector3d& x) { return (q - x).norm() < kCut + margin; });
  };
  PointCloud c;
  for (const Eigen::Vector3d& q : read.points)
    if (!inCut(q, 0)) c.points.push_back(q);
  ReconstructParams p;
  p.targetCount = 10000;
  p.evaluate = false;
  const ReconstructResult one = reconstruct(c, p, Execution{1});
  ASSERT_GE(one.largeHoles.filled, 2u);  // measured: 3
  // No face farther than 2 mean edge lengths from the input outside the cuts.
  double edges = 0;
  for (const auto& t : one.mesh.triangles)
    for (int k = 0; k < 3; ++k) edges += (one.mesh.vertices[t[k]] - one.mesh.vertices[t[(k + 1) % 3]]).norm();
  const double l = edges / static_cast<double>(3 * one.mesh.triangles.size());
  const KnnIndex input(c.points);
  std::size_t far = 0;
  for (const auto& t : one.mesh.triangles) {
    double sq = 0;
    const Eigen::Vector3d centroid = (one.mesh.vertices[t[0]] + one.mesh.vertices[t[1]] + one.mesh.vertices[t[2]]) / 3;
    input.nearest(centroid, &sq);
    far += sq > 4 * l * l && !inCut(centroid, l);
  }
  EXPECT_EQ(far, 0u);
  for (int run = 0; run < 3; ++run) {
    const TriangleMesh two = reconstruct(c, p, Execution{2}).mesh;
    ASSERT_EQ(one.mesh.vertices, two.vertices) << "run " << run;
    ASSERT_EQ(one.mesh.triangles, two.triangles) << "run " << run;
  }
}

// 3torus sampled with a 4x density gradient, meshed at 30k: a C⁰-faired fill of a loop round one of its creases
// folded, and the remeshed patch kept 72 triangles under Q 0.4 (worst 0.06) and split off a closed bubble of 54
// faces. Such a patch is made again without fairing and the better one kept: one part, no such triangle.
TEST(ReconstructRealData, LargeHolePatchesRoundACreaseKeepTheirShape) {
  const TriangleMesh truth = readMesh(test::dataPath("meshes/3torus.off"));
  MeshSamplingParams sp;
  sp.count = 200000;
  sp.densityRatio = 4;
  sp.seed = 1;
  const std::string path = test::tempDir() + "/3torus_gradient.xyz";  // as iires-sample-mesh writes it for the CLI
  writePointCloud(path, sampleMesh(truth, sp));
  ReconstructParams p;
  p.targetCount = 30000;
  const ReconstructResult r = reconstruct(readPointCloud(path), p);
  ASSERT_GT(r.largeHoles.filled, 10u);  // measured: 20
  EXPECT_EQ(r.quality.components, 1u);
  EXPECT_TRUE(r.quality.closed);
  EXPECT_EQ(r.quality.genus, 3);
  EXPECT_GT(r.quality.qualityMin, 0.3);  // measured 0.404
}

// Real data (issue 7 acceptance): a dense sampling of fandisk (sharp creases and corners) at N = 10k.
TEST(ReconstructRealData, Fandisk10k) {
  const TriangleMesh truth = readMesh(test::dataPath("meshes/fandisk.off"));
  MeshSamplingParams sp;
  sp.count = 100000;
  sp.seed = 3;
  ReconstructParams p;
  p.targetCount = 10000;
  const ReconstructResult r = reconstruct(sampleMesh(truth, sp), p);
  const MeshQuality& q = r.quality;
  expectClosedGenus(q, 2);
  EXPECT_GE(q.qualityMean, 0.90);  // issue 7's bound (0.9045 measured; the creases are not what lowers it)
  EXPECT_GE(q.qualityMin, 0.4);
  EXPECT_LT(q.shareBelow30, 0.01);
  const SurfaceDistance d = surfaceDistance(r.mesh, truth);
  EXPECT_LE(d.relativeHausdorff(), 0.01);
}

// A sparse, uneven scan (issue 7): the 1,197 vertices of CGAL's hand mesh upsampled to 10k and meshed end to end.
// The wrist cap is 11 large faces with no vertex inside, so the cloud has a 0.5-wide gap there (a 90-edge loop
// after the local triangulation); fillLargeHoles() closes it (and the loop where two fingers are bridged) with new
// vertices: closed, one manifold, oriented component, Q_avg ≥ 0.90 (0.904 measured), Hausdorff to the true mesh
// 3.4 % of the diagonal (13.0 % with the cap open). Q_min is 0.412 here after remeshBadRegions (0.278 without; not
// asserted: 0.26 at N = 20k, between the bridged fingers).
// NOT yet met (see BENCHMARKS.md): genus 0 (the bridge: Euler 0) and Hausdorff ≤ 1 % — the resampler puts samples
// up to 0.044 below the lowest input point (z = -0.5) at the open wrist: mesh → truth 3.4 %.
TEST(ReconstructRealData, SparseHandVerticesTo10k) {
  const TriangleMesh truth = readMesh(test::dataPath("meshes/hand.off"));
  PointCloud input;
  input.points = truth.vertices;
  ReconstructParams p;
  p.targetCount = 10000;
  const ReconstructResult r = reconstruct(input, p);
  const MeshQuality& q = r.quality;
  EXPECT_EQ(r.samples.size(), 10000u);
  EXPECT_GE(r.largeHoles.filled, 1u);
  EXPECT_GE(r.largeHoles.verticesAdded, 300u);  // the cap: area ≈ 0.12 at a spacing of ≈ 0.017 (587 measured)
  EXPECT_EQ(q.boundaryEdges, 0u);
  EXPECT_TRUE(q.closed);
  EXPECT_EQ(q.components, 1u);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 0u);
  EXPECT_TRUE(q.oriented);
  EXPECT_GE(q.qualityMean, 0.90);
  EXPECT_LT(q.shareBelow30, 0.01);
  // Every input vertex is near the mesh (the worst, 2.7 % of the diagonal, is on the wrist cap's rim).
  EXPECT_LT(q.distance.backwardMax / q.distance.diagonal, 0.04);
  // The true mesh's cap is covered now: the Hausdorff distance is the MLS bulge past the rim, not the gap.
  const SurfaceDistance d = surfaceDistance(r.mesh, truth);
  EXPECT_LT(d.relativeHausdorff(), 0.04);
}

// An open scan (issue 7): bunny00's samples above a plane removed. The mesh keeps the cut as one boundary loop
// that runs all the way round the cut, and no face reaches across it (above the plane).
TEST(ReconstructRealData, CroppedBunnyKeepsTheCut) {
  const TriangleMesh truth = readMesh(test::dataPath("meshes/bunny00.off"));
  MeshSamplingParams sp;
  sp.count = 60000;
  sp.seed = 3;
  const PointCloud full = sampleMesh(truth, sp);
  double zMin = full.points[0].z(), zMax = zMin;
  for (const auto& p : full.points) zMin = std::min(zMin, p.z()), zMax = std::max(zMax, p.z());
  const double zCut = zMin + 0.6 * (zMax - zMin);
  PointCloud cropped;
  for (const auto& p : full.points)
    if (p.z() <= zCut) cropped.points.push_back(p);  // no normals: a scan
  ReconstructParams p;
  p.targetCount = 4000;
  const ReconstructResult r = reconstruct(cropped, p);
  const MeshQuality& q = r.quality;
  EXPECT_EQ(q.boundaryLoops, 1u);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 0u);
  EXPECT_TRUE(q.oriented);
  EXPECT_EQ(q.components, 1u);
  EXPECT_GE(q.qualityMean, 0.88);
  const double l = q.meanEdgeLength;
  // No face across the cut: nothing above the plane, beyond the resampler's projection error.
  double top = -1e300;
  for (const auto& v : r.mesh.vertices) top = std::max(top, v.z());
  EXPECT_LE(top, zCut + 0.5 * l);
  // The boundary runs along the cut (every boundary vertex within ~1.5 edges of the plane) and all the way round:
  // its extent in the plane matches the cross-section of the true mesh's samples just below the cut.
  std::map<std::pair<int, int>, int> edgeUse;
  for (const auto& t : r.mesh.triangles)
    for (int k = 0; k < 3; ++k) ++edgeUse[std::minmax(t[k], t[(k + 1) % 3])];
  Eigen::Vector2d bMin(1e300, 1e300), bMax(-1e300, -1e300), cMin = bMin, cMax = bMax;
  std::size_t boundaryEdges = 0;
  double farthest = 0;  // from the plane, over boundary vertices
  for (const auto& [e, uses] : edgeUse) {
    if (uses != 1) continue;
    ++boundaryEdges;
    for (int v : {e.first, e.second}) {
      const Eigen::Vector3d& x = r.mesh.vertices[static_cast<std::size_t>(v)];
      farthest = std::max(farthest, std::abs(x.z() - zCut));
      bMin = bMin.cwiseMin(x.head<2>());
      bMax = bMax.cwiseMax(x.head<2>());
    }
  }
  for (const auto& x : cropped.points)
    if (x.z() > zCut - l) cMin = cMin.cwiseMin(x.head<2>()), cMax = cMax.cwiseMax(x.head<2>());
  EXPECT_GT(boundaryEdges, 20u);
  EXPECT_LT(farthest, 1.5 * l);
  for (int a = 0; a < 2; ++a) {
    EXPECT_GT(bMax[a] - bMin[a], 0.85 * (cMax[a] - cMin[a])) << "axis " << a;
    EXPECT_LT(bMax[a] - bMin[a], 1.05 * (cMax[a] - cMin[a])) << "axis " << a;
  }
}

// The CLI: exit codes, outputs, --quality-only.
class ReconstructCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::tempDir();
    cloud_ = dir_ + "/sphere.ply";
    writePointCloud(cloud_, test::sphereCloud(5000));
  }
  std::string dir_, cloud_;
};

TEST_F(ReconstructCli, WritesMeshAndReport) {
  const std::string mesh = dir_ + "/mesh.off", report = dir_ + "/report.json";
  std::string out;
  ASSERT_EQ(test::run(test::tool("iires-reconstruct") + " " + cloud_ + " " + mesh + " -n 800 --report " + report,
                      &out),
            0)
      << out;
  EXPECT_NE(out.find("triangle quality"), std::string::npos) << out;
  const TriangleMesh m = readMesh(mesh);
  EXPECT_EQ(m.vertices.size(), 800u);
  EXPECT_NE(test::readText(report).find("\"closed\": true"), std::string::npos);
  // Report on the mesh just written.
  ASSERT_EQ(test::run(test::tool("iires-reconstruct") + " " + cloud_ + " --quality-only " + mesh, &out), 0) << out;
  EXPECT_NE(out.find("Hausdorff"), std::string::npos) << out;
}

// Progress on stderr (issue 9): forced with --progress it names the resampling AND the meshing stages; -q silences
// it (and the report) even with --progress; stderr is a pipe here, so without --progress nothing is shown.
TEST_F(ReconstructCli, ProgressNamesStagesAndQuietSilencesIt) {
  const std::string t = test::tool("iires-reconstruct");
  std::string out;
  ASSERT_EQ(test::run("(" + t + " " + cloud_ + " " + dir_ + "/a.off -n 500 --progress 2>&1 >/dev/null)", &out), 0)
      << out;
  for (const char* stage : {"iires-reconstruct: read", "normals", "resample", "triangulate", "holes", "orient",
                            "quality", "write", "100%"})
    EXPECT_NE(out.find(stage), std::string::npos) << "no \"" << stage << "\" in:\n" << out;
  ASSERT_EQ(test::run("(" + t + " " + cloud_ + " " + dir_ + "/b.off -n 500 2>&1 >/dev/null)", &out), 0) << out;
  EXPECT_EQ(out, "");
  ASSERT_EQ(test::run(t + " " + cloud_ + " " + dir_ + "/c.off -n 500 --progress -q", &out), 0) << out;
  EXPECT_EQ(out, "");
  // Progress does not change the mesh.
  EXPECT_EQ(test::readText(dir_ + "/a.off"), test::readText(dir_ + "/c.off"));
}

// --quality-only on meshes with known defects reports them exactly (issue 20).
TEST_F(ReconstructCli, QualityOnlyReportsSelfIntersectionAndPinchedVertex) {
  using V = Eigen::Vector3d;
  TriangleMesh tet;
  tet.vertices = {V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), V(0, 0, 1)};
  tet.triangles = {Eigen::Vector3i(0, 2, 1), Eigen::Vector3i(0, 1, 3), Eigen::Vector3i(0, 3, 2), Eigen::Vector3i(1, 2, 3)};
  TriangleMesh pierced = tet;  // a triangle through the bottom face, ending inside: one pair
  pierced.vertices.insert(pierced.vertices.end(), {V(0.2, 0.2, -0.5), V(0.3, 0.2, -0.5), V(0.25, 0.25, 0.1)});
  pierced.triangles.emplace_back(4, 5, 6);
  TriangleMesh pinched = tet;  // a second tetrahedron sharing vertex 0 only
  for (int i = 1; i < 4; ++i) pinched.vertices.push_back(-tet.vertices[static_cast<std::size_t>(i)]);
  for (const auto& t : tet.triangles) {
    Eigen::Vector3i u = t;
    for (int c = 0; c < 3; ++c) u[c] = u[c] == 0 ? 0 : u[c] + 3;
    pinched.triangles.push_back(u);
  }
  writeMesh(dir_ + "/pierced.off", pierced);
  writeMesh(dir_ + "/pinched.off", pinched);
  const std::string t = test::tool("iires-reconstruct");
  std::string out;
  ASSERT_EQ(test::run(t + " " + cloud_ + " --quality-only " + dir_ + "/pierced.off --report " + dir_ + "/p.json", &out), 0);
  EXPECT_NE(out.find("self-intersecting face pairs  1\n"), std::string::npos) << out;
  EXPECT_NE(test::readText(dir_ + "/p.json").find("\"self_intersecting_face_pairs\": 1,"), std::string::npos);
  ASSERT_EQ(test::run(t + " " + cloud_ + " --quality-only " + dir_ + "/pinched.off", &out), 0);
  EXPECT_NE(out.find("non-manifold edges / vertices 0 / 1\n"), std::string::npos) << out;
  EXPECT_NE(out.find("closed / manifold / oriented  yes / no /"), std::string::npos) << out;
  EXPECT_NE(out.find("non-manifold, 8 faces"), std::string::npos) << out;
  EXPECT_EQ(out.find("genus -"), std::string::npos) << out;
  EXPECT_NE(out.find("self-intersecting face pairs  0\n"), std::string::npos) << out;
}

// The input the mesh does not cover is counted and, with --uncovered, written out.
TEST_F(ReconstructCli, UncoveredInputIsReportedAndWritten) {
  PointCloud c = test::sphereCloud(5000);
  for (int i = 0; i < 7; ++i) c.points.emplace_back(3.0 + 0.01 * i, 0, 0), c.normals.emplace_back(1, 0, 0);
  const std::string in = dir_ + "/with_far.ply", unc = dir_ + "/unc.ply";
  writePointCloud(in, c);
  std::string out;
  ASSERT_EQ(test::run(test::tool("iires-reconstruct") + " " + in + " " + dir_ + "/m.off -n 800 --uncovered " + unc, &out), 0)
      << out;
  const PointCloud u = readPointCloud(unc);
  ASSERT_GE(u.size(), 7u);  // the 7 far points (the resampler drops them as outliers or the mesh misses them)
  std::size_t far = 0;
  for (const auto& x : u.points) far += x.x() > 2.9 ? 1 : 0;
  EXPECT_EQ(far, 7u);
  EXPECT_NE(out.find("uncovered input"), std::string::npos) << out;
  EXPECT_EQ(test::run(test::tool("iires-reconstruct") + " " + in + " " + dir_ + "/m2.off -n 800 --uncovered " + dir_ +
                      "/unc.off"),
            2);  // a point cloud format is needed
}

// Samples the mesh leaves out (far points no triangle reaches) are counted in the text report, as in the JSON.
TEST_F(ReconstructCli, SamplesLeftOutAreReported) {
  PointCloud c = test::sphereCloud(2000);
  for (int i = 0; i < 7; ++i) c.points.emplace_back(3.0 + 0.01 * i, 0, 0), c.normals.emplace_back(1, 0, 0);
  const std::string in = dir_ + "/far_row.ply", report = dir_ + "/far_row.json";
  writePointCloud(in, c);
  std::string out;
  ASSERT_EQ(test::run(test::tool("iires-reconstruct") + " " + in + " " + dir_ + "/m.off --no-resample --report " +
                          report, &out), 0) << out;
  const std::string json = test::readText(report);
  const auto at = json.find("\"unused_samples\": ");
  ASSERT_NE(at, std::string::npos) << json;
  const long unused = std::stol(json.substr(at + 17));
  EXPECT_GE(unused, 7);
  EXPECT_NE(out.find("left out of the mesh          " + std::to_string(unused) + " samples in no triangle"),
            std::string::npos) << out;
}

TEST_F(ReconstructCli, ExitCodes) {
  const std::string t = test::tool("iires-reconstruct");
  EXPECT_EQ(test::run(t + " " + dir_ + "/missing.ply " + dir_ + "/m.ply"), 2);
  EXPECT_EQ(test::run(t + " " + cloud_ + " " + dir_ + "/m.ply -n 2"), 2);
  EXPECT_EQ(test::run(t + " " + cloud_ + " " + dir_ + "/m.xyz"), 2);
  EXPECT_EQ(test::run(t + " " + cloud_ + " " + dir_ + "/m.ply --method poisson"), 2);
  EXPECT_EQ(test::run(t + " " + cloud_), 2);  // no OUTPUT_MESH
  EXPECT_EQ(test::run(t + " " + cloud_ + " --quality-only " + dir_ + "/missing.off"), 2);
  EXPECT_FALSE(test::fileExists(dir_ + "/m.ply"));
  EXPECT_EQ(test::run(t + " --version"), 0);
}

}  // namespace
}  // namespace iires
