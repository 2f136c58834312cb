// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/reconstruct/advancing_front.hpp"

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace iires {

void AdvancingFrontParams::validate() const {
  if (!(radiusRatioBound > 0)) throw std::invalid_argument("advancing front: radiusRatioBound must be positive");
  if (!(beta > 0 && beta < M_PI)) throw std::invalid_argument("advancing front: beta must be in (0, pi)");
}

AdvancingFrontResult advancingFront(const PointCloud& cloud, const AdvancingFrontParams& params) {
  params.validate();
  using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
  if (cloud.size() < 4)
    throw InputError("advancing front needs at least 4 points (got " + std::to_string(cloud.size()) + ")");
  std::vector<Kernel::Point_3> points;
  points.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points[i];
    if (!p.allFinite()) throw InputError("point " + std::to_string(i) + " has a non-finite coordinate");
    points.emplace_back(p.x(), p.y(), p.z());
  }
  std::vector<std::array<std::size_t, 3>> facets;
  CGAL::advancing_front_surface_reconstruction(points.begin(), points.end(), std::back_inserter(facets),
                                               params.radiusRatioBound, params.beta);
  // CGAL lists the facets in an order that follows its cells' addresses, which differ from run to run: each
  // facet starts at its lowest vertex (its orientation kept) and the list is sorted, so that the same facets give
  // the same mesh after the later stages and the same file. (CGAL also breaks ties between edges of equal priority
  // by address, which can change the facets themselves: see the README.)
  for (auto& f : facets) std::rotate(f.begin(), std::min_element(f.begin(), f.end()), f.end());
  std::sort(facets.begin(), facets.end());
  AdvancingFrontResult result;
  result.mesh.vertices = cloud.points;
  result.mesh.triangles.reserve(facets.size());
  for (const auto& f : facets)
    result.mesh.triangles.emplace_back(static_cast<int>(f[0]), static_cast<int>(f[1]), static_cast<int>(f[2]));
  return result;
}

}  // namespace iires
