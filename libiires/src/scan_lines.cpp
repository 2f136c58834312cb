// SPDX-License-Identifier: GPL-3.0-or-later
// The geodesic graph's neighbour lists across scan lines (scan_lines.hpp).
#include "scan_lines.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <utility>

#include "iires/detail/parallel.hpp"

namespace iires::detail {

/// Scatter matrix of @p p and the @p w points @p list of @p pts about their mean.
Eigen::Matrix3d scatter(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& p, const std::uint32_t* list,
                        std::size_t w) {
  Eigen::Vector3d mean = p;
  for (std::size_t r = 0; r < w; ++r) mean += pts[list[r]];
  mean /= static_cast<double>(w + 1);
  Eigen::Matrix3d cov = (p - mean) * (p - mean).transpose();
  for (std::size_t r = 0; r < w; ++r) cov += (pts[list[r]] - mean) * (pts[list[r]] - mean).transpose();
  return cov;
}

namespace {
// Neighbours a line's axis and the majority over the line test read; the line test reads them too, and passes
// where they or the first kLineWindow of them lie on a line: 16 see through noise across the line (their extent
// along it is twice the 8's), 8 stay short of the next line wherever the lines lie eight spacings or more apart
// (also where a contour turns tightly or thinning spaced its points out).
constexpr std::size_t kLineTest = 16;
constexpr std::size_t kLineWindow = 8;
constexpr std::size_t kAlong = 4;      // a widened row keeps this many of its point's own line: two each way

/// The line test's neighbours of point @p i: the first kLineTest of its @p row (@p found entries) besides itself,
/// or a search where the row is shorter.
void testNeighbours(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index, std::size_t i,
                    const std::uint32_t* row, std::size_t found, std::vector<std::uint32_t>& test) {
  thread_local std::vector<std::uint32_t> idx;
  thread_local std::vector<double> d2;
  if (found < kLineTest + 1) {
    index.knn(points[i], kLineTest + 1, idx, d2);
    row = idx.data(), found = idx.size();
  }
  test.clear();
  for (std::size_t r = 0; r < found && test.size() < kLineTest; ++r)
    if (row[r] != i) test.push_back(row[r]);
}

/// The direction along which point @p i and the first @p window of its neighbours @p test spread most, and
/// whether they lie on a line (onALine); @p quick: give up (false, zero) early where a cheap test rules a line out.
bool lineAxis(const std::vector<Eigen::Vector3d>& points, std::size_t i, const std::vector<std::uint32_t>& test,
              std::size_t window, bool quick, Eigen::Vector3d& axis) {
  axis.setZero();
  if (test.size() < kLineTest) return false;
  const Eigen::Matrix3d cov = scatter(points, points[i], test.data(), std::min(window, test.size()));
  // Cheap first: on a line the second invariant (λ1λ2 + λ2λ3 + λ3λ1) stays under 0.13 of the trace squared; an
  // even sampling of a surface has about a quarter.
  const double tr = cov.trace();
  const double s2 = cov(0, 0) * cov(1, 1) + cov(1, 1) * cov(2, 2) + cov(2, 2) * cov(0, 0) - cov(0, 1) * cov(0, 1) -
                    cov(1, 2) * cov(1, 2) - cov(0, 2) * cov(0, 2);
  if (!(tr > 0) || (quick && s2 >= 0.13 * tr * tr)) return false;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cov);
  axis = eig.eigenvectors().col(2);
  return onALine(eig.eigenvalues());
}

/// The row of point @p i on a line along @p axis from the candidates @p idx (squared distances @p d2, nearest
/// first): the point, its kAlong nearest on the line, then the nearest farther than @p offLine from it, more across
/// it than along, on other lines (@p lined) or on a surface whose plane (normal @p flat) holds the line — half of
/// them from either side of the line where both sides have points among the candidates (@p bothSides), so that
/// the lines on both sides list each other (else a line's neighbour farther on one side is nobody's), the rest
/// from the nearer —, nearest first, @p k entries at most, in @p row.
/// @return the distance to the nearest point off the line; 0 when there is none among the candidates
double pickRow(const std::vector<Eigen::Vector3d>& points, std::size_t i, const Eigen::Vector3d& axis, double offLine,
               const std::vector<std::uint32_t>& idx, const std::vector<double>& d2, std::size_t k,
               const std::vector<std::uint8_t>& lined, const std::vector<Eigen::Vector3f>& flat,
               std::vector<std::uint32_t>& row, bool& bothSides) {
  thread_local std::vector<std::size_t> along, side[2];
  along.clear(), side[0].clear(), side[1].clear();
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (std::size_t r = 0; r < idx.size(); ++r) {
    if (idx[r] == i) continue;
    const Eigen::Vector3d d = points[idx[r]] - points[i];
    const Eigen::Vector3d across = d - axis.dot(d) * axis;
    if (across.norm() <= offLine) {
      if (along.size() < kAlong) along.push_back(r);
      continue;
    }
    // Beside the point, more across its line than along it (not its own line farther on, where the local axis has
    // drifted), and on a surface the line could lie in: another line, or a surface whose plane holds the line's
    // direction (a sampling even across, beside the lines), not a surface the line stands on (a wire's).
    const std::uint32_t j = idx[r];
    if (across.norm() < std::abs(axis.dot(d)) || (!lined[j] && std::abs(flat[j].cast<double>().dot(axis)) > 0.5))
      continue;
    if (first.isZero()) first = across;
    side[across.dot(first) >= 0 ? 0 : 1].push_back(r);
  }
  bothSides = !side[0].empty() && !side[1].empty();
  const std::size_t slots = k - 1 - along.size();
  std::size_t take1 = std::min(side[1].size(), slots / 2);
  const std::size_t take0 = std::min(side[0].size(), slots - take1);
  take1 = std::min(side[1].size(), slots - take0);
  thread_local std::vector<std::size_t> picked;
  picked.assign(along.begin(), along.end());
  picked.insert(picked.end(), side[0].begin(), side[0].begin() + static_cast<long>(take0));
  picked.insert(picked.end(), side[1].begin(), side[1].begin() + static_cast<long>(take1));
  std::sort(picked.begin(), picked.end());  // candidate order: nearest first
  row.assign(1, static_cast<std::uint32_t>(i));
  for (std::size_t r : picked) row.push_back(idx[r]);
  return side[0].empty() ? 0.0 : std::sqrt(d2[side[0].front()]);
}
}  // namespace

std::vector<float> widenAcrossScanLines(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index,
                                       std::size_t k, std::uint32_t* rows, std::uint8_t* found, int threads) {
  constexpr std::size_t kLineWiden = 8;      // candidates: 8·k nearest,
  constexpr std::size_t kMaxCandidates = 128;  // up to 128·k
  const std::size_t n = points.size();
  if (k <= kAlong + 1) return {};
  std::vector<std::uint8_t> onLine(n, 0);
  parallelFor(n, threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> test;
    Eigen::Vector3d axis;
    testNeighbours(points, index, i, rows + i * k, found[i], test);
    onLine[i] =
        lineAxis(points, i, test, kLineWindow, true, axis) || lineAxis(points, i, test, kLineTest, true, axis);
  });
  if (std::none_of(onLine.begin(), onLine.end(), [](std::uint8_t b) { return b != 0; })) return {};
  // A scan line is a structure, not one point's neighbourhood: a point is on one where most of its neighbours
  // pass the test (a point of an even sampling whose neighbours happen to line up, one in 20,000 of a random one,
  // is not; a point of a jittered line that narrowly fails it is).
  std::vector<std::uint8_t> lined(n, 0);
  parallelFor(n, threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> test;
    testNeighbours(points, index, i, rows + i * k, found[i], test);
    const auto passed = std::count_if(test.begin(), test.end(), [&](std::uint32_t j) { return onLine[j] != 0; });
    lined[i] = test.size() == kLineTest && 2 * static_cast<std::size_t>(passed) >= test.size();
  });
  if (std::none_of(lined.begin(), lined.end(), [](std::uint8_t b) { return b != 0; })) return {};
  // The normals of the points off the lines (of their 16 nearest's plane), for pickRow's test.
  std::vector<Eigen::Vector3f> flat(n, Eigen::Vector3f::Zero());
  parallelFor(n, threads, [&](std::size_t i) {
    if (lined[i]) return;
    thread_local std::vector<std::uint32_t> test;
    testNeighbours(points, index, i, rows + i * k, found[i], test);
    if (test.size() < 2) return;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(scatter(points, points[i], test.data(), test.size()));
    flat[i] = eig.eigenvectors().col(0).cast<float>();
  });
  std::vector<float> across(n, 0.0f);
  parallelFor(n, threads, [&](std::size_t i) {
    if (!lined[i]) return;
    thread_local std::vector<std::uint32_t> test, idx, keep;
    thread_local std::vector<double> d2;
    testNeighbours(points, index, i, rows + i * k, found[i], test);
    const Eigen::Vector3d& p = points[i];
    Eigen::Vector3d axis;
    lineAxis(points, i, test, kLineTest, false, axis);
    auto fromLine = [&](std::uint32_t j) {
      const Eigen::Vector3d d = points[j] - p;
      return (d - axis.dot(d) * axis).norm();
    };
    double spread = 0, reach = 0;
    for (std::uint32_t j : test) spread += fromLine(j) * fromLine(j), reach = std::max(reach, (points[j] - p).norm());
    const double offLine = std::max(0.5 * reach, 3.0 * std::sqrt(spread / static_cast<double>(test.size())));
    // Candidates: the 8·k nearest, four times as many while they leave the row short or find one side of the line
    // empty (lines far apart for their spacing along: the outer rings of a rotating scanner).
    double nearestOff = 0;
    for (std::size_t candidates = kLineWiden * k;; candidates *= 4) {
      index.knn(p, candidates, idx, d2);
      bool bothSides = false;
      nearestOff = pickRow(points, i, axis, offLine, idx, d2, k, lined, flat, keep, bothSides);
      if ((keep.size() == k && bothSides) || idx.size() < candidates ||
          candidates >= (keep.size() < k ? kMaxCandidates : kMaxCandidates / 4) * k)
        break;
    }
    if (nearestOff == 0) return;  // nothing off the line: a line of its own (a wire)
    std::copy(keep.begin(), keep.end(), rows + i * k);
    found[i] = static_cast<std::uint8_t>(keep.size());
    across[i] = static_cast<float>(nearestOff);
  });
  if (std::all_of(across.begin(), across.end(), [](float d) { return d == 0.0f; })) across.clear();
  return across;
}

}  // namespace iires::detail
