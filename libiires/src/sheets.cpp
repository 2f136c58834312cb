// SPDX-License-Identifier: GPL-3.0-or-later
// The sheet rule: DESIGN §3 step 6 (scope of the invariant), issue 19.
#include "iires/sheets.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "iires/detail/disjoint_sets.hpp"
#include "iires/normals.hpp"
#include "iires/detail/json.hpp"
#include "iires/detail/parallel.hpp"
#include "layers.hpp"

namespace iires {
namespace {

constexpr std::size_t kSpacingRow = 16;       // local spacing: mean nearest-neighbour distance over these row entries
constexpr int kConsensusPasses = 2;           // normal averaging passes over the same-sheet neighbours
constexpr std::size_t kOrientNeighbours = 8;  // neighbours per point in the orientation's spanning tree
constexpr std::size_t kPlainNormalRow = 13;   // the point and NormalParams' default 12 neighbours

/// Unit PCA normal of @p p and the points @p idx (fewer than 2 neighbours: @p fallback).
Eigen::Vector3d pcaNormal(const std::vector<Eigen::Vector3d>& points, std::size_t p,
                          const std::uint32_t* idx, std::size_t count, const Eigen::Vector3d& fallback) {
  std::size_t m = 1;
  Eigen::Vector3d mean = points[p];
  for (std::size_t a = 0; a < count; ++a)
    if (idx[a] != p) mean += points[idx[a]], ++m;
  if (m < 3) return fallback;
  mean /= static_cast<double>(m);
  Eigen::Matrix3d cov = (points[p] - mean) * (points[p] - mean).transpose();
  for (std::size_t a = 0; a < count; ++a)
    if (idx[a] != p) cov.noalias() += (points[idx[a]] - mean) * (points[idx[a]] - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cov);
  const Eigen::Vector3d n = eig.eigenvectors().col(0);
  return n.allFinite() && n.squaredNorm() > 0 ? Eigen::Vector3d(n.normalized()) : fallback;
}

/// A normal that ignores the neighbours on another sheet: of the planes through the point and two of its
/// kCandidates nearest, the one that most of the neighbours @p idx support (see below), refitted by PCA to
/// those within the sheet tolerance of it. Where two sheets are close the point's own sheet holds most of its
/// neighbours, so the plane with most support is its own. @p gap: the smallest gap between two sheets.
Eigen::Vector3d robustNormal(const std::vector<Eigen::Vector3d>& points, std::size_t p, const std::uint32_t* idx,
                             std::size_t count, double height, double slope, double gap) {
  constexpr std::size_t kCandidates = 6;
  std::array<std::uint32_t, 129> others{};
  std::size_t m = 0;
  for (std::size_t a = 0; a < count && m < others.size(); ++a)
    if (idx[a] != p) others[m++] = idx[a];
  const Eigen::Vector3d& o = points[p];
  auto inliers = [&](const Eigen::Vector3d& n, std::uint32_t* out) {
    std::size_t c = 0;
    for (std::size_t a = 0; a < m; ++a) {
      const Eigen::Vector3d d = points[others[a]] - o;
      if (std::abs(n.dot(d)) <= height + slope * d.norm()) {
        if (out) out[c] = others[a];
        ++c;
      }
    }
    return c;
  };
  // Support of a plane: Σ (1 − (h/height)²)⁺ over the neighbours' heights h, so that a plane tilted off the
  // sheet (whose far points it still holds within the tolerance) scores below the sheet's own. Where two
  // sheets are close a plane across both (along the gap's direction) can hold as many points in a strip as a
  // noisy sheet's own plane: the points off the plane count too when they form a second layer parallel to it
  // (within the tolerance of their median height, on the side that has more of them), at least the rule's
  // smallest gap off (@p gap). At a free edge the local spacing grows (the nearest lie on one side only), and
  // two sheets 2.5 spacings apart are less than 2 of those spacings apart there.
  auto support = [&](const Eigen::Vector3d& n) {
    const double inv2 = 1.0 / (height * height);
    std::array<double, 129> above, below;
    std::size_t na = 0, nb = 0;
    double sum = 0;
    for (std::size_t a = 0; a < m; ++a) {
      const double h = n.dot(points[others[a]] - o);
      sum += std::max(0.0, 1.0 - h * h * inv2);
      if (h >= gap) above[na++] = h;
      if (h <= -gap) below[nb++] = h;
    }
    std::array<double, 129>& layer = na >= nb ? above : below;
    const std::size_t nl = std::max(na, nb);
    if (nl >= 2) {
      std::nth_element(layer.begin(), layer.begin() + static_cast<long>(nl / 2), layer.begin() + static_cast<long>(nl));
      const double median = layer[nl / 2];
      for (std::size_t a = 0; a < nl; ++a) sum += std::max(0.0, 1.0 - (layer[a] - median) * (layer[a] - median) * inv2);
    }
    return sum;
  };
  // Candidates: the planes through the point and two of its kCandidates nearest; the few best are refitted
  // by PCA to the neighbours within the tolerance (a plane through three noisy points tilts), then scored
  // again. A plane across both sheets (containing the gap's direction) gathers points of both in a strip,
  // fewer than the sheet's own plane holds.
  constexpr std::size_t kRefined = 2;
  std::array<std::pair<double, Eigen::Vector3d>, kRefined> top;
  top.fill({-1.0, Eigen::Vector3d::UnitZ()});
  const std::size_t cand = std::min(m, kCandidates);
  for (std::size_t a = 0; a < cand; ++a)
    for (std::size_t b = a + 1; b < cand; ++b) {
      const Eigen::Vector3d da = points[others[a]] - o, db = points[others[b]] - o;
      Eigen::Vector3d n = da.cross(db);
      if (n.norm() < 0.3 * da.norm() * db.norm()) continue;  // nearly collinear: no plane
      n.normalize();
      const double c = support(n);
      if (c <= top.back().first) continue;
      top.back() = {c, n};
      for (std::size_t r = kRefined - 1; r > 0 && top[r].first > top[r - 1].first; --r) std::swap(top[r], top[r - 1]);
    }
  if (top.front().first <= 0) return pcaNormal(points, p, others.data(), m, Eigen::Vector3d::UnitZ());
  std::array<std::uint32_t, 129> sheet;
  Eigen::Vector3d best = top.front().second;
  double bestSupport = -1;
  for (const auto& [score, n] : top) {
    if (score <= 0) break;
    const std::size_t c = inliers(n, sheet.data());
    const Eigen::Vector3d refined = c >= 2 ? pcaNormal(points, p, sheet.data(), c, n) : n;
    const double refinedSupport = support(refined);
    if (refinedSupport > bestSupport) bestSupport = refinedSupport, best = refined;
  }
  const std::size_t c = inliers(best, sheet.data());
  return pcaNormal(points, p, sheet.data(), c, best);
}

}  // namespace

void SheetParams::validate() const {
  auto fail = [](const std::string& m) { throw std::invalid_argument("SheetParams: " + m); };
  if (pcaNeighbours < 2 || pcaNeighbours > 128) fail("pcaNeighbours must be in [2, 128]");
  if (firstNeighbours < 2 || firstNeighbours > pcaNeighbours) fail("firstNeighbours must be in [2, pcaNeighbours]");
  if (refits < 0 || refits > 8) fail("refits must be in [0, 8]");
  if (!(gapSpacings > 0) || !std::isfinite(gapSpacings)) fail("gapSpacings must be finite and > 0");
  if (!(gapAngleDeg > 0 && gapAngleDeg < 90)) fail("gapAngleDeg must be in (0, 90)");
  if (!(heightSpacings > 0) || !std::isfinite(heightSpacings)) fail("heightSpacings must be finite and > 0");
  if (!(heightSlope >= 0) || !std::isfinite(heightSlope)) fail("heightSlope must be finite and >= 0");
  if (!(maxNormalAngleDeg > 0 && maxNormalAngleDeg <= 180)) fail("maxNormalAngleDeg must be in (0, 180]");
}

std::string SheetReport::toJson() const {
  detail::JsonWriter j(6);
  j.beginObject().member("points", points).member("cross_pairs", crossPairs).member("near_points", nearPoints);
  j.member("near_zones", nearZones).member("sheet_pairs", sheetPairs).member("spacing", spacing);
  j.member("orientation_conflicts", orientationConflicts).member("reoriented_normals", reorientedNormals);
  j.member("time_s", seconds);
  return j.endObject().str();
}

namespace {

/// The working state of separateSheets(): the table's rows (flat, padded with the point itself), the local
/// spacing, the normals and which points' neighbourhoods are one sheet already ("plain").
struct SheetState {
  SheetState(const std::vector<Eigen::Vector3d>& p, const SheetParams& sp, std::vector<Eigen::Vector3d>& nrm)
      : points(p), params(sp), normals(nrm) {}
  const std::vector<Eigen::Vector3d>& points;
  const SheetParams& params;
  std::vector<Eigen::Vector3d>& normals;
  std::size_t n = 0, K = 0, pcaK = 0;
  std::vector<std::uint32_t> rows;
  std::vector<std::uint8_t> found, plain;
  std::vector<std::uint8_t> layer;  // the row holds a second layer parallel to the point's plane (findLayers)
  std::vector<double> spacing;
  double minDot = -1.0;
  double gapCos = 1.0;  // cos(gapAngleDeg)

  const std::uint32_t* row(std::size_t i) const { return rows.data() + i * K; }
  /// The rule with a height tolerance of @p heightSpacings local spacings (plus the slope term).
  bool same(std::size_t i, std::size_t j, double heightSpacings) const {
    const double d = (points[j] - points[i]).norm();
    const double tolerance = heightSpacings * std::min(spacing[i], spacing[j]) + params.heightSlope * d;
    return sameSheet(points[i], normals[i], points[j], normals[j], tolerance, minDot);
  }
  bool loose(std::size_t i, std::size_t j) const { return same(i, j, params.heightSpacings); }
  /// Whether q lies within the loose tolerance of point i's plane (rowOnPlane's test for one entry).
  bool onPlane(std::size_t i, const Eigen::Vector3d& q) const {
    const Eigen::Vector3d d = q - points[i];
    return std::abs(normals[i].dot(d)) <= params.heightSpacings * spacing[i] + params.heightSlope * d.norm();
  }
  /// The final rule: apart only across a gap. A point whose whole row lies on its plane ("plain") has only its
  /// sheet's points in it, and keeps whoever lies on that plane — but not a point from whose (asymmetric)
  /// row it comes, across a gap, off its plane: that pair takes the gap test.
  bool final(std::size_t i, std::size_t j) const {
    auto plainKeeps = [&] { return (plain[i] && onPlane(i, points[j])) || (plain[j] && onPlane(j, points[i])); };
    if (normals[i].dot(normals[j]) < minDot) return plainKeeps();
    if (!layer[i] && !layer[j]) return true;  // no second layer in either row: no gap to part them
    return plainKeeps() || !acrossGap(points[i], normals[i], points[j], normals[j],
                                      params.gapSpacings * std::min(spacing[i], spacing[j]), gapCos);
  }
  /// PCA normal of point i over its first pcaK same-sheet (loose) neighbours, or its normal when too few.
  Eigen::Vector3d sheetFit(std::size_t i) const {
    std::array<std::uint32_t, 129> sheet;
    std::size_t m = 0;
    for (std::size_t a = 0; a < found[i] && m < pcaK; ++a)
      if (const std::uint32_t j = row(i)[a]; j != i && loose(i, j)) sheet[m++] = j;
    return m > params.minNeighbours ? pcaNormal(points, i, sheet.data(), m, normals[i]) : normals[i];
  }
};

/// Rows, nearest-neighbour distances and the local spacing (the mean nearest-neighbour distance over the point
/// and its kSpacingRow nearest: a random sampling's nearest-neighbour distances vary by half their mean).
void readRows(SheetState& st, const NeighbourTable& table, int threads) {
  const std::size_t n = st.n, K = st.K;
  st.rows.resize(n * K);
  st.found.assign(n, 0);
  st.spacing.assign(n, 0.0);
  std::vector<double> nearest(n, 0.0);
  parallelFor(n, threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const std::size_t f = table.get(i, K, idx, d2);
    std::copy_n(idx.begin(), f, st.rows.begin() + static_cast<long>(i * K));
    std::fill(st.rows.begin() + static_cast<long>(i * K + f), st.rows.begin() + static_cast<long>((i + 1) * K),
              static_cast<std::uint32_t>(i));
    st.found[i] = static_cast<std::uint8_t>(f);
    for (std::size_t a = 0; a < f; ++a)
      if (idx[a] != i) {
        nearest[i] = std::sqrt(d2[a]);
        break;
      }
  });
  parallelFor(n, threads, [&](std::size_t i) {
    const std::size_t m = std::min<std::size_t>(st.found[i], kSpacingRow);
    double sum = 0;
    for (std::size_t a = 0; a < m; ++a) sum += nearest[st.row(i)[a]];
    st.spacing[i] = m ? sum / static_cast<double>(m) : 0.0;
  });
}

/// Whether every neighbour in point i's row lies within the loose tolerance of the plane (p_i, @p normal).
bool rowOnPlane(const SheetState& st, std::size_t i, const Eigen::Vector3d& normal) {
  const double height = st.params.heightSpacings * st.spacing[i];
  for (std::size_t a = 0; a < st.found[i]; ++a) {
    const Eigen::Vector3d d = st.points[st.row(i)[a]] - st.points[i];
    if (std::abs(normal.dot(d)) > height + st.params.heightSlope * d.norm()) return false;
  }
  return true;
}

/// Normals of a cloud without them: plain PCA where the whole row lies on its plane; elsewhere a robust plane,
/// refitted over the same-sheet neighbours, repaired from a confirmed neighbour when its own are too few, and
/// averaged with its same-sheet neighbours' (kConsensusPasses).
void estimateSheetNormals(SheetState& st, int threads) {
  const std::size_t n = st.n, firstK = std::min<std::size_t>(st.K, static_cast<std::size_t>(st.params.firstNeighbours) + 1);
  st.normals.assign(n, Eigen::Vector3d::UnitZ());
  parallelFor(n, threads, [&](std::size_t i) {
    const std::size_t count = std::min<std::size_t>(st.found[i], firstK);
    const Eigen::Vector3d n0 = pcaNormal(st.points, i, st.row(i), count, Eigen::Vector3d::UnitZ());
    st.plain[i] = rowOnPlane(st, i, n0);
    st.normals[i] = st.plain[i] ? n0
                                : robustNormal(st.points, i, st.row(i), count,
                                               st.params.heightSpacings * st.spacing[i], st.params.heightSlope,
                                               st.params.gapSpacings * st.spacing[i]);
  });
  std::vector<std::uint32_t> fitted;  // the points that are not plain: all further work is theirs
  for (std::size_t i = 0; i < n; ++i)
    if (!st.plain[i]) fitted.push_back(static_cast<std::uint32_t>(i));
  std::vector<Eigen::Vector3d> next(fitted.size());
  auto update = [&](auto&& fn) {  // Jacobi: every point reads the previous normals
    parallelFor(fitted.size(), threads, [&](std::size_t x) { next[x] = fn(fitted[x]); });
    for (std::size_t x = 0; x < fitted.size(); ++x) st.normals[fitted[x]] = next[x];
  };
  for (int r = 0; r < st.params.refits; ++r) update([&](std::size_t i) { return st.sheetFit(i); });
  // A normal that fewer than a third of its neighbours confirm (the fit failed where the sheets' samples mix)
  // takes its nearest confirmed neighbour's; then all are refitted over their sheet once more.
  std::vector<std::uint8_t> confirmed(st.plain);
  parallelFor(fitted.size(), threads, [&](std::size_t x) {
    const std::size_t i = fitted[x];
    std::size_t m = 0;
    for (std::size_t a = 0; a < st.found[i]; ++a) m += st.row(i)[a] != i && st.loose(i, st.row(i)[a]);
    confirmed[i] = m >= st.params.minNeighbours && 3 * m >= st.found[i];
  });
  update([&](std::size_t i) {
    if (!confirmed[i])
      for (std::size_t a = 0; a < st.found[i]; ++a)
        if (const std::uint32_t j = st.row(i)[a]; j != i && confirmed[j]) return st.normals[j];
    return st.normals[i];
  });
  update([&](std::size_t i) { return st.sheetFit(i); });
  // Consensus: a few neighbouring points whose fits all chose a plane across both sheets (a slab their sampling
  // happens to support) confirm each other, but their neighbourhoods hold mostly points of the sheet's normal.
  for (int pass = 0; pass < kConsensusPasses; ++pass)
    update([&](std::size_t i) {
      Eigen::Vector3d sum = st.normals[i];
      for (std::size_t a = 0, m = 0; a < st.found[i] && m < st.pcaK; ++a)
        if (const std::uint32_t j = st.row(i)[a]; j != i && st.loose(i, j)) {
          sum += st.normals[j].dot(st.normals[i]) < 0 ? -st.normals[j] : st.normals[j];
          ++m;
        }
      return sum.squaredNorm() > 0 ? Eigen::Vector3d(sum.normalized()) : st.normals[i];
    });
}

/// Which points see a second sheet in their row: the heights of the row's entries off the point's plane form
/// two layers at least the gap apart (layers.hpp). Where one surface turns at a crease whose normals the fits
/// blended, the other face's points rise steadily off the plane.
void findLayers(SheetState& st, int threads) {
  st.layer.assign(st.n, 0);
  std::vector<std::uint8_t> seen(st.n, 0);
  parallelFor(st.n, threads, [&](std::size_t i) {
    if (st.plain[i]) return;
    const std::size_t m = st.found[i];
    if (m < 2 * detail::kLayerPoints) return;
    std::array<double, 256> h;
    for (std::size_t a = 0; a < m; ++a) h[a] = st.normals[i].dot(st.points[st.row(i)[a]] - st.points[i]);
    std::sort(h.begin(), h.begin() + static_cast<long>(m));
    seen[i] = detail::twoLayers(h.data(), m, st.params.gapSpacings * st.spacing[i], st.spacing[i]);
  });
  // A second sheet within a few spacings is seen from the points around it too (a near-contact zone is a
  // region, not a point): a layer that fewer than kLayerPoints of the row's other points see is one sheet's noise.
  parallelFor(st.n, threads, [&](std::size_t i) {
    if (!seen[i]) return;
    std::size_t seeing = 0;
    for (std::size_t a = 0; a < st.found[i]; ++a)
      if (const std::uint32_t j = st.row(i)[a]; j != i) seeing += seen[j];
    st.layer[i] = seeing >= detail::kLayerPoints;
  });
}

/// Near-contact zones (points with a Euclidean neighbour on another sheet, connected through same-sheet
/// edges) and the distinct pairs of zones that face each other across a gap; returns which points are near.
std::vector<std::uint8_t> countZones(const SheetState& st, SheetReport& report, int threads) {
  const std::size_t n = st.n;
  std::vector<std::uint8_t> near(n, 0);
  parallelFor(n, threads, [&](std::size_t i) {
    if (st.plain[i]) return;  // a plain point's row holds only its sheet's points
    for (std::size_t a = 0; a < st.found[i] && !near[i]; ++a) near[i] = !st.final(i, st.row(i)[a]);
  });
  DisjointSets zones(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!near[i]) continue;
    ++report.nearPoints;
    for (std::size_t a = 0; a < st.found[i]; ++a)
      if (const std::uint32_t j = st.row(i)[a]; j != i && near[j] && st.final(i, j))
        zones.unite(static_cast<std::uint32_t>(i), j);
  }
  std::vector<std::array<std::uint32_t, 2>> pairs;
  for (std::size_t i = 0; i < n; ++i) {
    if (!near[i]) continue;
    report.nearZones += zones.find(static_cast<std::uint32_t>(i)) == i;
    for (std::size_t a = 0; a < st.found[i]; ++a) {
      const std::uint32_t j = st.row(i)[a];
      if (j == i || !near[j] || st.final(i, j)) continue;
      const std::uint32_t zi = zones.find(static_cast<std::uint32_t>(i)), zj = zones.find(j);
      pairs.push_back({std::min(zi, zj), std::max(zi, zj)});
    }
  }
  std::sort(pairs.begin(), pairs.end());
  report.sheetPairs = static_cast<std::size_t>(std::unique(pairs.begin(), pairs.end()) - pairs.begin());
  return near;
}

/// Where no other sheet is near — none of the point and its kPlainNormalRow nearest has a neighbour on another
/// sheet — the point's Euclidean row is its sheet's, and its normal is the plain PCA normal of that row (what
/// estimateNormals gives: across a crease it averages the two faces, as the feature detector expects), turned
/// to the sheet rule's orientation.
void plainNormalsAwayFromGaps(SheetState& st, const std::vector<std::uint8_t>& near, int threads) {
  parallelFor(st.n, threads, [&](std::size_t i) {
    if (st.plain[i]) return;
    const std::size_t count = std::min<std::size_t>(st.found[i], kPlainNormalRow);
    if (std::any_of(st.row(i), st.row(i) + count, [&](std::uint32_t j) { return near[j] != 0; })) return;
    const Eigen::Vector3d n = pcaNormal(st.points, i, st.row(i), count, st.normals[i]);
    st.normals[i] = n.dot(st.normals[i]) < 0 ? Eigen::Vector3d(-n) : n;
  });
}

/// Orientation over the same-sheet graph only (the filtered @p table: an edge across a gap would carry one
/// sheet's orientation to the other at no cost, the pair being parallel), on each point's kOrientNeighbours
/// nearest. The spanning tree carries the signs of PCA normals over the filtered rows, which turn gradually
/// over a crease or a tight fold where the sheet fits turn at once (and a sign carried across a right angle is
/// a guess); each normal then takes its PCA normal's side. With @p given normals each connected part of the graph
/// then takes the side most of them had (the tree's root convention, facing +x, is a guess).
void orientSheets(SheetState& st, const NeighbourTable& table, bool given, int threads) {
  const std::size_t orientK = std::min<std::size_t>(table.k(), kOrientNeighbours + 1);
  std::vector<std::uint32_t> graph(st.n * orientK);
  std::vector<Eigen::Vector3d> guide(st.n);
  parallelFor(st.n, threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const std::size_t f = table.get(i, std::min(table.k(), kPlainNormalRow), idx, d2);
    guide[i] = pcaNormal(st.points, i, idx.data(), f, st.normals[i]);
    for (std::size_t a = 0; a < orientK; ++a) graph[i * orientK + a] = a < f ? idx[a] : static_cast<std::uint32_t>(i);
  });
  // The patches' evidence: the rows before the rule filtered them (a thin part's two sides included), with the pairs
  // the rule puts across a gap.
  std::vector<std::uint8_t> apart(st.n * st.K, 0);
  parallelFor(st.n, threads, [&](std::size_t i) {
    for (std::size_t a = 0; a < st.found[i]; ++a) apart[i * st.K + a] = !st.final(i, st.row(i)[a]);
  });
  const OrientationEvidence evidence{st.rows, st.K, &apart};
  orientNormals(st.points, guide, graph, orientK, orientK, threads, true, given ? &st.normals : nullptr, &evidence);
  parallelFor(st.n, threads, [&](std::size_t i) {
    if (st.normals[i].dot(guide[i]) < 0) st.normals[i] = -st.normals[i];
  });
}

}  // namespace

SheetReport separateSheets(const std::vector<Eigen::Vector3d>& points, NeighbourTable& table,
                           std::vector<Eigen::Vector3d>& normals, const SheetParams& params, const Execution& exec,
                           const std::vector<Eigen::Vector3d>* givenNormals, std::vector<std::uint8_t>* near) {
  params.validate();
  const auto start = std::chrono::steady_clock::now();
  if (table.size() != points.size()) throw std::invalid_argument("separateSheets: the table is not of these points");
  exec.validate();
  const int threads = exec.threads;
  SheetState st(points, params, normals);
  st.n = points.size();
  st.K = table.k();
  st.pcaK = std::min<std::size_t>(st.K, static_cast<std::size_t>(params.pcaNeighbours) + 1);
  st.plain.assign(st.n, 0);
  st.gapCos = std::cos(params.gapAngleDeg * M_PI / 180.0);
  SheetReport report;
  report.points = st.n;
  readRows(st, table, threads);
  if (st.n > 0) {
    std::vector<double> sorted = st.spacing;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(st.n / 2), sorted.end());
    report.spacing = sorted[st.n / 2];
  }
  const bool given = givenNormals && givenNormals->size() == st.n;
  bool orient = true;
  if (given) {
    normals.resize(st.n);
    parallelFor(st.n, threads, [&](std::size_t i) {
      const double len = (*givenNormals)[i].norm();
      normals[i] = len > 0 ? Eigen::Vector3d((*givenNormals)[i] / len) : Eigen::Vector3d::UnitZ();
      st.plain[i] = rowOnPlane(st, i, normals[i]);
    });
    // Oriented normals part pairs that face opposite ways; unoriented ones are read as directions only, and
    // oriented here (the stages after the rule read them).
    report.orientationConflicts = orientationConflicts(points, normals, st.rows, st.K, st.pcaK, threads);
    orient = report.orientationConflicts > kMaxOrientationConflicts;
    if (!orient) st.minDot = std::cos(params.maxNormalAngleDeg * M_PI / 180.0);
  } else {
    estimateSheetNormals(st, threads);
  }
  findLayers(st, threads);
  report.crossPairs = table.filter([&](std::size_t i, std::size_t j) { return st.final(i, j); },
                                   params.minNeighbours, threads);
  if (orient) orientSheets(st, table, given, threads);
  if (given && orient)
    for (std::size_t i = 0; i < st.n; ++i) report.reorientedNormals += normals[i].dot((*givenNormals)[i]) < 0;
  std::vector<std::uint8_t> nearPoints = countZones(st, report, threads);
  if (!given) plainNormalsAwayFromGaps(st, nearPoints, threads);
  if (near) *near = std::move(nearPoints);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace iires
