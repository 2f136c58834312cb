// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file intrinsic.hpp
/// @brief The intrinsic neighbour rule (paper §3.2; DESIGN §3 step 6): two samples may be neighbours only
/// when they lie on the same connected component of the cloud, their geodesic coordinates are consistent
/// with their Euclidean distance and their tangent planes do not face each other across a gap. Used by the
/// resampler (ResampleParams::neighbourRule) and by the reconstruction's 1-rings.
///
/// Why the test works: |gₛ(p) − gₛ(q)| ≤ d_geo(p, q) for every satellite s (triangle inequality), and for
/// true neighbours d_geo ≈ |p − q|. A pair that is close in space but far along the surface (across a thin
/// gap or a fold) shows a jump max_s |gₛ(p) − gₛ(q)| ≫ |p − q| for at least one satellite, unless all three
/// satellites happen to be equidistant from both — the limitation the paper accepts. Mirror points (equal G,
/// far apart in space, e.g. on a sphere) are rejected by the Euclidean bound.

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

#include "iires/execution.hpp"
#include "iires/geodesic.hpp"
#include "iires/neighbourhood.hpp"

namespace iires {

/// @brief Parameters of IntrinsicRule.
struct IntrinsicParams {
  /// c: reject a pair when max_s |gₛ(p) − gₛ(q)| > c·|p − q| + tolerance (≥ 1; 1.5 leaves room for the
  /// graph distances' error and curvature between neighbours).
  double slope = 1.5;
  /// The tolerance in units of the dense cloud's spacing (median nearest-neighbour distance): covers mapping
  /// each sample to its nearest dense point and the graph's discretisation (≥ 0). In a part sampled on a
  /// coarser scale than the rest (GeodesicCoordinates::localScales) it grows by that scale.
  double toleranceSpacings = 4.0;
  /// Euclidean bound: reject pairs farther apart than this many *sample* spacings (estimated from the dense
  /// spacing and the sample count), so the rule is safe on its own against mirror points. 0 = no bound.
  double maxDistanceSpacings = 6.0;
  /// The sheet rule's gap test on the samples themselves (sheets.hpp, acrossGap), where the dense cloud has
  /// another sheet near (IntrinsicRule's nearSheets): two samples whose tangent planes are within 25° of
  /// parallel, each beyond the other's plane, offset on average by at least this many dense spacings plus a
  /// tenth of their distance (the normals' error), lie on two sheets across a gap and are never neighbours —
  /// where the geodesic coordinates cannot tell (a plate's two faces are as far from every satellite; a stray
  /// point between two sheets links their graphs). Only there: samples many spacings apart on one sheet with an
  /// inflection between them (a bump's two sides) meet the test too. 0 = off.
  double gapSpacings = 1.25;

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief Neighbour rule: same component and consistent geodesic coordinates (and within the Euclidean bound).
/// @note update() maps each sample to its nearest dense point (O(N log n)); accept() is O(1), symmetric and
/// thread-safe (read-only). Deterministic for any thread count.
class IntrinsicRule final : public NeighbourRule {
 public:
  /// @param geo geodesic coordinates of the dense cloud the samples live on (shared, must not be null)
  /// @param exec the threads of update()
  /// @param nearSheets per dense point, 1 where the sheet rule found another sheet near (ResampleResult::
  /// nearSheets); the gap test applies to pairs with such a point nearest either sample (empty: nowhere)
  explicit IntrinsicRule(std::shared_ptr<const GeodesicCoordinates> geo, const IntrinsicParams& params = {},
                         const Execution& exec = {}, std::vector<std::uint8_t> nearSheets = {});

  void update(const std::vector<Eigen::Vector3d>& samples, const std::vector<Eigen::Vector3d>& normals) override;
  /// @brief Whether samples @p i and @p j (of the last update()) may be neighbours.
  bool accept(std::size_t i, std::size_t j) const override;
  /// @brief Where another sheet is near sample @p i (the gap test's samples), a step offset along its normal
  /// by the gap test's distance that acceptPoints(from, to) refuses: the projection carried it onto the other
  /// sheet. Elsewhere every step is accepted.
  bool acceptMove(std::size_t i, const Eigen::Vector3d& from, const Eigen::Vector3d& to) const override;

  /// @brief The same test for two arbitrary points (each mapped to its nearest dense point), independent of
  /// update(); uses the Euclidean bound of the last update() (none before the first).
  bool acceptPoints(const Eigen::Vector3d& p, const Eigen::Vector3d& q) const;

  /// @brief Component of sample @p i (its nearest dense point's component) after update().
  std::uint32_t component(std::size_t i) const { return comp_[i]; }
  /// @brief Nearest dense point of sample @p i after update().
  std::uint32_t densePoint(std::size_t i) const { return dense_[i]; }
  /// @brief Tolerance (absolute units) and Euclidean bound (absolute, 0 = none) in use.
  double tolerance() const { return tolerance_; }
  double maxDistance() const { return maxDistance_; }
  const GeodesicCoordinates& geodesic() const { return *geo_; }

 private:
  /// The distance and coordinate bounds between two points of one component with coordinates @p ga, @p gb.
  bool consistent(const float* ga, const float* gb, double d, double scale) const;
  /// The coarser of two dense points' sampling scales.
  double pairScale(std::size_t a, std::size_t b) const {
    return std::max(geo_->localScales()[a], geo_->localScales()[b]);
  }

  std::shared_ptr<const GeodesicCoordinates> geo_;
  IntrinsicParams params_;
  int threads_ = 0;
  double tolerance_ = 0;
  double maxDistance_ = 0;
  std::size_t dims_ = 0;  // geo_->dimensions(), asked once (accept() runs for every candidate pair)
  double minGap_ = 0;  // gapSpacings in absolute units (0 = off)
  std::vector<std::uint8_t> nearSheets_;  // per dense point
  std::vector<std::uint8_t> near_;        // per sample: its dense point has another sheet near
  std::vector<Eigen::Vector3d> pos_, nrm_;
  std::vector<std::uint32_t> dense_, comp_;  // per sample: its nearest dense point and that point's component
  std::vector<float> scale_;                 // per sample: that point's sampling scale
  std::vector<float> coords_;        // per sample: that point's geodesic coordinates, sample-major
};

}  // namespace iires
