// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/icp.hpp"
#include "iires/register/open_side.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "shapes.hpp"

namespace {

using Points = std::vector<Eigen::Vector3d>;

/// An asymmetric test shape: an ellipsoid-ish blob with a bump (no rotational symmetry).
Points blob(std::size_t n) {
  Points p;
  for (const auto& d : iires::test::fibonacciSphere(n)) {
    const double bump = 0.4 * std::exp(-((d - Eigen::Vector3d(0.6, 0.6, 0.5).normalized()).squaredNorm()) / 0.1);
    p.push_back(Eigen::Vector3d(1.6 * d.x(), 1.0 * d.y(), 0.7 * d.z()) * (1 + bump));
  }
  return p;
}

Eigen::Matrix4d similarity(double s, const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = s * r;
  m.topRightCorner<3, 1>() = t;
  return m;
}

Points transformed(const Points& p, const Eigen::Matrix4d& m) {
  Points out;
  for (const auto& x : p) out.push_back(m.topLeftCorner<3, 3>() * x + m.topRightCorner<3, 1>());
  return out;
}

TEST(Icp, UmeyamaRecoversAnExactSimilarity) {
  const Points a = blob(200);
  const Eigen::Matrix4d truth =
      similarity(2.5, Eigen::AngleAxisd(2.5, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix(),
                 Eigen::Vector3d(3, -1, 7));
  EXPECT_TRUE(iires::reg::umeyamaTransform(a, transformed(a, truth), true).isApprox(truth, 1e-10));
  EXPECT_THROW(iires::reg::umeyamaTransform(Points(2), Points(2), true), std::invalid_argument);
}

TEST(Icp, ConvergesFromANearbyPoseWithScale) {
  const Points target = blob(3000);
  const Points source0 = blob(1500);  // a different sampling of the same shape
  const Eigen::Matrix4d move =
      similarity(0.3, Eigen::AngleAxisd(0.2, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix(),
                 Eigen::Vector3d(0.05, 0, 0.02));
  const Points source = transformed(source0, move);
  const iires::KnnIndex tree(target);
  // Start from the right scale-free neighbourhood: scale ~1/0.3, rotation 0.2 rad off.
  Eigen::Matrix4d init = Eigen::Matrix4d::Identity();
  init.topLeftCorner<3, 3>() *= 1.0 / 0.28;
  for (int threads : {1, 2}) {
    const auto r = iires::reg::similarityIcp(source, target, tree, init, {}, iires::Execution{threads});
    const Eigen::Matrix4d truth = move.inverse();
    EXPECT_NEAR(r.scale, 1.0 / 0.3, 0.01 / 0.3);
    EXPECT_LT(std::acos(std::clamp(((r.T_target_source.topLeftCorner<3, 3>() / r.scale).transpose() *
                                     (truth.topLeftCorner<3, 3>() * 0.3))
                                            .trace() * 0.5 - 0.5,
                                   -1.0, 1.0)),
              0.03);  // < 1.7°: two different samplings of the shape
    EXPECT_LT(r.rmse, 0.05);
    EXPECT_GT(r.iterations, 1);
  }
}

TEST(Icp, FractionalRmsdKeepsThePairsThatFitAndNotFewer) {
  // 600 residuals of 0.01 and 400 of 0.5: the estimate keeps exactly the 600 (a smaller k gains nothing,
  // a larger one takes in the far pairs).
  std::vector<double> d2(600, 0.01 * 0.01);
  d2.insert(d2.end(), 400, 0.25);
  const auto fit = iires::reg::fractionalRmsd(d2, 0.4, 1.5);
  EXPECT_EQ(fit.keep, 600u);
  EXPECT_NEAR(fit.rms, 0.01, 1e-12);
  EXPECT_NEAR(fit.score, 0.01 * std::pow(1000.0 / 600.0, 1.5), 1e-12);
  // All alike: everything is kept.
  EXPECT_EQ(iires::reg::fractionalRmsd(std::vector<double>(50, 1.0), 0.4, 1.5).keep, 50u);
  EXPECT_THROW(iires::reg::fractionalRmsd({}, 0.4, 1.5), std::invalid_argument);
}

TEST(Icp, EstimatedOverlapAlignsTwoPartialCloudsWithScale) {
  // Source and target each miss a different part of the blob (a cap of 30 % each) and the source carries
  // 10 % far outliers; with the overlap estimated per iteration and both directions matched, ICP with scale
  // still lands on the truth and reports the overlaps it used.
  const Points whole = blob(3000);
  Points target, part;
  for (const auto& x : whole)
    if (x.x() < 0.9) target.push_back(x);
  for (const auto& x : blob(2000))
    if (x.y() > -0.55) part.push_back(x);
  for (int i = 0; i < 150; ++i) part.emplace_back(4 + 0.01 * i, -3, 2);
  const Eigen::Matrix4d truth =
      similarity(1.0, Eigen::AngleAxisd(0.08, Eigen::Vector3d(1, 2, 0).normalized()).toRotationMatrix(),
                 Eigen::Vector3d(0.04, -0.03, 0.02));
  const Points source = transformed(part, truth.inverse());
  const iires::KnnIndex tree(target);
  iires::reg::IcpParams p;
  p.estimateOverlap = true;
  p.bidirectional = true;
  p.maxIterations = 100;
  const auto r = iires::reg::similarityIcp(source, target, tree, Eigen::Matrix4d::Identity(), p);
  EXPECT_TRUE(r.T_target_source.isApprox(truth, 0.01)) << r.T_target_source;
  EXPECT_NEAR(r.scale, 1.0, 0.01);
  EXPECT_GT(r.overlap, 0.5);
  EXPECT_LT(r.overlap, 0.95);
  EXPECT_LT(r.reverseOverlap, 0.95);
  // The caller's tree of the source for the reverse matches: the same result; a tree of other points is refused.
  const iires::KnnIndex sourceTree(source);
  const auto again = iires::reg::similarityIcp(source, target, tree, Eigen::Matrix4d::Identity(), p, {}, &sourceTree);
  EXPECT_EQ(again.T_target_source, r.T_target_source);
  EXPECT_EQ(again.iterations, r.iterations);
  EXPECT_THROW(iires::reg::similarityIcp(source, target, tree, Eigen::Matrix4d::Identity(), p, {}, &tree),
               std::invalid_argument);
}

TEST(Icp, RigidKeepsUnitScaleAndTrimmedIgnoresExtraPoints) {
  Points target = blob(2000);
  Points source = transformed(blob(1000), similarity(1.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.05, 0, 0)));
  for (int i = 0; i < 200; ++i) source.emplace_back(5 + 0.01 * i, 5, 5);  // 1/6 of the source has no partner
  const iires::KnnIndex tree(target);
  iires::reg::IcpParams p;
  p.estimateScale = false;
  p.overlap = 0.8;
  const auto r = iires::reg::similarityIcp(source, target, tree, Eigen::Matrix4d::Identity(), p);
  EXPECT_NEAR(r.scale, 1.0, 1e-9);
  EXPECT_NEAR(r.T_target_source(0, 3), -0.05, 0.01);
  EXPECT_EQ(r.matched, 960u);
  p.overlap = 0.0;
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

// The source covers more of the blob than the target (the target cut at z = 0.1, the source at z = −0.35), all
// pairs kept: each source point past the target's cut finds the target's rim as its nearest point, and those
// pairs shrink the scale (by 5 % here) and shift the fit 0.17 towards the cut. Dropping the pairs matched to a rim point
// (Turk & Levoy's boundary rule) leaves only true counterparts.
TEST(Icp, PairsMatchedToTheOtherCloudsRimAreLeftOut) {
  Points target, source;
  for (const auto& p : blob(6000))
    if (p.z() > 0.1) target.push_back(p);
  for (const auto& p : blob(4000))
    if (p.z() > -0.35) source.push_back(p);
  const iires::KnnIndex tree(target);
  const iires::reg::OpenSide rim = iires::reg::openSide(target, tree);
  ASSERT_GT(rim.rimPoints, 0u);
  const Eigen::Matrix4d init = similarity(1.03, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.02, 0, 0));
  const auto plain = iires::reg::similarityIcp(source, target, tree, init, {});
  const auto ruled = iires::reg::similarityIcp(source, target, tree, init, {}, {}, nullptr, {nullptr, &rim.rim});
  EXPECT_GT(std::abs(plain.scale - 1.0), 0.02);  // the bias the rule removes
  EXPECT_NEAR(ruled.scale, 1.0, 0.005);
  const Eigen::Vector3d shift = ruled.T_target_source.topRightCorner<3, 1>();
  EXPECT_LT(shift.norm(), 0.01);
  const std::vector<std::uint8_t> wrong(target.size() + 1, 0);
  EXPECT_THROW(iires::reg::similarityIcp(source, target, tree, init, {}, {}, nullptr, {nullptr, &wrong}),
               std::invalid_argument);
}

}  // namespace
