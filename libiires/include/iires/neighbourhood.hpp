// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file neighbourhood.hpp
/// @brief The neighbour rule: which of a sample's Euclidean candidates count as its neighbours.
/// The resampler (and later the reconstruction) asks the rule, so Euclidean and intrinsic (geodesic)
/// neighbourhoods are interchangeable.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace iires {

/// @brief Decides whether two samples may be neighbours.
class NeighbourRule {
 public:
  virtual ~NeighbourRule() = default;
  /// @brief Called whenever the sample set changed (before any accept() on it).
  virtual void update(const std::vector<Eigen::Vector3d>& samples, const std::vector<Eigen::Vector3d>& normals) {
    (void)samples;
    (void)normals;
  }
  /// @brief Whether candidate @p j (one of sample @p i's Euclidean nearest neighbours) is a neighbour of @p i.
  /// @note Must be symmetric and thread-safe (called concurrently).
  virtual bool accept(std::size_t i, std::size_t j) const = 0;
  /// @brief Whether sample @p i may move from @p from to @p to (a relaxation step projected onto the surface):
  /// false where the step left its sheet for another one a gap away. Thread-safe.
  virtual bool acceptMove(std::size_t i, const Eigen::Vector3d& from, const Eigen::Vector3d& to) const {
    (void)i;
    (void)from;
    (void)to;
    return true;
  }
};

/// @brief Plain Euclidean neighbourhoods: every candidate is accepted.
class EuclideanRule final : public NeighbourRule {
 public:
  bool accept(std::size_t, std::size_t) const override { return true; }
};

}  // namespace iires
