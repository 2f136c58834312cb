// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/knn.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "shapes.hpp"

namespace {

std::vector<Eigen::Vector3d> randomPoints(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> p(n);
  for (auto& x : p) x = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return p;
}

TEST(KnnIndex, MatchesBruteForce) {
  const auto pts = randomPoints(2000, 7);
  iires::KnnIndex index(pts);
  const auto queries = randomPoints(50, 8);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (const auto& q : queries) {
    std::vector<std::pair<double, std::uint32_t>> all;
    for (std::uint32_t i = 0; i < pts.size(); ++i) all.emplace_back((pts[i] - q).squaredNorm(), i);
    std::sort(all.begin(), all.end());
    ASSERT_EQ(index.knn(q, 10, idx, d2), 10u);
    for (int j = 0; j < 10; ++j) {
      EXPECT_EQ(idx[j], all[j].second);
      EXPECT_NEAR(d2[j], all[j].first, 1e-12);
    }
    const double r = std::sqrt(all[30].first) - 1e-9;
    index.radius(q, r, idx, d2);
    EXPECT_EQ(idx.size(), 30u);
    for (std::size_t j = 0; j < idx.size(); ++j) EXPECT_EQ(idx[j], all[j].second);
    double nd2 = 0;
    EXPECT_EQ(index.nearest(q, &nd2), all[0].second);
    EXPECT_NEAR(nd2, all[0].first, 1e-12);
  }
}

TEST(KnnIndex, SmallAndEmptySets) {
  std::vector<Eigen::Vector3d> none;
  iires::KnnIndex empty(none);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  EXPECT_EQ(empty.knn(Eigen::Vector3d::Zero(), 5, idx, d2), 0u);
  EXPECT_EQ(empty.nearest(Eigen::Vector3d::Zero()), -1);
  std::vector<Eigen::Vector3d> two{{0, 0, 0}, {1, 0, 0}};
  iires::KnnIndex small(two);
  EXPECT_EQ(small.knn(Eigen::Vector3d(0.9, 0, 0), 5, idx, d2), 2u);
  EXPECT_EQ(idx[0], 1u);
}

TEST(NeighbourTable, PrefixesAreTheTreesAnswers) {
  const auto pts = randomPoints(3000, 9);
  const iires::KnnIndex index(pts);
  const iires::NeighbourTable table(index, pts, 25, 2);
  ASSERT_EQ(table.size(), pts.size());
  EXPECT_EQ(table.k(), 25u);
  std::vector<std::uint32_t> idx, want;
  std::vector<double> d2, wantD2;
  for (std::size_t i = 0; i < pts.size(); i += 7)
    for (std::size_t k : {1, 9, 17, 25}) {
      ASSERT_EQ(table.get(i, k, idx, d2), k);
      index.knn(pts[i], k, want, wantD2);
      EXPECT_EQ(idx, want) << "point " << i << ", k " << k;
      EXPECT_EQ(d2, wantD2) << "point " << i << ", k " << k;  // the same arithmetic as the tree's
    }
  // A set smaller than k: every row holds all points.
  const std::vector<Eigen::Vector3d> three{{0, 0, 0}, {1, 0, 0}, {3, 0, 0}};
  const iires::KnnIndex small(three);
  const iires::NeighbourTable rows(small, three, 8);
  EXPECT_EQ(rows.get(2, 8, idx, d2), 3u);
  EXPECT_EQ(idx, (std::vector<std::uint32_t>{2, 1, 0}));
  EXPECT_EQ(d2, (std::vector<double>{0, 4, 9}));
}

TEST(NeighbourTable, TruncatedRowsKeepTheirPrefixes) {
  const auto pts = randomPoints(2000, 10);
  const iires::KnnIndex index(pts);
  const iires::NeighbourTable full(index, pts, 25, 2);
  iires::NeighbourTable cut(index, pts, 25, 2);
  cut.truncate(17);
  EXPECT_EQ(cut.k(), 17u);
  std::vector<std::uint32_t> idx, want;
  std::vector<double> d2, wantD2;
  for (std::size_t i = 0; i < pts.size(); i += 3)
    for (std::size_t k : {1, 9, 17}) {
      ASSERT_EQ(cut.get(i, k, idx, d2), k);
      full.get(i, k, want, wantD2);
      EXPECT_EQ(idx, want) << "point " << i << ", k " << k;
      EXPECT_EQ(d2, wantD2);
    }
  cut.truncate(30);  // wider than the table: no effect
  EXPECT_EQ(cut.k(), 17u);
}

// Scan lines (a lidar's sampling: points 0.002 apart along lines 0.02 apart): every row away from the lines' ends
// reaches the next lines within its first nine entries (the MLS kernel width's 8th neighbour) and knows how far
// they are; with the k nearest alone every row lay on its own line. (At a line's end its 16 nearest already
// reach the next lines: no line there.)
TEST(NeighbourTable, RowsOnScanLinesReachTheNextLines) {
  const iires::PointCloud cloud = iires::test::scanLineCloud(5);
  const iires::KnnIndex index(cloud.points);
  const iires::NeighbourTable table(index, cloud.points, 17);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::size_t inner = 0, reach = 0, across = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (i % 500 < 25 || i % 500 >= 475) continue;  // 500 points per line
    ++inner;
    table.get(i, 9, idx, d2);
    reach += std::any_of(idx.begin(), idx.end(),
                         [&](std::uint32_t j) { return std::abs(cloud.points[j].y() - cloud.points[i].y()) > 0.01; });
    across += table.acrossLines(i) > 0.015 && table.acrossLines(i) < 0.03;
  }
  EXPECT_GT(reach, 0.99 * static_cast<double>(inner));
  EXPECT_GT(across, 0.99 * static_cast<double>(inner));
}

// An even sampling keeps the tree's rows exactly, even where a few points happen to line up (sphere seed 12: one
// point's 16 nearest lie on a line; its neighbours' do not, so it is no scan line).
TEST(NeighbourTable, AnEvenSamplingKeepsItsRows) {
  for (std::uint64_t seed : {11, 12, 13}) {
    const iires::PointCloud cloud = iires::test::sphereCloud(20000, 1.0, seed);
    const iires::KnnIndex index(cloud.points);
    const iires::NeighbourTable table(index, cloud.points, 17);
    std::vector<std::uint32_t> idx, expected;
    std::vector<double> d2;
    std::size_t changed = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      table.get(i, 17, idx, d2);
      index.knn(cloud.points[i], 17, expected, d2);
      changed += idx != expected || table.acrossLines(i) != 0.0f;
    }
    EXPECT_EQ(changed, 0u) << "seed " << seed;
  }
}

// A wire standing on a sphere (an antenna: points 0.0025 apart along it) is a line with no other line beside it:
// its rows stay on the wire, and in particular never reach the sphere it stands on (its rows reached sphere points
// up to 1.0 away when any point beside the line counted).
TEST(NeighbourTable, AWireStandingOnASurfaceDoesNotReachIt) {
  iires::PointCloud cloud = iires::test::sphereCloud(20000, 1.0, 2);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 0.001);
  for (int a = 0; a < 400; ++a) cloud.points.emplace_back(g(rng), g(rng), 1.0 + a / 399.0 + g(rng));
  const iires::KnnIndex index(cloud.points);
  const iires::NeighbourTable table(index, cloud.points, 17);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::size_t reaching = 0;
  for (std::size_t i = 20000; i < cloud.size(); ++i) {
    if (cloud.points[i].z() < 1.1) continue;  // the wire's foot is among sphere points anyway
    table.get(i, 17, idx, d2);
    reaching += std::any_of(idx.begin(), idx.end(), [](std::uint32_t j) { return j < 20000; });
  }
  EXPECT_EQ(reaching, 0u);
}

}  // namespace
