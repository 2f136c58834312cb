// SPDX-License-Identifier: GPL-3.0-or-later
// Geodesic coordinates on a point cloud: paper §3.2 ("efficient intrinsic control"), DESIGN §3 step 6.
#include "iires/geodesic.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <thread>

#include "iires/detail/json.hpp"
#include "iires/detail/disjoint_sets.hpp"
#include "iires/io.hpp"
#include "io_format.hpp"
#include "scan_lines.hpp"
#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"

namespace iires {

namespace {

using detail::kInf;
using detail::kNone;
using Clock = std::chrono::steady_clock;
// A point's local sampling scale reads the nearest-neighbour distances of itself and at most this many of its
// neighbours (componentScales()).
constexpr std::size_t kMaxScaleNeighbours = 16;
// A neighbourhood sampled this many times more coarsely than the cloud has its own scale; under it the scale stays
// the component's (a random sampling's local median varies by ±20 %).
constexpr float kSparseScale = 2.0f;

double secondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// Undirected graph in compressed-row form; every edge is stored in both endpoints' rows.
struct Graph {
  std::vector<std::uint64_t> offset;  // n + 1
  std::vector<std::uint32_t> nbr;
  std::vector<float> length;
};

/// The segment (semi-Lagrangian, "Tsitsiklis") update of fast marching on a point cloud: the arrival time at
/// @p c when the front is linear along the segment [b, a] with times tb, ta:
///   min over λ ∈ (0, 1) of  tb + λ (ta − tb) + |c − (b + λ (a − b))|.
/// Exact for a planar front whose ray to c crosses the segment. Returns +inf when the minimum lies at an end
/// of the segment (those are the plain Dijkstra updates) or when the times are inconsistent (|ta − tb| ≥ |a − b|).
float segmentUpdate(const Eigen::Vector3f& a, float ta, const Eigen::Vector3f& b, float tb, const Eigen::Vector3f& c) {
  const Eigen::Vector3f e = a - b, w = c - b;
  const float el2 = e.squaredNorm();
  const float delta = ta - tb;
  if (el2 <= 1e-30f || delta * delta >= el2) return kInf;
  const float el = std::sqrt(el2);
  const float alpha = w.dot(e) / el;                           // component of c − b along the segment
  const float h2 = std::max(0.0f, w.squaredNorm() - alpha * alpha);  // squared distance of c from its line
  // Stationarity: |e| s / sqrt(s² + h²) = δ with s = α − λ|e| (signed offset of c's foot from the point x(λ)).
  const float s = delta * std::sqrt(h2 / (el2 - delta * delta));
  const float lambda = (alpha - s) / el;
  if (!(lambda > 0.0f && lambda < 1.0f)) return kInf;
  return tb + lambda * delta + std::sqrt(s * s + h2);
}

/// Monotone priority queue of (time, node) (a radix heap): times are non-negative floats, whose bit patterns
/// order like the values, and never below the last one popped (the sweep settles nodes in time order), so a
/// push is O(1) and a pop moves each item down O(32) buckets over its life — no comparison sort of the front.
/// Equal times pop last-in first-out: deterministic.
class RadixQueue {
 public:
  bool empty() const { return size_ == 0; }
  void clear() {
    for (auto& b : buckets_) b.clear();
    last_ = 0;
    size_ = 0;
  }
  void push(float t, std::uint32_t v) {
    const std::uint32_t key = bits(t);
    buckets_[bucket(key)].push_back({key, v});
    ++size_;
  }
  /// The node with the smallest time.
  std::uint32_t pop() {
    if (buckets_[0].empty()) {  // refill bucket 0 from the first non-empty one, keyed on its minimum
      std::size_t b = 1;
      while (buckets_[b].empty()) ++b;
      std::vector<Entry>& from = buckets_[b];
      last_ = from.front().key;
      for (const Entry& e : from) last_ = std::min(last_, e.key);
      for (const Entry& e : from) buckets_[bucket(e.key)].push_back(e);
      from.clear();
    }
    const Entry e = buckets_[0].back();
    buckets_[0].pop_back();
    --size_;
    return e.v;
  }

 private:
  struct Entry {
    std::uint32_t key, v;
  };
  static std::uint32_t bits(float t) {
    t += 0.0f;  // −0 → +0
    std::uint32_t k;
    std::memcpy(&k, &t, sizeof k);
    return k;
  }
  std::size_t bucket(std::uint32_t key) const {
    return key == last_ ? 0 : 32 - static_cast<std::size_t>(__builtin_clz(key ^ last_));
  }
  std::array<std::vector<Entry>, 33> buckets_;
  std::uint32_t last_ = 0;
  std::size_t size_ = 0;
};

/// Per-thread state of a single-source sweep; reset touches only the visited nodes, so a sweep over a
/// component of m points costs O(m k log m) however large the cloud.
class Sweep {
 public:
  explicit Sweep(std::size_t n) : dist_(n, kInf), done_(n, 0), up_(n, kNone), upScore_(n, kInf) {}

  /// Distances from @p source over its component. fm = fast-marching segment updates on top of Dijkstra.
  void run(const Graph& g, const std::vector<Eigen::Vector3f>& pos, std::uint32_t source, bool fm) {
    reset();
    dist_[source] = 0.0f;
    touched_.push_back(source);
    queue_.push(0.0f, source);
    while (!queue_.empty()) {
      const std::uint32_t a = queue_.pop();
      if (done_[a]) continue;  // lazy deletion: a stale copy of an already settled node
      done_[a] = 1;
      const float ta = dist_[a];
      for (std::uint64_t e = g.offset[a]; e < g.offset[a + 1]; ++e) {
        const std::uint32_t c = g.nbr[e];
        if (done_[c]) continue;
        const float direct = ta + g.length[e];
        float cand = direct;
        if (fm) {
          // Interpolate the front between a and c's best settled neighbour so far (its Dijkstra parent):
          // one upwind partner keeps the mean error within 0.1 % of using two, at 20 % less time.
          const std::uint32_t b = up_[c];
          if (b != kNone) {
            const float v = segmentUpdate(pos[a], ta, pos[b], dist_[b], pos[c]);
            if (v < cand) cand = std::max(v, ta);  // causality: never before the node being settled
          }
          if (direct < upScore_[c]) up_[c] = a, upScore_[c] = direct;
        }
        if (dist_[c] == kInf) touched_.push_back(c);
        if (cand < dist_[c]) {
          dist_[c] = cand;
          queue_.push(cand, c);
        }
      }
    }
  }

  const std::vector<std::uint32_t>& visited() const { return touched_; }
  float distance(std::uint32_t i) const { return dist_[i]; }

 private:
  void reset() {
    for (std::uint32_t i : touched_) {
      dist_[i] = kInf;
      done_[i] = 0;
      up_[i] = kNone;
      upScore_[i] = kInf;
    }
    touched_.clear();
    queue_.clear();
  }

  std::vector<float> dist_;
  std::vector<std::uint8_t> done_;
  std::vector<std::uint32_t> up_;
  std::vector<float> upScore_;
  std::vector<std::uint32_t> touched_;
  RadixQueue queue_;
};

}  // namespace

void GeodesicParams::validate() const {
  auto fail = [](const std::string& m) { throw std::invalid_argument("GeodesicParams: " + m); };
  if (k < 2 || k > 128) fail("k must be in [2, 128] (got " + std::to_string(k) + ")");
  if (spacingNeighbour < 1 || spacingNeighbour > k)
    fail("spacingNeighbour must be in [1, k] (got " + std::to_string(spacingNeighbour) + ")");
  if (!(maxEdgeRatio >= 0) || !std::isfinite(maxEdgeRatio)) fail("maxEdgeRatio must be finite and >= 0");
  if (!(maxEdgeSlopeDeg > 0 && maxEdgeSlopeDeg <= 90)) fail("maxEdgeSlopeDeg must be in (0, 90]");
  if (!(maxNormalAngleDeg > 0 && maxNormalAngleDeg <= 180)) fail("maxNormalAngleDeg must be in (0, 180]");
  if (satellites < 1 || satellites > 16) fail("satellites must be in [1, 16] (got " + std::to_string(satellites) + ")");
}

std::string GeodesicReport::toJson() const {
  detail::JsonWriter j(6);
  j.beginObject().member("points", points).member("edges", edges).member("components", components);
  j.member("attached_components", attachedComponents).member("spacing", spacing);
  j.member("graph_s", graphSeconds).member("components_s", componentSeconds);
  j.member("satellites_s", satelliteSeconds).member("fields_s", fieldSeconds).member("time_s", totalSeconds);
  return j.endObject().str();
}

struct GeodesicCoordinates::Impl {
  GeodesicParams params;
  int threads = 0;  // of the build
  // Public side, in the caller's point order.
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;
  std::vector<std::uint32_t> component;
  std::vector<float> coords;                            // point-major, params.satellites per point
  std::vector<std::vector<std::uint32_t>> satellites;  // per component, caller's indices
  std::vector<std::size_t> componentSize;
  // Internal side, in Z-order: internal i is the caller's point order[i].
  std::vector<std::uint32_t> order, rank;
  std::vector<Eigen::Vector3d> sortedCopy;      // the points in Z-order, unless they already are (then empty)
  const std::vector<Eigen::Vector3d>* sorted = nullptr;  // sortedCopy or points
  std::vector<Eigen::Vector3f> pos;  // float copy for the sweeps
  std::unique_ptr<KnnIndex> index;   // over sorted
  Graph graph;
  double spacing = 0;
  double area = 0;
  std::vector<float> scale;       // per point (caller's order): its component's samplingScale()
  std::vector<float> localScale;  // per point (caller's order): localScales()
  GeodesicReport report;

  using NeighbourLists = detail::NeighbourLists;
  /// Connected components of the filtered graph, numbered by their first point in the caller's order.
  struct Components {
    std::vector<std::uint32_t> id;  ///< per internal point
    std::uint32_t count = 0;
    std::vector<std::array<std::uint32_t, 2>> attaching;  ///< edges that attach tiny components
  };

  void build(const NeighbourTable* table, const GeodesicCoordinates::Alongside& alongside);
  // The steps of build(), in order.
  void sortPoints();
  NeighbourLists neighbourLists(const NeighbourTable* table);
  std::vector<std::uint8_t> filterEdges(const NeighbourLists& lists) const;
  Components findComponents(const NeighbourLists& lists, const std::vector<std::uint8_t>& keep);
  void componentScales(const NeighbourLists& lists, const Components& components);
  void buildGraph(const NeighbourLists& lists, const std::vector<std::uint8_t>& keep, const Components& components);
  void satellitesAndFields(const Components& components, const GeodesicCoordinates::Alongside& alongside);
  // Parts of satellitesAndFields().
  struct Members;
  void fieldsOfComponent(std::size_t c, const Members& members, std::vector<std::uint32_t>& sat,
                         std::vector<float>& field, bool spareThread, Sweep& sweep, std::optional<Sweep>& second,
                         std::vector<float>& minDist, double& seedSeconds) const;
  void toCallerOrder(const Components& components, const std::vector<float>& field,
                     const std::vector<std::vector<std::uint32_t>>& sat);
};

void GeodesicCoordinates::Impl::build(const NeighbourTable* table,
                                      const GeodesicCoordinates::Alongside& alongside) {
  const auto start = Clock::now();
  // 1. k-NN lists, local spacing, normals; 2. filter the edges
  auto t = Clock::now();
  sortPoints();
  NeighbourLists lists = neighbourLists(table);
  std::vector<std::uint8_t> keep = filterEdges(lists);
  report.graphSeconds = secondsSince(t);
  // 3. components and the graph
  t = Clock::now();
  const Components components = findComponents(lists, keep);
  componentScales(lists, components);
  buildGraph(lists, keep, components);
  report.componentSeconds = secondsSince(t);
  lists = {};
  keep = {};
  // 4. satellites and fields
  satellitesAndFields(components, alongside);
  report.points = points.size();
  report.components = components.count;
  report.spacing = spacing;
  report.totalSeconds = secondsSince(start);
}

/// Z-order (order, rank), the sorted points (a cloud already in Z-order, the resampler's, is not copied) and
/// their float copy.
void GeodesicCoordinates::Impl::sortPoints() {
  const std::size_t n = points.size();
  order = mortonOrder(points, threads);
  rank.assign(n, 0);
  bool identity = true;
  for (std::size_t i = 0; i < n && identity; ++i) identity = order[i] == i;
  if (!identity) sortedCopy.resize(n);
  sorted = identity ? &points : &sortedCopy;
  pos.resize(n);
  // The float copy is taken relative to the bounding-box centre: a small object far from the origin (scan
  // coordinates) would otherwise lose its spacing to float rounding.
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const auto& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  for (std::size_t i = 0; i < n; ++i) {
    rank[order[i]] = static_cast<std::uint32_t>(i);
    if (!identity) sortedCopy[i] = points[order[i]];
    pos[i] = ((*sorted)[i] - centre).cast<float>();
  }
}

/// The k-NN lists from @p table (when it fits; else a table of its own over a k-d tree) — widened across scan
/// lines as the table's rows are —, each point's spacing and normal, and the median nearest-neighbour distance
/// (spacing).
GeodesicCoordinates::Impl::NeighbourLists GeodesicCoordinates::Impl::neighbourLists(const NeighbourTable* table) {
  const std::size_t n = points.size();
  const std::size_t k = static_cast<std::size_t>(params.k);
  const std::vector<Eigen::Vector3d>& zp = *sorted;
  std::optional<NeighbourTable> own;
  if (table && (table->k() < k + 1 || table->size() != n)) table = nullptr;
  if (!table) {  // with a table only nearest() needs the tree: built later
    index = std::make_unique<KnnIndex>(zp);
    own.emplace(*index, zp, k + 1, threads);
  }
  NeighbourLists lists;
  std::vector<std::uint32_t>& knn = lists.index;
  std::vector<float>& knnDist = lists.distance;
  knn.assign(n * k, kNone);
  knnDist.assign(n * k, kInf);
  lists.rho.assign(n, 0.0f);
  lists.across.assign(n, 0.0f);
  std::vector<float> nearestDist(n, 0.0f);
  const bool given = lists.givenNormals = normals.size() == n;
  lists.normal.assign(n, Eigen::Vector3f::Zero());
  parallelFor(n, threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    if (table) {  // the caller's order: map the neighbours to ours
      table->get(order[i], k + 1, idx, d2);
      for (std::uint32_t& j : idx) j = rank[j];
      lists.across[i] = table->acrossLines(order[i]);
    } else {
      own->get(i, k + 1, idx, d2);
      lists.across[i] = own->acrossLines(i);
    }
    std::size_t w = 0;
    for (std::size_t r = 0; r < idx.size() && w < k; ++r) {
      if (idx[r] == i) continue;
      knn[i * k + w] = idx[r];
      knnDist[i * k + w] = static_cast<float>(std::sqrt(d2[r]));
      ++w;
    }
    if (w == 0) return;
    nearestDist[i] = knnDist[i * k];
    // On a scan line the spacing across the lines bounds the edge lengths.
    lists.rho[i] = std::max(
        knnDist[i * k + std::min<std::size_t>(w, static_cast<std::size_t>(params.spacingNeighbour)) - 1],
        lists.across[i]);
    if (given) {
      const double len = normals[order[i]].norm();
      if (len > 0) lists.normal[i] = (normals[order[i]] / len).cast<float>();
    } else if (w >= 2) {  // the PCA normal of the point and its k nearest (unoriented; the tangent test only)
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
      eig.computeDirect(detail::scatter(zp, zp[i], &knn[i * k], w));
      lists.normal[i] = eig.eigenvectors().col(0).cast<float>();
    }
  });
  area = 0;  // in a fixed order
  for (float d : nearestDist) area += M_PI * static_cast<double>(d) * d;
  std::nth_element(nearestDist.begin(), nearestDist.begin() + static_cast<std::ptrdiff_t>(n / 2), nearestDist.end());
  spacing = nearestDist[n / 2];
  return lists;
}

/// Per point (scale), how much more coarsely than the cloud its component is sampled: the component's median
/// nearest-neighbour distance over the cloud's (spacing), at least 1 — and on or beside scan lines at least half
/// the largest distance to the next line among the point and its k nearest over the spacing (a point between two
/// lines lies that far from the nearest one; a point that noise or a tight turn kept off the lines, or whose
/// nearest line lies on one side while the other side's is farther, takes its neighbours' spacing). localScale: the
/// same, or the point's own neighbourhood's median nearest-neighbour distance over the spacing where that is at
/// least kSparseScale.
void GeodesicCoordinates::Impl::componentScales(const NeighbourLists& lists, const Components& components) {
  const std::size_t n = points.size(), k = static_cast<std::size_t>(params.k);
  std::vector<std::vector<float>> nearest(components.count);
  for (std::size_t i = 0; i < n; ++i)
    if (lists.distance[i * k] < kInf) nearest[components.id[i]].push_back(lists.distance[i * k]);
  std::vector<float> of(components.count, 1.0f);
  for (std::uint32_t c = 0; c < components.count; ++c) {
    std::vector<float>& d = nearest[c];
    if (d.empty() || !(spacing > 0)) continue;
    std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
    of[c] = std::max(1.0f, static_cast<float>(d[d.size() / 2] / spacing));
  }
  scale.resize(n);
  localScale.resize(n);
  parallelFor(n, threads, [&](std::size_t i) {
    float across = lists.across[i];
    std::array<float, kMaxScaleNeighbours + 1> near;
    std::size_t m = 0;
    if (lists.distance[i * k] < kInf) near[m++] = lists.distance[i * k];
    for (std::size_t r = 0; r < k && lists.index[i * k + r] != kNone; ++r) {
      const std::uint32_t j = lists.index[i * k + r];
      across = std::max(across, lists.across[j]);
      if (m < near.size() && lists.distance[j * k] < kInf) near[m++] = lists.distance[j * k];
    }
    float local = 1.0f;  // the median nearest-neighbour distance around the point, over the cloud's
    if (m > 0 && spacing > 0) {
      std::nth_element(near.begin(), near.begin() + static_cast<long>(m / 2), near.begin() + static_cast<long>(m));
      local = static_cast<float>(near[m / 2] / spacing);
      if (local < kSparseScale) local = 1.0f;
    }
    scale[order[i]] = std::max(of[components.id[i]], spacing > 0 ? static_cast<float>(0.5 * across / spacing) : 1.0f);
    localScale[order[i]] = std::max(scale[order[i]], local);
  });
}

/// Which k-NN entries become edges, by symmetric tests (so both directions agree): 0 = dropped, 1 = kept and
/// mutual, 2 = kept, not mutual (the reverse direction must be added).
std::vector<std::uint8_t> GeodesicCoordinates::Impl::filterEdges(const NeighbourLists& lists) const {
  const std::size_t n = points.size();
  const std::size_t k = static_cast<std::size_t>(params.k);
  const std::vector<std::uint32_t>& knn = lists.index;
  const std::vector<Eigen::Vector3f>& nrm = lists.normal;
  const float sinSlope = static_cast<float>(std::sin(params.maxEdgeSlopeDeg * M_PI / 180.0));
  const float cosNormal = static_cast<float>(std::cos(params.maxNormalAngleDeg * M_PI / 180.0));
  const bool slopeTest = params.maxEdgeSlopeDeg < 90.0;
  const bool normalTest = lists.givenNormals && params.maxNormalAngleDeg < 180.0;
  const float ratio = static_cast<float>(params.maxEdgeRatio);
  auto inList = [&](std::uint32_t of, std::uint32_t x) {
    const std::uint32_t* l = &knn[static_cast<std::size_t>(of) * k];
    return std::find(l, l + k, x) != l + k;
  };
  std::vector<std::uint8_t> keep(n * k, 0);
  parallelFor(n, threads, [&](std::size_t i) {
    for (std::size_t r = 0; r < k; ++r) {
      const std::uint32_t j = knn[i * k + r];
      if (j == kNone) break;
      const bool mutual = inList(j, static_cast<std::uint32_t>(i));
      // A row widened across scan lines lists a few chosen points of the next lines, whose own rows list
      // their nearest on this line: the same two lines linked, seldom the same two points. Such a link stands
      // one way.
      if (params.mutualNeighbours && !mutual && !(lists.across[i] > 0)) continue;
      const float d = lists.distance[i * k + r];
      if (ratio > 0 && d > ratio * std::min(lists.rho[i], lists.rho[j])) continue;
      if (d > 0) {
        const Eigen::Vector3f dir = (pos[j] - pos[i]) / d;
        if (slopeTest && std::abs(nrm[i].dot(dir)) > sinSlope && std::abs(nrm[j].dot(dir)) > sinSlope) continue;
        if (normalTest && nrm[i].dot(nrm[j]) < cosNormal) continue;
      }
      keep[i * k + r] = mutual ? 1 : 2;
    }
  });
  return keep;
}

/// Components by union-find over the kept edges; a tiny one (< minComponentSize) is attached to a large one
/// by its shortest k-NN link. Sets componentSize and report.attachedComponents.
GeodesicCoordinates::Impl::Components GeodesicCoordinates::Impl::findComponents(
    const NeighbourLists& lists, const std::vector<std::uint8_t>& keep) {
  const std::size_t n = points.size();
  const std::size_t k = static_cast<std::size_t>(params.k);
  const std::vector<std::uint32_t>& knn = lists.index;
  Components components;
  std::vector<std::array<std::uint32_t, 2>>& extra = components.attaching;
  DisjointSets sets(n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t r = 0; r < k; ++r)
      if (keep[i * k + r]) sets.unite(static_cast<std::uint32_t>(i), knn[i * k + r]);
  report.attachedComponents = 0;
  if (params.minComponentSize > 1) {
    std::vector<std::size_t> rootSize(n, 0);
    for (std::size_t i = 0; i < n; ++i) ++rootSize[sets.find(static_cast<std::uint32_t>(i))];
    // Best link per tiny root: (length, i, j), smallest wins; lexicographic ties → deterministic.
    struct Link {
      float d = kInf;
      std::uint32_t i = kNone, j = kNone;
    };
    std::vector<Link> best(n);
    bool anyTiny = false, anyLarge = false;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t s = rootSize[sets.find(static_cast<std::uint32_t>(i))];
      (s < params.minComponentSize ? anyTiny : anyLarge) = true;
    }
    if (anyTiny && anyLarge) {
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t ri = sets.find(static_cast<std::uint32_t>(i));
        if (rootSize[ri] >= params.minComponentSize) continue;
        for (std::size_t r = 0; r < k; ++r) {
          const std::uint32_t j = knn[i * k + r];
          if (j == kNone) break;
          if (rootSize[sets.find(j)] < params.minComponentSize) continue;
          const float d = lists.distance[i * k + r];
          if (d < best[ri].d) best[ri] = {d, static_cast<std::uint32_t>(i), j};
          break;  // lists are sorted: the first large neighbour is this point's shortest link
        }
      }
      for (std::size_t root = 0; root < n; ++root)
        if (best[root].i != kNone) {
          extra.push_back({best[root].i, best[root].j});
          ++report.attachedComponents;
        }
      for (const auto& e : extra) sets.unite(e[0], e[1]);
    }
  }
  // Number components by their first point in the caller's order; the ids are per internal point.
  std::vector<std::uint32_t> rootId(n, kNone);
  std::uint32_t& count = components.count;
  for (std::size_t o = 0; o < n; ++o) {
    const std::uint32_t r = sets.find(rank[o]);
    if (rootId[r] == kNone) rootId[r] = count++;
  }
  components.id.assign(n, kNone);
  for (std::size_t i = 0; i < n; ++i) components.id[i] = rootId[sets.find(static_cast<std::uint32_t>(i))];
  componentSize.assign(count, 0);
  for (std::size_t i = 0; i < n; ++i) ++componentSize[components.id[i]];
  return components;
}

/// The adjacency (CSR): each point's own kept entries (in distance order), then the reverse directions of
/// non-mutual edges and the attaching edges, in index order.
void GeodesicCoordinates::Impl::buildGraph(const NeighbourLists& lists, const std::vector<std::uint8_t>& keep,
                                           const Components& components) {
  const std::size_t n = points.size();
  const std::size_t k = static_cast<std::size_t>(params.k);
  const std::vector<std::uint32_t>& knn = lists.index;
  const std::vector<float>& knnDist = lists.distance;
  const std::vector<std::array<std::uint32_t, 2>>& extra = components.attaching;
  std::vector<std::uint32_t> degree(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t r = 0; r < k; ++r)
      if (keep[i * k + r]) {
        ++degree[i];
        if (keep[i * k + r] == 2) ++degree[knn[i * k + r]];
      }
  for (const auto& e : extra) ++degree[e[0]], ++degree[e[1]];
  graph.offset.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) graph.offset[i + 1] = graph.offset[i] + degree[i];
  graph.nbr.assign(graph.offset[n], kNone);
  graph.length.assign(graph.offset[n], 0.0f);
  std::vector<std::uint64_t> fill(graph.offset.begin(), graph.offset.end() - 1);
  auto addEdge = [&](std::uint32_t a, std::uint32_t b, float d) {
    graph.nbr[fill[a]] = b;
    graph.length[fill[a]++] = d;
  };
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t r = 0; r < k; ++r)
      if (keep[i * k + r]) addEdge(static_cast<std::uint32_t>(i), knn[i * k + r], knnDist[i * k + r]);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t r = 0; r < k; ++r)
      if (keep[i * k + r] == 2) addEdge(knn[i * k + r], static_cast<std::uint32_t>(i), knnDist[i * k + r]);
  for (const auto& e : extra) {
    const float d = static_cast<float>(((*sorted)[e[0]] - (*sorted)[e[1]]).norm());
    addEdge(e[0], e[1], d);
    addEdge(e[1], e[0], d);
  }
  report.edges = graph.offset[n] / 2;
}

/// Members of each component (internal indices, ascending, list[offset[c], offset[c + 1])) and its first
/// point in the caller's order (seed).
struct GeodesicCoordinates::Impl::Members {
  std::vector<std::uint32_t> offset, list, seed;
};

/// Satellites and fields of component @p c (paper §3.2): satellite 1 is the point farthest (straight-line)
/// from its first point; satellite s+1 the point farthest from satellites 1..s on their accurate fields, which
/// are the coordinates gₛ themselves (farthest-point sampling). Satellite 3 is chosen before field 2 exists —
/// farthest from satellite 1 on g₁ and from satellite 2 in straight line — so that fields 2 and 3 are swept at
/// once where a thread is free (@p spareThread).
void GeodesicCoordinates::Impl::fieldsOfComponent(std::size_t c, const Members& members,
                                                  std::vector<std::uint32_t>& sc, std::vector<float>& field,
                                                  bool spareThread, Sweep& sweep, std::optional<Sweep>& second,
                                                  std::vector<float>& minDist, double& seedSeconds) const {
  const int m = params.satellites;
  const std::size_t n = points.size();
  const auto t0 = Clock::now();
  const std::uint32_t* member = members.list.data() + members.offset[c];
  const std::size_t size = members.offset[c + 1] - members.offset[c];
  minDist.assign(size, kInf);
  auto pickFarthest = [&](auto value) {
    std::size_t best = 0;
    for (std::size_t x = 1; x < size; ++x)
      if (value(x) > value(best)) best = x;  // ties: lowest internal index (members are sorted)
    return member[best];
  };
  const Eigen::Vector3f& first = pos[members.seed[c]];
  sc.push_back(pickFarthest([&](std::size_t x) { return (pos[member[x]] - first).squaredNorm(); }));
  seedSeconds += secondsSince(t0);
  auto keep = [&](const Sweep& from, int s) {  // field s from a finished sweep
    for (std::size_t x = 0; x < size; ++x) {
      const float d = from.distance(member[x]);
      field[member[x] * static_cast<std::size_t>(m) + static_cast<std::size_t>(s)] = d;
      minDist[x] = std::min(minDist[x], d);
    }
  };
  for (int s = 0; s < m; ++s) {
    if (s == 1 && m >= 3) {
      const Eigen::Vector3f& satellite2 = pos[sc.back()];
      sc.push_back(pickFarthest(
          [&](std::size_t x) { return std::min(minDist[x], (pos[member[x]] - satellite2).norm()); }));
      if (spareThread) {
        if (!second) second.emplace(n);
        std::thread other([&] { second->run(graph, pos, sc[2], params.fastMarching); });
        sweep.run(graph, pos, sc[1], params.fastMarching);
        other.join();
        keep(sweep, 1);
        keep(*second, 2);
      } else {
        for (int f : {1, 2}) {
          sweep.run(graph, pos, sc[static_cast<std::size_t>(f)], params.fastMarching);
          keep(sweep, f);
        }
      }
      ++s;
    } else {
      sweep.run(graph, pos, sc.back(), params.fastMarching);
      keep(sweep, s);
    }
    if (s + 1 < m) sc.push_back(pickFarthest([&](std::size_t x) { return minDist[x]; }));
  }
}

/// Satellites and fields per component, components in parallel; meanwhile, on the idle threads, the work that
/// does not need the fields (the caller's @p alongside and the k-d tree for nearest(), if not built yet).
void GeodesicCoordinates::Impl::satellitesAndFields(const Components& components,
                                                    const GeodesicCoordinates::Alongside& alongside) {
  const auto t = Clock::now();
  const std::size_t n = points.size();
  const std::uint32_t count = components.count;
  const std::vector<std::uint32_t>& comp = components.id;
  Members members;
  members.offset.assign(count + 1, 0);
  members.list.resize(n);
  for (std::size_t i = 0; i < n; ++i) ++members.offset[comp[i] + 1];
  for (std::uint32_t c = 0; c < count; ++c) members.offset[c + 1] += members.offset[c];
  {
    std::vector<std::uint32_t> fill(members.offset.begin(), members.offset.end() - 1);
    for (std::size_t i = 0; i < n; ++i) members.list[fill[comp[i]]++] = static_cast<std::uint32_t>(i);
  }
  members.seed.assign(count, kNone);
  for (std::size_t o = n; o-- > 0;) members.seed[comp[rank[o]]] = rank[o];
  std::vector<std::vector<std::uint32_t>> sat(count);
  std::vector<float> field(n * static_cast<std::size_t>(params.satellites), kInf);  // internal order
  const int team = resolveThreads(threads);
  const int nThreads = std::max(1, std::min<int>(team, static_cast<int>(std::min<std::size_t>(count, 1024))));
  const bool spareThread = team > nThreads;  // fields 2 and 3 are swept on two threads
  double seedSeconds = 0, sweepSeconds = 0;
  auto sweeps = [&] {
#pragma omp parallel num_threads(nThreads) reduction(+ : seedSeconds)
    {
      Sweep sweep(n);
      std::optional<Sweep> second;  // for the second of two fields swept at once
      std::vector<float> minDist;
#pragma omp for schedule(dynamic, 1)
      for (long long c = 0; c < static_cast<long long>(count); ++c)
        fieldsOfComponent(static_cast<std::size_t>(c), members, sat[static_cast<std::size_t>(c)], field,
                          spareThread, sweep, second, minDist, seedSeconds);
    }
    sweepSeconds = secondsSince(t);
  };
  auto besides = [&](int spare) {
    if (!index) index = std::make_unique<KnnIndex>(*sorted);
    if (alongside) alongside(spare, sortedCopy.empty() ? index.get() : nullptr, scale);
  };
  if (team > nThreads) {  // the sweeps on a thread of their own, the other work on the idle ones
    std::exception_ptr failure;
    std::thread sweeper([&] {
      try {
        sweeps();
      } catch (...) {
        failure = std::current_exception();
      }
    });
    try {
      besides(team - nThreads);
    } catch (...) {
      sweeper.join();
      throw;
    }
    sweeper.join();
    if (failure) std::rethrow_exception(failure);
  } else {
    sweeps();
    besides(team);
  }
  report.satelliteSeconds = seedSeconds;
  toCallerOrder(components, field, sat);
  report.fieldSeconds = sweepSeconds - seedSeconds / nThreads;
}

/// Components, coordinates and satellites back in the caller's point order.
void GeodesicCoordinates::Impl::toCallerOrder(const Components& components, const std::vector<float>& field,
                                              const std::vector<std::vector<std::uint32_t>>& sat) {
  const std::size_t n = points.size();
  const auto m = static_cast<std::size_t>(params.satellites);
  component.assign(n, 0);
  coords.assign(n * m, kInf);
  for (std::size_t i = 0; i < n; ++i) {
    component[order[i]] = components.id[i];
    std::copy_n(&field[i * m], m, &coords[order[i] * m]);
  }
  satellites.assign(components.count, {});
  for (std::size_t c = 0; c < components.count; ++c)
    for (std::uint32_t x : sat[c]) satellites[c].push_back(order[x]);
}

GeodesicCoordinates::GeodesicCoordinates(const PointCloud& cloud, const GeodesicParams& params, const Execution& exec,
                                         const NeighbourTable* table, const Alongside& alongside)
    : impl_(std::make_unique<Impl>()) {
  params.validate();
  if (cloud.empty()) throw InputError("geodesic coordinates: the cloud is empty");
  if (cloud.size() >= kNone) throw InputError("geodesic coordinates: too many points");
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!cloud.points[i].allFinite())
      throw InputError("geodesic coordinates: point " + std::to_string(i) + " has a non-finite coordinate");
  impl_->params = params;
  impl_->threads = exec.threads;
  impl_->points = cloud.points;
  if (cloud.hasNormals()) impl_->normals = cloud.normals;
  impl_->build(table, alongside);
}

GeodesicCoordinates::~GeodesicCoordinates() = default;
GeodesicCoordinates::GeodesicCoordinates(GeodesicCoordinates&&) noexcept = default;
GeodesicCoordinates& GeodesicCoordinates::operator=(GeodesicCoordinates&&) noexcept = default;

std::size_t GeodesicCoordinates::size() const { return impl_->points.size(); }
const std::vector<Eigen::Vector3d>& GeodesicCoordinates::points() const { return impl_->points; }
const std::vector<Eigen::Vector3d>& GeodesicCoordinates::normals() const { return impl_->normals; }
std::int64_t GeodesicCoordinates::nearest(const Eigen::Vector3d& query, double* sqDist) const {
  const std::int64_t i = impl_->index->nearest(query, sqDist);
  return i < 0 ? i : static_cast<std::int64_t>(impl_->order[static_cast<std::size_t>(i)]);
}
const GeodesicParams& GeodesicCoordinates::params() const { return impl_->params; }
int GeodesicCoordinates::dimensions() const { return impl_->params.satellites; }
float GeodesicCoordinates::coordinate(std::size_t i, int s) const {
  return impl_->coords[i * static_cast<std::size_t>(impl_->params.satellites) + static_cast<std::size_t>(s)];
}
const std::vector<float>& GeodesicCoordinates::coordinates() const { return impl_->coords; }
std::size_t GeodesicCoordinates::components() const { return impl_->componentSize.size(); }
std::uint32_t GeodesicCoordinates::component(std::size_t i) const { return impl_->component[i]; }
const std::vector<std::uint32_t>& GeodesicCoordinates::componentIds() const { return impl_->component; }
std::size_t GeodesicCoordinates::componentSize(std::size_t c) const { return impl_->componentSize.at(c); }
const std::vector<std::uint32_t>& GeodesicCoordinates::satellites(std::size_t c) const {
  return impl_->satellites.at(c);
}
double GeodesicCoordinates::spacing() const { return impl_->spacing; }
double GeodesicCoordinates::area() const { return impl_->area; }
const std::vector<float>& GeodesicCoordinates::samplingScales() const { return impl_->scale; }
const std::vector<float>& GeodesicCoordinates::localScales() const { return impl_->localScale; }
const GeodesicReport& GeodesicCoordinates::report() const { return impl_->report; }

std::vector<float> GeodesicCoordinates::distanceField(std::uint32_t source) const {
  return distanceField(source, impl_->params.fastMarching);
}

std::vector<float> GeodesicCoordinates::distanceField(std::uint32_t source, bool fastMarching) const {
  if (source >= size()) throw std::out_of_range("distanceField: source index out of range");
  Sweep sweep(size());
  sweep.run(impl_->graph, impl_->pos, impl_->rank[source], fastMarching);
  std::vector<float> out(size(), kInf);
  for (std::uint32_t i : sweep.visited()) out[impl_->order[i]] = sweep.distance(i);
  return out;
}

std::vector<std::array<std::uint32_t, 2>> GeodesicCoordinates::edges() const {
  std::vector<std::array<std::uint32_t, 2>> out;
  const Graph& g = impl_->graph;
  for (std::size_t a = 0; a + 1 < g.offset.size(); ++a)
    for (std::uint64_t e = g.offset[a]; e < g.offset[a + 1]; ++e)
      if (a < g.nbr[e]) {
        const std::uint32_t x = impl_->order[a], y = impl_->order[g.nbr[e]];
        out.push_back({std::min(x, y), std::max(x, y)});
      }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void writeGeodesicPly(OutputBatch& batch, const std::string& path, const GeodesicCoordinates& geo) {
  if (extensionOf(path) != ".ply")
    throw InputError("cannot write " + path + ": geodesic coordinates are written as .ply only");
  detail::io::PlyContent content{geo.points(), geo.normals().size() == geo.size() ? &geo.normals() : nullptr, {}};
  for (int s = 0; s < geo.dimensions(); ++s)
    content.properties.push_back(
        {"g" + std::to_string(s + 1), "float", [&geo, s](std::size_t i) { return geo.coordinate(i, s); }});
  content.properties.push_back({"component", "uint", [&geo](std::size_t i) { return geo.component(i); }});
  content.comment = "geodesic coordinates (iires, paper 3.2)";
  detail::io::stagePly(batch, path, content, false);
}

void writeGeodesicPly(const std::string& path, const GeodesicCoordinates& geo) {
  OutputBatch batch;
  writeGeodesicPly(batch, path, geo);
  batch.commit();
}

}  // namespace iires
