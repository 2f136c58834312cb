// SPDX-License-Identifier: GPL-3.0-or-later
// Tests for intrinsic.hpp: the intrinsic neighbour rule alone and inside the resampler (issue 3 acceptance).
#include "iires/intrinsic.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <queue>
#include <random>
#include <set>

#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/resample.hpp"
#include "iires/sampling.hpp"
#include "iires/sheets.hpp"
#include "shapes.hpp"
#include "test_util.hpp"

namespace iires {
namespace {

using test::uStrip;

/// Distance from @p p to the U-strip with gap 0.02 (squares [0,1]², fold radius 0.01 at x = 1).
double stripDistance(const Eigen::Vector3d& p, double gap = 0.02) {
  const double r = gap / 2;
  auto clamp01 = [](double v) { return std::clamp(v, 0.0, 1.0); };
  const double dy = p.y() - clamp01(p.y());
  double best = 1e9;
  for (double z : {0.0, gap}) {
    const double dx = p.x() - clamp01(p.x());
    best = std::min(best, std::sqrt(dx * dx + dy * dy + (p.z() - z) * (p.z() - z)));
  }
  // Half-cylinder x ≥ 1 round the axis (1, ·, r).
  const Eigen::Vector2d q(p.x() - 1.0, p.z() - r);
  double radial;
  if (q.x() >= 0) {
    radial = std::abs(q.norm() - r);
  } else {
    radial = std::min(Eigen::Vector2d(q.x(), q.y() - r).norm(), Eigen::Vector2d(q.x(), q.y() + r).norm());
  }
  best = std::min(best, std::sqrt(radial * radial + dy * dy));
  return best;
}

/// Which part of the strip a point is on: 0 bottom square, 1 top square, 2 fold.
int part(const Eigen::Vector3d& p) { return p.x() > 1.0 ? 2 : (p.z() < 0.01 ? 0 : 1); }

/// A pair joins the two squares away from the fold (both endpoints more than 0.05 — about an output
/// spacing — from it).
bool crossesGap(const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
  return part(p) != 2 && part(q) != 2 && part(p) != part(q) && std::max(p.x(), q.x()) < 0.95;
}

std::shared_ptr<const GeodesicCoordinates> geodesicOf(const PointCloud& c, const GeodesicParams& p = {},
                                                      const Execution& exec = {}) {
  return std::make_shared<const GeodesicCoordinates>(c, p, exec);
}

TEST(IntrinsicRule, ValidatesParams) {
  IntrinsicParams p;
  EXPECT_NO_THROW(p.validate());
  p.slope = 0.5;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.toleranceSpacings = -1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.maxDistanceSpacings = std::nan("");
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.gapSpacings = -1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  EXPECT_THROW(IntrinsicRule(nullptr), std::invalid_argument);
}

// On a sphere true neighbours are accepted; mirror points (equal G, far apart in space) are not.
TEST(IntrinsicRule, SphereNeighboursAcceptedMirrorPointsRejected) {
  const PointCloud dense = test::sphereCloud(20000, 1.0, 8);
  const auto geo = geodesicOf(dense);
  IntrinsicRule rule(geo);
  const std::vector<Eigen::Vector3d> samples = test::fibonacciSphere(1000);
  rule.update(samples, {});
  const KnnIndex index(samples);
  std::size_t accepted = 0, total = 0;
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    index.knn(samples[i], 15, idx, d2);
    for (std::uint32_t j : idx) {
      if (j == i) continue;
      ++total;
      accepted += rule.accept(i, j);
      ASSERT_EQ(rule.accept(i, j), rule.accept(j, i));
    }
  }
  EXPECT_EQ(accepted, total) << "true neighbours rejected";
  // Mirror points: reflect samples through the plane of the three satellites; G is (nearly) equal.
  const auto& sat = geo->satellites(0);
  const Eigen::Vector3d a = dense.points[sat[0]], b = dense.points[sat[1]], c = dense.points[sat[2]];
  const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
  const double offset = n.dot(a);
  std::vector<Eigen::Vector3d> all = samples;
  std::vector<std::size_t> mirrorOf;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double h = n.dot(samples[i]) - offset;
    if (std::abs(h) < 0.35) continue;  // mirror pairs ≥ 0.7 apart in space
    mirrorOf.push_back(i);
    all.push_back(samples[i] - 2 * h * n);
  }
  ASSERT_GT(mirrorOf.size(), 200u);
  rule.update(all, {});
  std::size_t similarG = 0;
  for (std::size_t m = 0; m < mirrorOf.size(); ++m) {
    const std::size_t i = mirrorOf[m], j = samples.size() + m;
    EXPECT_FALSE(rule.accept(i, j)) << "mirror pair accepted";
    double jump = 0;
    for (int s = 0; s < 3; ++s)
      jump = std::max(jump, double(std::abs(geo->coordinate(rule.densePoint(i), s) -
                                            geo->coordinate(rule.densePoint(j), s))));
    similarG += jump < 0.1;
  }
  EXPECT_GT(similarG, mirrorOf.size() / 4) << "the reflection should give nearly equal G";
}

// On a separate object sampled at a tenth of the density, samples lie up to half its input spacing from
// their nearest input point and the graph's steps are as long — more than the tolerance set by the cloud's
// median spacing (the dense object's) allows. Neighbours there are accepted all the same (but where the sparse
// graph detours): the tolerance takes the sparse part's scale (GeodesicCoordinates::samplingScales). Mirror points are still rejected (the distance
// bound from the area the dense cloud covers, its sparse part included).
TEST(IntrinsicRule, NeighboursOnASparseSeparateObjectAccepted) {
  const PointCloud dense = test::twoDensitySpheres(10000, 9);
  const auto geo = geodesicOf(dense);
  IntrinsicRule rule(geo);
  std::vector<Eigen::Vector3d> samples = test::fibonacciSphere(1800, 3.0);  // the output spacing at N = 2000
  for (auto& p : samples) p += Eigen::Vector3d(10, 0, 0);
  samples.push_back(Eigen::Vector3d(13, 0, 0));
  samples.push_back(Eigen::Vector3d(7, 0, 0));  // its mirror through the centre
  rule.update(samples, {});
  const KnnIndex index(samples);
  std::size_t accepted = 0, total = 0;
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < 1800; ++i) {
    index.knn(samples[i], 7, idx, d2);
    for (std::uint32_t j : idx) {
      if (j == i || j >= 1800) continue;
      ++total;
      accepted += rule.accept(i, j);
    }
  }
  // A graph of 1,000 random points has a few detours of several spacings (two pairs here).
  EXPECT_GE(static_cast<double>(accepted), 0.999 * static_cast<double>(total)) << accepted << " of " << total;
  EXPECT_FALSE(rule.accept(1800, 1801));
}

// Two spheres 0.01 apart: two components; no pair across is ever accepted.
TEST(IntrinsicRule, TwoSpheresNeverLinked) {
  PointCloud dense = test::sphereCloud(20000, 0.5, 5, Eigen::Vector3d(-0.505, 0, 0));
  const PointCloud b = test::sphereCloud(20000, 0.5, 6, Eigen::Vector3d(0.505, 0, 0));
  dense.points.insert(dense.points.end(), b.points.begin(), b.points.end());
  dense.normals.insert(dense.normals.end(), b.normals.begin(), b.normals.end());
  const auto geo = geodesicOf(dense);
  ASSERT_EQ(geo->components(), 2u);
  IntrinsicRule rule(geo);
  // Samples near the contact: a dense patch on each sphere.
  std::vector<Eigen::Vector3d> samples;
  for (const auto& p : dense.points)
    if (std::abs(p.x()) < 0.05) samples.push_back(p);
  rule.update(samples, {});
  std::size_t across = 0, within = 0;
  for (std::size_t i = 0; i < samples.size(); ++i)
    for (std::size_t j = i + 1; j < samples.size(); ++j) {
      if ((samples[i] - samples[j]).norm() > 0.05) continue;
      const bool cross = (samples[i].x() < 0) != (samples[j].x() < 0);
      if (cross) {
        ++across;
        ASSERT_FALSE(rule.accept(i, j));
      } else {
        within += rule.accept(i, j);
      }
    }
  EXPECT_GT(across, 100u);
  EXPECT_GT(within, 100u);
}

// A closed plate 3 dense spacings thick: its two faces are about as far from every satellite, so the geodesic
// coordinates alone accept pairs straight across it; the gap test on the samples' tangent planes, where the sheet
// rule found the other face near, parts them all and keeps every pair on one face (and, applied everywhere,
// every neighbour pair on a sphere, whose planes curve the same way).
TEST(IntrinsicRule, PlateFacesPartedByTheGapTest) {
  const test::ThinCase plate = test::thinPlate(40000, 3.0, 0.0, 19);
  const auto geo = geodesicOf(plate.cloud);
  const KnnIndex plateIndex(plate.cloud.points);
  NeighbourTable table(plateIndex, plate.cloud.points, 24);
  std::vector<Eigen::Vector3d> ruleNormals;
  std::vector<std::uint8_t> near;  // the dense points with another sheet near: the gap test's domain
  separateSheets(plate.cloud.points, table, ruleNormals, {}, {}, nullptr, &near);
  std::vector<Eigen::Vector3d> samples, normals;
  for (std::size_t i = 0; i < plate.cloud.size(); i += 7)
    if (plate.side(plate.cloud.points[i]) >= 0)
      samples.push_back(plate.cloud.points[i]), normals.push_back(plate.cloud.normals[i]);
  auto count = [&](const IntrinsicParams& params, bool acrossFaces) {
    IntrinsicRule rule(geo, params, {}, near);
    rule.update(samples, normals);
    std::size_t accepted = 0, pairs = 0;
    for (std::size_t i = 0; i < samples.size(); ++i)
      for (std::size_t j = i + 1; j < samples.size(); ++j) {
        if ((samples[i] - samples[j]).norm() > 4 * plate.gap) continue;
        if ((plate.side(samples[i]) != plate.side(samples[j])) != acrossFaces) continue;
        ++pairs;
        accepted += rule.accept(i, j);
      }
    return std::make_pair(accepted, pairs);
  };
  IntrinsicParams without;
  without.gapSpacings = 0;
  const auto [acrossWithout, acrossPairs] = count(without, true);
  const auto [acrossWith, acrossPairs2] = count({}, true);
  const auto [withinWithout, withinPairs] = count(without, false);
  const auto [withinWith, withinPairs2] = count({}, false);
  std::printf("  pairs across the faces accepted: %zu of %zu without the gap test, %zu with it; on one face %zu "
              "and %zu of %zu\n", acrossWithout, acrossPairs, acrossWith, withinWithout, withinWith, withinPairs);
  ASSERT_GT(acrossPairs, 1000u);
  EXPECT_GT(acrossWithout, acrossPairs / 2);  // what the coordinates alone let through
  EXPECT_EQ(acrossWith, 0u);
  EXPECT_EQ(withinWith, withinWithout);

  const PointCloud sphere = test::sphereCloud(20000, 1.0, 8);
  IntrinsicRule rule(geodesicOf(sphere), {}, {}, std::vector<std::uint8_t>(sphere.size(), 1));
  const std::vector<Eigen::Vector3d> onSphere = test::fibonacciSphere(1000);
  rule.update(onSphere, onSphere);  // unit sphere: the normal is the position
  const KnnIndex index(onSphere);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < onSphere.size(); ++i) {
    index.knn(onSphere[i], 15, idx, d2);
    for (std::uint32_t j : idx) ASSERT_TRUE(rule.accept(i, j)) << i << " " << j;
  }
}

// The U-strip, rule level: pairs straight across the gap are rejected away from the fold; neighbours on one
// sheet (and round the fold) are accepted.
TEST(IntrinsicRule, UStripRejectsPairsAcrossTheGap) {
  const PointCloud dense = uStrip(40000, 0.02, 3);
  const auto geo = geodesicOf(dense);
  ASSERT_EQ(geo->components(), 1u);
  IntrinsicRule rule(geo);
  std::vector<Eigen::Vector3d> s;
  for (double x = 0.005; x < 0.999; x += 0.01)
    for (double y : {0.1, 0.5, 0.9}) {
      s.emplace_back(x, y, 0.0);    // 2i: bottom
      s.emplace_back(x, y, 0.02);   // 2i+1: top, straight across
    }
  rule.update(s, {});
  std::size_t rejectedNearFold = 0, nearFold = 0;
  for (std::size_t i = 0; i + 1 < s.size(); i += 2) {
    if (s[i].x() < 0.95) {
      EXPECT_FALSE(rule.accept(i, i + 1)) << "across the gap at x = " << s[i].x();
    } else {
      ++nearFold;
      rejectedNearFold += !rule.accept(i, i + 1);
    }
    if (i + 6 < s.size()) {  // same sheet, 0.01 apart along x: neighbours
      EXPECT_TRUE(rule.accept(i, i + 6));
      EXPECT_TRUE(rule.accept(i + 1, i + 7));
    }
  }
  EXPECT_GT(nearFold, 0u);
  // Round the fold: bottom (0.99, y, 0) and the top of the cylinder are neighbours along the surface.
  EXPECT_TRUE(rule.acceptPoints(Eigen::Vector3d(0.99, 0.5, 0), Eigen::Vector3d(1.01, 0.5, 0.01)));
}

/// Runs the issue-3 U-strip acceptance through resample() with the given rule and reports the figures.
struct StripOutcome {
  std::size_t points = 0, bottom = 0, top = 0, fold = 0;
  double maxDistance = 0;
  std::size_t offStrip = 0;        // output points farther than 10 % of the gap from the strip
  std::size_t crossRingEdges = 0;  // 1-ring edges joining the squares away from the fold
  std::size_t ringEdges = 0;
  std::size_t crossCandidates = 0;  // output k-NN pairs across the gap (8 nearest)
  std::size_t crossAccepted = 0;    // ... accepted by the intrinsic rule
};

StripOutcome resampleStrip(const PointCloud& dense, std::shared_ptr<NeighbourRule> rule,
                           const std::shared_ptr<const GeodesicCoordinates>& geo) {
  ResampleParams params;
  params.targetCount = 1000;
  params.neighbourRule = std::move(rule);
  params.ringEdges = true;
  const ResampleResult r = resample(dense, params);
  StripOutcome o;
  const auto& pts = r.cloud.points;
  o.points = pts.size();
  for (const auto& p : pts) {
    const double d = stripDistance(p);
    o.maxDistance = std::max(o.maxDistance, d);
    o.offStrip += d > 0.002;
    const int k = part(p);
    (k == 0 ? o.bottom : k == 1 ? o.top : o.fold)++;
  }
  o.ringEdges = r.ringEdges.size();
  for (const auto& e : r.ringEdges) o.crossRingEdges += crossesGap(pts[e[0]], pts[e[1]]);
  // Neighbour pairs of the output (its 8 nearest), judged by the intrinsic rule on the output.
  IntrinsicRule judge(geo);
  judge.update(pts, r.cloud.normals);
  const KnnIndex index(pts);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    index.knn(pts[i], 9, idx, d2);
    for (std::uint32_t j : idx)
      if (j != i && crossesGap(pts[i], pts[j])) {
        ++o.crossCandidates;
        o.crossAccepted += judge.accept(i, j);
      }
  }
  std::printf("  %zu points: bottom %zu, top %zu, fold %zu; max distance to the strip %.5f, %zu beyond 0.002; "
              "ring edges %zu, across the gap %zu; 8-NN pairs across %zu, accepted %zu\n",
              o.points, o.bottom, o.top, o.fold, o.maxDistance, o.offStrip, o.ringEdges, o.crossRingEdges,
              o.crossCandidates, o.crossAccepted);
  return o;
}

// Acceptance (issue 3): the U-strip (gap 0.02, 40k random points per square) resampled to N = 1000
// (output spacing ≈ 0.045 > gap) with intrinsic control: every output point within 10 % of the gap of the
// strip, equal shares for the squares (± 2 % of N), no 1-ring edge and no accepted neighbour pair joining
// the squares away from the fold; with intrinsic control off (EuclideanRule) the same run shows the failure.
// Measured (with the resampler's voxel initialisation keyed by cell *and* oriented-normal direction, see
// below): on — bottom 492 / top 495 / fold 13, max distance 0.0003, 0 of 2,845 ring edges across the gap,
// 0 of 3,243 cross-gap 8-NN pairs accepted; off — bottom 554 / top 426 / fold 20, 1,617 of 3,102 ring edges
// across the gap. NOTE: the density initialisation keeps one point per 3-D voxel; voxels larger than the gap
// take every point from the sheet nearer the voxel centre, so without that key all 974 square samples land
// on the top sheet (with either rule) and the share assertion fails until resample.cpp keys the voxels by
// sheet as well.
TEST(IntrinsicRule, UStripResampledEndToEnd) {
  const PointCloud dense = uStrip(40000, 0.02, 3);
  const auto geo = geodesicOf(dense);
  std::printf("intrinsic control on:\n");
  const StripOutcome on = resampleStrip(dense, std::make_shared<IntrinsicRule>(geo), geo);
  EXPECT_EQ(on.points, 1000u);
  EXPECT_EQ(on.offStrip, 0u);
  EXPECT_LE(on.maxDistance, 0.002);
  EXPECT_LE(std::abs(double(on.top) - double(on.bottom)), 0.02 * 1000);
  EXPECT_EQ(on.crossAccepted, 0u);
  EXPECT_GT(on.ringEdges, 2000u);
  EXPECT_EQ(on.crossRingEdges, 0u);

  std::printf("intrinsic control off (Euclidean neighbours):\n");
  const StripOutcome off = resampleStrip(dense, std::make_shared<EuclideanRule>(), geo);
  EXPECT_EQ(off.points, 1000u);
  // The failure this issue fixes: 1-rings link the two squares straight across the gap.
  EXPECT_GT(off.crossRingEdges, 100u);
}

/// Dijkstra distances on the vertex graph of a mesh from @p source (an upper bound of the geodesic distance,
/// within ~15 % of it on a good mesh); exact up to @p limit, larger or infinite beyond.
std::vector<double> meshGraphDistances(const TriangleMesh& mesh, std::size_t source, double limit) {
  std::vector<std::vector<std::pair<std::uint32_t, double>>> adj(mesh.vertices.size());
  for (const auto& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      const int a = t[e], b = t[(e + 1) % 3];
      const double len = (mesh.vertices[a] - mesh.vertices[b]).norm();
      adj[a].push_back({static_cast<std::uint32_t>(b), len});
      adj[b].push_back({static_cast<std::uint32_t>(a), len});
    }
  std::vector<double> dist(mesh.vertices.size(), std::numeric_limits<double>::infinity());
  using Item = std::pair<double, std::uint32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
  dist[source] = 0;
  heap.push({0, static_cast<std::uint32_t>(source)});
  while (!heap.empty()) {
    const auto [d, v] = heap.top();
    heap.pop();
    if (d > dist[v]) continue;
    if (d > limit) break;  // only distances up to limit are needed
    for (const auto& [w, len] : adj[v])
      if (d + len < dist[w]) dist[w] = d + len, heap.push({d + len, w});
  }
  return dist;
}

// A real model with parts close in space but far along the surface: armadillo (hands against the body,
// legs, ears). Samples: a 150-point subset of a 150k-point sampling (a very low N, where candidates reach
// across to nearby parts; at 500 samples no candidate pair is far along the surface); every sample's 14
// nearest samples are the candidates. Measured: 2,100 pairs, 2 far along the surface, both rejected.
// (CGAL's hand.off is no ground truth: its fingers are separate, touching shells, so the mesh graph says "far"
// for pairs the sampled cloud genuinely connects.) Ground truth: graph distance on the true mesh. No accepted
// pair may be far along the surface (mesh distance > 3 × Euclidean + 2 mean mesh edges); and the rule must
// actually meet such pairs among the candidates and reject them.
TEST(IntrinsicRule, ArmadilloCloseButFarAlongTheSurface) {
  const TriangleMesh mesh = readMesh(test::dataPath("meshes/armadillo.off"));
  MeshSamplingParams sp;
  sp.count = 150000;
  sp.seed = 5;
  const PointCloud dense = sampleMesh(mesh, sp);
  const auto geo = geodesicOf(dense);
  EXPECT_LE(geo->components(), 2u);
  IntrinsicRule rule(geo);
  std::vector<Eigen::Vector3d> samples;
  for (std::size_t i = 0; i < dense.size(); i += 1000) samples.push_back(dense.points[i]);
  rule.update(samples, {});
  // Nearest mesh vertex of every sample, and the pairs to check.
  const KnnIndex vertexIndex(mesh.vertices);
  std::vector<std::uint32_t> vertexOf(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i)
    vertexOf[i] = static_cast<std::uint32_t>(vertexIndex.nearest(samples[i]));
  double meanEdge = 0;
  for (const auto& t : mesh.triangles) meanEdge += (mesh.vertices[t[0]] - mesh.vertices[t[1]]).norm();
  meanEdge /= static_cast<double>(mesh.triangles.size());
  const KnnIndex index(samples);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::vector<std::vector<std::uint32_t>> candidates(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    index.knn(samples[i], 15, idx, d2);
    for (std::uint32_t j : idx)
      if (j != i) candidates[i].push_back(j);
  }
  std::size_t farPairs = 0, farRejected = 0, accepted = 0, total = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    double reach = 0;
    for (std::uint32_t j : candidates[i]) reach = std::max(reach, (samples[i] - samples[j]).norm());
    const std::vector<double> dist = meshGraphDistances(mesh, vertexOf[i], 3.0 * reach + 2.0 * meanEdge);
    for (std::uint32_t j : candidates[i]) {
      const double eu = (samples[i] - samples[j]).norm();
      const double surface = dist[vertexOf[j]];
      const bool far = surface > 3.0 * eu + 2.0 * meanEdge;
      const bool ok = rule.accept(i, j);
      ++total;
      accepted += ok;
      farPairs += far;
      farRejected += far && !ok;
      if (far) {
        EXPECT_FALSE(ok) << "pair " << i << "-" << j << ": euclidean " << eu << ", along the mesh " << surface;
      }
    }
  }
  std::printf("armadillo: %zu candidate pairs, %zu accepted; %zu far along the surface, %zu of them rejected\n",
              total, accepted, farPairs, farRejected);
  EXPECT_GT(farPairs, 0u) << "the model should contain close-but-far pairs at this spacing";
  EXPECT_GT(double(accepted), 0.97 * double(total - farPairs));
}

TEST(IntrinsicRule, DeterministicForAnyThreadCount) {
  const PointCloud dense = uStrip(10000, 0.05, 4);
  GeodesicParams gp;
  IntrinsicParams ip;
  std::vector<std::vector<bool>> decisions;
  for (int threads : {1, 2}) {
    IntrinsicRule rule(geodesicOf(dense, gp, Execution{threads}), ip, Execution{threads});
    std::vector<Eigen::Vector3d> s;
    for (std::size_t i = 0; i < dense.size(); i += 20) s.push_back(dense.points[i]);
    rule.update(s, {});
    std::vector<bool> d;
    for (std::size_t i = 0; i < s.size(); ++i)
      for (std::size_t j = i + 1; j < std::min(s.size(), i + 40); ++j) d.push_back(rule.accept(i, j));
    decisions.push_back(d);
  }
  EXPECT_EQ(decisions[0], decisions[1]);
}

}  // namespace
}  // namespace iires
