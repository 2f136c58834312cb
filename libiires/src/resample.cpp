#include "iires/resample.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

#include <Eigen/Geometry>

#include "iires/knn.hpp"
#include "iires/parallel.hpp"
#include "iires/tangent_cell.hpp"
#include "iires/validate.hpp"

namespace iires {
namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

constexpr std::uint32_t kNone = 0xffffffffu;
constexpr double kOffSurfaceLimit = 0.6;  // MlsSurface::project's offSurface beyond which a move left the cloud

/// The working sample set S.
struct Samples {
  std::vector<Eigen::Vector3d> pos, nrm;
  std::vector<char> fixed;
  std::vector<MlsCache> cache;  // each sample's last MLS neighbourhood (saves most k-NN searches in relaxation)
  std::size_t size() const { return pos.size(); }
  void add(const Eigen::Vector3d& p, const Eigen::Vector3d& n, bool isFixed, MlsCache c = {}) {
    pos.push_back(p);
    nrm.push_back(n);
    fixed.push_back(isFixed ? 1 : 0);
    cache.push_back(std::move(c));
  }
};

/// Per sample: its 1-ring (tangent-plane Delaunay neighbours) and the centroid of its tangent-plane Voronoi cell.
struct Rings {
  int stride = 0;
  std::vector<std::uint32_t> ring;  // stride entries per sample, kNone-padded
  std::vector<Eigen::Vector3d> centroid;
  std::vector<double> nearest;  // distance to the nearest accepted neighbour
  std::vector<Eigen::Vector3d> outward;  // unit tangent pointing off the surface at boundary samples, else 0
  std::vector<double> size;  // each sample's target size factor s (1 in isotropic mode)
};

struct Edge {
  double length;  // in units of the local target size (s_a + s_b) / 2: the plain length in isotropic mode
  std::uint32_t a, b;
};

/// Voxel thinning (DESIGN §3.5): cells sized by secant steps on the cell size (from @p cell) so that about
/// @p target are occupied; per cell the point nearest its centre, indices ascending. With normals, the normal's
/// dominant signed axis is part of the cell key, so facing sheets of a thin part that share a cell (a gap
/// narrower than the cell) each keep a point.
std::vector<std::uint32_t> voxelThin(const std::vector<Eigen::Vector3d>& pts, const std::vector<Eigen::Vector3d>& normals,
                                     std::size_t target, double cell) {
  Eigen::Vector3d lo = pts[0];
  for (const auto& p : pts) lo = lo.cwiseMin(p);
  auto occupancy = [&](double size, std::vector<std::uint32_t>* chosen) {
    std::unordered_map<std::uint64_t, std::uint32_t> best;
    best.reserve(std::min(pts.size(), target * 4));
    auto key = [&](const Eigen::Vector3d& p, Eigen::Vector3d& centre) {
      const Eigen::Vector3d q = (p - lo) / size;
      const auto ix = static_cast<std::uint64_t>(q.x()), iy = static_cast<std::uint64_t>(q.y()),
                 iz = static_cast<std::uint64_t>(q.z());
      centre = lo + size * Eigen::Vector3d(ix + 0.5, iy + 0.5, iz + 0.5);
      return (ix << 42) ^ (iy << 21) ^ iz;
    };
    auto normalClass = [&](std::uint32_t i) -> std::uint64_t {
      if (normals.empty()) return 0;
      Eigen::Index axis;
      normals[i].cwiseAbs().maxCoeff(&axis);
      return static_cast<std::uint64_t>(2 * axis + (normals[i][axis] < 0 ? 1 : 0));
    };
    Eigen::Vector3d centre;
    for (std::uint32_t i = 0; i < pts.size(); ++i) {
      auto [it, inserted] = best.emplace(key(pts[i], centre) * 8 + normalClass(i), i);
      if (!inserted && chosen && (pts[i] - centre).squaredNorm() < (pts[it->second] - centre).squaredNorm())
        it->second = i;
    }
    if (chosen) {
      chosen->clear();
      for (const auto& [h, i] : best) chosen->push_back(i);
      std::sort(chosen->begin(), chosen->end());
    }
    return best.size();
  };
  // Occupied cells scale like cell⁻² on a surface.
  for (int step = 0; step < 8; ++step) {
    const double ratio = static_cast<double>(occupancy(cell, nullptr)) / static_cast<double>(target);
    if (ratio > 0.85 && ratio < 1.2) break;
    cell *= std::sqrt(std::clamp(ratio, 0.25, 4.0));
  }
  std::vector<std::uint32_t> chosen;
  occupancy(cell, &chosen);
  return chosen;
}

class Resampler {
 public:
  /// @param size per input point target-size factor (curvature mode), or null (isotropic)
  Resampler(const std::vector<Eigen::Vector3d>& pts, const std::vector<Eigen::Vector3d>& normals,
            const MlsSurface& surface, const ResampleParams& params, NeighbourRule& rule,
            const std::vector<double>* size)
      : pts_(pts), normals_(normals), surface_(surface), params_(params), rule_(rule), size_(size) {}

  Samples initialise(ResampleResult& result);
  void run(Samples& s, ResampleResult& result);

 private:
  Rings computeRings(const Samples& s, double cellRadius, bool refreshRule = true) const;
  std::vector<Edge> edges(const Samples& s, const Rings& r) const;
  double relax(Samples& s, double l, int iterations);
  void splitAndCollapse(Samples& s, const std::vector<Edge>& sorted, std::size_t splits, double minSplit,
                        std::size_t collapses, double maxCollapse, ResampleResult& result);
  void eliminate(Samples& s, std::size_t count);

  const std::vector<Eigen::Vector3d>& pts_;
  const std::vector<Eigen::Vector3d>& normals_;
  const MlsSurface& surface_;
  const ResampleParams& params_;
  NeighbourRule& rule_;
  const std::vector<double>* size_;
};

Rings Resampler::computeRings(const Samples& s, double cellRadius, bool refreshRule) const {
  if (refreshRule) rule_.update(s.pos, s.nrm);
  const int k = params_.neighbours;
  Rings r;
  r.stride = k;
  r.ring.assign(s.size() * static_cast<std::size_t>(k), kNone);
  r.centroid.resize(s.size());
  r.nearest.assign(s.size(), 0.0);
  r.outward.assign(s.size(), Eigen::Vector3d::Zero());
  r.size.assign(s.size(), 1.0);
  if (size_)  // adaptive mode (eq. 10): a sample takes the size factor of its nearest input point
    parallelFor(s.size(), params_.threads, [&](std::size_t i) { r.size[i] = (*size_)[surface_.index().nearest(s.pos[i])]; });
  KnnIndex index(s.pos);
  parallelFor(s.size(), params_.threads, [&](std::size_t i) {
    // Per-thread scratch buffers: this runs for every sample in every iteration.
    thread_local std::vector<std::uint32_t> idx, lab, tmpL;
    thread_local std::vector<double> d2, angles;
    thread_local std::vector<std::pair<std::uint32_t, Eigen::Vector2d>> nb;
    thread_local std::vector<Eigen::Vector2d> poly, tmpV;
    index.knn(s.pos[i], static_cast<std::size_t>(k) + 1, idx, d2);
    const Eigen::Vector3d& n = s.nrm[i];
    const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
    // Accepted neighbours in tangent coordinates. Log-map approximation: the tangent direction of the neighbour
    // with its true 3-D distance, so that on curved patches Lloyd equalises real spacings rather than their
    // (shorter) tangent-plane projections.
    nb.clear();
    for (std::size_t c = 0; c < idx.size(); ++c) {
      const std::uint32_t j = idx[c];
      if (j == i || !rule_.accept(i, j)) continue;
      const Eigen::Vector3d d = s.pos[j] - s.pos[i];
      Eigen::Vector2d q(d.dot(u), d.dot(v));
      const double qn = q.norm(), dist = std::sqrt(d2[c]);
      if (qn < 1e-12 * dist || qn == 0.0) continue;
      nb.emplace_back(j, q * (dist / qn));
    }
    // The cell is bounded by a disc of radius R (for open boundaries); R follows the local spacing where the
    // samples are sparser than l (upsampling), so rings never depend on how far the count still is from N.
    const double nearest = nb.empty() ? 0.0 : nb.front().second.norm();
    const double radius = std::max(cellRadius * r.size[i], nearest);
    poly.clear();
    lab.clear();
    const double rad = radius / std::cos(M_PI / 16);
    for (int e = 0; e < 16; ++e) {
      poly.emplace_back(rad * std::cos(2 * M_PI * e / 16), rad * std::sin(2 * M_PI * e / 16));
      lab.push_back(kNone);
    }
    for (const auto& [j, q] : nb) {
      if (q.norm() > 4.0 * radius) break;  // sorted by distance: the rest cannot touch the cell
      clipByBisector(poly, lab, q, r.size[i] / (r.size[i] + r.size[j]), j, tmpV, tmpL);
      if (poly.size() < 3) break;
    }
    const Eigen::Vector2d c2 = poly.size() >= 3 ? polygonCentroid(poly) : Eigen::Vector2d::Zero();
    r.centroid[i] = s.pos[i] + c2.x() * u + c2.y() * v;
    r.nearest[i] = nearest;
    std::sort(lab.begin(), lab.end());
    lab.erase(std::unique(lab.begin(), lab.end()), lab.end());
    int w = 0;
    angles.clear();
    for (std::uint32_t j : lab) {
      if (j == kNone || w >= k) continue;
      r.ring[i * static_cast<std::size_t>(k) + static_cast<std::size_t>(w++)] = j;
      const auto it = std::find_if(nb.begin(), nb.end(), [&](const auto& x) { return x.first == j; });
      angles.push_back(std::atan2(it->second.y(), it->second.x()));
    }
    // Open boundary: the 1-ring leaves an angular gap wider than 135° and the surface does not continue into
    // it (a probe half a cell into the gap leaves the cloud); the gap's bisector then points off the surface.
    // A gap with surface behind it is merely a sparse region (e.g. while upsampling) and stays open to moves.
    std::sort(angles.begin(), angles.end());
    for (std::size_t a = 0; a < angles.size(); ++a) {
      const double from = angles[a], to = a + 1 < angles.size() ? angles[a + 1] : angles[0] + 2 * M_PI;
      if (to - from <= 0.75 * M_PI) continue;
      const double mid = 0.5 * (from + to);
      const Eigen::Vector3d dir = std::cos(mid) * u + std::sin(mid) * v;
      double off = 0;
      surface_.project(s.pos[i] + 0.5 * radius * dir, nullptr, &off, &s.nrm[i]);
      if (off > kOffSurfaceLimit) r.outward[i] = dir;
    }
  });
  return r;
}

/// Edges present in both endpoints' 1-rings, each once (a < b), in a deterministic order.
std::vector<Edge> Resampler::edges(const Samples& s, const Rings& r) const {
  std::vector<Edge> out;
  const std::size_t k = static_cast<std::size_t>(r.stride);
  for (std::size_t a = 0; a < s.size(); ++a)
    for (std::size_t x = 0; x < k; ++x) {
      const std::uint32_t b = r.ring[a * k + x];
      if (b == kNone || b <= a) continue;
      const auto* rb = &r.ring[b * k];
      if (std::find(rb, rb + k, static_cast<std::uint32_t>(a)) == rb + k) continue;
      out.push_back({(s.pos[a] - s.pos[b]).norm() / (0.5 * (r.size[a] + r.size[b])), static_cast<std::uint32_t>(a), b});
    }
  return out;
}

/// Lloyd relaxation: move each free sample to the centroid of its tangent-plane Voronoi cell, projected onto
/// the MLS surface (halving the step if the move would leave the cloud). Returns the spacing CV after the last
/// iteration (from the 1-rings, so it costs nothing extra).
double Resampler::relax(Samples& s, double l, int iterations) {
  double cv = 0;
  for (int it = 0; it < iterations; ++it) {
    // Relaxation moves samples by a fraction of a spacing and keeps their order: the neighbour rule's view of
    // them is refreshed on the first iteration of each call only.
    const Rings r = computeRings(s, l, it == 0);
    std::vector<Eigen::Vector3d> pos(s.pos), nrm(s.nrm);
    parallelFor(s.size(), params_.threads, [&](std::size_t i) {
      if (s.fixed[i]) return;
      Eigen::Vector3d step = params_.overRelaxation * (r.centroid[i] - s.pos[i]);
      // Boundary samples may slide along the boundary or move inwards, never off the surface.
      step -= std::max(0.0, step.dot(r.outward[i])) * r.outward[i];
      Eigen::Vector3d target = s.pos[i] + step;
      for (int attempt = 0; attempt < 3; ++attempt) {
        Eigen::Vector3d n;
        double off = 0;
        const Eigen::Vector3d p = surface_.project(target, &n, &off, &s.nrm[i], &s.cache[i]);
        if (off <= kOffSurfaceLimit) {
          pos[i] = p;
          nrm[i] = n;
          return;
        }
        target = 0.5 * (target + s.pos[i]);
      }
    });
    s.pos.swap(pos);
    s.nrm.swap(nrm);
    double sum = 0, sq = 0;
    for (double d : r.nearest) sum += d, sq += d * d;
    const double mean = sum / static_cast<double>(r.nearest.size());
    cv = mean > 0 ? std::sqrt(std::max(0.0, sq / static_cast<double>(r.nearest.size()) - mean * mean)) / mean : 0;
  }
  return cv;
}

/// One round of edge operations on the 1-ring edges (@p sorted ascending by length):
/// - split the longest edges longer than @p minSplit, at most @p splits: insert the edge midpoint projected onto
///   the surface (a point cloud has no connectivity to keep, so a sample may take part in several splits);
/// - collapse the shortest edges shorter than @p maxCollapse, at most @p collapses, each sample in at most one
///   collapse: both ends are replaced by their midpoint on the surface (a fixed end stays put).
void Resampler::splitAndCollapse(Samples& s, const std::vector<Edge>& sorted, std::size_t splits,
                                 double minSplit, std::size_t collapses, double maxCollapse,
                                 ResampleResult& result) {
  // Longest first; midpoints are projected in parallel batches and an edge spanning a hole of the cloud (its
  // midpoint leaves the surface) is not split.
  std::vector<Eigen::Vector3d> newPos, newNrm;
  std::vector<const Edge*> batch;
  auto next = sorted.rbegin();
  while (newPos.size() < splits && next != sorted.rend() && next->length > minSplit) {
    batch.clear();
    for (; next != sorted.rend() && next->length > minSplit && batch.size() < 2 * (splits - newPos.size()) + 16;
         ++next)
      batch.push_back(&*next);
    std::vector<Eigen::Vector3d> pos(batch.size()), nrm(batch.size());
    std::vector<double> off(batch.size());
    parallelFor(batch.size(), params_.threads, [&](std::size_t c) {
      const Edge& e = *batch[c];
      pos[c] = surface_.project(0.5 * (s.pos[e.a] + s.pos[e.b]), &nrm[c], &off[c], &s.nrm[e.a]);
    });
    for (std::size_t c = 0; c < batch.size() && newPos.size() < splits; ++c)
      if (off[c] <= kOffSurfaceLimit) newPos.push_back(pos[c]), newNrm.push_back(nrm[c]);
  }
  std::vector<char> touched(s.size(), 0), removed(s.size(), 0);
  std::size_t collapsed = 0;
  for (const Edge& e : sorted) {
    if (collapsed >= collapses || e.length >= maxCollapse) break;
    if (touched[e.a] || touched[e.b] || (s.fixed[e.a] && s.fixed[e.b])) continue;
    touched[e.a] = touched[e.b] = 1;
    std::uint32_t keep = e.a, drop = e.b;
    if (s.fixed[drop]) std::swap(keep, drop);
    if (!s.fixed[keep])
      s.pos[keep] = surface_.project(0.5 * (s.pos[e.a] + s.pos[e.b]), &s.nrm[keep], nullptr, &s.nrm[keep]);
    removed[drop] = 1;
    ++collapsed;
  }
  Samples kept;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (!removed[i]) kept.add(s.pos[i], s.nrm[i], s.fixed[i], std::move(s.cache[i]));
  for (std::size_t c = 0; c < newPos.size(); ++c) kept.add(newPos[c], newNrm[c], false);
  s = std::move(kept);
  result.splits += newPos.size();
  result.collapses += collapsed;
}

/// Weighted sample elimination (Yuksel 2015) of free samples down to @p count: repeatedly drop the sample whose
/// neighbours within 2·r_max crowd it most. Gives a Poisson-disk-like set whatever the input density.
void Resampler::eliminate(Samples& s, std::size_t count) {
  if (s.size() <= count) return;
  const double rmax = std::sqrt(surface_.area() / (2.0 * std::sqrt(3.0) * static_cast<double>(count)));
  const double ratio = static_cast<double>(count) / static_cast<double>(s.size());
  const double rmin = rmax * (1.0 - 0.65 * std::pow(ratio, 1.5));
  // Adaptive mode: the Poisson-disk radius of a pair scales with the mean size factor of its two samples.
  std::vector<double> sz(s.size(), 1.0);
  if (size_)
    parallelFor(s.size(), params_.threads, [&](std::size_t i) { sz[i] = (*size_)[surface_.index().nearest(s.pos[i])]; });
  const double maxSize = *std::max_element(sz.begin(), sz.end());
  KnnIndex index(s.pos);
  rule_.update(s.pos, s.nrm);  // only neighbours by the rule crowd each other (not across a thin gap)
  std::vector<std::vector<std::pair<std::uint32_t, double>>> nb(s.size());
  parallelFor(s.size(), params_.threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.radius(s.pos[i], 2.0 * rmax * 0.5 * (sz[i] + maxSize), idx, d2);
    for (std::size_t c = 0; c < idx.size(); ++c) {
      if (idx[c] == i || !rule_.accept(i, idx[c])) continue;
      const double scale = 0.5 * (sz[i] + sz[idx[c]]), radius = 2.0 * rmax * scale;
      const double d = std::max(std::sqrt(d2[c]), 2.0 * rmin * scale);
      if (d < radius) nb[i].emplace_back(idx[c], std::pow(1.0 - d / radius, 8.0));
    }
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
  using Item = std::tuple<double, std::uint64_t, std::uint32_t>;
  std::priority_queue<Item> heap;
  for (std::uint32_t i = 0; i < s.size(); ++i)
    if (!s.fixed[i]) heap.emplace(weight[i], tie(i), i);
  std::vector<char> removed(s.size(), 0);
  std::size_t alive = s.size();
  while (alive > count && !heap.empty()) {
    const auto [w, t, i] = heap.top();
    heap.pop();
    if (removed[i] || w != weight[i]) continue;
    removed[i] = 1;
    --alive;
    for (const auto& [j, wj] : nb[i]) {
      if (removed[j]) continue;
      weight[j] -= wj;
      if (!s.fixed[j]) heap.emplace(weight[j], tie(j), j);
    }
  }
  Samples kept;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (!removed[i]) kept.add(s.pos[i], s.nrm[i], s.fixed[i]);
  s = std::move(kept);
}

Samples Resampler::initialise(ResampleResult& result) {
  const std::size_t n = params_.targetCount;
  Samples s;
  for (const auto& p : params_.fixedSamples) {
    Eigen::Vector3d nrm;
    surface_.project(p, &nrm);
    s.add(p, nrm, true);
  }
  std::vector<std::uint32_t> chosen;
  const std::size_t candidates = static_cast<std::size_t>(params_.candidateFactor * static_cast<double>(n));
  if (pts_.size() <= candidates) {
    chosen.resize(pts_.size());
    std::iota(chosen.begin(), chosen.end(), 0u);
  } else {
    chosen = voxelThin(pts_, normals_, candidates, std::sqrt(surface_.area() / static_cast<double>(candidates)));
  }
  std::vector<Eigen::Vector3d> pos(chosen.size()), nrm(chosen.size());
  parallelFor(chosen.size(), params_.threads, [&](std::size_t c) { pos[c] = surface_.project(pts_[chosen[c]], &nrm[c]); });
  for (std::size_t c = 0; c < chosen.size(); ++c) s.add(pos[c], nrm[c], false);
  eliminate(s, n);
  result.initialSamples = s.size();
  return s;
}

void Resampler::run(Samples& s, ResampleResult& result) {
  const std::size_t n = params_.targetCount;
  const double countD = static_cast<double>(n);
  auto sortedEdges = [&](const Rings& r) {
    std::vector<Edge> e = edges(s, r);
    std::sort(e.begin(), e.end(), [](const Edge& a, const Edge& b) {
      return std::tie(a.length, a.a, a.b) < std::tie(b.length, b.a, b.b);
    });
    return e;
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
  for (int pass = 0; pass < params_.maxPasses; ++pass) {
    if (params_.progress) params_.progress("resample", 0.8 * pass / params_.maxPasses);
    const std::vector<Edge> e = sortedEdges(computeRings(s, 1.5 * l));
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
    }
    splitAndCollapse(s, e, splits, minSplit, collapses, maxCollapse, result);
    relax(s, l, params_.relaxPerPass);
    result.relaxIterations += params_.relaxPerPass;
  }
  // Exact-count finish: collapse the shortest or split the longest edges until |S| == N.
  for (int guard = 0; s.size() != n && guard < 64; ++guard) {
    const std::vector<Edge> e = sortedEdges(computeRings(s, 1.5 * l));
    const std::size_t excess = s.size() > n ? s.size() - n : 0, deficit = n > s.size() ? n - s.size() : 0;
    splitAndCollapse(s, e, deficit, 0.0, excess, std::numeric_limits<double>::max(), result);
    l = targetLength(e);
    relax(s, l, 1);
    ++result.relaxIterations;
  }
  if (s.size() != n) throw std::runtime_error("resample: could not reach the requested count");
  // Lloyd relaxation in rounds of 4 iterations until the spacing CV has not improved for relaxPatience rounds.
  double best = std::numeric_limits<double>::max();
  for (int it = 0, stale = 0; it < params_.maxRelaxIterations && stale < params_.relaxPatience; it += 4) {
    if (params_.progress) params_.progress("resample", 0.8 + 0.2 * it / params_.maxRelaxIterations);
    const double cv = relax(s, l, std::min(4, params_.maxRelaxIterations - it));
    result.relaxIterations += std::min(4, params_.maxRelaxIterations - it);
    stale = cv < best - 1e-5 ? 0 : stale + 1;
    best = std::min(best, cv);
  }
  result.targetLength = l;
  for (const Edge& e : edges(s, computeRings(s, l))) result.ringEdges.push_back({e.a, e.b});
}

std::string jsonNumber(double x) {
  if (!std::isfinite(x)) return "null";
  std::ostringstream os;
  os.precision(10);
  os << x;
  return os.str();
}

template <typename T>
std::string jsonArray(const std::vector<T>& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i)
    out += (i ? ", " : "") + jsonNumber(static_cast<double>(values[i]));
  return out + "]";
}

}  // namespace

void ResampleParams::validate() const {
  if (targetCount < 1) throw std::invalid_argument("the requested point count N must be at least 1");
  if (neighbours < 6 || neighbours > 64) throw std::invalid_argument("neighbours must be in [6, 64]");
  if (!(splitRatio > 1.0)) throw std::invalid_argument("splitRatio must be > 1");
  if (!(collapseRatio > 0.0 && collapseRatio < 1.0)) throw std::invalid_argument("collapseRatio must be in (0, 1)");
  if (maxPasses < 0 || relaxPerPass < 0 || maxRelaxIterations < 0 || relaxPatience < 1)
    throw std::invalid_argument("pass and iteration counts must be >= 0 (patience >= 1)");
  if (!(overRelaxation >= 1.0 && overRelaxation < 2.0)) throw std::invalid_argument("overRelaxation must be in [1, 2)");
  if (!(maxEditShare >= 0.0 && maxEditShare <= 0.5)) throw std::invalid_argument("maxEditShare must be in [0, 0.5]");
  if (maxInputPerSample > 0 && maxInputPerSample < 4) throw std::invalid_argument("maxInputPerSample must be 0 or >= 4");
  if (!(candidateFactor >= 1.0)) throw std::invalid_argument("candidateFactor must be >= 1");
  if (mls.k < 3) throw std::invalid_argument("mls.k must be >= 3");
  if (threads < 0) throw std::invalid_argument("threads must be >= 0 (0 = all cores)");
  if (mode == ResampleMode::kCurvature) curvature.validate();
  if (sharpEdges && !(edgeRatio > 0.0)) throw std::invalid_argument("edgeRatio must be > 0");
  if (fixedSamples.size() > targetCount)
    throw std::invalid_argument("more fixed samples than the requested point count");
}

std::string ResampleResult::toJson() const {
  std::ostringstream os;
  os << "{\n  \"input_points\": " << inputPoints << ",\n  \"duplicates_merged\": " << duplicatesMerged
     << ",\n  \"requested_points\": " << requestedPoints << ",\n  \"output_points\": " << cloud.size()
     << ",\n  \"working_points\": " << thinnedPoints << ",\n  \"initial_samples\": " << initialSamples << ",\n  \"passes\": " << passes
     << ",\n  \"relax_iterations\": " << relaxIterations << ",\n  \"splits\": " << splits
     << ",\n  \"collapses\": " << collapses << ",\n  \"target_length\": " << jsonNumber(targetLength)
     << ",\n  \"components\": " << components << ",\n  \"satellites\": " << satellites
     << ",\n  \"feature_points\": " << featurePoints << ",\n  \"feature_samples\": " << featureSamples
     << ",\n  \"points_per_level\": " << jsonArray(pointsPerLevel)
     << ",\n  \"spacing_per_level\": " << jsonArray(spacingPerLevel)
     << ",\n  \"preprocess\": " << preprocessing.toJson()
     << ",\n  \"spacing\": {\"mean\": " << jsonNumber(spacing.mean) << ", \"min\": " << jsonNumber(spacing.min)
     << ", \"max\": " << jsonNumber(spacing.max) << ", \"cv\": " << jsonNumber(spacing.cv) << "},\n  \"time_s\": {";
  for (std::size_t i = 0; i < timings.size(); ++i)
    os << (i ? ", " : "") << "\"" << timings[i].name << "\": " << jsonNumber(timings[i].seconds);
  os << "}\n}\n";
  return os.str();
}

ResampleResult resample(const PointCloud& input, const ResampleParams& params) {
  params.validate();
  const auto start = Clock::now();
  ResampleResult result;
  result.requestedPoints = params.targetCount;
  result.inputPoints = input.size();
  auto stage = [&](const char* name, Clock::time_point t) {
    result.timings.push_back({name, secondsSince(t)});
    if (params.progress && std::string(name) != "total") params.progress(name, 1.0);
  };
  auto begin = [&](const char* name) {
    if (params.progress) params.progress(name, 0.0);
    return Clock::now();
  };

  auto t = begin("validate");
  PointCloud cloud = input;
  const ValidationReport report = validateCloud(cloud, 4, "input");
  result.duplicatesMerged = report.duplicatesMerged;
  stage("validate", t);

  constexpr std::size_t kMinWorkingPoints = 100000;  // thinning never goes below this: small N keep a fine surface
  const std::size_t workingTarget = std::max(kMinWorkingPoints, params.maxInputPerSample * params.targetCount);
  if (params.maxInputPerSample > 0 && cloud.size() > workingTarget) {
    // Far denser than the output: thin first, so every O(n) stage below works on ≈ maxInputPerSample·N points.
    t = begin("thin");
    const std::size_t target = workingTarget;
    const std::vector<std::uint32_t> keep =
        voxelThin(cloud.points, cloud.normals, target, bboxDiagonal(cloud.points) / std::sqrt(static_cast<double>(target)));
    PointCloud thin;
    for (std::uint32_t i : keep) {
      thin.points.push_back(cloud.points[i]);
      if (cloud.hasNormals()) thin.normals.push_back(cloud.normals[i]);
    }
    cloud = std::move(thin);
    stage("thin", t);
  }
  result.thinnedPoints = cloud.size();

  constexpr std::size_t kPreprocessMinPoints = 25;
  if (params.preprocess && cloud.size() >= kPreprocessMinPoints) {
    t = begin("preprocess");
    PreprocessParams pp = params.preprocessing;
    pp.threads = params.threads;
    result.preprocessing = iires::preprocess(cloud, pp);
    cloud = std::move(result.preprocessing.cloud);
    result.preprocessing.cloud = {};
    stage("preprocess", t);
  }

  t = begin("normals");
  if (!cloud.hasNormals()) {
    NormalParams np = params.normals;
    np.threads = params.threads;
    cloud.normals = estimateNormals(cloud.points, np);
  } else {
    for (auto& nrm : cloud.normals) nrm.normalize();
  }
  stage("normals", t);

  t = begin("surface");
  const MlsSurface surface(cloud.points, cloud.normals, params.mls);
  stage("surface", t);

  std::shared_ptr<NeighbourRule> rule = params.neighbourRule;
  if (!rule && params.intrinsic) {
    t = begin("geodesic");
    GeodesicParams gp = params.geodesic;
    IntrinsicParams ip = params.intrinsicRule;
    gp.threads = ip.threads = params.threads;
    result.geodesic = std::make_shared<const GeodesicCoordinates>(cloud, gp);
    rule = std::make_shared<IntrinsicRule>(result.geodesic, ip);
    result.components = result.geodesic->components();
    result.satellites = result.components * static_cast<std::size_t>(gp.satellites);
    stage("geodesic", t);
  }
  if (!rule) rule = std::make_shared<EuclideanRule>();

  std::optional<CurvatureResult> curvature;
  if (params.mode == ResampleMode::kCurvature) {
    t = begin("curvature");
    CurvatureParams cp = params.curvature;
    cp.threads = params.threads;
    curvature = computeCurvature(cloud.points, cloud.normals, cp);  // eq. (8)–(10)
    stage("curvature", t);
  }
  ResampleParams local = params;  // sharp edges add fixed samples
  if (params.sharpEdges) {
    t = begin("features");
    FeatureParams fp = params.features;
    fp.threads = params.threads;
    const FeatureResult features = detectFeatures(cloud, fp);
    const double l0 = std::sqrt(2.0 * surface.area() / (std::sqrt(3.0) * static_cast<double>(params.targetCount)));
    std::vector<std::uint32_t> chainOf;
    std::vector<Eigen::Vector3d> onEdges = sampleFeatureChains(features.chains, params.edgeRatio * l0, &chainOf);
    if (onEdges.size() + params.fixedSamples.size() > params.targetCount / 2)  // never let edges take over N
      onEdges = sampleFeatureChains(features.chains, params.edgeRatio * l0 * 2.0 *
                                                         static_cast<double>(onEdges.size()) /
                                                         static_cast<double>(params.targetCount), &chainOf);
    onEdges = snapToCreases(cloud, onEdges, chainOf, features.spacing, fp);  // exactly on the creases
    result.featurePoints = features.featureIndices.size();
    result.featureSamples = std::min(onEdges.size(), params.targetCount - params.fixedSamples.size());
    local.fixedSamples.insert(local.fixedSamples.end(), onEdges.begin(),
                              onEdges.begin() + static_cast<long>(result.featureSamples));
    stage("features", t);
  }
  Resampler resampler(cloud.points, cloud.normals, surface, local, *rule,
                      curvature ? &curvature->sizeFactor : nullptr);
  t = begin("initialise");
  Samples s = resampler.initialise(result);
  stage("initialise", t);

  t = begin("resample");
  resampler.run(s, result);
  stage("resample", t);

  result.cloud.points = std::move(s.pos);
  result.cloud.normals = std::move(s.nrm);
  t = begin("report");
  result.spacing = spacingStats(result.cloud.points, params.threads);
  if (curvature) {  // points and mean spacing per level (each output point takes its nearest input's level)
    const std::size_t levels = curvature->pointsPerLevel.size();
    result.pointsPerLevel.assign(levels, 0);
    result.spacingPerLevel.assign(levels, 0.0);
    const KnnIndex out(result.cloud.points);
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    for (const Eigen::Vector3d& p : result.cloud.points) {
      const auto level = static_cast<std::size_t>(curvature->level[surface.index().nearest(p)]);
      ++result.pointsPerLevel[level];
      if (out.knn(p, 2, idx, d2) == 2) result.spacingPerLevel[level] += std::sqrt(d2[1]);
    }
    for (std::size_t q = 0; q < levels; ++q)
      if (result.pointsPerLevel[q]) result.spacingPerLevel[q] /= static_cast<double>(result.pointsPerLevel[q]);
  }
  stage("report", t);
  stage("total", start);
  return result;
}

}  // namespace iires
