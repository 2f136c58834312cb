// The sheet rule: DESIGN §3 step 6 (scope of the invariant), issue 19.
#include "iires/sheets.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "iires/disjoint_sets.hpp"
#include "iires/normals.hpp"
#include "iires/parallel.hpp"

namespace iires {
namespace {

constexpr double kMadToSigma = 1.4826;   // a normal distribution's σ per median absolute deviation
constexpr std::size_t kSpacingRow = 16;
constexpr int kConsensusPasses = 2;       // normal averaging passes over the same-sheet neighbours  // local spacing: mean nearest-neighbour distance over these row entries

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
/// neighbours, so the plane with most support is its own.
Eigen::Vector3d robustNormal(const std::vector<Eigen::Vector3d>& points, std::size_t p, const std::uint32_t* idx,
                             std::size_t count, double height, double slope) {
  constexpr std::size_t kCandidates = 8;
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
  // (within the tolerance of their median height, on the side that has more of them).
  auto support = [&](const Eigen::Vector3d& n) {
    const double inv2 = 1.0 / (height * height);
    std::array<double, 129> above, below;
    std::size_t na = 0, nb = 0;
    double sum = 0;
    for (std::size_t a = 0; a < m; ++a) {
      const double h = n.dot(points[others[a]] - o);
      sum += std::max(0.0, 1.0 - h * h * inv2);
      if (h > 2 * height) above[na++] = h;
      if (h < -2 * height) below[nb++] = h;
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
  constexpr std::size_t kRefined = 3;
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
  if (!(finalHeightSpacings > 0) || !std::isfinite(finalHeightSpacings)) fail("finalHeightSpacings must be finite and > 0");
  if (!(noiseFactor >= 0) || !std::isfinite(noiseFactor)) fail("noiseFactor must be finite and >= 0");
  if (!(heightSpacings > 0) || !std::isfinite(heightSpacings)) fail("heightSpacings must be finite and > 0");
  if (!(heightSlope >= 0) || !std::isfinite(heightSlope)) fail("heightSlope must be finite and >= 0");
  if (!(maxNormalAngleDeg > 0 && maxNormalAngleDeg <= 180)) fail("maxNormalAngleDeg must be in (0, 180]");
  if (threads < 0) fail("threads must be >= 0 (0 = all cores)");
}

std::string SheetReport::toJson() const {
  std::ostringstream o;
  o.precision(6);
  o << "{\"points\": " << points << ", \"cross_pairs\": " << crossPairs << ", \"near_points\": " << nearPoints
    << ", \"near_zones\": " << nearZones << ", \"sheet_pairs\": " << sheetPairs << ", \"spacing\": " << spacing
    << ", \"time_s\": " << seconds << "}";
  return o.str();
}

SheetReport separateSheets(const std::vector<Eigen::Vector3d>& points, NeighbourTable& table,
                           std::vector<Eigen::Vector3d>& normals, const SheetParams& params,
                           const std::vector<Eigen::Vector3d>* givenNormals) {
  params.validate();
  const auto start = std::chrono::steady_clock::now();
  const std::size_t n = points.size(), K = table.k();
  if (table.size() != n) throw std::invalid_argument("separateSheets: the table is not of these points");
  SheetReport report;
  report.points = n;
  const bool given = givenNormals && givenNormals->size() == n;
  const int threads = params.threads;
  // The rows once, flat (padded with the point itself), and each point's nearest-neighbour distance.
  std::vector<std::uint32_t> rows(n * K);
  std::vector<std::uint8_t> found(n);
  std::vector<double> nearest(n, 0.0), spacing(n, 0.0);
  parallelFor(n, threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const std::size_t f = table.get(i, K, idx, d2);
    std::copy_n(idx.begin(), f, rows.begin() + static_cast<long>(i * K));
    std::fill(rows.begin() + static_cast<long>(i * K + f), rows.begin() + static_cast<long>((i + 1) * K),
              static_cast<std::uint32_t>(i));
    found[i] = static_cast<std::uint8_t>(f);
    for (std::size_t a = 0; a < f; ++a)
      if (idx[a] != i) {
        nearest[i] = std::sqrt(d2[a]);
        break;
      }
  });
  // Local spacing: the mean nearest-neighbour distance over the point and its nearest (a random sampling's
  // nearest-neighbour distances vary by half their mean; the mean of kSpacingRow of them by an eighth).
  parallelFor(n, threads, [&](std::size_t i) {
    const std::size_t m = std::min<std::size_t>(found[i], kSpacingRow);
    double sum = 0;
    for (std::size_t a = 0; a < m; ++a) sum += nearest[rows[i * K + a]];
    spacing[i] = m ? sum / static_cast<double>(m) : 0.0;
  });
  {
    std::vector<double> sorted = spacing;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(n / 2), sorted.end());
    report.spacing = n ? sorted[n / 2] : 0.0;
  }
  const double minDot = given ? std::cos(params.maxNormalAngleDeg * M_PI / 180.0) : -1.0;
  auto keep = [&](std::size_t i, std::size_t j) {
    const double d = (points[j] - points[i]).norm();
    const double tolerance = params.heightSpacings * std::min(spacing[i], spacing[j]) + params.heightSlope * d;
    return sameSheet(points[i], normals[i], points[j], normals[j], tolerance, minDot);
  };
  const std::size_t pcaK = std::min<std::size_t>(K, static_cast<std::size_t>(params.pcaNeighbours) + 1);
  if (given) {
    normals.resize(n);
    parallelFor(n, threads, [&](std::size_t i) {
      const double len = (*givenNormals)[i].norm();
      normals[i] = len > 0 ? Eigen::Vector3d((*givenNormals)[i] / len) : Eigen::Vector3d::UnitZ();
    });
  } else {
    // A robust plane over the nearest (most of them on the point's sheet where two are close), then PCA over
    // the same-sheet ones among more.
    const std::size_t firstK = std::min<std::size_t>(K, static_cast<std::size_t>(params.firstNeighbours) + 1);
    // A neighbourhood that the plain PCA plane holds entirely (within the tolerance) is one sheet: most points
    // of a surface without close sheets stop there.
    normals.assign(n, Eigen::Vector3d::UnitZ());
    std::vector<std::uint8_t> plain(n, 0);
    parallelFor(n, threads, [&](std::size_t i) {
      const std::uint32_t* row = rows.data() + i * K;
      const std::size_t count = std::min<std::size_t>(found[i], firstK);
      const double height = params.heightSpacings * spacing[i];
      const Eigen::Vector3d n0 = pcaNormal(points, i, row, count, Eigen::Vector3d::UnitZ());
      bool held = true;
      for (std::size_t a = 0; a < count && held; ++a) {
        const Eigen::Vector3d d = points[row[a]] - points[i];
        held = std::abs(n0.dot(d)) <= height + params.heightSlope * d.norm();
      }
      plain[i] = held;
      normals[i] = held ? n0 : robustNormal(points, i, row, count, height, params.heightSlope);
    });
    std::vector<Eigen::Vector3d> refit(normals);
    for (int r = 0; r < params.refits; ++r) {
      parallelFor(n, threads, [&](std::size_t i) {
        if (plain[i]) return;
        std::array<std::uint32_t, 129> same;
        std::size_t m = 0;
        for (std::size_t a = 0; a < found[i] && m < pcaK; ++a)
          if (keep(i, rows[i * K + a])) same[m++] = rows[i * K + a];
        refit[i] = m > params.minNeighbours ? pcaNormal(points, i, same.data(), m, normals[i]) : normals[i];
      });
      normals.swap(refit);
      refit = normals;
    }
    // A point whose normal its neighbours do not confirm (fewer than a third of them on its sheet by it: the
    // fit failed where the sheets' samples mix) takes the normal of its nearest neighbour that is confirmed;
    // then every fitted one is refitted over its sheet once more.
    std::vector<std::uint8_t> confirmed(n, 0);
    parallelFor(n, threads, [&](std::size_t i) {
      std::size_t m = 0;
      for (std::size_t a = 0; a < found[i]; ++a) m += rows[i * K + a] != i && keep(i, rows[i * K + a]);
      confirmed[i] = plain[i] || (m >= params.minNeighbours && 3 * m >= found[i]);
    });
    parallelFor(n, threads, [&](std::size_t i) {
      if (confirmed[i]) return;
      for (std::size_t a = 0; a < found[i]; ++a)
        if (const std::uint32_t j = rows[i * K + a]; j != i && confirmed[j]) {
          refit[i] = normals[j];
          break;
        }
    });
    normals.swap(refit);
    refit = normals;
    parallelFor(n, threads, [&](std::size_t i) {
      if (plain[i]) return;
      std::array<std::uint32_t, 129> same;
      std::size_t m = 0;
      for (std::size_t a = 0; a < found[i] && m < pcaK; ++a)
        if (keep(i, rows[i * K + a])) same[m++] = rows[i * K + a];
      if (m > params.minNeighbours) refit[i] = pcaNormal(points, i, same.data(), m, normals[i]);
    });
    normals.swap(refit);
    // Consensus: each normal becomes the mean of its same-sheet neighbours' (signs aligned with its own). A few
    // neighbouring points whose fits all chose a plane across both sheets (a slab their sampling happens to
    // support) confirm each other, but their neighbourhoods hold mostly points with the sheet's normal.
    for (int pass = 0; pass < kConsensusPasses; ++pass) {
      parallelFor(n, threads, [&](std::size_t i) {
        Eigen::Vector3d sum = normals[i];
        for (std::size_t a = 0, m = 0; a < found[i] && m < pcaK; ++a)
          if (const std::uint32_t j = rows[i * K + a]; j != i && keep(i, j)) {
            sum += normals[j].dot(normals[i]) < 0 ? -normals[j] : normals[j];
            ++m;
          }
        refit[i] = sum.squaredNorm() > 0 ? Eigen::Vector3d(sum.normalized()) : normals[i];
      });
      normals.swap(refit);
    }
  }
  // The final rule, with the normals settled: the height tolerance narrows to finalHeightSpacings plus
  // noiseFactor × the larger of the two points' noise (the median height of their same-sheet neighbours off
  // their planes), so that a normal the fit got a little wrong leaves no pair across a gap, while a noisy sheet
  // keeps its neighbours (a gap narrower than the noise cannot be told from it).
  std::vector<double> noise(n, 0.0);
  parallelFor(n, threads, [&](std::size_t i) {
    std::array<double, 129> h;
    std::size_t m = 0;
    for (std::size_t a = 0; a < found[i] && m < pcaK; ++a)
      if (const std::uint32_t j = rows[i * K + a]; j != i && keep(i, j))
        h[m++] = std::abs(normals[i].dot(points[j] - points[i]));
    if (m == 0) return;
    std::nth_element(h.begin(), h.begin() + static_cast<long>(m / 2), h.begin() + static_cast<long>(m));
    noise[i] = kMadToSigma * h[m / 2];
  });
  auto keepFinal = [&](std::size_t i, std::size_t j) {
    const double d = (points[j] - points[i]).norm();
    const double tolerance = params.finalHeightSpacings * std::min(spacing[i], spacing[j]) +
                             params.heightSlope * d + params.noiseFactor * std::max(noise[i], noise[j]);
    return sameSheet(points[i], normals[i], points[j], normals[j], tolerance, minDot);
  };
  std::vector<std::uint8_t> near(n, 0);
  std::vector<std::uint32_t> sheetRows(n * K);
  parallelFor(n, threads, [&](std::size_t i) {
    std::size_t w = 0;
    for (std::size_t a = 0; a < found[i]; ++a) {
      const std::uint32_t j = rows[i * K + a];
      if (j == i || keepFinal(i, j)) {
        sheetRows[i * K + w++] = j;
      } else {
        near[i] = 1;
      }
    }
    std::fill(sheetRows.begin() + static_cast<long>(i * K + w), sheetRows.begin() + static_cast<long>((i + 1) * K),
              static_cast<std::uint32_t>(i));
  });
  // Orientation over the same-sheet graph only: an edge across a gap would carry one sheet's orientation to
  // the other at no cost (the pair is parallel).
  if (!given) orientNormals(points, normals, sheetRows, K, K, threads);
  report.crossPairs = table.filter(keepFinal, params.minNeighbours, threads);
  // Near-contact zones: the near points, connected through same-sheet edges; sheet pairs: the distinct pairs
  // of zones facing each other across a gap.
  DisjointSets zones(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!near[i]) continue;
    ++report.nearPoints;
    for (std::size_t a = 0; a < K; ++a)
      if (const std::uint32_t j = sheetRows[i * K + a]; j != i && near[j]) zones.unite(static_cast<std::uint32_t>(i), j);
  }
  std::vector<std::array<std::uint32_t, 2>> pairs;
  for (std::size_t i = 0; i < n; ++i) {
    if (!near[i]) continue;
    report.nearZones += zones.find(static_cast<std::uint32_t>(i)) == i;
    for (std::size_t a = 0; a < found[i]; ++a) {
      const std::uint32_t j = rows[i * K + a];
      if (j == i || !near[j] || keepFinal(i, j)) continue;
      const std::uint32_t zi = zones.find(static_cast<std::uint32_t>(i)), zj = zones.find(j);
      pairs.push_back({std::min(zi, zj), std::max(zi, zj)});
    }
  }
  std::sort(pairs.begin(), pairs.end());
  report.sheetPairs = static_cast<std::size_t>(std::unique(pairs.begin(), pairs.end()) - pairs.begin());
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace iires
