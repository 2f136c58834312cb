// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file sampling.hpp
/// @brief Make dense test clouds from a mesh (DESIGN §7): uniform or deliberately non-uniform surface
/// sampling, optional noise along the normal and outliers, always reproducible from a seed.

#include <cstdint>

#include "iires/types.hpp"

namespace iires {

struct MeshSamplingParams {
  std::size_t count = 100000;   ///< points to draw
  double densityRatio = 1.0;    ///< ≥ 1: density varies smoothly by this factor across the model (1 = uniform)
  double noise = 0.0;           ///< noise amplitude along the normal, absolute units (0 = none)
  bool gaussianNoise = true;    ///< true: N(0, noise²); false: uniform in [0, noise] (paper §6.1)
  double outlierFraction = 0.0; ///< share of points moved outlierMin..outlierMax along the normal
  double outlierMin = 0.0, outlierMax = 0.0;  ///< outlier offsets, absolute units
  std::uint64_t seed = 1;       ///< same seed → same cloud
};

/// @brief Draw points on the mesh surface (area-weighted triangles, uniform barycentrics); normals are the
/// face normals. With densityRatio > 1 the density is modulated along the longest bounding-box axis so the
/// densest part is densityRatio × the sparsest.
/// @throws InputError when the mesh has no triangles of positive area.
PointCloud sampleMesh(const TriangleMesh& mesh, const MeshSamplingParams& params);

}  // namespace iires
