// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/outliers.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "iires/denoise.hpp"
#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"
#include "tangent_hull.hpp"

namespace iires {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kMaxRounds = 6;  // of the outlier test: scattered outliers are gone after three or four
constexpr std::size_t kSpacingNeighbours = 6;  // l = mean distance to the 6 nearest neighbours (paper §6.1)
constexpr std::size_t kNearPlaneSheets = 4;  // a flagged point's trusted neighbours whose planes are tried
// How far past the trusted points around it, on its plane, a pulled point may land, in units of the fit's radius h:
// a true outlier by an open boundary, pulled along a plane the noise tilts, lands up to about 0.6 h past them (a
// noisy plane's edge); the points of a face seen at a grazing angle, pulled onto the face they meet at a crease,
// up to 1.4 h (a one-view scan of a hexagonal nut).
constexpr double kPullBeyond = 0.75;
// The least elevation, seen from its nearest trusted point q, of a point the pull moves (the move over its distance
// from q): past the plane's points a surface of radius R ≥ t bends away from their plane by t²/2R at a distance t,
// by up to t/2; a point lower than that lies beside the plane's points, not above them.
constexpr double kPullElevation = 0.5;
// A flagged point that a plane through it shares with this share of its planeNeighbours nearest (within this many
// local spacings of the plane, around the point within this largest angular gap, three of them within the reach)
// is on a sheet (onSharedPlane).
constexpr double kSharedPlaneShare = 0.625;
constexpr double kSharedPlaneTolerance = 0.5;
constexpr double kSharedPlaneGap = 240.0 * M_PI / 180.0;
constexpr double kSharedPlaneReach = 2.0;
constexpr std::size_t kSharedPlaneNear = 3;
constexpr std::size_t kNearPlanePoints = 9;     // the nearest trusted point and its 8 nearest trusted neighbours
/// A point whose spacing exceeds this many times the cloud's 90th-percentile spacing is an outlier unless its
/// neighbours form a surface (a sheet, or a cloud of local dimension about 2: a separate object sampled sparsely).
constexpr double kIsolation = 3.0;
/// The surface's sparse spacing, which kIsolation multiplies: the cloud's 90th-percentile spacing, but at most
/// kSurfaceSpread times its median — background clutter over a tenth of the points (a scan of a room's contents,
/// a noisy sensor) would otherwise set the 90th percentile itself, and none of it would stand out (a sphere with
/// 10 % of its points scattered in its box failed the run, with 20 % 85 % of the output lay off it). A surface
/// sampled evenly has its 90th percentile within 1.3 of its median; a density gradient's sparse side, under the
/// bound, is still no clutter: a surface (kVolumeDimension).
constexpr double kSurfaceSpread = 1.5;
/// Beyond this many times, off a sheet is enough; between the two, three in four of its neighbours must be as
/// sparse (an outlier a few spacings off a surface has the surface around it: the tests above find it, and it is
/// pulled back) and they must fill space around it (kVolumeDimension). Isolated points have no surface to land on.
constexpr double kFarIsolation = 10.0;
/// Points scattered in space, for the isolation test: the local intrinsic dimension of the cloud around them (the
/// Levina–Bickel maximum-likelihood estimate from the kDimensionNeighbours nearest distances, averaged over the
/// point and those neighbours) is about 3, a sampled surface's about 2 — also where a sparse object curves too
/// much within the neighbourhood for the sheet test (armadillo, hand and knot1 sampled with 1,000 points: 95 % of
/// their points under 2.55, 99 % under 2.67; points uniform in a box: 95 % over 2.65).
constexpr std::size_t kDimensionNeighbours = 24;
constexpr double kVolumeDimension = 2.6;
/// A sheet, for the isolation test: at least kSheetPoints neighbours whose smallest covariance eigenvalue is at
/// most kSheetVariation of the three (a noisy scan's sheet stays well under it; points scattered in space lie
/// near 1/3), and the point within kSheetDistance local spacings of their plane.
constexpr std::size_t kSheetPoints = 8;
constexpr double kSheetVariation = 0.05;
constexpr double kSheetDistance = 0.5;

/// The maximum-likelihood intrinsic dimension at @p p from its kDimensionNeighbours nearest distances (0 where
/// they coincide).
double pointDimension(const KnnIndex& index, const Eigen::Vector3d& p) {
  thread_local std::vector<std::uint32_t> idx;
  thread_local std::vector<double> d2;
  const std::size_t found = index.knn(p, kDimensionNeighbours + 1, idx, d2);
  if (found < 3) return 0;
  const double far = 0.5 * std::log(d2[found - 1]);
  double sum = 0;
  std::size_t terms = 0;
  for (std::size_t j = 1; j + 1 < found; ++j)
    if (d2[j] > 0) sum += far - 0.5 * std::log(d2[j]), ++terms;
  return terms > 0 && sum > 0 ? static_cast<double>(terms) / sum : 0.0;
}

/// pointDimension() averaged over @p p and its kDimensionNeighbours nearest points.
double localDimension(const KnnIndex& index, const std::vector<Eigen::Vector3d>& P, const Eigen::Vector3d& p) {
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  const std::size_t found = index.knn(p, kDimensionNeighbours + 1, idx, d2);
  double sum = 0;
  for (std::size_t j = 0; j < found; ++j) sum += pointDimension(index, P[idx[j]]);
  return found > 0 ? sum / static_cast<double>(found) : 0.0;
}

void checkCloud(const PointCloud& cloud, std::size_t minPoints) {
  if (cloud.empty()) throw InputError("processOutliers: the cloud is empty");
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!cloud.points[i].allFinite())
      throw InputError("processOutliers: point " + std::to_string(i) + " has a NaN/Inf coordinate");
  if (cloud.size() < minPoints)
    throw InputError("processOutliers: " + std::to_string(cloud.size()) + " points, need at least " +
                     std::to_string(minPoints));
}

/// Unweighted least-squares plane through points[idx]: |distance| of @p p to it.
double planeDistance(const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& points,
                     const std::vector<std::uint32_t>& idx, double* variation = nullptr) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (std::uint32_t j : idx) c += points[j];
  c /= static_cast<double>(idx.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::uint32_t j : idx) {
    const Eigen::Vector3d d = points[j] - c;
    cov.noalias() += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cov);
  const Eigen::Vector3d n = eig.eigenvectors().col(0);
  if (variation) *variation = eig.eigenvalues()(0) / std::max(eig.eigenvalues().sum(), 1e-300);
  return std::abs(n.dot(p - c));
}

/// Whether point @p i, sparser than kIsolation × @p surface (the surface's sparse spacing, surfaceSpacing()), is
/// isolated: off a sheet of its neighbours @p around (@p local: their spacing), and sparser than kFarIsolation ×
/// @p p90 (the cloud's 90th-percentile spacing) or among sparse neighbours that fill space around it.
bool isolatedPoint(const std::vector<Eigen::Vector3d>& P, const std::vector<double>& spacing, std::size_t i,
                   const std::vector<std::uint32_t>& around, double local, double surface, double p90,
                   const KnnIndex& index) {
  double variation = 1;
  const double offSheet = planeDistance(P[i], P, around, &variation) / local;
  if (around.size() >= kSheetPoints && variation <= kSheetVariation && offSheet <= kSheetDistance) return false;
  if (spacing[i] > kFarIsolation * p90) return true;
  const auto sparse =
      std::count_if(around.begin(), around.end(), [&](std::uint32_t j) { return spacing[j] > surface; });
  return 4 * static_cast<std::size_t>(sparse) >= 3 * around.size() &&
         localDimension(index, P, P[i]) > kVolumeDimension;
}

double median(std::vector<double>& v) {
  const auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// The q-quantile of @p values (a copy is partially sorted).
double quantile(std::vector<double> values, double q) {
  const auto at = values.begin() + static_cast<long>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), at, values.end());
  return *at;
}


/// Drops the points flagged in @p drop (and their normals and attributes) from @p input into @p result.cloud.
void removeOutliers(const PointCloud& input, const std::vector<std::uint8_t>& drop, OutlierResult& result) {
  const bool normals = input.hasNormals();
  result.cloud = PointCloud{};
  std::vector<const PointAttribute*> carried;  // those with one value per point
  for (const PointAttribute& a : input.attributes)
    if (a.values.size() == input.size()) {
      carried.push_back(&a);
      result.cloud.attributes.push_back({a.name, a.kind, a.type, {}});
    }
  for (std::size_t i = 0; i < input.size(); ++i) {
    if (drop[i]) continue;
    result.cloud.points.push_back(input.points[i]);
    if (normals) result.cloud.normals.push_back(input.normals[i]);
    for (std::size_t a = 0; a < carried.size(); ++a) result.cloud.attributes[a].values.push_back(carried[a]->values[i]);
  }
  result.removed = input.size() - result.cloud.size();
}

/// Whether a plane through @p P[row[0]] and two of its neighbours row[1 … m−1] (at least 17° apart as seen from
/// it) holds kSharedPlaneShare of those neighbours within kSharedPlaneTolerance local spacings @p local, lying
/// around the point (no angular gap over kSharedPlaneGap between them as seen from it, in the plane) and
/// kSharedPlaneNear of them within kSharedPlaneReach local spacings of it: the point lies on the sheet most of
/// its neighbourhood lies on. Beside a crease, where every plane fitted to the neighbourhood spans both sheets,
/// the point's own sheet still holds its side's points, on one side of it at worst. A plane through an outlier
/// holds a strip of a surface at most, seen from the outlier within a narrow angle, or (between two sheets)
/// strips of both, few of their points near it.
bool onSharedPlane(const std::vector<Eigen::Vector3d>& P, const std::uint32_t* row, std::size_t m, double local) {
  const Eigen::Vector3d& p = P[row[0]];
  const double tol = kSharedPlaneTolerance * local, reach2 = std::pow(kSharedPlaneReach * local, 2);
  const auto need = static_cast<std::size_t>(std::ceil(kSharedPlaneShare * static_cast<double>(m - 1)));
  std::vector<double> angle;
  for (std::size_t a = 1; a < m; ++a)
    for (std::size_t b = a + 1; b < m; ++b) {
      const Eigen::Vector3d u = P[row[a]] - p, v = P[row[b]] - p;
      Eigen::Vector3d n = u.cross(v);
      if (!(n.norm() > 0.3 * u.norm() * v.norm())) continue;  // nearly in line with p: no plane
      n.normalize();
      const Eigen::Vector3d e1 = u.normalized(), e2 = n.cross(e1);
      angle.clear();
      std::size_t near = 0;
      for (std::size_t t = 1; t < m; ++t) {
        const Eigen::Vector3d d = P[row[t]] - p;
        if (std::abs(n.dot(d)) > tol) continue;
        angle.push_back(std::atan2(d.dot(e2), d.dot(e1)));
        near += d.squaredNorm() <= reach2;
      }
      if (angle.size() < need || near < kSharedPlaneNear) continue;
      std::sort(angle.begin(), angle.end());
      double gap = angle.front() + 2 * M_PI - angle.back();
      for (std::size_t t = 1; t < angle.size(); ++t) gap = std::max(gap, angle[t] - angle[t - 1]);
      if (gap <= kSharedPlaneGap) return true;
    }
  return false;
}

/// eq. (5): projects each outlier onto the MLS plane of its nearest trusted point q's neighbourhood. Outliers
/// flagged in @p isolated (far from the object) have no surface to land on and are removed instead; so is an
/// outlier whose projection lands more than twice the fit's support radius h from a(q), where the plane no
/// longer stands for the surface. An outlier within the plane's own scatter stays where it is, and so does one
/// whose projection lands past the trusted points around it on the plane (by more than kPullBeyond·h): there the
/// plane extrapolates. Such points are mostly true ones beside a crease or an open boundary: a face seen at a
/// grazing angle, sparse beside the face it meets, had its points pulled onto that face's plane, past the crease
/// and five spacings from any input point. Nor is a point moved that lies beside the plane's points rather than
/// above them (its move under kPullElevation of its distance from q): a true point of a curved surface sampled
/// sparsely beside a dense patch — a radar's far field on its sphere, 17–29 units from the patch and 1.8–6.1 units
/// off its plane — would land that far off the surface, and the MLS surface bulge over it.
void pullOutliers(const PointCloud& input, const OutlierParams& params, const std::vector<std::uint8_t>& trusted,
                  const std::vector<std::uint8_t>& isolated, OutlierResult& result, int threads) {
  const std::size_t n = input.size();
  const auto& P = input.points;
  const std::size_t fitK = static_cast<std::size_t>(std::max(params.planeNeighbours, params.k)) + 1;
  std::vector<std::uint8_t> outlier(n, 0);
  for (std::uint32_t o : result.outliers) outlier[o] = 1;
  // Pull targets are *trusted* points (mutual, not outliers): an undetected outlier never serves as q.
  std::size_t trustedCount = 0;
  for (std::size_t i = 0; i < n; ++i) trustedCount += trusted[i];
  const bool useTrusted = trustedCount >= fitK;
  const bool normals = input.hasNormals();
  std::vector<Eigen::Vector3d> cleanPoints, cleanNormals;
  for (std::size_t i = 0; i < n; ++i) {
    if (useTrusted ? !trusted[i] : outlier[i]) continue;
    cleanPoints.push_back(P[i]);
    if (normals) cleanNormals.push_back(input.normals[i]);
  }
  result.cloud = input;
  std::vector<std::uint8_t> unsupported(n, 0), moved(n, 0);
  for (std::uint32_t o : result.outliers) unsupported[o] = isolated[o];
  const std::optional<KnnIndex> cleanTree =
      cleanPoints.size() >= 3 ? std::optional<KnnIndex>(std::in_place, cleanPoints) : std::nullopt;
  parallelFor(cleanTree ? result.found : 0, threads, [&](std::size_t a) {
    const std::uint32_t o = result.outliers[a];
    if (isolated[o]) return;
    const auto q = static_cast<std::size_t>(cleanTree->nearest(P[o]));
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    // q's fitK nearest with h = the distance to the farthest of them, so all of them count: a stable plane under
    // noise (eq. 5's MLS plane at a(q)).
    const std::size_t f = cleanTree->knn(cleanPoints[q], fitK, idx, d2);
    const double h = std::sqrt(d2[f - 1]) > 0 ? std::sqrt(d2[f - 1]) : 1.0;
    const Eigen::Vector3d qn = normals ? cleanNormals[q] : Eigen::Vector3d(Eigen::Vector3d::Zero());
    const MlsPlane plane = fitMlsPlane(cleanPoints[q], cleanPoints, idx.data(), f, h, nullptr, qn);
    const Eigen::Vector3d pulled = projectOntoPlane(P[o], plane);
    if (!((pulled - plane.centre).norm() <= 2 * h)) {
      unsupported[o] = 1;
      return;
    }
    // Landing past the trusted points around it, the plane extrapolates: it does not show the point off the surface.
    // Three fit rows of them, so that on a scan's lines (a profile scanner's slices) they span the gap to the next.
    std::vector<std::uint32_t> around;
    std::vector<double> aroundD2;
    cleanTree->knn(pulled, 3 * fitK, around, aroundD2);
    if (detail::beyondHull(cleanPoints, around.data(), around.size(), nullptr, pulled, plane.normal) > kPullBeyond * h)
      return;
    // A point no farther from the plane than the plane's own points (twice their RMS distance) is not shown off
    // the surface by it: beside a crease the plane spans both sheets, and pulling a true point of one sheet onto
    // it would move it inside the object. It stays where it is.
    double rss = 0;
    for (std::size_t j = 0; j < f; ++j) rss += std::pow(plane.normal.dot(cleanPoints[idx[j]] - plane.centre), 2);
    const double move = (pulled - P[o]).norm();
    if (move <= 2.0 * std::sqrt(rss / static_cast<double>(f))) return;
    if (move < kPullElevation * (cleanPoints[q] - P[o]).norm()) return;
    result.cloud.points[o] = pulled;
    if (normals) result.cloud.normals[o] = plane.normal;
    moved[o] = 1;
  });
  result.pulled = static_cast<std::size_t>(std::count(moved.begin(), moved.end(), 1));
  if (std::count(unsupported.begin(), unsupported.end(), 1) > 0) {
    const PointCloud pulledCloud = std::move(result.cloud);
    removeOutliers(pulledCloud, unsupported, result);
  }
}

}  // namespace

OutlierMode parseOutlierMode(const std::string& name) {
  if (name == "pull") return OutlierMode::kPull;
  if (name == "remove") return OutlierMode::kRemove;
  if (name == "keep") return OutlierMode::kKeep;
  throw std::invalid_argument("unknown outlier mode '" + name + "' (expected pull, remove or keep)");
}

std::string toString(OutlierMode mode) {
  switch (mode) {
    case OutlierMode::kPull:
      return "pull";
    case OutlierMode::kRemove:
      return "remove";
    case OutlierMode::kKeep:
      return "keep";
  }
  return "?";
}

void OutlierParams::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("OutlierParams: " + what); };
  if (k < 2) fail("k must be at least 2");
  if (minMutual < 1 || minMutual > k) fail("minMutual must lie in [1, k]");
  if (planeNeighbours < 3) fail("planeNeighbours must be at least 3");
  if (!(planeThreshold > 0) || !std::isfinite(planeThreshold))
    fail("planeThreshold must be a finite value > 0");
  if (!(nearPlaneThreshold > 0)) fail("nearPlaneThreshold must be > 0 (infinity: off)");
}

std::size_t outlierNeighbours(const OutlierParams& params) {
  const auto k = static_cast<std::size_t>(params.k), planeK = static_cast<std::size_t>(params.planeNeighbours);
  return std::max({k, planeK, kSpacingNeighbours}) + 1;
}

namespace {

/// What one round of the outlier test found, per point.
struct Detection {
  std::vector<std::uint8_t> outlier, trusted, isolated;
};

/// One round of the outlier test over @p P (its k-NN rows from @p table when that holds enough columns).
/// @p strongOnly: only the points off the plane of their neighbours by twice planeThreshold, or isolated, are
/// outliers (not the suspects off it by planeThreshold).
Detection detect(const std::vector<Eigen::Vector3d>& P, const OutlierParams& params, const Execution& exec,
                 const NeighbourTable* table, bool strongOnly) {
  const std::size_t k = static_cast<std::size_t>(params.k);
  const std::size_t planeK = static_cast<std::size_t>(params.planeNeighbours);
  const std::size_t n = P.size();
  // Neighbours per point, itself first (index 0).
  const std::size_t K = outlierNeighbours(params);

  // Every per-point loop visits the points in Morton order (neighbours in space are visited together, which
  // keeps the k-d tree and the neighbour rows in cache); each iteration writes only its own point's slot.
  const std::vector<std::uint32_t> order = mortonOrder(P, exec.threads);
  auto forEachPoint = [&](auto&& fn) { parallelFor(n, exec.threads, [&](std::size_t a) { fn(order[a]); }); };
  std::vector<std::uint32_t> nbr(n * K);
  std::vector<std::uint32_t> count(n);
  std::vector<double> spacing(n);
  std::optional<KnnIndex> own;  // without a table; also the isolation test's index
  {
    if (table && table->k() < K) table = nullptr;
    if (!table) own.emplace(P);
    forEachPoint([&](std::size_t i) {
      std::vector<std::uint32_t> idx;
      std::vector<double> d2;
      const std::size_t f = table ? table->get(i, K, idx, d2) : own->knn(P[i], K, idx, d2);
      // Put i itself first even when exact duplicates tie with it.
      const auto self =
          std::find(idx.begin(), idx.begin() + static_cast<long>(f), static_cast<std::uint32_t>(i));
      if (self != idx.begin() + static_cast<long>(f)) std::rotate(idx.begin(), self, self + 1);
      std::copy(idx.begin(), idx.begin() + static_cast<long>(f), nbr.begin() + static_cast<long>(i * K));
      count[i] = static_cast<std::uint32_t>(f);
      double s = 0;
      const std::size_t m = std::min(f - 1, kSpacingNeighbours);
      for (std::size_t j = 1; j <= m; ++j) s += std::sqrt(d2[j]);
      spacing[i] = m > 0 ? s / static_cast<double>(m) : 0.0;
    });
  }
  auto row = [&](std::size_t i) { return nbr.data() + i * K; };

  // eq. (4): the k-NN relation i → j is mutual when i is also among j's k nearest. Suspects are in fewer
  // than minMutual of their neighbours' lists.
  std::vector<std::uint8_t> suspect(n, 0);  // written once per point below
  forEachPoint([&](std::size_t i) {
    const std::uint32_t* ri = row(i);
    const std::size_t ki = std::min<std::size_t>(k + 1, count[i]);
    int mutual = 0;
    for (std::size_t a = 1; a < ki; ++a) {
      const std::uint32_t* rj = row(ri[a]);
      const std::size_t kj = std::min<std::size_t>(k + 1, count[ri[a]]);
      for (std::size_t b = 1; b < kj; ++b)
        if (rj[b] == i) {
          ++mutual;
          break;
        }
    }
    suspect[i] = mutual < params.minMutual ? 1 : 0;
  });

  // Geometric test: distance to the plane of the trusted (non-suspect) points among the planeNeighbours
  // nearest, in local spacings. A suspect beyond planeThreshold, or beyond nearPlaneThreshold from the small
  // plane of the nearest of those points, is an outlier; so is any point beyond twice planeThreshold (a small cluster of
  // outliers can be mutual among itself). Trusted = mutual and near its plane.
  Detection d;
  std::vector<std::uint8_t>& outlier = d.outlier;
  std::vector<std::uint8_t>& trusted = d.trusted;
  std::vector<std::uint8_t>& isolated = d.isolated;
  outlier.assign(n, 0);
  trusted.assign(n, 0);
  std::vector<double> localSpacing(n, 0.0);
  // Isolated points: every local test above compares a point with its neighbours, and points scattered far from
  // the object (and from each other) are each other's neighbours. Against the whole cloud they stand out: their
  // spacing is several times the spacing of the sparsest tenth of the cloud, their neighbours lie on no sheet
  // through them and fill space around them. A separate object sampled sparsely (under a tenth of the points) is
  // as sparse, but a surface: its neighbours' plane holds them (kSheetVariation) and it (kSheetDistance), or,
  // where it curves within them, they spread in two dimensions, not three (kVolumeDimension).
  const double p90 = quantile(spacing, 0.9), surface = std::min(p90, kSurfaceSpread * quantile(spacing, 0.5));
  const double isolation = kIsolation * surface;
  isolated.assign(n, 0);
  // The local dimension reads more neighbours than the table holds: the cloud's own index, built only when a
  // point is that sparse.
  if (!own && std::any_of(spacing.begin(), spacing.end(), [&](double x) { return x > isolation; })) own.emplace(P);
  forEachPoint([&](std::size_t i) {
    const std::uint32_t* ri = row(i);
    const std::size_t ki = std::min<std::size_t>(planeK + 1, count[i]);
    std::vector<std::uint32_t> used;
    used.reserve(ki);
    for (std::size_t a = 1; a < ki; ++a)
      if (!suspect[ri[a]]) used.push_back(ri[a]);
    if (used.size() < 3) used.assign(ri + 1, ri + ki);  // no trusted neighbourhood: use every neighbour
    std::vector<double> s;
    s.reserve(used.size());
    for (std::uint32_t j : used) s.push_back(spacing[j]);
    const double local = std::max(median(s), 1e-300);
    const double ratio = planeDistance(P[i], P, used) / local;
    bool off = ratio > params.planeThreshold;
    if (suspect[i] && !off && std::isfinite(params.nearPlaneThreshold)) {
      // The small plane of the nearest trusted point q (rows are sorted: used[0] is the nearest).
      const std::uint32_t q = used.front();
      const std::uint32_t* rq = row(q);
      std::vector<std::uint32_t> near;
      for (std::size_t a = 0; a < count[q] && near.size() < kNearPlanePoints; ++a)
        if (!suspect[rq[a]]) near.push_back(rq[a]);
      off = near.size() >= 3 && planeDistance(P[i], P, near) / local > params.nearPlaneThreshold;
    }
    if (spacing[i] > isolation)
      isolated[i] =
          isolatedPoint(P, spacing, i, std::vector<std::uint32_t>(ri + 1, ri + ki), local, surface, p90, *own);
    outlier[i] = (suspect[i] && off && !strongOnly) || ratio > 2 * params.planeThreshold || isolated[i];
    trusted[i] = !suspect[i] && !isolated[i] && ratio <= params.planeThreshold;
    localSpacing[i] = local;
  });
  // A flagged point on a sheet is not an outlier: at a crease the planes above span both sheets and flag true
  // points of it (joint, a clean 100k sampling: 15 points by the concave edge at y ≈ −0.46, pulled onto a
  // tilted plane 0.33 output spacings below the floor). On a sheet = the small plane (it and its 8 nearest
  // trusted neighbours) of one of its kNearPlaneSheets nearest trusted points within planeThreshold passes
  // within nearPlaneThreshold of it. An outlier between two close sheets is off both sheets' planes. Isolated
  // points are not rescued: their neighbours are other scattered points, whose planes prove nothing.
  if (std::isfinite(params.nearPlaneThreshold))
    forEachPoint([&](std::size_t i) {
      if (!outlier[i] || isolated[i]) return;
      const std::uint32_t* ri = row(i);
      std::vector<std::uint32_t> near;
      for (std::size_t a = 1, tried = 0; a < count[i] && tried < kNearPlaneSheets; ++a) {
        const std::uint32_t q = ri[a];
        if (!trusted[q]) continue;
        if ((P[q] - P[i]).norm() > params.planeThreshold * localSpacing[i]) break;  // rows are sorted
        ++tried;
        const std::uint32_t* rq = row(q);
        near.clear();
        for (std::size_t b = 0; b < count[q] && near.size() < kNearPlanePoints; ++b)
          if (trusted[rq[b]]) near.push_back(rq[b]);
        if (near.size() >= 3 && planeDistance(P[i], P, near) / localSpacing[i] <= params.nearPlaneThreshold) {
          outlier[i] = 0;
          return;
        }
      }
      if (onSharedPlane(P, ri, std::min<std::size_t>(planeK + 1, count[i]), localSpacing[i])) outlier[i] = 0;
    });

  return d;
}

}  // namespace

OutlierResult processOutliers(const PointCloud& input, const OutlierParams& params, const Execution& exec,
                              const NeighbourTable* table) {
  params.validate();
  const auto start = Clock::now();
  const std::size_t minPoints = static_cast<std::size_t>(std::max(params.planeNeighbours, params.k)) + 1;
  checkCloud(input, minPoints);
  const std::size_t n = input.size();
  Detection d = detect(input.points, params, exec, table, false);
  // Outliers scattered near one another are one another's mutual neighbours and planes: the test passes them
  // while their company is there. Another round over the points the last one kept sees them stand alone, until
  // a round finds none; those rounds take only the clear cases (between two close sheets, true points whose
  // neighbours an earlier round took would turn suspect).
  for (int round = 1; round < kMaxRounds; ++round) {
    std::vector<std::uint32_t> kept;
    for (std::size_t i = 0; i < n; ++i)
      if (!d.outlier[i]) kept.push_back(static_cast<std::uint32_t>(i));
    if (kept.size() == n || kept.size() < minPoints) break;
    std::vector<Eigen::Vector3d> rest(kept.size());
    for (std::size_t t = 0; t < kept.size(); ++t) rest[t] = input.points[kept[t]];
    const Detection again = detect(rest, params, exec, nullptr, true);
    std::size_t found = 0;
    for (std::size_t t = 0; t < kept.size(); ++t)
      if (again.outlier[t]) ++found, d.outlier[kept[t]] = 1, d.trusted[kept[t]] = 0, d.isolated[kept[t]] = again.isolated[t];
    if (found == 0) break;
  }
  const std::vector<std::uint8_t>& outlier = d.outlier;
  const std::vector<std::uint8_t>& trusted = d.trusted;
  const std::vector<std::uint8_t>& isolated = d.isolated;

  OutlierResult result;
  for (std::size_t i = 0; i < n; ++i)
    if (outlier[i]) result.outliers.push_back(static_cast<std::uint32_t>(i));
  result.found = result.outliers.size();

  if (params.mode == OutlierMode::kPull) pullOutliers(input, params, trusted, isolated, result, exec.threads);
  if (params.mode == OutlierMode::kRemove) removeOutliers(input, outlier, result);
  if (params.mode == OutlierMode::kKeep) result.cloud = input;
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

PointCloud cleanOutliers(const PointCloud& cloud, const OutlierParams& params, const Execution& exec,
                        std::size_t* found) {
  if (params.mode == OutlierMode::kKeep || cloud.size() <= outlierNeighbours(params)) return cloud;
  OutlierResult cleaned = processOutliers(cloud, params, exec);
  if (found) *found += cleaned.found;
  return std::move(cleaned.cloud);
}

}  // namespace iires
