// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file tangent_cell.hpp
/// @brief A sample's cell in its tangent plane: a convex polygon around the origin (the sample) clipped by the
/// bisectors of its neighbours. Each polygon edge carries the label of the neighbour that made it, so the labels
/// left on the final polygon are the sample's Delaunay 1-ring. Shared by the resampler and the reconstruction.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

namespace iires {

/// @brief Clip the convex polygon @p v (edge e runs from v[e] to v[e+1] and carries lab[e]) by the half-plane
/// {x : x·q ≤ t·|q|²} — with t = 1/2 the bisector between the origin and q; other t weight it (adaptive sizes).
/// The new edge carries @p label. @p outV / @p outL are scratch buffers (swapped in).
void clipByBisector(std::vector<Eigen::Vector2d>& v, std::vector<std::uint32_t>& lab, const Eigen::Vector2d& q,
                    double t, std::uint32_t label, std::vector<Eigen::Vector2d>& outV,
                    std::vector<std::uint32_t>& outL);

/// @brief Area centroid of a simple polygon (the origin for a degenerate one).
Eigen::Vector2d polygonCentroid(const std::vector<Eigen::Vector2d>& v);

/// @brief A monotone stand-in for the angle of the unit vector @p d, in [0, 4): sorts directions counter-clockwise
/// from +x like atan2 does from −x, without the transcendental call.
double pseudoAngle(const Eigen::Vector2d& d);

/// @brief The counter-clockwise gap from unit direction @p from to the next one @p to of a 1-ring: its bisector
/// when the gap is wider than 135°, else nothing. @p full: the two are the same direction and the gap is the whole
/// circle (a ring with one direction).
std::optional<Eigen::Vector2d> gapBisector(const Eigen::Vector2d& from, const Eigen::Vector2d& to, bool full);

}  // namespace iires
