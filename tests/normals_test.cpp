#include "iires/normals.hpp"

#include <gtest/gtest.h>

#include "shapes.hpp"

namespace {

TEST(Normals, SphereNormalsAreRadialAndOutward) {
  const auto cloud = iires::test::sphereCloud(5000, 2.0, 3);
  for (int threads : {1, 2}) {
    iires::NormalParams p;
    p.threads = threads;
    const auto n = iires::estimateNormals(cloud.points, p);
    ASSERT_EQ(n.size(), cloud.size());
    for (std::size_t i = 0; i < n.size(); ++i) {
      EXPECT_NEAR(n[i].norm(), 1.0, 1e-9);
      EXPECT_GT(n[i].dot(cloud.points[i].normalized()), 0.95) << "point " << i;
    }
  }
}

TEST(Normals, TwoSpheresEachOrientedOutward) {
  auto a = iires::test::sphereCloud(3000, 1.0, 4);
  const auto b = iires::test::sphereCloud(3000, 1.0, 5, Eigen::Vector3d(5, 0, 0));
  a.points.insert(a.points.end(), b.points.begin(), b.points.end());
  const auto n = iires::estimateNormals(a.points);
  for (std::size_t i = 0; i < n.size(); ++i) {
    const Eigen::Vector3d c = i < 3000 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(5, 0, 0);
    EXPECT_GT(n[i].dot((a.points[i] - c).normalized()), 0.95) << "point " << i;
  }
}

TEST(Normals, DeterministicAcrossThreadCounts) {
  const auto cloud = iires::test::planeCloud(4000, 1.0, 5.0);
  iires::NormalParams one, two;
  one.threads = 1;
  two.threads = 2;
  EXPECT_EQ(iires::estimateNormals(cloud.points, one), iires::estimateNormals(cloud.points, two));
}

}  // namespace
