// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Synthetic shapes with known answers for the tests.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "iires/knn.hpp"
#include "iires/types.hpp"

namespace iires::test {

/// Random points on a sphere (uniform by area), outward normals.
inline PointCloud sphereCloud(std::size_t n, double radius = 1.0, std::uint64_t seed = 1,
                              const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    c.points.push_back(centre + radius * d);
    c.normals.push_back(d);
  }
  return c;
}

/// Two separate spheres sampled at very different densities, as the objects of a scan at different ranges: radius
/// 1 at the origin with @p denseCount points and radius 3 centred at (10, 0, 0) with a tenth of them (9× the area
/// with under a tenth of the points: a tenth of the density of the first, squared). Outward normals.
inline PointCloud twoDensitySpheres(std::size_t denseCount, std::uint64_t seed = 1) {
  PointCloud c = sphereCloud(denseCount, 1.0, seed);
  const PointCloud sparse = sphereCloud(denseCount / 10, 3.0, seed + 1, Eigen::Vector3d(10, 0, 0));
  c.points.insert(c.points.end(), sparse.points.begin(), sparse.points.end());
  c.normals.insert(c.normals.end(), sparse.normals.begin(), sparse.normals.end());
  return c;
}

/// A lidar-like sampling of the unit square (gently curved, z = 0.1·sin 3x·cos 2y): scan lines 0.02 apart along
/// y, points 0.002 apart along each (with 0.0003 and 0.001 of jitter), 25,000 in all; no normals. A point's 16
/// nearest all lie on its own line.
inline PointCloud scanLineCloud(std::uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  PointCloud c;
  for (int line = 0; line < 50; ++line)
    for (int a = 0; a < 500; ++a) {
      const double x = 0.002 * a + 0.0003 * g(rng), y = 0.02 * line + 0.001 * g(rng);
      c.points.emplace_back(x, y, 0.1 * std::sin(3 * x) * std::cos(2 * y));
    }
  return c;
}

/// A thin plate's two faces scanned by lines: the squares z = 0 and z = @p gap over [0,1]², each scanned along x by
/// 50 lines 0.02 apart (the top face's lines offset by 0.01 in y), points 0.002 apart along each (with 0.0003 and
/// 0.0005 of jitter), 50,000 in all; no normals.
inline PointCloud scannedSheets(double gap, std::uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  PointCloud c;
  for (int face = 0; face < 2; ++face)
    for (int line = 0; line < 50; ++line)
      for (int a = 0; a < 500; ++a)
        c.points.emplace_back(0.002 * a + 0.0003 * g(rng), 0.02 * line + 0.01 * face + 0.0005 * g(rng), gap * face);
  return c;
}

/// A floor as one scanner 1 above its corner sees it: @p count points on [0, 8]² (z = 0), the density falling with
/// the range as cos θ / r² (r² = 1 + x² + y²), so that the far corner is about 14 times more sparsely spaced than the
/// median. Positions only.
inline PointCloud floorFromCorner(std::size_t count, std::uint64_t seed = 5) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud c;
  while (c.size() < count) {
    const double x = 8 * u(rng), y = 8 * u(rng), r2 = 1 + x * x + y * y;
    if (u(rng) < std::pow(r2, -1.5)) c.points.emplace_back(x, y, 0.0);
  }
  return c;
}

/// A rotating scanner's rings on the ground: a sensor 1.7 above the z = 0 plane, 17 beams from 30° to 10°
/// below the horizon, a point every 0.3° of azimuth (jittered), so that the rings lie 0.15 apart near the
/// sensor and 1.1 apart at the outer ones (radius 2.9 to 9.7) while points along a ring are 0.015–0.05 apart.
/// Positions only.
inline PointCloud groundRings(std::uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  PointCloud c;
  for (int beam = 0; beam <= 16; ++beam)
    for (int a = 0; a < 1200; ++a) {
      const double elevation = (30.0 - 1.25 * beam) * M_PI / 180.0 + 0.0005 * g(rng);
      const double azimuth = (0.3 * a) * M_PI / 180.0 + 0.0005 * g(rng), r = 1.7 / std::tan(elevation);
      c.points.emplace_back(r * std::cos(azimuth), r * std::sin(azimuth), 0.003 * g(rng));
    }
  return c;
}

/// Random points on the square [0,size]² in the z = 0 plane; density grows by @p ratio along x.
inline PointCloud planeCloud(std::size_t n, double size = 1.0, double ratio = 1.0, std::uint64_t seed = 2) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud c;
  while (c.points.size() < n) {
    const double x = u(rng), y = u(rng);
    if (u(rng) * ratio > 1.0 + (ratio - 1.0) * x) continue;  // accept with weight 1 + (ratio − 1) x
    c.points.emplace_back(size * x, size * y, 0.0);
  }
  return c;
}

/// A regular grid on the unit sphere's octahedral parameterisation is overkill; a Fibonacci sphere is
/// near-uniform and deterministic.
inline std::vector<Eigen::Vector3d> fibonacciSphere(std::size_t n, double radius = 1.0) {
  std::vector<Eigen::Vector3d> p;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (static_cast<double>(i) + 0.5) / static_cast<double>(n);
    const double r = std::sqrt(1.0 - z * z), t = golden * static_cast<double>(i);
    p.emplace_back(radius * r * std::cos(t), radius * r * std::sin(t), radius * z);
  }
  return p;
}

/// The U-shaped strip of issue 3: bottom square z = 0 and top square z = gap over [0,1]², joined at x = 1 by
/// a half-cylinder of radius gap/2 (axis along y). Uniform random points, perSquare per square and the same
/// density on the cylinder; outward normals (bottom −z, top +z, cylinder radial).
inline PointCloud uStrip(std::size_t perSquare, double gap, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud c;
  const double r = gap / 2;
  for (int sheet = 0; sheet < 2; ++sheet)
    for (std::size_t i = 0; i < perSquare; ++i) {
      const double x = u(rng), y = u(rng);
      c.points.emplace_back(x, y, sheet ? gap : 0.0);
      c.normals.emplace_back(0, 0, sheet ? 1 : -1);
    }
  const auto nc = static_cast<std::size_t>(std::lround(M_PI * r * static_cast<double>(perSquare)));
  for (std::size_t i = 0; i < nc; ++i) {
    const double th = M_PI * u(rng), y = u(rng);
    c.points.emplace_back(1 + r * std::sin(th), y, r - r * std::cos(th));
    c.normals.emplace_back(std::sin(th), 0, -std::cos(th));
  }
  return c;
}


// Thin parts and near-contact surfaces with known answers (issue 19): two sheets joined by a fold, a thin
// closed plate, two spheres nearly touching, a sphere inside a sphere. Every case is sampled uniformly at
// random by area with a fixed seed; the gap is given in *input spacings*, the project's spacing of a cloud
// (mean distance to the nearest neighbour), which for a uniform random sampling of density ρ is 0.5/√ρ.
// Used by the tests (small clouds) and by bench/thin_parts_bench (large ones).


/// @p m without the faces @p drop(face) selects (a hole cut into a mesh).
template <class Drop>
TriangleMesh withoutFaces(TriangleMesh m, Drop drop) {
  std::vector<Eigen::Vector3i> kept;
  for (const auto& t : m.triangles)
    if (!drop(t)) kept.push_back(t);
  m.triangles = std::move(kept);
  return m;
}

/// Whether face @p t of @p m has a corner below height @p z.
inline bool hasCornerBelow(const TriangleMesh& m, const Eigen::Vector3i& t, double z) {
  for (int k = 0; k < 3; ++k)
    if (m.vertices[static_cast<std::size_t>(t[k])].z() < z) return true;
  return false;
}

/// The cube [0, size]³ as 12 triangles, outward.
inline TriangleMesh cubeMesh(double size = 1.0) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(size * (i & 1), size * ((i >> 1) & 1), size * ((i >> 2) & 1));
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& t : f) m.triangles.emplace_back(t[0], t[1], t[2]);
  return m;
}

/// A closed right prism over a regular @p sides-gon of circumradius @p radius, @p height tall, outward: its side
/// faces meet at creases whose normals are 360°/sides apart (a triangle's: an acute 60° edge).
inline TriangleMesh prismMesh(int sides, double radius, double height) {
  TriangleMesh m;
  for (int z = 0; z < 2; ++z)
    for (int k = 0; k < sides; ++k)
      m.vertices.emplace_back(radius * std::cos(2 * M_PI * k / sides), radius * std::sin(2 * M_PI * k / sides),
                              height * z);
  m.vertices.emplace_back(0, 0, 0);
  m.vertices.emplace_back(0, 0, height);
  const int bottom = 2 * sides, top = bottom + 1;
  for (int k = 0; k < sides; ++k) {
    const int a = k, b = (k + 1) % sides;
    m.triangles.emplace_back(a, b, b + sides);
    m.triangles.emplace_back(a, b + sides, a + sides);
    m.triangles.emplace_back(bottom, b, a);
    m.triangles.emplace_back(top, a + sides, b + sides);
  }
  return m;
}

/// A closed UV sphere (no intersections by construction).
inline TriangleMesh uvSphereMesh(int rings, int segments) {
  TriangleMesh m;
  m.vertices.emplace_back(0, 0, 1);
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double th = M_PI * r / rings, ph = 2 * M_PI * s / segments;
      m.vertices.emplace_back(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
    }
  m.vertices.emplace_back(0, 0, -1);
  const int south = static_cast<int>(m.vertices.size()) - 1;
  auto at = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) {
    m.triangles.emplace_back(0, at(1, s), at(1, s + 1));
    m.triangles.emplace_back(south, at(rings - 1, s + 1), at(rings - 1, s));
  }
  for (int r = 1; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      m.triangles.emplace_back(at(r, s), at(r + 1, s), at(r + 1, s + 1));
      m.triangles.emplace_back(at(r, s), at(r + 1, s + 1), at(r, s + 1));
    }
  return m;
}

/// A closed torus about the z axis (ring radius @p ring, tube radius @p tube), @p around × @p across quads as
/// triangles, outward.
inline TriangleMesh torusMesh(double ring, double tube, int around, int across) {
  TriangleMesh m;
  for (int i = 0; i < around; ++i)
    for (int j = 0; j < across; ++j) {
      const double u = 2 * M_PI * i / around, v = 2 * M_PI * j / across, rho = ring + tube * std::cos(v);
      m.vertices.emplace_back(rho * std::cos(u), rho * std::sin(u), tube * std::sin(v));
    }
  auto at = [&](int i, int j) { return (i % around) * across + (j % across); };
  for (int i = 0; i < around; ++i)
    for (int j = 0; j < across; ++j) {
      m.triangles.emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      m.triangles.emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  return m;
}

/// A profile scanner's slices of @p mesh: the contours cut by @p planes planes evenly across its longest axis,
/// sampled at random along each contour segment (mean step @p step times the planes' distance) with Gaussian
/// jitter (each coordinate) of @p jitter times the step. Positions only.
inline PointCloud sliceContours(const TriangleMesh& mesh, int planes, std::uint64_t seed, double step = 0.1,
                                double jitter = 0.03) {
  Eigen::Vector3d lo = mesh.vertices.front(), hi = lo;
  for (const auto& v : mesh.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const double gap = (hi[axis] - lo[axis]) / planes;
  step *= gap;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, jitter * step);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud c;
  for (int s = 0; s < planes; ++s) {
    const double level = lo[axis] + gap * (s + 0.5);
    for (const auto& t : mesh.triangles) {
      std::vector<Eigen::Vector3d> ends;
      for (int e = 0; e < 3; ++e) {
        const Eigen::Vector3d &a = mesh.vertices[t[e]], &b = mesh.vertices[t[(e + 1) % 3]];
        if ((a[axis] < level) != (b[axis] < level))
          ends.push_back(a + (level - a[axis]) / (b[axis] - a[axis]) * (b - a));
      }
      if (ends.size() != 2) continue;
      std::poisson_distribution<int> count((ends[1] - ends[0]).norm() / step);
      for (int k = count(rng); k > 0; --k)
        c.points.push_back(ends[0] + u(rng) * (ends[1] - ends[0]) +
                           Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    }
  }
  return c;
}

/// A closed genus-1 polyhedron with sharp creases: a ring of triangular cross-section (outer corner at radius 1 in
/// the plane z = 0, inner corners at radius 0.4 and z = ±h) swept around an equilateral triangle; 9 vertices, 9
/// planar quads as 18 triangles, outward. The rims of its triangular hole are convex edges of 41° (the faces'
/// normals differ by 139°), the hole's own edges concave ones of 300° (normals 120° apart), the rest 98° and flat.
inline TriangleMesh triangularRing() {
  const double h = std::tan(49.0 * M_PI / 180.0) * 0.3;  // the top faces rise 49° over the inradii's difference
  TriangleMesh m;
  for (int k = 0; k < 3; ++k) {
    const double a = (90.0 + 120.0 * k) * M_PI / 180.0;
    m.vertices.emplace_back(std::cos(a), std::sin(a), 0.0);               // outer
    m.vertices.emplace_back(0.4 * std::cos(a), 0.4 * std::sin(a), h);     // inner top
    m.vertices.emplace_back(0.4 * std::cos(a), 0.4 * std::sin(a), -h);    // inner bottom
  }
  auto quad = [&m](int a, int b, int c, int d) {
    m.triangles.emplace_back(a, b, c);
    m.triangles.emplace_back(a, c, d);
  };
  for (int k = 0; k < 3; ++k) {
    const int o = 3 * k, t = o + 1, b = o + 2, o1 = 3 * ((k + 1) % 3), t1 = o1 + 1, b1 = o1 + 2;
    quad(o, o1, t1, t);  // top
    quad(o1, o, b, b1);  // bottom
    quad(t, t1, b1, b);  // the hole
  }
  return m;
}

/// A generated thin case: the cloud (outward unit normals), its input spacing and gap, and the truth.
struct ThinCase {
  std::string name;
  PointCloud cloud;
  double spacing = 0;  ///< mean nearest-neighbour distance of the sampling (0.5/√ρ)
  double gap = 0;      ///< distance between the two surfaces that nearly touch
  int kind = 0;        ///< 0 folded sheets, 1 plate, 2 two spheres, 3 sphere in sphere
  double size = 1;     ///< sheets/plate: side; spheres: radius of the (outer/first) sphere
  int components = 1;  ///< connected surfaces
  int genus = 0;       ///< genus of each component

  /// Distance from @p p to the true surface.
  double distance(const Eigen::Vector3d& p) const;
  /// Which of the two near surfaces @p p belongs to (0 or 1), or −1 for points on the fold (within a gap of
  /// it) or the plate's rim (within two gaps of its edges: the rim face and the rounded creases beside it).
  int side(const Eigen::Vector3d& p) const;
};

namespace thin {
inline Eigen::Vector3d gaussianDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Vector3d d(g(rng), g(rng), g(rng));
  return d.normalized();
}
/// Gap in absolute units for @p count points on a surface of area area(gap) (fixed point: the area may
/// depend on the gap).
template <typename Area>
double solveGap(std::size_t count, double gapSpacings, Area area, double& spacing) {
  double gap = 0;
  for (int it = 0; it < 20; ++it) {
    spacing = 0.5 / std::sqrt(static_cast<double>(count) / area(gap));
    gap = gapSpacings * spacing;
  }
  return gap;
}
inline void addNoise(PointCloud& c, double sigma, std::mt19937_64& rng) {
  if (sigma <= 0) return;
  std::normal_distribution<double> g(0.0, sigma);
  for (std::size_t i = 0; i < c.size(); ++i) c.points[i] += g(rng) * c.normals[i];
}
}  // namespace thin

/// Two unit squares z = 0 and z = gap over [0,1]², joined at x = 1 by a half-cylinder of radius gap/2.
/// @param noiseSpacings Gaussian noise along the normal, σ in input spacings
inline ThinCase foldedSheets(std::size_t count, double gapSpacings, double noiseSpacings, std::uint64_t seed) {
  ThinCase t;
  t.name = "folded-sheets";
  t.kind = 0;
  t.gap = thin::solveGap(count, gapSpacings, [](double g) { return 2.0 + M_PI * g / 2; }, t.spacing);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double r = t.gap / 2, area = 2.0 + M_PI * r;
  for (std::size_t i = 0; i < count; ++i) {
    const double pick = u(rng) * area;
    if (pick < 2.0) {
      const int sheet = pick < 1.0 ? 0 : 1;
      t.cloud.points.emplace_back(u(rng), u(rng), sheet ? t.gap : 0.0);
      t.cloud.normals.emplace_back(0, 0, sheet ? 1 : -1);
    } else {
      const double th = M_PI * u(rng), y = u(rng);
      t.cloud.points.emplace_back(1 + r * std::sin(th), y, r - r * std::cos(th));
      t.cloud.normals.emplace_back(std::sin(th), 0, -std::cos(th));
    }
  }
  thin::addNoise(t.cloud, noiseSpacings * t.spacing, rng);
  return t;
}

/// A closed box [0,1]² × [0, t], t = gapSpacings input spacings, every face sampled.
inline ThinCase thinPlate(std::size_t count, double gapSpacings, double noiseSpacings, std::uint64_t seed) {
  ThinCase t;
  t.name = "plate";
  t.kind = 1;
  t.gap = thin::solveGap(count, gapSpacings, [](double g) { return 2.0 + 4.0 * g; }, t.spacing);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double g = t.gap, area = 2.0 + 4.0 * g;
  for (std::size_t i = 0; i < count; ++i) {
    double pick = u(rng) * area;
    const double a = u(rng), b = u(rng);
    if (pick < 2.0) {
      const int top = pick < 1.0 ? 0 : 1;
      t.cloud.points.emplace_back(a, b, top ? g : 0.0);
      t.cloud.normals.emplace_back(0, 0, top ? 1 : -1);
      continue;
    }
    pick = (pick - 2.0) / g;  // which rim face: [0, 4)
    const int face = std::min(3, static_cast<int>(pick));
    const double z = b * g;
    if (face == 0) t.cloud.points.emplace_back(0, a, z), t.cloud.normals.emplace_back(-1, 0, 0);
    if (face == 1) t.cloud.points.emplace_back(1, a, z), t.cloud.normals.emplace_back(1, 0, 0);
    if (face == 2) t.cloud.points.emplace_back(a, 0, z), t.cloud.normals.emplace_back(0, -1, 0);
    if (face == 3) t.cloud.points.emplace_back(a, 1, z), t.cloud.normals.emplace_back(0, 1, 0);
  }
  thin::addNoise(t.cloud, noiseSpacings * t.spacing, rng);
  return t;
}

/// Two unit spheres whose surfaces are gapSpacings input spacings apart (centres on the x axis).
inline ThinCase twoSpheres(std::size_t count, double gapSpacings, double noiseSpacings, std::uint64_t seed) {
  ThinCase t;
  t.name = "two-spheres";
  t.kind = 2;
  t.components = 2;
  t.gap = thin::solveGap(count, gapSpacings, [](double) { return 8.0 * M_PI; }, t.spacing);
  std::mt19937_64 rng(seed);
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector3d d = thin::gaussianDirection(rng);
    const double cx = i % 2 ? 1.0 + t.gap / 2 : -1.0 - t.gap / 2;
    t.cloud.points.push_back(Eigen::Vector3d(cx, 0, 0) + d);
    t.cloud.normals.push_back(d);
  }
  thin::addNoise(t.cloud, noiseSpacings * t.spacing, rng);
  return t;
}

/// A unit sphere inside a sphere of radius 1 + gap (same centre), both sampled at the same density.
inline ThinCase nestedSpheres(std::size_t count, double gapSpacings, double noiseSpacings, std::uint64_t seed) {
  ThinCase t;
  t.name = "nested-spheres";
  t.kind = 3;
  t.components = 2;
  t.gap = thin::solveGap(
      count, gapSpacings, [](double g) { return 4.0 * M_PI * (1.0 + (1.0 + g) * (1.0 + g)); }, t.spacing);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double outer = 1.0 + t.gap, share = 1.0 / (1.0 + outer * outer);
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector3d d = thin::gaussianDirection(rng);
    t.cloud.points.push_back((u(rng) < share ? 1.0 : outer) * d);
    t.cloud.normals.push_back(d);
  }
  thin::addNoise(t.cloud, noiseSpacings * t.spacing, rng);
  return t;
}

inline double ThinCase::distance(const Eigen::Vector3d& p) const {
  auto clamp01 = [](double v) { return std::clamp(v, 0.0, 1.0); };
  switch (kind) {
    case 0: {
      const double r = gap / 2, dy = p.y() - clamp01(p.y());
      double best = 1e300;
      for (double z : {0.0, gap}) {
        const double dx = p.x() - std::min(p.x(), 1.0) + std::min(0.0, p.x());
        best = std::min(best, std::sqrt(dx * dx + dy * dy + (p.z() - z) * (p.z() - z)));
      }
      if (p.x() >= 1.0) {
        const double radial = std::abs(Eigen::Vector2d(p.x() - 1.0, p.z() - r).norm() - r);
        best = std::min(best, std::sqrt(radial * radial + dy * dy));
      }
      return best;
    }
    case 1: {  // distance to the box surface
      const Eigen::Vector3d lo(0, 0, 0), hi(1, 1, gap);
      const Eigen::Vector3d c = p.cwiseMax(lo).cwiseMin(hi);
      if (c != p) return (p - c).norm();
      return std::min({p.x(), 1 - p.x(), p.y(), 1 - p.y(), p.z(), gap - p.z()});
    }
    case 2: {
      const double a = (p - Eigen::Vector3d(-1 - gap / 2, 0, 0)).norm(), b = (p - Eigen::Vector3d(1 + gap / 2, 0, 0)).norm();
      return std::min(std::abs(a - 1), std::abs(b - 1));
    }
    default: {
      const double r = p.norm();
      return std::min(std::abs(r - 1), std::abs(r - 1 - gap));
    }
  }
}

inline int ThinCase::side(const Eigen::Vector3d& p) const {
  switch (kind) {
    case 0:
      return p.x() > 1.0 - gap ? -1 : (p.z() < gap / 2 ? 0 : 1);
    case 1:
      return std::min({p.x(), 1 - p.x(), p.y(), 1 - p.y()}) < 2 * gap ? -1 : (p.z() < gap / 2 ? 0 : 1);
    case 2:
      return p.x() < 0 ? 0 : 1;  // the whole spheres: their areas are equal
    default:
      return p.norm() < 1.0 + gap / 2 ? 0 : 1;
  }
}

/// Nearest-neighbour spacing cv of @p points, each near surface's points among their own (across a gap
/// narrower than the output spacing the straight-line nearest neighbour is on the other surface); points on
/// the fold or the rim are not counted.
inline double sideSpacingCv(const ThinCase& t, const std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector3d> part[2];
  for (const auto& p : points)
    if (const int s = t.side(p); s >= 0) part[s].push_back(p);
  double sum = 0, sq = 0, count = 0;
  for (const auto& pts : part) {
    if (pts.size() < 2) continue;
    const KnnIndex index(pts);
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    for (const auto& p : pts) {
      index.knn(p, 2, idx, d2);
      const double d = std::sqrt(d2[1]);
      sum += d, sq += d * d, ++count;
    }
  }
  const double mean = sum / count;
  return std::sqrt(std::max(0.0, sq / count - mean * mean)) / mean;
}

}  // namespace iires::test
