// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file advancing_front.hpp
/// @brief CGAL's advancing-front surface reconstruction (Cohen-Steiner & Da 2004; the paper's ref. [60]),
/// offered as a second method and as the baseline the local method is compared against.

#include <cstddef>

#include "iires/types.hpp"

namespace iires {

/// @brief Parameters of advancingFront() (CGAL's names and defaults).
struct AdvancingFrontParams {
  double radiusRatioBound = 5.0;  ///< candidate facets with a larger radius ratio are not taken first [CGAL 5]
  double beta = 0.52;             ///< angle bound (radians) for sliver facets [CGAL 0.52 ≈ 30°]

  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief What advancingFront() produced.
struct AdvancingFrontResult {
  TriangleMesh mesh;  ///< vertices = the input points (same order)
};

/// @brief Run CGAL::advancing_front_surface_reconstruction on the points of @p cloud (normals are not used).
/// @throws InputError for fewer than 4 points or non-finite coordinates.
/// @note Sequential (CGAL's 3-D Delaunay triangulation). The facets come sorted, each from its lowest vertex;
/// which facets CGAL keeps may depend on memory addresses where edges tie in priority.
AdvancingFrontResult advancingFront(const PointCloud& cloud, const AdvancingFrontParams& params = {});

}  // namespace iires
