// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Mesh helpers shared by the reconstruction tests (they need libreconstruct).
#include <gtest/gtest.h>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/triangulate.hpp"
#include "shapes.hpp"

namespace iires::test {

/// Signed volume of a closed mesh (positive when its faces point outward).
inline double signedVolume(const TriangleMesh& m) {
  double v = 0;
  for (const auto& t : m.triangles)
    v += m.vertices[t[0]].dot(m.vertices[t[1]].cross(m.vertices[t[2]])) / 6.0;
  return v;
}

/// One closed, oriented, manifold component with Euler characteristic @p euler.
inline void expectClosedGenus(const MeshQuality& q, long long euler) {
  EXPECT_EQ(q.boundaryEdges, 0u);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 0u);
  EXPECT_TRUE(q.closed);
  EXPECT_TRUE(q.oriented);
  EXPECT_EQ(q.components, 1u);
  EXPECT_EQ(q.euler, euler);
}

/// The local triangulation of a 3,000-point Fibonacci unit sphere (outward normals, its cloud in @p cloud): a
/// closed mesh to punch holes in.
inline TriangleMesh sphereMesh(PointCloud& cloud) {
  cloud.points = fibonacciSphere(3000);
  cloud.normals = cloud.points;
  return triangulateLocal(cloud).mesh;
}

}  // namespace iires::test
