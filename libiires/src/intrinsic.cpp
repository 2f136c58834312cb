// SPDX-License-Identifier: GPL-3.0-or-later
// The intrinsic neighbour rule: paper §3.2 ("efficient intrinsic control"), DESIGN §3 step 6.
#include "iires/intrinsic.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "iires/detail/parallel.hpp"
#include "iires/sheets.hpp"

namespace iires {
namespace {
const double kGapParallelCos = std::cos(25.0 * M_PI / 180.0);  // SheetParams::gapAngleDeg
// Plus this × the pair's distance: the samples' normals' error (SheetParams::heightSlope, ≈ 6°). Samples many
// dense spacings apart on one slightly wavy sheet (a noisy sheet's residue) otherwise meet the test.
constexpr double kGapSlope = 0.1;
}  // namespace

void IntrinsicParams::validate() const {
  auto fail = [](const std::string& m) { throw std::invalid_argument("IntrinsicParams: " + m); };
  if (!(slope >= 1.0) || !std::isfinite(slope)) fail("slope must be finite and >= 1");
  if (!(toleranceSpacings >= 0) || !std::isfinite(toleranceSpacings))
    fail("toleranceSpacings must be finite and >= 0");
  if (!(maxDistanceSpacings >= 0) || !std::isfinite(maxDistanceSpacings))
    fail("maxDistanceSpacings must be finite and >= 0 (0 = no bound)");
  if (!(gapSpacings >= 0) || !std::isfinite(gapSpacings)) fail("gapSpacings must be finite and >= 0 (0 = off)");
}

IntrinsicRule::IntrinsicRule(std::shared_ptr<const GeodesicCoordinates> geo, const IntrinsicParams& params,
                             const Execution& exec, std::vector<std::uint8_t> nearSheets)
    : geo_(std::move(geo)), params_(params), threads_(exec.threads), nearSheets_(std::move(nearSheets)) {
  if (!geo_) throw std::invalid_argument("IntrinsicRule: geodesic coordinates are null");
  if (!nearSheets_.empty() && nearSheets_.size() != geo_->size())
    throw std::invalid_argument("IntrinsicRule: nearSheets must hold one flag per dense point");
  params_.validate();
  tolerance_ = params_.toleranceSpacings * geo_->spacing();
  minGap_ = params_.gapSpacings * geo_->spacing();
  dims_ = static_cast<std::size_t>(geo_->dimensions());
}

void IntrinsicRule::update(const std::vector<Eigen::Vector3d>& samples, const std::vector<Eigen::Vector3d>& normals) {
  const std::size_t n = samples.size();
  pos_ = samples;
  const bool gapTest = minGap_ > 0 && !nearSheets_.empty() && normals.size() == n;
  nrm_ = gapTest ? normals : std::vector<Eigen::Vector3d>{};
  near_.assign(gapTest ? n : 0, 0);
  const std::size_t dims = dims_;
  dense_.assign(n, 0);
  comp_.assign(n, 0);
  scale_.assign(n, 1.0f);
  coords_.assign(n * dims, 0.0f);
  parallelFor(n, threads_, [&](std::size_t i) {
    const std::int64_t d = geo_->nearest(samples[i]);
    dense_[i] = static_cast<std::uint32_t>(d < 0 ? 0 : d);
    comp_[i] = geo_->component(dense_[i]);
    scale_[i] = geo_->localScales()[dense_[i]];
    std::copy_n(&geo_->coordinates()[dense_[i] * dims], dims, &coords_[i * dims]);
    if (gapTest) near_[i] = nearSheets_[dense_[i]];
  });
  // Sample spacing estimate: N samples on the dense cloud's area are about √(area / N) apart, and never closer
  // than the dense points (a random sampling's mean nearest-neighbour distance is half their spacing).
  // Generous by design: the bound only has to stop mirror points.
  maxDistance_ = 0;
  if (params_.maxDistanceSpacings > 0 && n > 0) {
    const double denseSpacing = 2.0 * geo_->spacing();
    const double sampleSpacing = std::max(denseSpacing, std::sqrt(geo_->area() / static_cast<double>(n)));
    maxDistance_ = params_.maxDistanceSpacings * sampleSpacing;
  }
}

bool IntrinsicRule::consistent(const float* ga, const float* gb, double d, double scale) const {
  if (maxDistance_ > 0 && d > maxDistance_) return false;
  // |gₛ(p) − gₛ(q)| ≤ d_geo(p, q) ≈ |p − q| for true neighbours (paper §3.2). The tolerance, in dense spacings,
  // grows by @p scale where the dense points are sampled more coarsely (their mapping's and the graph's errors
  // grow with their spacing).
  const double limit = params_.slope * d + tolerance_ * scale;
  for (std::size_t s = 0; s < dims_; ++s)
    if (std::abs(static_cast<double>(ga[s]) - gb[s]) > limit) return false;
  return true;
}

bool IntrinsicRule::accept(std::size_t i, std::size_t j) const {
  if (i == j) return true;
  const double d = (pos_[i] - pos_[j]).norm();
  if (comp_[i] != comp_[j]) return false;
  if (!consistent(&coords_[i * dims_], &coords_[j * dims_], d, std::max(scale_[i], scale_[j]))) return false;
  return near_.empty() || !(near_[i] || near_[j]) ||
         !acrossGap(pos_[i], nrm_[i], pos_[j], nrm_[j], minGap_ + kGapSlope * d, kGapParallelCos);
}

bool IntrinsicRule::acceptMove(std::size_t i, const Eigen::Vector3d& from, const Eigen::Vector3d& to) const {
  if (i >= near_.size() || !near_[i]) return true;
  // A step along the sheet keeps to its tangent plane; one onto the other sheet is offset along the normal by
  // the gap (the samples' gap test: minGap_ plus the normals' error over the step), and the geodesic
  // coordinates (noisy where a noisy gap is bridged) must confirm it.
  const Eigen::Vector3d d = to - from;
  if (std::abs(nrm_[i].dot(d)) < minGap_ + kGapSlope * d.norm()) return true;
  return acceptPoints(from, to);
}

bool IntrinsicRule::acceptPoints(const Eigen::Vector3d& p, const Eigen::Vector3d& q) const {
  const std::int64_t a = geo_->nearest(p), b = geo_->nearest(q);
  if (a < 0 || b < 0 || geo_->component(static_cast<std::size_t>(a)) != geo_->component(static_cast<std::size_t>(b)))
    return false;
  const auto ua = static_cast<std::size_t>(a), ub = static_cast<std::size_t>(b);
  return consistent(&geo_->coordinates()[ua * dims_], &geo_->coordinates()[ub * dims_], (p - q).norm(),
                    pairScale(ua, ub));
}

}  // namespace iires
