// The intrinsic neighbour rule: paper §3.2 ("efficient intrinsic control"), DESIGN §3 step 6.
#include "iires/intrinsic.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "iires/parallel.hpp"

namespace iires {

void IntrinsicParams::validate() const {
  auto fail = [](const std::string& m) { throw std::invalid_argument("IntrinsicParams: " + m); };
  if (!(slope >= 1.0) || !std::isfinite(slope)) fail("slope must be finite and >= 1");
  if (!(toleranceSpacings >= 0) || !std::isfinite(toleranceSpacings))
    fail("toleranceSpacings must be finite and >= 0");
  if (!(maxDistanceSpacings >= 0) || !std::isfinite(maxDistanceSpacings))
    fail("maxDistanceSpacings must be finite and >= 0 (0 = no bound)");
  if (threads < 0) fail("threads must be >= 0 (0 = all cores)");
}

IntrinsicRule::IntrinsicRule(std::shared_ptr<const GeodesicCoordinates> geo, const IntrinsicParams& params)
    : geo_(std::move(geo)), params_(params) {
  if (!geo_) throw std::invalid_argument("IntrinsicRule: geodesic coordinates are null");
  params_.validate();
  tolerance_ = params_.toleranceSpacings * geo_->spacing();
}

void IntrinsicRule::update(const std::vector<Eigen::Vector3d>& samples, const std::vector<Eigen::Vector3d>&) {
  const std::size_t n = samples.size();
  pos_ = samples;
  dense_.assign(n, 0);
  comp_.assign(n, 0);
  parallelFor(n, params_.threads, [&](std::size_t i) {
    const std::int64_t d = geo_->nearest(samples[i]);
    dense_[i] = static_cast<std::uint32_t>(d < 0 ? 0 : d);
    comp_[i] = geo_->component(dense_[i]);
  });
  // Sample spacing estimate: the dense cloud covers about size()·(2·spacing)² of surface (a random sampling's
  // mean nearest-neighbour distance is half its hexagonal spacing); N samples on it are about
  // √(area / N) apart. Generous by design: the bound only has to stop mirror points.
  maxDistance_ = 0;
  if (params_.maxDistanceSpacings > 0 && n > 0) {
    const double denseSpacing = 2.0 * geo_->spacing();
    const double sampleSpacing =
        std::max(denseSpacing, denseSpacing * std::sqrt(static_cast<double>(geo_->size()) / static_cast<double>(n)));
    maxDistance_ = params_.maxDistanceSpacings * sampleSpacing;
  }
}

bool IntrinsicRule::consistent(std::uint32_t a, std::uint32_t b, double d) const {
  if (geo_->component(a) != geo_->component(b)) return false;
  if (maxDistance_ > 0 && d > maxDistance_) return false;
  // |gₛ(p) − gₛ(q)| ≤ d_geo(p, q) ≈ |p − q| for true neighbours (paper §3.2).
  const double limit = params_.slope * d + tolerance_;
  for (int s = 0; s < geo_->dimensions(); ++s)
    if (std::abs(static_cast<double>(geo_->coordinate(a, s)) - geo_->coordinate(b, s)) > limit) return false;
  return true;
}

bool IntrinsicRule::accept(std::size_t i, std::size_t j) const {
  if (i == j) return true;
  return consistent(dense_[i], dense_[j], (pos_[i] - pos_[j]).norm());
}

bool IntrinsicRule::acceptPoints(const Eigen::Vector3d& p, const Eigen::Vector3d& q) const {
  const std::int64_t a = geo_->nearest(p), b = geo_->nearest(q);
  if (a < 0 || b < 0) return false;
  return consistent(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b), (p - q).norm());
}

}  // namespace iires
