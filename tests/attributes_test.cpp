// SPDX-License-Identifier: GPL-3.0-or-later
// Per-point attributes: interpolation onto new points, through resample() and reconstruct(), and in and out
// of the file formats and the tools.
#include "iires/attributes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <utility>
#include <vector>

#include "iires/io.hpp"
#include "iires/outliers.hpp"
#include "iires/reconstruct/reconstruct.hpp"
#include "iires/register/registration.hpp"
#include "iires/resample.hpp"
#include "iires/sampling.hpp"
#include "shapes.hpp"
#include "test_util.hpp"

namespace {

using Eigen::Vector3d;
using iires::AttributeKind;
using iires::PointAttribute;
using iires::PointCloud;

/// A smooth colour field over the box [lo, hi]: each channel in [0, 255].
Vector3d smoothColour(const Vector3d& p, const Vector3d& lo, const Vector3d& hi) {
  const Vector3d t = (p - lo).cwiseQuotient(hi - lo);
  return {255 * t.x(), 127.5 * (1 + std::sin(3 * t.y())), 255 * (0.5 * t.z() + 0.5 * t.x() * t.y())};
}

/// Gives @p cloud red/green/blue uchar channels from smoothColour().
void paint(PointCloud& cloud, Vector3d& lo, Vector3d& hi) {
  lo = hi = cloud.points[0];
  for (const Vector3d& p : cloud.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const char* names[] = {"red", "green", "blue"};
  for (int c = 0; c < 3; ++c) cloud.attributes.push_back({names[c], AttributeKind::kColor, "uchar", {}});
  for (const Vector3d& p : cloud.points) {
    const Vector3d rgb = smoothColour(p, lo, hi);
    for (int c = 0; c < 3; ++c) cloud.attributes[c].values.push_back(std::round(rgb[c]));
  }
}

/// Mean absolute colour error of @p cloud against smoothColour(), as a share of the range 255.
double meanColourError(const PointCloud& cloud, const Vector3d& lo, const Vector3d& hi) {
  double sum = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3d rgb = smoothColour(cloud.points[i], lo, hi);
    for (int c = 0; c < 3; ++c) sum += std::abs(cloud.attributes[c].values[i] - rgb[c]);
  }
  return sum / (3.0 * static_cast<double>(cloud.size()) * 255.0);
}

const PointAttribute* find(const std::vector<PointAttribute>& attributes, const std::string& name) {
  for (const PointAttribute& a : attributes)
    if (a.name == name) return &a;
  return nullptr;
}

TEST(Attributes, MeanOfNeighboursAndMajorityOfLabels) {
  PointCloud source;
  source.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 0.5, 0}};
  source.attributes.push_back({"intensity", AttributeKind::kScalar, "float", {1, 1, 1, 1, 5}});
  source.attributes.push_back({"label", AttributeKind::kLabel, "int", {7, 7, 3, 3, 3}});
  iires::AttributeParams params;
  params.neighbours = 5;
  const auto out = iires::interpolateAttributes(source, {{0.5, 0.5, 0}, {0, 0, 0}}, {}, {}, params);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].name, "intensity");
  EXPECT_EQ(out[1].kind, AttributeKind::kLabel);
  EXPECT_EQ(out[1].type, "int");
  // At the centre: the centre point weighs most, the corners equally.
  EXPECT_GT(out[0].values[0], 1.0);
  EXPECT_LT(out[0].values[0], 5.0);
  EXPECT_EQ(out[1].values[0], 3.0);  // three of five neighbours, the nearest among them
  EXPECT_EQ(out[1].values[1], 7.0);  // at a corner labelled 7: it and its neighbour at distance 1 outweigh
  for (const PointAttribute& a : out)
    for (double v : a.values) EXPECT_TRUE(std::isfinite(v));
}

TEST(Attributes, SameSheetPredicateExcludesOtherSheets) {
  PointCloud source;
  source.points = {{0, 0, 0}, {0.1, 0, 0}, {0, 0, 0.05}, {0.1, 0, 0.05}};
  source.attributes.push_back({"red", AttributeKind::kColor, "uchar", {0, 0, 255, 255}});
  const auto onBottom = [](const Vector3d& target, const Vector3d& p) { return (p.z() > 0.025) == (target.z() > 0.025); };
  const auto mixed = iires::interpolateAttributes(source, {{0.05, 0, 0.01}});
  const auto kept = iires::interpolateAttributes(source, {{0.05, 0, 0.01}}, {}, onBottom);
  EXPECT_GT(mixed[0].values[0], 10.0);
  EXPECT_EQ(kept[0].values[0], 0.0);
  // A predicate that accepts nothing falls back to the nearest point.
  const auto none = iires::interpolateAttributes(source, {{0.1, 0, 0.04}}, {}, [](auto&, auto&) { return false; });
  EXPECT_EQ(none[0].values[0], 255.0);
  // With the target's normal: the top pair lies 44 degrees off its tangent plane z = 0.001, the bottom pair 1.
  const auto slope = iires::interpolateAttributes(source, {{0.05, 0, 0.001}}, {{0, 0, 1}});
  EXPECT_EQ(slope[0].values[0], 0.0);
  iires::AttributeParams flat;
  flat.maxSlopeDeg = 90;
  EXPECT_GT(iires::interpolateAttributes(source, {{0.05, 0, 0.001}}, {{0, 0, 1}}, {}, flat)[0].values[0], 1.0);
}

TEST(Attributes, RejectsBadInput) {
  PointCloud source;
  source.points = {{0, 0, 0}, {1, 0, 0}};
  source.attributes.push_back({"i", AttributeKind::kScalar, "float", {1}});
  EXPECT_THROW(iires::interpolateAttributes(source, {{0, 0, 0}}), std::invalid_argument);
  iires::AttributeParams zero;
  zero.neighbours = 0;
  EXPECT_THROW(zero.validate(), std::invalid_argument);
}

// The acceptance of issue 24: a real scan's shape (bunny00, sampled with a 3x density gradient) coloured by a
// smooth function of position, resampled to 10k, keeps its colours: mean error <= 2 % of the range.
TEST(Attributes, SmoothColoursSurviveResamplingOfARealModel) {
  const iires::TriangleMesh mesh = iires::readMesh(iires::test::dataPath("meshes/bunny00.off"));
  iires::MeshSamplingParams sp;
  sp.count = 60000;
  sp.densityRatio = 3;
  PointCloud cloud = iires::sampleMesh(mesh, sp);
  cloud.normals.clear();
  Vector3d lo, hi;
  paint(cloud, lo, hi);
  iires::ResampleParams params;
  params.targetCount = 10000;
  const iires::ResampleResult r = iires::resample(std::move(cloud), params);
  ASSERT_EQ(r.cloud.attributes.size(), 3u);
  for (const PointAttribute& a : r.cloud.attributes) {
    EXPECT_EQ(a.values.size(), 10000u);
    EXPECT_EQ(a.type, "uchar");
    EXPECT_EQ(a.kind, AttributeKind::kColor);
  }
  const double error = meanColourError(r.cloud, lo, hi);
  std::printf("mean colour error %.4f %% of the range\n", 100 * error);
  EXPECT_LE(error, 0.02);
}

/// Output points on one square of the U-strip (away from the fold, within 10 % of the gap of a square) whose
/// red is mixed (off its square's 0 or 255 by more than 2 % of the range) or whose label is not their square's.
struct Bleeding {
  std::size_t checked = 0, mixed = 0, wrongLabel = 0;
};

Bleeding bleeding(const PointCloud& out, double gap) {
  Bleeding b;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const Vector3d& p = out.points[i];
    const bool top = std::abs(p.z() - gap) < 0.1 * gap;
    if (p.x() > 0.9 || (!top && std::abs(p.z()) >= 0.1 * gap)) continue;  // the fold, or between the squares
    ++b.checked;
    b.mixed += std::abs(out.attributes[0].values[i] - (top ? 255 : 0)) > 0.02 * 255;
    b.wrongLabel += out.attributes[1].values[i] != (top ? 2 : 1);
  }
  return b;
}

// Thin sheets: the U-strip's squares are 1.3 input spacings apart, so a point's 8 nearest input points reach
// across the gap (with neither sheet test, most output colours would mix); the tangent-plane test and the
// intrinsic rule keep the other square's colour and labels out.
TEST(Attributes, ColoursDoNotBleedAcrossAThinGap) {
  const double gap = 0.02;
  PointCloud cloud = iires::test::uStrip(4000, gap, 5);
  PointAttribute red{"red", AttributeKind::kColor, "uchar", {}};
  PointAttribute label{"label", AttributeKind::kLabel, "int", {}};
  for (const Vector3d& p : cloud.points) {
    const bool top = p.z() > gap / 2;
    red.values.push_back(top ? 255 : 0);
    label.values.push_back(top ? 2 : 1);
  }
  cloud.attributes = {red, label};
  iires::ResampleParams params;
  params.targetCount = 2000;
  const iires::ResampleResult r = iires::resample(cloud, params);
  const Bleeding kept = bleeding(r.cloud, gap);
  iires::AttributeParams noTest;
  noTest.maxSlopeDeg = 90;
  PointCloud plain = r.cloud;
  plain.attributes = iires::interpolateAttributes(cloud, plain.points, {}, {}, noTest);
  const Bleeding mixed = bleeding(plain, gap);
  std::printf("on the squares: %zu of %zu mixed, %zu wrong labels; without the sheet tests %zu mixed\n",
              kept.mixed, kept.checked, kept.wrongLabel, mixed.mixed);
  EXPECT_GT(kept.checked, 1500u);
  EXPECT_LE(kept.mixed, kept.checked / 100);
  EXPECT_LE(kept.wrongLabel, kept.checked / 100);
  EXPECT_GT(mixed.mixed, mixed.checked / 3);
}

TEST(Attributes, AlignedCloudKeepsItsAttributes) {
  PointCloud cloud;
  cloud.points = {{0, 0, 0}, {1, 0, 0}};
  cloud.attributes.push_back({"label", AttributeKind::kLabel, "int", {4, 5}});
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T(0, 3) = 2;
  const PointCloud moved = iires::reg::transformCloud(cloud, T);
  EXPECT_EQ(moved.points[1].x(), 3.0);
  ASSERT_EQ(moved.attributes.size(), 1u);
  EXPECT_EQ(moved.attributes[0].values, (std::vector<double>{4, 5}));
}

// iires-register -o writes the source without its outliers: the points that stay keep their own values.
TEST(Attributes, RemovedOutliersTakeTheirValuesAlong) {
  PointCloud cloud = iires::test::sphereCloud(4000, 1.0, 8);
  for (int i = 0; i < 5; ++i) cloud.points.emplace_back(50.0 + 10 * i, 40.0, -30.0);  // far points
  cloud.normals.clear();
  PointAttribute id{"id", AttributeKind::kLabel, "int", {}};
  for (std::size_t i = 0; i < cloud.size(); ++i) id.values.push_back(static_cast<double>(i));
  cloud.attributes = {id};
  for (const iires::OutlierMode mode : {iires::OutlierMode::kRemove, iires::OutlierMode::kPull}) {
    iires::OutlierParams params;
    params.mode = mode;
    const PointCloud cleaned = iires::cleanOutliers(cloud, params);
    ASSERT_LE(cleaned.size(), 4000u);
    ASSERT_EQ(cleaned.attributes.size(), 1u);
    ASSERT_EQ(cleaned.attributes[0].values.size(), cleaned.size());
    std::size_t same = 0;  // kept points (not pulled) carry their own id
    for (std::size_t i = 0; i < cleaned.size(); ++i) {
      const auto original = static_cast<std::size_t>(cleaned.attributes[0].values[i]);
      same += (cleaned.points[i] - cloud.points[original]).norm() == 0.0;
    }
    EXPECT_GT(same, 3900u);
  }
}

TEST(Attributes, NoAttributesNoStage) {
  const PointCloud cloud = iires::test::sphereCloud(3000, 1.0, 4);
  iires::ResampleParams params;
  params.targetCount = 200;
  const iires::ResampleResult r = iires::resample(cloud, params);
  EXPECT_TRUE(r.cloud.attributes.empty());
  for (const auto& s : r.timings) EXPECT_NE(s.name, "attributes");
}

TEST(Attributes, MeshVerticesGetColours) {
  PointCloud cloud = iires::test::sphereCloud(20000, 1.0, 6);
  Vector3d lo, hi;
  paint(cloud, lo, hi);
  iires::ReconstructParams params;
  params.targetCount = 2000;
  params.evaluate = false;
  const iires::ReconstructResult r = iires::reconstruct(cloud, params);
  ASSERT_EQ(r.mesh.vertexAttributes.size(), 3u);
  PointCloud vertices;
  vertices.points = r.mesh.vertices;
  vertices.attributes = r.mesh.vertexAttributes;
  for (const PointAttribute& a : vertices.attributes) EXPECT_EQ(a.values.size(), vertices.size());
  EXPECT_LE(meanColourError(vertices, lo, hi), 0.02);
}

// ------------------------------------------------------------------------------------------------- files

TEST(AttributesIo, PlyRoundTripKeepsNamesTypesAndValues) {
  const std::string dir = iires::test::tempDir();
  PointCloud cloud;
  cloud.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  cloud.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  cloud.attributes.push_back({"red", AttributeKind::kColor, "uchar", {0, 127.6, 300}});
  cloud.attributes.push_back({"intensity", AttributeKind::kScalar, "float", {0.25, 1.5, -2}});
  cloud.attributes.push_back({"label", AttributeKind::kLabel, "int", {-1, 4, 70000}});
  for (const bool ascii : {false, true}) {
    const std::string path = dir + (ascii ? "/a.ply" : "/b.ply");
    iires::writePointCloud(path, cloud, ascii);
    const PointCloud back = iires::readPointCloud(path);
    ASSERT_EQ(back.attributes.size(), 3u);
    EXPECT_TRUE(back.hasNormals());
    EXPECT_EQ(back.attributes[0].type, "uchar");
    EXPECT_EQ(back.attributes[0].kind, AttributeKind::kColor);
    EXPECT_EQ(back.attributes[0].values, (std::vector<double>{0, 128, 255}));  // rounded, clamped to a byte
    EXPECT_EQ(back.attributes[1].kind, AttributeKind::kScalar);
    EXPECT_EQ(back.attributes[1].values, (std::vector<double>{0.25, 1.5, -2}));
    EXPECT_EQ(back.attributes[2].kind, AttributeKind::kLabel);
    EXPECT_EQ(back.attributes[2].values, (std::vector<double>{-1, 4, 70000}));
  }
}

TEST(AttributesIo, XyzColumnsAndPcdPackedColour) {
  const std::string dir = iires::test::tempDir();
  std::ofstream(dir + "/c.xyz") << "0 0 0 255 0 10 0.5 3\n1 0 0 0 255 20 0.25 4\n0 1 0 0 0 30 1 3\n";
  const PointCloud xyz =
      iires::readPointCloud(dir + "/c.xyz", {"x", "y", "z", "red", "green", "blue", "intensity", "label:int"});
  ASSERT_EQ(xyz.size(), 3u);
  ASSERT_EQ(xyz.attributes.size(), 5u);
  EXPECT_EQ(find(xyz.attributes, "red")->type, "uchar");
  EXPECT_EQ(find(xyz.attributes, "intensity")->kind, AttributeKind::kScalar);
  EXPECT_EQ(find(xyz.attributes, "label")->kind, AttributeKind::kLabel);
  EXPECT_EQ(find(xyz.attributes, "blue")->values, (std::vector<double>{10, 20, 30}));
  EXPECT_THROW(iires::readPointCloud(dir + "/c.xyz", {"x", "y", "red"}), iires::InputError);  // no z
  EXPECT_THROW(iires::readPointCloud(dir + "/c.xyz", {"x", "y", "z"}), iires::InputError);    // 8 values a line
  EXPECT_THROW(iires::readPointCloud(dir + "/c.xyz", {"x", "y", "z", "a:quad", "b", "c", "d", "e"}),
               iires::InputError);

  // PCL's packed rgb: a float whose bytes are b g r (0).
  const auto packed = [](unsigned r, unsigned g, unsigned b) {
    const std::uint32_t bits = r << 16 | g << 8 | b;
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  };
  std::ofstream pcd(dir + "/d.pcd", std::ios::binary);
  pcd << "VERSION .7\nFIELDS x y z rgb intensity\nSIZE 4 4 4 4 4\nTYPE F F F F F\nCOUNT 1 1 1 1 1\n"
         "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n";
  for (const float v : {0.f, 0.f, 0.f, packed(10, 20, 30), 0.5f, 1.f, 0.f, 0.f, packed(200, 100, 0), 2.f})
    pcd.write(reinterpret_cast<const char*>(&v), 4);
  pcd.close();
  const PointCloud fromPcd = iires::readPointCloud(dir + "/d.pcd");
  ASSERT_EQ(fromPcd.attributes.size(), 4u);
  EXPECT_EQ(find(fromPcd.attributes, "red")->values, (std::vector<double>{10, 200}));
  EXPECT_EQ(find(fromPcd.attributes, "green")->values, (std::vector<double>{20, 100}));
  EXPECT_EQ(find(fromPcd.attributes, "blue")->values, (std::vector<double>{30, 0}));
  EXPECT_EQ(find(fromPcd.attributes, "intensity")->values, (std::vector<double>{0.5, 2}));
}

TEST(AttributesIo, ToolsCarryColumnsToThePly) {
  const std::string dir = iires::test::tempDir();
  PointCloud cloud = iires::test::sphereCloud(6000, 1.0, 7);
  {
    std::ofstream xyz(dir + "/in.xyz");
    for (const Vector3d& p : cloud.points)
      xyz << p.x() << " " << p.y() << " " << p.z() << " " << std::lround(127.5 * (1 + p.z())) << "\n";
  }
  std::string out;
  ASSERT_EQ(iires::test::run(iires::test::tool("iires-resample") + " " + dir + "/in.xyz " + dir +
                                 "/out.ply -n 500 -q --columns x,y,z,red",
                             &out),
            0)
      << out;
  const PointCloud resampled = iires::readPointCloud(dir + "/out.ply");
  ASSERT_EQ(resampled.attributes.size(), 1u);
  double worst = 0;
  for (std::size_t i = 0; i < resampled.size(); ++i)
    worst = std::max(worst, std::abs(resampled.attributes[0].values[i] - 127.5 * (1 + resampled.points[i].z())));
  EXPECT_LT(worst, 8.0);  // a few units of 255 where the sphere is coarsest
  ASSERT_EQ(iires::test::run(iires::test::tool("iires-reconstruct") + " " + dir + "/in.xyz " + dir +
                                 "/mesh.ply -n 500 -q --columns x,y,z,red",
                             &out),
            0)
      << out;
  std::ifstream mesh(dir + "/mesh.ply");
  std::string header((std::istreambuf_iterator<char>(mesh)), {});
  EXPECT_NE(header.find("property uchar red"), std::string::npos);
  // --columns applies to .xyz only: exit 2 with the one-line message.
  EXPECT_EQ(iires::test::run(iires::test::tool("iires-resample") + " " + dir + "/out.ply " + dir +
                                 "/again.ply -n 100 --columns x,y,z 2>&1",
                             &out),
            2);
  EXPECT_NE(out.find("iires-resample: error: " + dir + "/out.ply: column names apply to .xyz files only"),
            std::string::npos)
      << out;
  // --denoise-only keeps each point's own values (it wrote positions and normals only); where --outliers remove
  // drops points (scattered ones added to the sphere here), each point left keeps its own.
  {
    std::ofstream xyz(dir + "/scattered.xyz");
    xyz << std::ifstream(dir + "/in.xyz").rdbuf();
    for (int i = 0; i < 40; ++i) xyz << 3 + 0.05 * i << " " << 2 - 0.1 * i << " " << 4 << " 0\n";
  }
  for (const auto& [file, outliers] : {std::pair{"in", "pull"}, std::pair{"scattered", "remove"}}) {
    ASSERT_EQ(iires::test::run(iires::test::tool("iires-resample") + " " + dir + "/" + file + ".xyz " + dir +
                                   "/clean.ply --denoise-only -q --columns x,y,z,red --outliers " + outliers,
                               &out),
              0)
        << out;
    const PointCloud cleaned = iires::readPointCloud(dir + "/clean.ply");
    ASSERT_EQ(cleaned.attributes.size(), 1u) << outliers;
    EXPECT_LE(cleaned.size(), cloud.size()) << outliers;  // the scattered points removed
    double off = 0;
    for (std::size_t i = 0; i < cleaned.size(); ++i)
      off = std::max(off, std::abs(cleaned.attributes[0].values[i] - 127.5 * (1 + cleaned.points[i].z())));
    EXPECT_LE(off, 1.0) << outliers;  // rounding only
  }
}

// A flag that would change nothing is refused (exit 2, the flag named), not ignored.
TEST(AttributesIo, FlagsWithoutEffectAreRefused) {
  const std::string dir = iires::test::tempDir();
  iires::writePointCloud(dir + "/in.ply", iires::test::sphereCloud(3000, 1.0, 8));
  const std::string resample = iires::test::tool("iires-resample") + " " + dir + "/in.ply " + dir + "/o.ply ";
  const std::string reconstruct = iires::test::tool("iires-reconstruct") + " " + dir + "/in.ply ";
  for (const auto& [command, flag] : std::vector<std::pair<std::string, std::string>>{
           {resample + "--denoise-only -n 100", "-n"},
           {resample + "--denoise-only --sharp-edges", "--sharp-edges"},
           {resample + "-n 100 --mode curvature --levels 6 --ratios 3,2,1,0.5", "--levels 6"},
           {reconstruct + dir + "/m.ply --no-resample -n 500", "-n"},
           {reconstruct + "--quality-only " + dir + "/in.ply --method advancing-front", "--method"}}) {
    std::string out;
    EXPECT_EQ(iires::test::run(command + " 2>&1", &out), 2) << command << "\n" << out;
    EXPECT_NE(out.find(flag), std::string::npos) << out;
  }
  EXPECT_FALSE(iires::test::fileExists(dir + "/o.ply"));
  EXPECT_FALSE(iires::test::fileExists(dir + "/m.ply"));
}

}  // namespace
