// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/rotation_search.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "iires/io.hpp"
#include "iires/register/hausdorff.hpp"
#include "iires/register/rotation_grid.hpp"
#include "iires/sampling.hpp"
#include "test_util.hpp"

namespace {

using Points = std::vector<Eigen::Vector3d>;
using iires::reg::RotationSearch;
using iires::reg::RotationSearchParams;

/// An ellipsoid-like blob with three bumps (no symmetry), n points, centred and scaled to unit RMS radius.
Points lumpyShape(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const double bumps = 1 + 0.5 * std::exp(-8 * (d - Eigen::Vector3d(1, 0, 0)).squaredNorm()) +
                         0.3 * std::exp(-6 * (d - Eigen::Vector3d(0, 1, 0)).squaredNorm()) +
                         0.2 * std::exp(-10 * (d - Eigen::Vector3d(0, -0.6, 0.8)).squaredNorm());
    p.push_back(bumps * Eigen::Vector3d(1.6 * d.x(), 1.0 * d.y(), 0.7 * d.z()));
  }
  return p;
}

/// An ellipsoid with four bumps of different sizes (no symmetry), n points (not normalised).
Points fourBumps(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const double bumps = 1 + 0.5 * std::exp(-6 * (d - Eigen::Vector3d(1, 0, 0)).squaredNorm()) +
                         0.35 * std::exp(-6 * (d - Eigen::Vector3d(0, 1, 0)).squaredNorm()) +
                         0.25 * std::exp(-8 * (d - Eigen::Vector3d(0, -0.6, 0.8)).squaredNorm()) +
                         0.3 * std::exp(-8 * (d - Eigen::Vector3d(-0.7, 0.1, -0.7)).squaredNorm());
    p.push_back(bumps * Eigen::Vector3d(1.4 * d.x(), 1.0 * d.y(), 0.8 * d.z()));
  }
  return p;
}

/// @p n area-uniform samples of a CGAL model (no noise).
Points modelSamples(const std::string& name, std::size_t n, std::uint64_t seed) {
  iires::MeshSamplingParams sp;
  sp.count = n;
  sp.seed = seed;
  return iires::sampleMesh(iires::readMesh(iires::test::dataPath("meshes/" + name + ".off")), sp).points;
}

/// Centroid to the origin, unit RMS radius (the registration's normalisation).
Points normalised(Points p) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& x : p) c += x;
  c /= static_cast<double>(p.size());
  double s = 0;
  for (const auto& x : p) s += (x - c).squaredNorm();
  s = std::sqrt(s / static_cast<double>(p.size()));
  for (auto& x : p) x = (x - c) / s;
  return p;
}

/// The points on the negative side of the plane n·x = the (1 − share) quantile: the share cut off.
Points cut(const Points& p, const Eigen::Vector3d& n, double share) {
  std::vector<double> h;
  for (const auto& x : p) h.push_back(x.dot(n));
  std::vector<double> sorted = h;
  const auto k = static_cast<std::size_t>((1 - share) * static_cast<double>(h.size()));
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
  Points out;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (h[i] < sorted[k]) out.push_back(p[i]);
  return out;
}

TEST(RotationSearch, EnergyWithTranslationAndScaleMatchesTheSymmetricHausdorff) {
  // E(R, t, s) with one untrimmed level is the plain symmetric Hausdorff distance of s·R·S + t and T; both
  // directions in target units.
  const Points s = lumpyShape(300, 1), t = lumpyShape(400, 2);
  RotationSearchParams p;
  p.coarsePoints = 64;
  const RotationSearch search(s, t, p);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  for (const double scale : {1.0, 0.7, 1.4}) {
    const Eigen::Vector3d shift(0.3, -0.1, 0.2);
    Points moved;
    for (const auto& x : s) moved.push_back(scale * r * x + shift);
    const double expected = iires::reg::hausdorffDistance(moved, t, 1.0, 1);
    EXPECT_NEAR(search.energy(r, shift, scale), expected, 1e-12) << scale;
    // The early exit: above the bound it returns +inf.
    EXPECT_TRUE(std::isinf(search.energy(r, shift, scale, 0.5 * expected)));
  }
  EXPECT_NEAR(search.energy(r), search.energy(r, Eigen::Vector3d::Zero(), 1.0), 1e-15);
  EXPECT_THROW(search.energy(r, Eigen::Vector3d::Zero(), 0.0), std::invalid_argument);
}

TEST(RotationSearch, AffineBoundedHausdorffMatchesTheMappedSet) {
  const Points a = lumpyShape(200, 3), b = lumpyShape(250, 4);
  const iires::KnnIndex ib(b);
  const Eigen::Matrix3d l = 1.3 * Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d t(0.1, 0.2, -0.3);
  Points mapped;
  for (const auto& x : a) mapped.push_back(l * x + t);
  const auto levels = iires::reg::trimLevels(a.size(), {1.0, 0.8}, 2.0);
  std::vector<double> scratch;
  const double inf = std::numeric_limits<double>::infinity();
  const double affine = iires::reg::boundedPartialHausdorff(a, l, t, ib, levels, inf, scratch);
  const double direct =
      iires::reg::boundedPartialHausdorff(mapped, Eigen::Matrix3d::Identity(), ib, levels, inf, scratch);
  EXPECT_DOUBLE_EQ(affine, direct);
}

TEST(RotationSearch, TranslationSearchRecentresCutClouds) {
  // Both clouds cut by different planes (a fifth each) and normalised on what is left: at the true rotation
  // their frames are offset. The translation search must give the candidate near the true rotation an offset
  // close to the true one; without it (radius 0) every candidate keeps t = 0.
  const Points whole = modelSamples("bunny00", 1000, 5), other = modelSamples("bunny00", 1000, 6);
  const Eigen::Matrix3d truth = Eigen::AngleAxisd(2.0, Eigen::Vector3d(0.3, 1, -0.2).normalized()).toRotationMatrix();
  Points rotated;
  for (const auto& x : cut(whole, Eigen::Vector3d(0.35, -0.94, 0.02), 0.2)) rotated.push_back(truth.transpose() * x);
  const Points t0 = cut(other, Eigen::Vector3d(-0.72, 0.28, -0.63), 0.2);
  // The true pose between the normalised clouds: s·R·S + offset, from the two normalisations.
  auto frame = [](const Points& p) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& x : p) c += x;
    c /= static_cast<double>(p.size());
    double r = 0;
    for (const auto& x : p) r += (x - c).squaredNorm();
    return std::make_pair(c, std::sqrt(r / static_cast<double>(p.size())));
  };
  const auto [cs, rs] = frame(rotated);
  const auto [ct, rt] = frame(t0);
  const double trueScale = rs / rt;
  const Eigen::Vector3d trueOffset = (truth * cs - ct) / rt;
  ASSERT_GT(trueOffset.norm(), 0.3);  // the frames are offset
  const Points s = normalised(rotated), t = normalised(t0);
  const auto grid = iires::reg::rotationGrid(iires::reg::RotationGridType::kSo3, 24, 6144);
  for (const double radius : {0.8, 0.0}) {
    RotationSearchParams p;
    p.overlaps = {1.0, 0.8, 0.6};
    p.keep = 12;
    p.translationRadius = radius;
    const auto found = RotationSearch(s, t, p, iires::Execution{2}).search(grid);
    ASSERT_FALSE(found.candidates.empty());
    if (radius > 0) {
      // The best candidate is the true rotation (within the grid's spacing), recentred.
      const auto& best = found.candidates.front();
      EXPECT_LT(iires::reg::rotationAngle(best.rotation, truth) * 180 / M_PI, 12.0);
      EXPECT_LT((best.translation - trueOffset).norm(), 0.15) << best.translation.transpose();
      EXPECT_NEAR(trueScale, 1.0, 0.1);
    } else {
      for (const auto& c : found.candidates) EXPECT_EQ(c.translation, Eigen::Vector3d::Zero());
    }
  }
}

TEST(RotationSearch, SameCandidatesForAnyThreadCount) {
  const Points s = normalised(cut(lumpyShape(1500, 7), Eigen::Vector3d(0, 0, 1), 0.2));
  const Points t = normalised(lumpyShape(1500, 8));
  const auto grid = iires::reg::rotationGrid(iires::reg::RotationGridType::kSo3, 24, 6144);
  RotationSearchParams p;
  p.overlaps = {1.0, 0.8, 0.6};
  const auto one = RotationSearch(s, t, p, iires::Execution{1}).search(grid);
  const auto two = RotationSearch(s, t, p, iires::Execution{2}).search(grid);
  ASSERT_EQ(one.candidates.size(), two.candidates.size());
  for (std::size_t i = 0; i < one.candidates.size(); ++i) {
    EXPECT_EQ(one.candidates[i].gridIndex, two.candidates[i].gridIndex);
    EXPECT_EQ(one.candidates[i].translation, two.candidates[i].translation);
    EXPECT_EQ(one.candidates[i].energy, two.candidates[i].energy);
  }
  EXPECT_EQ(one.pointQueries, two.pointQueries);
}

TEST(RotationSearch, CoarseOffsetsFindTheRotationOfAFortyPercentCut) {
  // 40 % of the source cut off by a plane: normalised on what is left, its frame is offset from the target's
  // by ≈ 0.35 RMS radii at the true rotation. Scored at t = 0 only (coarseOffsetRadius = 0), the true
  // rotation does not survive the coarse pass in this fixed case; scored at the best of the coarse offsets,
  // it is the best candidate. One fixed case (a plane and rotation drawn once, kept to full precision: the
  // outcome is sensitive to them): over twelve such random cuts of this shape the top candidate was within
  // 20° of the truth in 5 either way; the registration benchmark measures the aggregate.
  const Eigen::Vector3d axis(0.88767215422550383, 0.37544075743414607, -0.26661279839859159);
  const Eigen::Vector3d normal(-0.16254868569683611, -0.36355014529506008, 0.91728360752505111);
  const Eigen::Matrix3d truth = Eigen::AngleAxisd(2.0832329215359735, axis.normalized()).toRotationMatrix();
  Points rotated;
  for (const auto& x : cut(fourBumps(1000, 108), normal.normalized(), 0.4))
    rotated.push_back(truth.transpose() * x);
  const Points s = normalised(rotated), t = normalised(fourBumps(1000, 208));
  const auto grid = iires::reg::rotationGrid(iires::reg::RotationGridType::kSo3, 24, 6144);
  for (const double radius : {0.4, 0.0}) {
    RotationSearchParams p;
    p.overlaps = {1.0, 0.8, 0.6};  // the registration's levels when the overlap is not given
    p.coarseOffsetRadius = radius;
    p.coarseKeep = 48;  // the case was drawn for 48 coarse survivors (with 96 the true rotation survives anyway)
    const auto found = RotationSearch(s, t, p, iires::Execution{2}).search(grid);
    ASSERT_FALSE(found.candidates.empty());
    const double error = iires::reg::rotationAngle(found.candidates.front().rotation, truth) * 180 / M_PI;
    if (radius > 0)
      EXPECT_LT(error, 12.0);  // within the grid's spacing
    else
      EXPECT_GT(error, 25.0);  // the case this test exists for: without the offsets the search fails
  }
}

TEST(RotationSearch, BadCoarseParametersThrow) {
  RotationSearchParams p;
  p.coarseOffsetStep = 0;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.coarseOffsetRadius = -0.1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.coarseOffsetRefineLevels = -1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.openSideShift = -0.1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.openSideScaleSlope = 1.0 / p.openSideShift;  // the scale of a shifted pose would be 0
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.fieldCells = 1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.fieldMargin = -1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.fieldMargin = std::numeric_limits<double>::infinity();
  EXPECT_THROW(p.validate(), std::invalid_argument);
  // The constructor validates too.
  p = {};
  p.coarseOffsetStep = -1;
  const Points s = lumpyShape(50, 1);
  EXPECT_THROW(RotationSearch(s, s, p), std::invalid_argument);
  // Off switches are valid: no field (k-d trees), no offsets.
  p = {};
  p.fieldCells = 0;
  p.coarseOffsetRadius = 0;
  p.coarseOffsetRefineLevels = 0;
  EXPECT_NO_THROW(p.validate());
}

TEST(RotationSearch, BadTranslationParametersThrow) {
  RotationSearchParams p;
  p.translationStep = 0;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.translationRadius = -1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.translationScales = {};
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.translationPoints = 4;
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

}  // namespace

