// SPDX-License-Identifier: GPL-3.0-or-later
#include "resampler.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#include <Eigen/Geometry>

#include "iires/detail/parallel.hpp"
#include "iires/detail/radix_sort.hpp"
#include "iires/detail/tangent_cell.hpp"
#include "iires/knn.hpp"
#include "crowded.hpp"
#include "voxel_thin.hpp"

namespace iires::detail {
namespace {

constexpr std::uint32_t kNone = 0xffffffffu;
constexpr double kOffSurfaceLimit = 0.6;  // MlsSurface::project's offSurface beyond which a move left the cloud
// MlsSurface::project's `beyond` (tangent-plane distance outside the input neighbours' hull, in kernel widths,
// ≈ 0.15 input spacings) past which a move left the input's extent at an open boundary. kOffSurfaceLimit alone
// lets a sample sit 0.6 kernel widths (≈ 2 input spacings) from the nearest input point, which at an open
// boundary of a sparse input is several output spacings past the data (upsampling).
constexpr double kBeyondLimit = 0.05;
// A collapsed edge's midpoint projected farther than this (offSurface, kernel widths) from every input point left
// the cloud: at the rim corner of a plate a few spacings thick a quadric fit extrapolates 1–3 input spacings
// out. Looser than kOffSurfaceLimit, which a clean 5× density gradient's sparse side reaches (h capped there).
constexpr double kCollapseOffLimit = 1.0;
// A split's midpoint projected farther than this × the chord from where it was: the new sample would jump farther
// than the two it splits are apart — the chord cuts across a bore, a recess or a gap (a sparse input's, or the MLS
// surface of unoriented normals) rather than spanning surface (a half circle's sagitta is half the chord). Tighter
// bounds help sparse inputs more but, on a very noisy input, leave holes the mesh closes with a handle.
constexpr double kSplitSagitta = 1.0;
constexpr double kCarryShare = 0.05;     // edits touching more than this share of samples restart the relaxation
constexpr double kCoincident = 1e-9;     // a split's sample this close to one (× the edge): at its position
constexpr std::size_t kWiderQuery = 3;   // candidates queried for a sample the rule refuses some of

/// The samples of @p s not marked in @p removed, in Morton order (loops over samples and their k-NN queries then
/// stay in cache).
Samples spatiallySorted(Samples& s, const std::vector<char>& removed, int threads) {
  std::vector<std::uint32_t> order = mortonOrder(s.pos, threads);
  Samples out;
  for (std::uint32_t i : order)
    if (!removed[i]) out.add(s.pos[i], s.nrm[i], s.fixed[i], std::move(s.cache[i]));
  return out;
}

/// x⁸ by three squarings (std::pow with a real exponent costs a log and an exp).
float pow8(double x) {
  x *= x;
  x *= x;
  return static_cast<float>(x * x);
}

}  // namespace

/// Neighbours are filtered by the neighbour rule as of its last update, which follows every change of the
/// sample set (relaxation moves samples by a fraction of a spacing and keeps their order).
/// @param relaxation with the rings of the previous iteration on the same samples: samples it marks inactive
/// keep their ring and cell, and unless @p requery the others re-sort their previous candidate lists by the
/// current distances instead of querying a new k-d tree (samples moved by a fraction of a spacing, so the few
/// neighbours that shape a cell stay among the nearest of a step ago). Its rings are moved into the result (the
/// caller replaces them with it). Without it every ring is computed from scratch.
void Resampler::acceptedNearest(const KnnIndex& index, const Samples& s, std::size_t i, std::size_t stride,
                                std::vector<std::uint32_t>& idx, std::vector<double>& d2) const {
  index.knn(s.pos[i], stride, idx, d2);
  // Samples the rule refuses (another sheet a gap away, narrower than the spacing) take the places of
  // neighbours: then a wider query, of which the first stride accepted ones are kept.
  std::size_t w = 0;
  for (std::size_t c = 0; c < idx.size(); ++c)
    if (idx[c] == i || rule_.accept(i, idx[c])) idx[w] = idx[c], d2[w] = d2[c], ++w;
  if (w < idx.size()) {
    index.knn(s.pos[i], kWiderQuery * stride, idx, d2);
    w = 0;
    for (std::size_t c = 0; c < idx.size() && w < stride; ++c)
      if (idx[c] == i || rule_.accept(i, idx[c])) idx[w] = idx[c], d2[w] = d2[c], ++w;
  }
  idx.resize(w);
  d2.resize(w);
}

Rings Resampler::computeRings(const Samples& s, double cellRadius, Relaxation* relaxation, bool requery,
                              const KnnIndex* built) const {
  const bool previous = relaxation && relaxation->rings;
  if (!previous) requery = true;
  auto active = [&](std::size_t i) { return !previous || relaxation->active[i]; };
  const std::vector<char>* stale = relaxation && !relaxation->stale.empty() ? &relaxation->stale : nullptr;
  const int k = params_.neighbours;
  const std::size_t stride = static_cast<std::size_t>(k) + 1;
  Rings r;
  if (previous) {  // inactive samples keep everything; the rest is overwritten below
    r = std::move(*relaxation->rings);
  } else {
    r.stride = k;
    r.ring.assign(s.size() * static_cast<std::size_t>(k), kNone);
    r.candidates.assign(s.size() * stride, kNone);
    r.centroid.resize(s.size());
    r.nearest.assign(s.size(), 0.0);
    r.outward.assign(s.size(), Eigen::Vector3d::Zero());
    r.size.assign(s.size(), 1.0);
    r.open.assign(s.size(), 0);
  }
  if (size_)  // adaptive mode (eq. 10): a sample takes the size factor of its nearest input point
    parallelFor(s.size(), exec_.threads, [&](std::size_t i) {
      if (active(i)) r.size[i] = (*size_)[surface_.index().nearest(s.pos[i])];
    });
  std::optional<KnnIndex> own;
  const KnnIndex* index = built;
  if ((requery || stale) && !index) index = &own.emplace(s.pos);
  // The disc bounding each cell, as a polygon circumscribing the unit circle.
  constexpr int kDiscEdges = 16;
  std::array<Eigen::Vector2d, kDiscEdges> unitDisc;
  for (int e = 0; e < kDiscEdges; ++e)
    unitDisc[static_cast<std::size_t>(e)] = {std::cos(2 * M_PI * e / kDiscEdges), std::sin(2 * M_PI * e / kDiscEdges)};
  parallelFor(s.size(), exec_.threads, [&](std::size_t i) {
    if (!active(i)) return;
    // Per-thread scratch buffers (one thread-local lookup): this runs for every sample in every iteration.
    struct Scratch {
      std::vector<std::uint32_t> idx, lab, tmpL, coincident;
      std::vector<double> d2;
      std::vector<std::pair<double, Eigen::Vector2d>> dirs;
      std::vector<std::pair<double, std::uint32_t>> byDistance;
      std::vector<std::pair<std::uint32_t, Eigen::Vector2d>> nb;
      std::vector<Eigen::Vector2d> poly, tmpV;
    };
    thread_local Scratch scratch;
    Scratch& sc = scratch;
    auto &idx = sc.idx, &lab = sc.lab, &tmpL = sc.tmpL, &coincident = sc.coincident;
    auto& d2 = sc.d2;
    auto& dirs = sc.dirs;
    auto &poly = sc.poly, &tmpV = sc.tmpV;
    auto& byDistance = sc.byDistance;
    auto& nb = sc.nb;
    const auto candidates = r.candidates.begin() + static_cast<long>(i * stride);
    const bool queried = requery || (stale && (*stale)[i]);  // then idx holds accepted samples only
    if (queried) {
      acceptedNearest(*index, s, i, stride, idx, d2);
    } else {
      byDistance.clear();
      for (std::size_t c = 0; c < stride; ++c)
        if (const std::uint32_t j = candidates[static_cast<long>(c)]; j != kNone)
          byDistance.emplace_back((s.pos[j] - s.pos[i]).squaredNorm(), j);
      std::sort(byDistance.begin(), byDistance.end());
      idx.clear();
      d2.clear();
      for (const auto& [d, j] : byDistance) idx.push_back(j), d2.push_back(d);
    }
    std::fill_n(candidates, stride, kNone);
    std::copy(idx.begin(), idx.end(), candidates);
    std::fill_n(r.ring.begin() + static_cast<long>(i * static_cast<std::size_t>(k)), k, kNone);
    r.outward[i].setZero();
    const Eigen::Vector3d& n = s.nrm[i];
    const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
    // Accepted neighbours in tangent coordinates. Log-map approximation: the tangent direction of the neighbour
    // with its true 3-D distance, so that on curved patches Lloyd equalises real spacings rather than their
    // (shorter) tangent-plane projections.
    nb.clear();
    coincident.clear();
    for (std::size_t c = 0; c < idx.size(); ++c) {
      const std::uint32_t j = idx[c];
      if (j == i || (!queried && !rule_.accept(i, j))) continue;
      const Eigen::Vector3d d = s.pos[j] - s.pos[i];
      Eigen::Vector2d q(d.dot(u), d.dot(v));
      const double qn = q.norm(), dist = std::sqrt(d2[c]);
      if (dist <= 1e-9 * cellRadius) {  // no cell between them: a ring edge of length 0, collapsed first
        coincident.push_back(j);
        continue;
      }
      if (qn < 1e-12 * dist || qn == 0.0) continue;
      nb.emplace_back(j, q * (dist / qn));
    }
    // The cell is bounded by a disc of radius R (for open boundaries); R follows the local spacing where the
    // samples are sparser than l (upsampling), so rings never depend on how far the count still is from N.
    const double nearest = nb.empty() ? 0.0 : nb.front().second.norm();
    const double radius = std::max(cellRadius * r.size[i], nearest);
    poly.clear();
    lab.clear();
    const double rad = radius / std::cos(M_PI / kDiscEdges);
    for (const Eigen::Vector2d& corner : unitDisc) {
      poly.push_back(rad * corner);
      lab.push_back(kNone);
    }
    for (const auto& [j, q] : nb) {
      if (q.norm() > 4.0 * radius) break;  // sorted by distance: the rest cannot touch the cell
      clipByBisector(poly, lab, q, r.size[i] / (r.size[i] + r.size[j]), j, tmpV, tmpL);
      if (poly.size() < 3) break;
    }
    // Samples at one position (e.g. a split onto a sample its edge's ends did not see) would share a cell and
    // move together for good: of each such pair the lower index keeps the −u side of the cell, the higher +u.
    for (std::uint32_t j : coincident) {
      if (poly.size() < 3) break;
      clipByBisector(poly, lab, Eigen::Vector2d(j > i ? 1e-6 * radius : -1e-6 * radius, 0.0), 0.5, j, tmpV, tmpL);
    }
    const Eigen::Vector2d c2 = poly.size() >= 3 ? polygonCentroid(poly) : Eigen::Vector2d::Zero();
    r.centroid[i] = s.pos[i] + c2.x() * u + c2.y() * v;
    r.nearest[i] = nearest;
    std::sort(lab.begin(), lab.end());
    lab.erase(std::unique(lab.begin(), lab.end()), lab.end());
    r.open[i] = !lab.empty() && lab.back() == kNone;
    int w = 0;
    dirs.clear();
    for (std::uint32_t j : lab) {
      if (j == kNone || w >= k) continue;
      r.ring[i * static_cast<std::size_t>(k) + static_cast<std::size_t>(w++)] = j;
      const auto it = std::find_if(nb.begin(), nb.end(), [&](const auto& x) { return x.first == j; });
      if (it == nb.end()) continue;  // a coincident sample: no direction
      const Eigen::Vector2d d = it->second.normalized();
      dirs.emplace_back(pseudoAngle(d), d);
    }
    const auto ringBegin = r.ring.begin() + static_cast<long>(i * static_cast<std::size_t>(k));
    for (std::uint32_t j : coincident)  // a ring edge of length 0, collapsed first (once, if clipping put it there)
      if (w < k && std::find(ringBegin, ringBegin + w, j) == ringBegin + w) ringBegin[w++] = j;
    // Open boundary: the 1-ring leaves an angular gap wider than 135° and the surface does not continue into
    // it (a probe half a cell into the gap leaves the cloud, or the input's extent: when upsampling, half a cell
    // is a fraction of the input spacing and stays near the last input points); the gap's bisector then points
    // off the surface.
    // A gap with surface behind it is merely a sparse region (e.g. while upsampling) and stays open to moves.
    std::sort(dirs.begin(), dirs.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    for (std::size_t a = 0; a < dirs.size(); ++a) {
      const bool wrap = a + 1 == dirs.size();
      const std::optional<Eigen::Vector2d> mid =
          gapBisector(dirs[a].second, dirs[wrap ? 0 : a + 1].second, wrap && dirs[0].first == dirs[a].first);
      if (!mid) continue;
      const Eigen::Vector3d dir = mid->x() * u + mid->y() * v;
      double off = 0, out = 0;
      surface_.project(s.pos[i] + 0.5 * radius * dir, nullptr, &off, &s.nrm[i], nullptr, 0, &out);
      if (off > kOffSurfaceLimit || out > kBeyondLimit) r.outward[i] = dir;
    }
  });
  return r;
}

/// Edges present in both endpoints' 1-rings, each once (a < b), ordered by (a, b).
std::vector<Edge> Resampler::edges(const Samples& s, const Rings& r) const {
  const std::size_t n = s.size(), k = static_cast<std::size_t>(r.stride);
  // The edge a–b, from its lower end. Edges between two context samples are left out: they are finished
  // (never split, collapsed or counted).
  auto mutual = [&](std::size_t a, std::uint32_t b) {
    if (b == kNone || b <= a || (s.fixed[a] == Samples::kContext && s.fixed[b] == Samples::kContext)) return false;
    const auto* rb = &r.ring[b * k];
    return std::find(rb, rb + k, static_cast<std::uint32_t>(a)) != rb + k;
  };
  std::vector<std::uint32_t> offset(n + 1, 0);
  parallelFor(n, exec_.threads, [&](std::size_t a) {
    for (std::size_t x = 0; x < k; ++x) offset[a + 1] += mutual(a, r.ring[a * k + x]);
  });
  for (std::size_t a = 0; a < n; ++a) offset[a + 1] += offset[a];
  std::vector<Edge> out(offset[n]);
  parallelFor(n, exec_.threads, [&](std::size_t a) {
    const auto first = out.begin() + offset[a];
    auto at = first;
    for (std::size_t x = 0; x < k; ++x)
      if (const std::uint32_t b = r.ring[a * k + x]; mutual(a, b))
        *at++ = {(s.pos[a] - s.pos[b]).norm() / (0.5 * (r.size[a] + r.size[b])), static_cast<std::uint32_t>(a), b};
    std::sort(first, at, [](const Edge& x, const Edge& y) { return x.b < y.b; });
  });
  return out;
}

/// Lloyd relaxation: move each free sample to the centroid of its tangent-plane Voronoi cell, projected onto
/// the MLS surface (halving the step if the move would leave the cloud). Returns the spacing CV after the last
/// iteration (from the 1-rings, so it costs nothing extra).
/// Only active samples are recomputed: a sample whose cell neighbours and itself all moved by less than
/// kStillMove·l last time has (nearly) the same cell and centroid, and keeps them. Late in the relaxation most
/// samples are still, so an iteration costs a fraction of the first ones.
double Resampler::relax(Samples& s, double l, int iterations, Relaxation& state, int projectionSteps) {
  constexpr double kStillMove = 0.005;  // in units of l
  constexpr int kRequeryEvery = 4;     // iterations between fresh k-d tree candidate lists
  constexpr double kRuleDrift = 0.5;   // in units of l: a drift from the rule's last positions that updates it
  constexpr double kStaleReach = 2.0;  // in units of l: around a drifted sample, the candidate lists it may join
  const std::size_t n = s.size(), k = static_cast<std::size_t>(params_.neighbours);
  double cv = 0;
  std::vector<Eigen::Vector3d> pos, nrm;  // the moved samples; swapped with s's, so both keep their memory
  std::optional<KnnIndex> afterDrift;      // over the positions the next iteration starts from, when a drift built it
  for (int it = 0; it < iterations; ++it) {
    const bool requery = !state.rings || state.sinceQuery >= kRequeryEvery;
    Rings r = computeRings(s, l, &state, requery, afterDrift ? &*afterDrift : nullptr);
    afterDrift.reset();
    state.sinceQuery = requery ? 1 : state.sinceQuery + 1;
    state.stale.clear();
    if (!state.rings) state.active.assign(n, 1);
    pos = s.pos;
    nrm = s.nrm;
    parallelFor(n, exec_.threads, [&](std::size_t i) {
      if (s.fixed[i] || !state.active[i]) return;
      Eigen::Vector3d step = params_.overRelaxation * (r.centroid[i] - s.pos[i]);
      // Boundary samples may slide along the boundary or move inwards, never off the surface.
      step -= std::max(0.0, step.dot(r.outward[i])) * r.outward[i];
      Eigen::Vector3d target = s.pos[i] + step;
      for (int attempt = 0; attempt < 3; ++attempt) {
        Eigen::Vector3d nn;
        double off = 0, out = 0;
        const Eigen::Vector3d p =
            surface_.project(target, &nn, &off, &s.nrm[i], &s.cache[i], projectionSteps, &out);
        // A boundary sample never ends farther out than it was (the projection itself may push it there,
        // where the MLS surface only extrapolates past the last input points) and stays closer to the cloud.
        // Nor does the projection carry it onto another sheet a gap away (its neighbours would not follow).
        if (off <= (r.outward[i].isZero() ? kOffSurfaceLimit : 0.5 * kOffSurfaceLimit) && out <= kBeyondLimit &&
            (p - s.pos[i]).dot(r.outward[i]) <= 0 && rule_.acceptMove(i, s.pos[i], p)) {
          pos[i] = p;
          nrm[i] = nn;
          return;
        }
        target = 0.5 * (target + s.pos[i]);
      }
    });
    // Next iteration's active set: samples that moved and the 1-ring neighbours of those (both directions).
    std::vector<char> moved(n, 0), next(n, 0);
    const double still2 = kStillMove * kStillMove * l * l;
    for (std::size_t i = 0; i < n; ++i) moved[i] = (pos[i] - s.pos[i]).squaredNorm() > still2;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t x = 0; x < k; ++x) {
        const std::uint32_t j = r.ring[i * k + x];
        if (j == kNone) break;
        if (moved[i] || moved[j]) next[i] = next[j] = 1;
      }
    for (std::size_t i = 0; i < n; ++i) next[i] |= moved[i];
    s.pos.swap(pos);
    s.nrm.swap(nrm);
    // The rule judges pairs at the positions of its last update. A sample that drifted far from there (into
    // a hole, over several iterations) would be judged where it was: two samples that met on the same sheet
    // can then be refused as neighbours — where the geodesic coordinates are a few tens of per cent off over
    // that distance — and their cells overlap, so they pile up. Such a drift updates the rule.
    const double drift2 = kRuleDrift * kRuleDrift * l * l;
    std::vector<std::uint32_t> drifted, idx;
    for (std::size_t i = 0; i < n; ++i)
      if ((s.pos[i] - rulePos_[i]).squaredNorm() > drift2) drifted.push_back(static_cast<std::uint32_t>(i));
    if (!drifted.empty()) {
      updateRule(s);
      // The candidate lists hold the samples the rule accepted at their last query: a drifted sample, judged where
      // it was, is missing from those around where it is now (it could sit on a sample unseen). They are queried anew.
      const KnnIndex& index = afterDrift.emplace(s.pos);
      std::vector<double> d2;
      state.stale.assign(n, 0);
      for (std::uint32_t j : drifted) {
        index.radius(s.pos[j], kStaleReach * l, idx, d2);
        for (std::uint32_t i : idx) state.stale[i] = next[i] = 1;
      }
    }
    double sum = 0, sq = 0;
    for (double d : r.nearest) sum += d, sq += d * d;
    const double mean = sum / static_cast<double>(n);
    cv = mean > 0 ? std::sqrt(std::max(0.0, sq / static_cast<double>(n) - mean * mean)) / mean : 0;
    state.rings = std::move(r);
    state.active = std::move(next);
  }
  return cv;
}

/// One round of edge operations on the 1-ring edges (@p sorted ascending by length):
/// - split the longest edges longer than @p minSplit, at most @p splits: insert the edge midpoint projected onto
///   the surface (a point cloud has no connectivity to keep, so a sample may take part in several splits);
/// - collapse the shortest edges shorter than @p maxCollapse, at most @p collapses, each sample in at most one
///   collapse: both ends are replaced by their midpoint on the surface (a fixed end stays put).
EditMap Resampler::splitAndCollapse(Samples& s, const std::vector<Edge>& sorted, std::size_t splits,
                                    double minSplit, std::size_t collapses, double maxCollapse,
                                    ResampleResult& result) {
  EditMap map;
  // Longest first; midpoints are projected in parallel batches and an edge spanning a hole of the cloud (its
  // midpoint leaves the surface) is not split.
  std::vector<Eigen::Vector3d> newPos, newNrm;
  std::vector<const Edge*> batch;
  std::optional<KnnIndex> samples;  // built for the first batch (a round without splits needs none)
  auto next = sorted.rbegin();
  while (newPos.size() < splits && next != sorted.rend() && next->length > minSplit) {
    batch.clear();
    for (; next != sorted.rend() && next->length > minSplit && batch.size() < 2 * (splits - newPos.size()) + 16;
         ++next)
      batch.push_back(&*next);
    std::vector<Eigen::Vector3d> pos(batch.size()), nrm(batch.size());
    std::vector<double> off(batch.size()), out(batch.size());
    std::vector<char> clear(batch.size(), 1);
    if (!samples) samples.emplace(s.pos);
    parallelFor(batch.size(), exec_.threads, [&](std::size_t c) {
      const Edge& e = *batch[c];
      pos[c] = surface_.project(0.5 * (s.pos[e.a] + s.pos[e.b]), &nrm[c], &off[c], &s.nrm[e.a], nullptr, 0, &out[c]);
      // Never onto a sample already there: the ends of an edge over a dense speck (a part of its own to the rule)
      // do not see the sample its split put there, and every pass would split the edge onto that spot again.
      const std::int64_t q = samples->nearest(pos[c]);
      const double edge = (s.pos[e.a] - s.pos[e.b]).norm();
      clear[c] = q < 0 || (s.pos[static_cast<std::size_t>(q)] - pos[c]).norm() > kCoincident * edge;
    });
    for (std::size_t c = 0; c < batch.size() && newPos.size() < splits; ++c) {
      const Eigen::Vector3d &a = s.pos[batch[c]->a], &b = s.pos[batch[c]->b];
      if (clear[c] && off[c] <= kOffSurfaceLimit && out[c] <= kBeyondLimit &&
          (pos[c] - 0.5 * (a + b)).norm() <= kSplitSagitta * (a - b).norm()) {
        newPos.push_back(pos[c]), newNrm.push_back(nrm[c]);
        map.touched.push_back(batch[c]->a), map.touched.push_back(batch[c]->b);
      }
    }
  }
  std::vector<char> touched(s.size(), 0), removed(s.size(), 0);
  std::size_t collapsed = 0;
  for (const Edge& e : sorted) {
    if (collapsed >= collapses || e.length >= maxCollapse) break;
    if (touched[e.a] || touched[e.b] || (s.fixed[e.a] && s.fixed[e.b])) continue;
    touched[e.a] = touched[e.b] = 1;
    std::uint32_t keep = e.a, drop = e.b;
    if (s.fixed[drop]) std::swap(keep, drop);
    if (!s.fixed[keep]) {  // to the edge's midpoint, unless its projection left the cloud (then it stays)
      Eigen::Vector3d nrm;
      double off = 0;
      const Eigen::Vector3d p = surface_.project(0.5 * (s.pos[e.a] + s.pos[e.b]), &nrm, &off, &s.nrm[keep]);
      if (off <= kCollapseOffLimit) s.pos[keep] = p, s.nrm[keep] = nrm;
    }
    removed[drop] = 1;
    map.touched.push_back(keep), map.touched.push_back(drop);
    ++collapsed;
  }
  // Kept samples stay in order (the Morton order of the initialisation degrades only by the few edits), split
  // samples follow.
  map.newIndex.assign(s.size(), kNone);
  Samples kept;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (!removed[i]) {
      map.newIndex[i] = static_cast<std::uint32_t>(kept.size());
      kept.add(s.pos[i], s.nrm[i], s.fixed[i], std::move(s.cache[i]));
    }
  for (std::size_t c = 0; c < newPos.size(); ++c) kept.add(newPos[c], newNrm[c], 0);
  s = std::move(kept);
  map.added = newPos.size();
  updateRule(s);
  result.splits += newPos.size();
  result.collapses += collapsed;
  return map;
}

/// Carries a relaxation across a few edits: kept samples keep their rings (indices renumbered), and only the
/// samples whose cell an edit can change — the split samples, the edited ones and their old neighbourhoods —
/// are active, with fresh k-d tree candidates. @p count is the new number of samples.
void Resampler::carry(Relaxation& state, const EditMap& edits, std::size_t count) const {
  if (!state.rings) return;
  const Rings& old = *state.rings;
  const std::size_t k = static_cast<std::size_t>(old.stride), stride = k + 1;
  Rings r;
  r.stride = old.stride;
  r.ring.assign(count * k, kNone);
  r.candidates.assign(count * stride, kNone);
  r.centroid.assign(count, Eigen::Vector3d::Zero());
  r.nearest.assign(count, 0.0);
  r.outward.assign(count, Eigen::Vector3d::Zero());
  r.size.assign(count, 1.0);
  r.open.assign(count, 0);
  std::vector<char> active(count, 0);
  for (std::size_t i = 0; i < edits.newIndex.size(); ++i) {
    const std::uint32_t to = edits.newIndex[i];
    if (to == kNone) continue;
    std::size_t w = 0;
    for (std::size_t x = 0; x < k; ++x)
      if (const std::uint32_t j = old.ring[i * k + x]; j != kNone && edits.newIndex[j] != kNone)
        r.ring[to * k + w++] = edits.newIndex[j];
    for (std::size_t x = 0; x < stride; ++x)
      if (const std::uint32_t j = old.candidates[i * stride + x]; j != kNone)
        r.candidates[to * stride + x] = edits.newIndex[j];
    r.centroid[to] = old.centroid[i];
    r.nearest[to] = old.nearest[i];
    r.outward[to] = old.outward[i];
    r.size[to] = old.size[i];
    r.open[to] = old.open[i];
    active[to] = state.active[i];
  }
  // The samples an edit can affect (split samples, edited ones and their old neighbourhoods) get fresh
  // candidates next iteration; the others only re-sort theirs.
  std::vector<char> edited(count, 0);
  for (std::size_t a = count - edits.added; a < count; ++a) edited[a] = 1;
  for (std::uint32_t e : edits.touched) {
    if (edits.newIndex[e] != kNone) edited[edits.newIndex[e]] = 1;
    for (std::size_t x = 0; x < stride; ++x)
      if (const std::uint32_t j = old.candidates[e * stride + x]; j != kNone && edits.newIndex[j] != kNone)
        edited[edits.newIndex[j]] = 1;
  }
  for (std::size_t i = 0; i < count; ++i) active[i] |= edited[i];
  state.rings = std::move(r);
  state.active = std::move(active);
  state.stale = std::move(edited);
}

/// Rings for the edge operations, from a relaxation's last rings: cells bounded by their neighbours alone are
/// the same with a wider bounding disc, so only the open ones (boundaries, sparse regions) are recomputed, with
/// the disc of radius 1.5·l that lets long edges — across holes — show. The others keep the rings of the last
/// iteration: one Lloyd step moves a sample by a fraction of a spacing, which changes few 1-rings, and the edge
/// lengths are measured at the current positions.
Rings Resampler::edgeRings(const Samples& s, double l, const Relaxation& state) const {
  if (!state.rings) return computeRings(s, 1.5 * l);
  Relaxation wide{state.rings, state.rings->open, 0, {}};
  return computeRings(s, 1.5 * l, &wide, false);
}

/// How many samples the input points cannot stand for where the input is sparser than @p count samples: Σ over
/// the input points of (the samples the area a point represents holds − 1) where that is positive. The area
/// of point i is π/8 · MlsSurface::pointArea(i) (as in MlsSurface::area()); in adaptive mode divided by its size
/// factor squared.
std::size_t Resampler::sparseDeficit(std::size_t count) const {
  auto area = [&](std::size_t i) {
    const double sz = size_ ? (*size_)[i] : 1.0;
    return surface_.pointArea(i) / (sz * sz);
  };
  double total = 0;
  for (std::size_t i = 0; i < pts_.size(); ++i) total += area(i);
  if (!(total > 0)) return 0;
  double deficit = 0;
  const double perArea = static_cast<double>(count) / total;
  for (std::size_t i = 0; i < pts_.size(); ++i) deficit += std::max(0.0, perArea * area(i) - 1.0);
  return static_cast<std::size_t>(deficit);
}

/// Weighted sample elimination (Yuksel 2015) of free samples down to @p count: repeatedly drop the sample whose
/// neighbours within 2·r_max crowd it most. Gives a Poisson-disk-like set whatever the input density.
void Resampler::eliminate(Samples& s, std::size_t count) {
  if (s.size() <= count) return;
  const double rmax = std::sqrt(surface_.area() / (2.0 * std::sqrt(3.0) * static_cast<double>(count)));
  const double ratio = static_cast<double>(count) / static_cast<double>(s.size());
  const double rmin = rmax * (1.0 - std::pow(ratio, 1.5)) * 0.65;  // Yuksel 2015: γ = 1.5, β = 0.65
  // Adaptive mode: the Poisson-disk radius of a pair scales with the mean size factor of its two samples.
  std::vector<double> sz(s.size(), 1.0);
  if (size_)
    parallelFor(s.size(), exec_.threads, [&](std::size_t i) { sz[i] = (*size_)[surface_.index().nearest(s.pos[i])]; });
  const double maxSize = *std::max_element(sz.begin(), sz.end());
  KnnIndex index(s.pos);
  updateRule(s);  // only neighbours by the rule crowd each other (not across a thin gap)
  // float: 8 bytes a pair, and each row allocated once at its size (memory at 5M)
  std::vector<std::vector<std::pair<std::uint32_t, float>>> nb(s.size());
  parallelFor(s.size(), exec_.threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    thread_local std::vector<std::pair<std::uint32_t, float>> row;
    index.radius(s.pos[i], 2.0 * rmax * 0.5 * (sz[i] + maxSize), idx, d2);
    row.clear();
    for (std::size_t c = 0; c < idx.size(); ++c) {
      if (idx[c] == i || !rule_.accept(i, idx[c])) continue;
      const double scale = 0.5 * (sz[i] + sz[idx[c]]), radius = 2.0 * rmax * scale;
      const double d = std::max(std::sqrt(d2[c]), 2.0 * rmin * scale);
      if (d < radius) row.emplace_back(idx[c], pow8(1.0 - d / radius));
    }
    nb[i].assign(row.begin(), row.end());
  });
  std::vector<double> weight(s.size(), 0.0);
  for (std::size_t i = 0; i < s.size(); ++i)
    for (const auto& [j, w] : nb[i]) weight[i] += w;
  // Ties broken by a seeded hash of the index, so equal weights do not always favour low indices.
  auto tie = [&](std::uint32_t i) {
    std::uint64_t z = params_.seed + 0x9e3779b97f4a7c15ull * (i + 1);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    return z ^ (z >> 27);
  };
  // The most crowded sample (largest weight) goes first, ties by (hash, index). Weights only decrease, so an
  // entry's key is at least its sample's weight: a stale entry that reaches the top is sifted down again with
  // the current weight, and a current one at the top is the true maximum (the same order as a heap keeping
  // every weight current). A binary max-heap of (weight, index), the hash computed only on equal weights.
  struct Item {
    double weight;
    std::uint32_t i;
  };
  auto before = [&](const Item& a, const Item& b) {  // a below b in the heap: b goes first
    if (a.weight != b.weight) return a.weight < b.weight;
    const std::uint64_t ta = tie(a.i), tb = tie(b.i);
    return ta != tb ? ta < tb : a.i < b.i;
  };
  std::vector<Item> heap;
  heap.reserve(s.size());
  for (std::uint32_t i = 0; i < s.size(); ++i)
    if (!s.fixed[i]) heap.push_back({weight[i], i});
  std::make_heap(heap.begin(), heap.end(), before);
  auto siftDownTop = [&] {  // restores the heap after heap[0] decreased
    const std::size_t size = heap.size();
    const Item x = heap[0];
    std::size_t at = 0;
    for (std::size_t child; (child = 2 * at + 1) < size; at = child) {
      if (child + 1 < size && before(heap[child], heap[child + 1])) ++child;
      if (!before(x, heap[child])) break;
      heap[at] = heap[child];
    }
    heap[at] = x;
  };
  std::vector<char> removed(s.size(), 0);
  std::size_t alive = s.size();
  while (alive > count && !heap.empty()) {
    const Item top = heap[0];
    if (top.weight != weight[top.i]) {
      heap[0].weight = weight[top.i];
      siftDownTop();
      continue;
    }
    heap[0] = heap.back();
    heap.pop_back();
    if (!heap.empty()) siftDownTop();
    removed[top.i] = 1;
    --alive;
    for (const auto& [j, wj] : nb[top.i])
      if (!removed[j]) weight[j] -= wj;
  }
  s = spatiallySorted(s, removed, exec_.threads);
}

void Resampler::updateRule(const Samples& s) {
  rule_.update(s.pos, s.nrm);
  rulePos_ = s.pos;
}

/// Last resort when the edge operations cannot reach N (a handful of points with degenerate 1-rings): drop the
/// free samples closest to another sample, or add the input points farthest from the samples, one at a time.
void Resampler::forceCount(Samples& s, Relaxation& relaxation) {
  const std::size_t n = total();
  const std::vector<char> removed = mostCrowded(s.pos, s.fixed, s.size() > n ? s.size() - n : 0);
  Samples kept;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (!removed[i]) kept.add(s.pos[i], s.nrm[i], s.fixed[i], std::move(s.cache[i]));
  if (kept.size() < n) {  // the input points farthest from the samples, one at a time
    std::vector<double> toSamples(pts_.size(), std::numeric_limits<double>::max());
    if (!kept.pos.empty()) {
      const KnnIndex index(kept.pos);
      std::vector<std::uint32_t> idx;
      std::vector<double> d2;
      for (std::size_t q = 0; q < pts_.size(); ++q)
        if (index.knn(pts_[q], 1, idx, d2) == 1) toSamples[q] = d2[0];
    }
    while (kept.size() < n) {
      const auto far = static_cast<std::size_t>(std::max_element(toSamples.begin(), toSamples.end()) - toSamples.begin());
      kept.add(pts_[far], normals_[far], 0);
      for (std::size_t q = 0; q < pts_.size(); ++q)
        toSamples[q] = std::min(toSamples[q], (pts_[q] - pts_[far]).squaredNorm());
    }
  }
  s = std::move(kept);
  updateRule(s);
  relaxation = {};
}

Samples Resampler::initialise(const std::vector<std::uint32_t>& chosen, ResampleResult& result) {
  const std::size_t n = total();
  Samples s;
  auto hold = [&](const std::vector<Eigen::Vector3d>& given, char kind) {
    for (const auto& p : given) {
      Eigen::Vector3d nrm;
      surface_.project(p, &nrm);
      s.add(p, nrm, kind);
    }
  };
  hold(params_.fixedSamples, Samples::kHeld);
  hold(params_.contextSamples, Samples::kContext);
  // Candidates are input points (on the cloud already): only the survivors of the elimination are projected.
  for (std::uint32_t c : chosen) s.add(pts_[c], normals_[c], 0);
  // Parts sparser than the output (another object sampled sparsely) hold fewer input points than samples: the
  // rest is thinned to its own share, and the count passes split the sparse parts' edges up to N. The deficit is
  // that of the N samples to place: the context samples are there already (counted in, they would take the
  // free candidates' places and leave the passes no free sample to split from).
  const std::size_t toPlace = params_.targetCount;
  eliminate(s, n - std::min(toPlace, sparseDeficit(toPlace)));
  parallelFor(s.size(), exec_.threads, [&](std::size_t i) {
    if (!s.fixed[i]) s.pos[i] = surface_.project(s.pos[i], &s.nrm[i], nullptr, &s.nrm[i], &s.cache[i]);
  });
  updateRule(s);
  result.initialSamples = s.size();
  return s;
}

void Resampler::run(Samples& s, ResampleResult& result) {
  const std::size_t n = total();
  const double countD = static_cast<double>(n);
  // By (length, a, b): a stable radix sort on the lengths' bits (non-negative doubles order like them) of
  // edges in (a, b) order.
  auto sortedEdges = [&](const Rings& r) {
    const std::vector<Edge> e = edges(s, r);
    std::vector<KeyedIndex> byLength(e.size());
    for (std::size_t x = 0; x < e.size(); ++x) {
      std::uint64_t bits;
      std::memcpy(&bits, &e[x].length, sizeof bits);
      byLength[x] = {bits, static_cast<std::uint32_t>(x)};
    }
    radixSort(byLength, exec_.threads);
    std::vector<Edge> out(e.size());
    for (std::size_t x = 0; x < e.size(); ++x) out[x] = e[byLength[x].second];
    return out;
  };
  // Count control: l = mean 1-ring edge · √(|S|/N), the length at which N samples would cover the surface.
  auto targetLength = [&](const std::vector<Edge>& e) {
    double mean = 0;
    for (const Edge& x : e) mean += x.length;
    mean = e.empty() ? std::sqrt(surface_.area() / countD) : mean / static_cast<double>(e.size());
    return mean * std::sqrt(static_cast<double>(s.size()) / countD);
  };
  double l = std::sqrt(2.0 * surface_.area() / (std::sqrt(3.0) * countD));
  // Passes: split edges > splitRatio·l, collapse edges < collapseRatio·l, then relax. Away from N the net
  // change always moves |S| towards N without overshooting; at N every collapse is paired with a split of
  // one of the longest edges, so close pairs and holes that Lloyd alone cannot undo are replaced.
  // One relaxation state throughout: a round of edits renumbers it and activates the cells around the edits
  // (a large round, away from N, starts it afresh).
  Relaxation relaxation;
  auto edit = [&](const std::vector<Edge>& e, std::size_t splits, double minSplit, std::size_t collapses,
                  double maxCollapse) {
    const EditMap map = splitAndCollapse(s, e, splits, minSplit, collapses, maxCollapse, result);
    if (static_cast<double>(map.touched.size()) > kCarryShare * static_cast<double>(s.size())) relaxation = {};
    carry(relaxation, map, s.size());
  };
  // maxPasses bounds the passes at N; count-changing passes come on top (up to kMaxCountPasses). Up to 8 × maxPasses
  // at N while the cv falls by over 5 % a pass (0.9 over two), or at all above kEvenCv: each moves 1 % of the samples
  // from the densest spots to the sparsest, too few where the density varies widely (a scanner's rings: 0.40 → 0.28).
  constexpr int kMaxCountPasses = 8, kMaxPassFactor = 8;
  constexpr double kEvenCv = 0.08;  // the isotropic spacing cv the issues ask for
  std::vector<double> passCv;
  auto another = [&](int pass, int atN) {
    if (atN < params_.maxPasses) return pass < params_.maxPasses + kMaxCountPasses;
    const std::size_t m = passCv.size();
    if (atN >= kMaxPassFactor * params_.maxPasses || m < 3) return false;
    return passCv[m - 1] < (passCv[m - 1] > kEvenCv ? 1.0 : 0.9) * passCv[m - 3];
  };
  for (int pass = 0, atN = 0; another(pass, atN); ++pass) {
    exec_.report("resample", 0.8 * std::min(atN, params_.maxPasses) / params_.maxPasses);
    // At N, or off by what one balanced round of edits can leave (a collapse may find its samples taken).
    atN += static_cast<double>(s.size() > n ? s.size() - n : n - s.size()) <= params_.maxEditShare * countD + 1;
    const std::vector<Edge> e = sortedEdges(edgeRings(s, l, relaxation));
    l = targetLength(e);
    ++result.passes;
    const auto longCount = static_cast<std::size_t>(
        std::count_if(e.begin(), e.end(), [&](const Edge& x) { return x.length > params_.splitRatio * l; }));
    const auto shortCount = static_cast<std::size_t>(
        std::count_if(e.begin(), e.end(), [&](const Edge& x) { return x.length < params_.collapseRatio * l; }));
    std::size_t splits = longCount, collapses = shortCount;
    double minSplit = params_.splitRatio * l, maxCollapse = params_.collapseRatio * l;
    if (s.size() == n) {
      if (longCount == 0 && shortCount == 0) break;
      splits = collapses = std::min(std::max(longCount, shortCount),
                                    static_cast<std::size_t>(params_.maxEditShare * countD) + 1);
      minSplit = 0;
      maxCollapse = std::numeric_limits<double>::max();
    } else {
      const std::size_t excess = s.size() > n ? s.size() - n : 0, deficit = n > s.size() ? n - s.size() : 0;
      collapses = std::min(collapses, splits + excess);
      splits = std::min(splits, collapses + deficit);
      // Upsampling can stall short of N: l comes from the 1-ring edges, which miss the holes a sparse input
      // leaves, so few edges exceed splitRatio·l. The longest edges then make up the deficit (up to half the
      // samples per pass).
      if (deficit > 0 && splits < collapses + deficit) {
        splits = std::min(collapses + deficit, std::max(splits, s.size() / 2));
        minSplit = 0;
      }
    }
    edit(e, splits, minSplit, collapses, maxCollapse);
    // One projection step per move while the passes still edit the set; the final relaxation below projects fully.
    passCv.push_back(relax(s, l, params_.relaxPerPass, relaxation, 1));
    result.relaxIterations += params_.relaxPerPass;
  }
  // Exact-count finish: collapse the shortest or split the longest edges until |S| == N.
  for (int guard = 0; s.size() != n && guard < 64; ++guard) {
    const std::vector<Edge> e = sortedEdges(edgeRings(s, l, relaxation));
    const std::size_t excess = s.size() > n ? s.size() - n : 0, deficit = n > s.size() ? n - s.size() : 0;
    edit(e, deficit, 0.0, excess, std::numeric_limits<double>::max());
    l = targetLength(e);
    relax(s, l, 1, relaxation);
    ++result.relaxIterations;
  }
  if (s.size() != n) forceCount(s, relaxation);
  // Lloyd relaxation in rounds of 4 iterations until the spacing CV has not improved for relaxPatience rounds.
  double best = std::numeric_limits<double>::max();
  for (int it = 0, stale = 0; it < params_.maxRelaxIterations && stale < params_.relaxPatience; it += 4) {
    exec_.report("resample", 0.8 + 0.2 * it / params_.maxRelaxIterations);
    const double cv = relax(s, l, std::min(4, params_.maxRelaxIterations - it), relaxation);
    result.relaxIterations += std::min(4, params_.maxRelaxIterations - it);
    stale = cv < best - 1e-5 ? 0 : stale + 1;
    best = std::min(best, cv);
  }
  result.targetLength = l;
  if (params_.ringEdges)
    for (const Edge& e : edges(s, computeRings(s, l))) result.ringEdges.push_back({e.a, e.b});
}

}  // namespace iires::detail
