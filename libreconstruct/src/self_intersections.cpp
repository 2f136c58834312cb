#include "iires/reconstruct/self_intersections.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>

#include <algorithm>
#include <array>

#include "iires/parallel.hpp"

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

}  // namespace

std::vector<std::pair<std::size_t, std::size_t>> selfIntersections(const TriangleMesh& mesh, int threads) {
  std::vector<Point> p;
  p.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) p.emplace_back(v.x(), v.y(), v.z());
  const auto& faces = mesh.triangles;
  std::vector<Box> boxes;
  boxes.reserve(faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& t = faces[f];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    const Point &a = p[static_cast<std::size_t>(t[0])], &b = p[static_cast<std::size_t>(t[1])],
                &c = p[static_cast<std::size_t>(t[2])];
    if (CGAL::collinear(a, b, c)) continue;  // degenerate: counted apart
    boxes.emplace_back(a.bbox() + b.bbox() + c.bbox(), f);
  }
  std::vector<const Box*> ptr;
  ptr.reserve(boxes.size());
  for (const Box& b : boxes) ptr.push_back(&b);
  // Candidates from overlapping boxes (cheap, sequential), then the exact tests in parallel.
  std::vector<std::pair<std::size_t, std::size_t>> candidates;
  CGAL::box_self_intersection_d(ptr.begin(), ptr.end(), [&](const Box* x, const Box* y) {
    candidates.emplace_back(std::min(x->info(), y->info()), std::max(x->info(), y->info()));
  });
  std::vector<char> hit(candidates.size(), 0);
  parallelFor(candidates.size(), threads, [&](std::size_t k) {
    hit[k] = facesIntersect(faces[candidates[k].first], faces[candidates[k].second], p) ? 1 : 0;
  });
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t k = 0; k < candidates.size(); ++k)
    if (hit[k]) pairs.push_back(candidates[k]);
  std::sort(pairs.begin(), pairs.end());
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
