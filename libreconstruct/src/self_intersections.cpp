// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/reconstruct/self_intersections.hpp"

#include "vertex_faces.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <Eigen/Geometry>
#include <cstdint>
#include <stdexcept>

#include "iires/detail/parallel.hpp"
#include "iires/detail/radix_sort.hpp"

namespace iires {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, std::size_t,
                                                      CGAL::Box_intersection_d::ID_FROM_BOX_ADDRESS>;

/// Whether faces f and g (vertex indices, points p) intersect other than in their common vertices and edge.
bool facesIntersect(const Eigen::Vector3i& f, const Eigen::Vector3i& g, const std::vector<Point>& p) {
  auto pt = [&](int v) -> const Point& { return p[static_cast<std::size_t>(v)]; };
  // Corners of f shared with g: sf[i] = the corner of g with f's vertex i, or -1.
  std::array<int, 3> sf{-1, -1, -1};
  int shared = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (f[i] == g[j]) sf[i] = j, ++shared;
  if (shared == 3) return true;  // the same triangle twice
  if (shared == 2) {
    // Common edge: they overlap only when coplanar with the two apexes on the same side of the edge.
    int i = 0;
    while (sf[i] >= 0) ++i;  // f's apex
    int j = 0;
    while (g[j] == f[(i + 1) % 3] || g[j] == f[(i + 2) % 3]) ++j;  // g's apex
    const Point &a = pt(f[(i + 1) % 3]), &b = pt(f[(i + 2) % 3]), &fa = pt(f[i]), &ga = pt(g[j]);
    return CGAL::coplanar(a, b, fa, ga) && CGAL::coplanar_orientation(a, b, fa, ga) == CGAL::POSITIVE;
  }
  const Kernel::Triangle_3 tf(pt(f[0]), pt(f[1]), pt(f[2])), tg(pt(g[0]), pt(g[1]), pt(g[2]));
  if (shared == 1) {
    // Common vertex: the edge of either face opposite it must not meet the other triangle.
    int i = 0;
    while (sf[i] < 0) ++i;
    const int j = sf[i];
    const Kernel::Segment_3 ef(pt(f[(i + 1) % 3]), pt(f[(i + 2) % 3])), eg(pt(g[(j + 1) % 3]), pt(g[(j + 2) % 3]));
    return CGAL::do_intersect(tf, eg) || CGAL::do_intersect(tg, ef);
  }
  return CGAL::do_intersect(tf, tg);
}

/// Whether vertex @p v's faces provably meet each other only in their common vertex and edges: seen along the
/// fan's mean normal n, every face leans less than 60° from n (so it projects one-to-one onto the plane ⊥ n, into
/// the angular wedge between its two spokes) and the wedges do not overlap — two of them touch only along a common
/// spoke. Then two faces of the fan can only meet over a common ray, i.e. in their common edge. The test is in
/// floating point with a margin (kMargin radians) no rounding can cross; fans that fail it get the exact tests.
bool separatedFan(const TriangleMesh& mesh, const detail::VertexFaces& vf, std::size_t v) {
  constexpr double kMargin = 1e-9, kMinLean = 0.5;  // cos 60°
  struct Wedge {
    double from, to, length;  // angles of its spokes, and the angle between them
    int first, last;          // spoke vertices
  };
  thread_local std::vector<Wedge> wedges;
  thread_local std::vector<std::array<int, 2>> spokes;
  if (vf.start[v] == vf.start[v + 1]) return false;
  const Eigen::Vector3d& o = mesh.vertices[v];
  auto at = [&](int x) -> const Eigen::Vector3d& { return mesh.vertices[static_cast<std::size_t>(x)]; };
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  spokes.clear();
  for (std::uint32_t s = vf.start[v]; s < vf.start[v + 1]; ++s) {
    const auto& t = mesh.triangles[vf.incident[s]];
    int c = 0;
    while (static_cast<std::size_t>(t[c]) != v) ++c;
    const int a = t[(c + 1) % 3], b = t[(c + 2) % 3];
    if (a == b || static_cast<std::size_t>(a) == v || static_cast<std::size_t>(b) == v) return false;
    spokes.push_back({a, b});
    n += (at(a) - o).cross(at(b) - o);
  }
  if (!(n.norm() > 0)) return false;
  n.normalize();
  const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
  auto angle = [&](int x) {
    const Eigen::Vector3d d = at(x) - o;
    return std::atan2(d.dot(w), d.dot(u));
  };
  wedges.clear();
  for (const auto& [a, b] : spokes) {
    const Eigen::Vector3d fn = (at(a) - o).cross(at(b) - o);
    if (!(fn.dot(n) >= kMinLean * fn.norm())) return false;
    const double from = angle(a), to = angle(b);
    double length = to - from;
    if (length < 0) length += 2 * M_PI;
    if (!(length > kMargin && length < M_PI - kMargin)) return false;
    wedges.push_back({from, to, length, a, b});
  }
  if (wedges.size() == 1) return true;
  // Sorted by their first spoke, each wedge must end before the next begins (or on the same spoke), and all of
  // them together must go round once.
  std::sort(wedges.begin(), wedges.end(), [](const Wedge& x, const Wedge& y) { return x.from < y.from; });
  double turn = 0;
  for (std::size_t i = 0; i < wedges.size(); ++i) {
    const Wedge &x = wedges[i], &y = wedges[(i + 1) % wedges.size()];
    double gap = y.from - x.to;  // in [0, 2π): an overlap becomes a gap near 2π, and the turn two rounds
    if (gap < 0) gap += 2 * M_PI;
    if (!(gap > kMargin || (x.last == y.first && y.from == x.to))) return false;
    turn += x.length + gap;
  }
  return std::abs(turn - 2 * M_PI) <= 1e-6;
}

/// separatedFan() of every vertex (of the vertices flagged in @p only, when given; 0 for the others).
std::vector<char> separatedFans(const TriangleMesh& mesh, int threads, const std::vector<char>* only = nullptr) {
  const detail::VertexFaces vf = detail::vertexFaces(mesh);
  std::vector<char> good(mesh.vertices.size(), 0);
  parallelFor(good.size(), threads, [&](std::size_t v) {
    if (!only || (*only)[v]) good[v] = separatedFan(mesh, vf, v) ? 1 : 0;
  });
  return good;
}

bool overlap(const CGAL::Bbox_3& a, const CGAL::Bbox_3& b) {
  for (int d = 0; d < 3; ++d)
    if (a.max(d) < b.min(d) || b.max(d) < a.min(d)) return false;
  return true;
}

/// The pairs of overlapping (closed) boxes, each once, from a uniform grid of cells twice the median box size:
/// every box is entered in the cells it overlaps and a pair is reported in the one cell that holds the lowest
/// corner of the two boxes' intersection. Linear for a mesh of similar triangles (a reconstruction). The few boxes
/// over many cells (long fill faces) are left out of the grid and paired by CGAL's box intersection with all the
/// others; returns false, leaving all the work to it, when there are many of them.
template <typename Skip>
bool gridCandidates(const std::vector<Box>& boxes, const Skip& skip, int threads,
                    std::vector<std::pair<std::size_t, std::size_t>>& out) {
  if (boxes.size() < 2) return true;
  std::vector<double> extent(boxes.size());
  CGAL::Bbox_3 all;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const CGAL::Bbox_3& b = boxes[i].bbox();
    extent[i] = std::max({b.xmax() - b.xmin(), b.ymax() - b.ymin(), b.zmax() - b.zmin()});
    all += b;
  }
  std::nth_element(extent.begin(), extent.begin() + static_cast<std::ptrdiff_t>(extent.size() / 2), extent.end());
  const double cell = 2.0 * extent[extent.size() / 2];
  constexpr double kMaxCells = 1 << 20;  // per axis: cell coordinates fit 21 bits
  if (!(cell > 0)) return false;
  for (int d = 0; d < 3; ++d)
    if ((all.max(d) - all.min(d)) / cell > kMaxCells) return false;
  auto coord = [&](double x, int d) { return static_cast<std::uint32_t>((x - all.min(d)) / cell); };
  auto key = [](std::uint64_t x, std::uint64_t y, std::uint64_t z) { return (x << 42) | (y << 21) | z; };
  constexpr std::uint64_t kMaxCellsPerBox = 27;
  constexpr std::size_t kMaxLargeShare = 16;  // more than 1 box in 16 over kMaxCellsPerBox cells: no grid
  std::vector<std::array<std::uint32_t, 3>> low(boxes.size());  // each box's lowest cell
  std::vector<KeyedIndex> entries;                               // (cell, box), boxes in index order
  std::vector<const Box*> large, small;                          // over kMaxCellsPerBox cells, and the others
  entries.reserve(4 * boxes.size());
  for (std::uint32_t i = 0; i < boxes.size(); ++i) {
    const CGAL::Bbox_3& b = boxes[i].bbox();
    std::uint32_t hi[3];
    for (int d = 0; d < 3; ++d) low[i][d] = coord(b.min(d), d), hi[d] = coord(b.max(d), d);
    const auto& lo = low[i];
    if (std::uint64_t{hi[0] - lo[0] + 1} * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1) > kMaxCellsPerBox) {
      large.push_back(&boxes[i]);
      if (large.size() > boxes.size() / kMaxLargeShare) return false;
      continue;
    }
    small.push_back(&boxes[i]);
    for (std::uint64_t x = lo[0]; x <= hi[0]; ++x)
      for (std::uint64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::uint64_t z = lo[2]; z <= hi[2]; ++z) entries.emplace_back(key(x, y, z), i);
  }
  radixSort(entries, threads);  // stable: boxes in index order within a cell
  std::vector<std::size_t> cellStart;  // where each cell's entries begin, and the end
  for (std::size_t r = 0; r < entries.size(); ++r)
    if (r == 0 || entries[r].first != entries[r - 1].first) cellStart.push_back(r);
  cellStart.push_back(entries.size());
  // The cells in parallel blocks, each block's pairs apart, joined in block order.
  constexpr std::size_t kCellsPerBlock = 1024;
  const std::size_t cells = cellStart.size() - 1, blocks = (cells + kCellsPerBlock - 1) / kCellsPerBlock;
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> found(blocks);
  parallelFor(blocks, threads, [&](std::size_t block) {
    for (std::size_t c = block * kCellsPerBlock; c < std::min(cells, (block + 1) * kCellsPerBlock); ++c)
      for (std::size_t i = cellStart[c]; i < cellStart[c + 1]; ++i)
        for (std::size_t j = i + 1; j < cellStart[c + 1]; ++j) {
          const std::uint32_t bi = entries[i].second, bj = entries[j].second;
          // The lowest corner of the two boxes' intersection lies in the cell max(low_i, low_j).
          if (key(std::max(low[bi][0], low[bj][0]), std::max(low[bi][1], low[bj][1]),
                  std::max(low[bi][2], low[bj][2])) != entries[i].first)
            continue;  // reported in another cell
          if (!overlap(boxes[bi].bbox(), boxes[bj].bbox()) || skip(boxes[bi].info(), boxes[bj].info())) continue;
          found[block].emplace_back(boxes[bi].info(), boxes[bj].info());  // bi < bj, faces are in box order
        }
  });
  for (const auto& f : found) out.insert(out.end(), f.begin(), f.end());
  if (large.empty()) return true;
  auto report = [&](const Box* x, const Box* y) {
    if (!skip(x->info(), y->info())) out.emplace_back(std::min(x->info(), y->info()), std::max(x->info(), y->info()));
  };
  CGAL::box_intersection_d(large.begin(), large.end(), small.begin(), small.end(), report);
  CGAL::box_self_intersection_d(large.begin(), large.end(), report);
  return true;
}

/// The boxes of @p changed faces (the first @p changedCount of @p boxes) and the others that may overlap one of
/// them: those entering a cell of a grid (cells the largest changed box's size) that a changed box enters, and
/// those over more than 64 cells (kept unlooked-at). The others cannot meet a changed face. Keeps every box when
/// the grid would be too fine for its keys.
void keepNearChanged(std::vector<Box>& boxes, std::size_t changedCount) {
  if (changedCount == 0 || changedCount == boxes.size()) return;
  CGAL::Bbox_3 all;
  double cell = 0;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const CGAL::Bbox_3& b = boxes[i].bbox();
    all += b;
    if (i < changedCount) cell = std::max({cell, b.xmax() - b.xmin(), b.ymax() - b.ymin(), b.zmax() - b.zmin()});
  }
  constexpr double kMaxCells = 1 << 20;  // per axis: cell coordinates fit 21 bits
  if (!(cell > 0)) return;
  for (int d = 0; d < 3; ++d)
    if ((all.max(d) - all.min(d)) / cell > kMaxCells) return;
  auto coord = [&](double x, int d) { return static_cast<std::uint64_t>((x - all.min(d)) / cell); };
  auto cells = [&](const CGAL::Bbox_3& b, auto&& visit) {
    for (std::uint64_t x = coord(b.xmin(), 0); x <= coord(b.xmax(), 0); ++x)
      for (std::uint64_t y = coord(b.ymin(), 1); y <= coord(b.ymax(), 1); ++y)
        for (std::uint64_t z = coord(b.zmin(), 2); z <= coord(b.zmax(), 2); ++z)
          if (!visit((x << 42) | (y << 21) | z)) return false;
    return true;
  };
  std::vector<std::uint64_t> changedCells;
  for (std::size_t i = 0; i < changedCount; ++i)
    cells(boxes[i].bbox(), [&](std::uint64_t key) { return changedCells.push_back(key), true; });
  std::sort(changedCells.begin(), changedCells.end());
  std::size_t kept = changedCount;
  auto span = [&](const CGAL::Bbox_3& b) {
    std::uint64_t count = 1;
    for (int d = 0; d < 3; ++d) count *= coord(b.max(d), d) - coord(b.min(d), d) + 1;
    return count;
  };
  constexpr std::uint64_t kMaxLookedAt = 64;
  for (std::size_t i = changedCount; i < boxes.size(); ++i) {
    const bool near = span(boxes[i].bbox()) > kMaxLookedAt || !cells(boxes[i].bbox(), [&](std::uint64_t key) {
      return !std::binary_search(changedCells.begin(), changedCells.end(), key);
    });
    if (near) boxes[kept++] = boxes[i];
  }
  boxes.resize(kept);
}

/// selfIntersections() of every face pair, or (@p changed given) of the pairs with a changed face.
std::vector<std::pair<std::size_t, std::size_t>> intersectingPairs(const TriangleMesh& mesh, int threads,
                                                                   const std::vector<char>* changed) {
  std::vector<Point> p;
  p.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) p.emplace_back(v.x(), v.y(), v.z());
  const auto& faces = mesh.triangles;
  if (changed && changed->size() != faces.size())
    throw std::invalid_argument("selfIntersections: one changed flag per face is needed");
  auto isChanged = [&](std::size_t f) { return !changed || (*changed)[f]; };
  if (changed && std::none_of(changed->begin(), changed->end(), [](char c) { return c != 0; })) return {};
  std::vector<Box> boxes;
  boxes.reserve(faces.size());
  for (const bool first : {true, false}) {  // the changed faces' boxes first
    if (!changed && !first) break;
    for (std::size_t f = 0; f < faces.size(); ++f) {
      const auto& t = faces[f];
      if (isChanged(f) != first || t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
      const Point &a = p[static_cast<std::size_t>(t[0])], &b = p[static_cast<std::size_t>(t[1])],
                  &c = p[static_cast<std::size_t>(t[2])];
      boxes.emplace_back(a.bbox() + b.bbox() + c.bbox(), f);
    }
  }
  std::vector<char> fanVertices;  // the vertices a pair with a changed face can share
  if (changed) {
    std::size_t changedBoxes = 0;
    while (changedBoxes < boxes.size() && (*changed)[boxes[changedBoxes].info()]) ++changedBoxes;
    keepNearChanged(boxes, changedBoxes);
    std::sort(boxes.begin(), boxes.end(), [](const Box& a, const Box& b) { return a.info() < b.info(); });
    fanVertices.assign(mesh.vertices.size(), 0);
    for (std::size_t f = 0; f < faces.size(); ++f)
      if ((*changed)[f])
        for (int c = 0; c < 3; ++c) fanVertices[static_cast<std::size_t>(faces[f][c])] = 1;
  }
  // Degenerate faces (collinear corners) are counted apart: tested only on the boxes kept.
  boxes.erase(std::remove_if(boxes.begin(), boxes.end(), [&](const Box& b) {
                const auto& t = faces[b.info()];
                return CGAL::collinear(p[static_cast<std::size_t>(t[0])], p[static_cast<std::size_t>(t[1])],
                                       p[static_cast<std::size_t>(t[2])]);
              }), boxes.end());
  // Candidates from overlapping boxes, then the exact tests.
  // Faces with a common vertex whose fan is separated (separatedFans) need no test.
  const std::vector<char> separated = separatedFans(mesh, threads, changed ? &fanVertices : nullptr);
  auto skip = [&](std::size_t f, std::size_t g) {
    if (!isChanged(f) && !isChanged(g)) return true;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (faces[f][i] == faces[g][j] && separated[static_cast<std::size_t>(faces[f][i])]) return true;
    return false;
  };
  std::vector<std::pair<std::size_t, std::size_t>> candidates;
  if (!gridCandidates(boxes, skip, threads, candidates)) {
    candidates.clear();
    std::vector<const Box*> ptr;
    ptr.reserve(boxes.size());
    for (const Box& b : boxes) ptr.push_back(&b);
    constexpr std::ptrdiff_t kCutoff = 2000;  // below this many boxes a scan beats the segment tree (CGAL PMP's)
    CGAL::box_self_intersection_d(
        ptr.begin(), ptr.end(),
        [&](const Box* x, const Box* y) {
          if (!skip(x->info(), y->info()))
            candidates.emplace_back(std::min(x->info(), y->info()), std::max(x->info(), y->info()));
        },
        kCutoff);
  }
  std::vector<char> hit(candidates.size(), 0);
  constexpr std::size_t kParallelFrom = 20000;  // fewer tests take less than starting the threads
  parallelFor(candidates.size(), candidates.size() < kParallelFrom ? 1 : threads, [&](std::size_t k) {
    hit[k] = facesIntersect(faces[candidates[k].first], faces[candidates[k].second], p) ? 1 : 0;
  });
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t k = 0; k < candidates.size(); ++k)
    if (hit[k]) pairs.push_back(candidates[k]);
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace

std::vector<std::pair<std::size_t, std::size_t>> selfIntersections(const TriangleMesh& mesh, int threads) {
  return intersectingPairs(mesh, threads, nullptr);
}

std::vector<std::pair<std::size_t, std::size_t>> selfIntersections(const TriangleMesh& mesh,
                                                                   const std::vector<char>& changed, int threads) {
  return intersectingPairs(mesh, threads, &changed);
}

std::vector<char> facesChangedSince(const TriangleMesh& before, const TriangleMesh& after) {
  std::vector<char> changed(after.triangles.size(), 1);
  constexpr std::size_t kMaxIndex = std::size_t{1} << 21;  // three indices in one 63-bit key
  if (before.vertices.size() > kMaxIndex || after.vertices.size() > kMaxIndex) return changed;
  // A vertex is the same where it exists in both at the same position.
  std::vector<char> same(after.vertices.size(), 0);
  for (std::size_t v = 0; v < std::min(before.vertices.size(), after.vertices.size()); ++v)
    same[v] = before.vertices[v] == after.vertices[v];
  auto key = [](const Eigen::Vector3i& t) {
    std::array<std::uint64_t, 3> v{static_cast<std::uint64_t>(t[0]), static_cast<std::uint64_t>(t[1]),
                                   static_cast<std::uint64_t>(t[2])};
    std::sort(v.begin(), v.end());
    return (v[0] << 42) | (v[1] << 21) | v[2];
  };
  // Both face lists sorted by key and merged: a face of after is new where before has no face of its key.
  auto sortedKeys = [&](const std::vector<Eigen::Vector3i>& faces) {
    std::vector<KeyedIndex> keyed;
    keyed.reserve(faces.size());
    for (std::uint32_t f = 0; f < faces.size(); ++f) keyed.emplace_back(key(faces[f]), f);
    radixSort(keyed, 1);
    return keyed;
  };
  const std::vector<KeyedIndex> old = sortedKeys(before.triangles), now = sortedKeys(after.triangles);
  std::size_t i = 0;
  for (const auto& [k, f] : now) {
    while (i < old.size() && old[i].first < k) ++i;
    const auto& t = after.triangles[f];
    const bool moved = !same[static_cast<std::size_t>(t[0])] || !same[static_cast<std::size_t>(t[1])] ||
                       !same[static_cast<std::size_t>(t[2])];
    changed[f] = moved || i == old.size() || old[i].first != k;
  }
  return changed;
}

std::vector<std::pair<std::size_t, std::size_t>> selfIntersectionsBruteForce(const TriangleMesh& mesh) {
  std::vector<Point> p;
  for (const auto& v : mesh.vertices) p.emplace_back(v.x(), v.y(), v.z());
  const auto& faces = mesh.triangles;
  std::vector<char> degenerate(faces.size(), 0);
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& t = faces[f];
    degenerate[f] = t[0] == t[1] || t[1] == t[2] || t[0] == t[2] ||
                    CGAL::collinear(p[static_cast<std::size_t>(t[0])], p[static_cast<std::size_t>(t[1])],
                                    p[static_cast<std::size_t>(t[2])]);
  }
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (std::size_t g = f + 1; g < faces.size(); ++g)
      if (!degenerate[f] && !degenerate[g] && facesIntersect(faces[f], faces[g], p)) pairs.emplace_back(f, g);
  return pairs;
}

std::vector<std::size_t> selfIntersectingFaces(const TriangleMesh& mesh, int threads) {
  std::vector<std::size_t> out;
  for (const auto& [f, g] : selfIntersections(mesh, threads)) out.push_back(f), out.push_back(g);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace iires
