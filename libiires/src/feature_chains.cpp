// SPDX-License-Identifier: GPL-3.0-or-later
// Feature chains: crease points linked into finished polylines, and their sampling by arc length.
#include "features_internal.hpp"



#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <list>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>

#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"


namespace iires {
using namespace detail;
namespace {



struct Dsu {
  std::vector<std::uint32_t> parent;
  explicit Dsu(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
};

struct TreeEdge {
  std::uint32_t to;
  double w;
};

/// Farthest vertex from @p src within the alive part of a forest (weighted), with parent links.
std::uint32_t farthest(const std::vector<std::vector<TreeEdge>>& g, const std::vector<char>& alive,
                       std::uint32_t src, std::vector<double>& dist, std::vector<std::int64_t>& parent,
                       std::vector<std::uint32_t>& visited) {
  visited.clear();
  std::vector<std::uint32_t> stack{src};
  dist[src] = 0;
  parent[src] = -1;
  std::uint32_t best = src;
  while (!stack.empty()) {
    const std::uint32_t u = stack.back();
    stack.pop_back();
    visited.push_back(u);
    if (dist[u] > dist[best] || (dist[u] == dist[best] && u < best)) best = u;
    for (const TreeEdge& e : g[u])
      if (alive[e.to] && static_cast<std::int64_t>(e.to) != parent[u]) {
        parent[e.to] = u;
        dist[e.to] = dist[u] + e.w;
        stack.push_back(e.to);
      }
  }
  return best;
}

double arcLength(const FeatureChain& c) {
  double len = 0;
  for (std::size_t t = 1; t < c.points.size(); ++t) len += (c.points[t] - c.points[t - 1]).norm();
  return len;
}

/// Denoise a chain: every vertex is projected onto the line fitted (PCA) to the vertices within ±w of it;
/// directions become the fitted lines' directions, oriented along the chain. Removes the per-point jitter
/// of the crease estimates, also across the crease, without shrinking the ends.
void fitLocalLines(FeatureChain& c, int w) {
  const std::size_t n = c.points.size();
  if (n == 2)
    for (auto& dd : c.directions)
      if (dd.dot(c.points[1] - c.points[0]) < 0) dd = -dd;
  if (n < 3) return;
  std::vector<Eigen::Vector3d> p(n), d(n);
  for (std::size_t t = 0; t < n; ++t) {
    const std::size_t lo = t >= static_cast<std::size_t>(w) ? t - w : 0, hi = std::min(n - 1, t + w);
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (std::size_t u = lo; u <= hi; ++u) m += c.points[u];
    m /= static_cast<double>(hi - lo + 1);
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (std::size_t u = lo; u <= hi; ++u) cov += (c.points[u] - m) * (c.points[u] - m).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    Eigen::Vector3d dir = es.eigenvectors().col(2);
    if (dir.dot(c.points[hi] - c.points[lo]) < 0) dir = -dir;
    p[t] = m + dir * (c.points[t] - m).dot(dir);
    d[t] = dir;
  }
  c.points.swap(p);
  c.directions.swap(d);
}

/// An open chain end: its position and the unit direction pointing out of the chain.
struct ChainEnd {
  std::size_t chain;
  bool back;
  Eigen::Vector3d pos, out;
};

std::vector<ChainEnd> openEnds(const std::vector<FeatureChain>& chains) {
  std::vector<ChainEnd> ends;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const auto& ch = chains[c];
    if (ch.closed || ch.points.size() < 2) continue;
    ends.push_back({c, false, ch.points.front(), -ch.directions.front()});
    ends.push_back({c, true, ch.points.back(), ch.directions.back()});
  }
  return ends;
}

/// Step 2 of finishChains: the ends of @p c (where a third surface or a fading crease biases the fit) trimmed
/// by @p trim and grown back along the end lines.
void trimAndRegrowEnds(FeatureChain& c, double trim) {
  if (arcLength(c) > 4 * trim) {
    for (int side = 0; side < 2; ++side) {
      std::reverse(c.points.begin(), c.points.end());
      std::reverse(c.directions.begin(), c.directions.end());
      for (auto& dd : c.directions) dd = -dd;
      const Eigen::Vector3d end = c.points.back();
      while (c.points.size() > 2 && (c.points.back() - end).norm() < trim) {
        c.points.pop_back();
        c.directions.pop_back();
      }
      // End line: PCA of the last vertices (beyond the trimmed part).
      const std::size_t n = c.points.size(), lo = n > 12 ? n - 12 : 0;
      Eigen::Vector3d m = Eigen::Vector3d::Zero();
      for (std::size_t u = lo; u < n; ++u) m += c.points[u];
      m /= static_cast<double>(n - lo);
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (std::size_t u = lo; u < n; ++u) cov += (c.points[u] - m) * (c.points[u] - m).transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
      Eigen::Vector3d dir = es.eigenvectors().col(2);
      if (dir.dot(c.points.back() - c.points[lo]) < 0) dir = -dir;
      const Eigen::Vector3d tip = m + dir * (end - m).dot(dir);
      c.points.push_back(tip);
      c.directions.push_back(dir);
      c.directions[n - 1] = dir;
    }
  }
}

/// Candidate pairs (gap, end a, end b) of chain ends that meet head-on (anti-parallel end directions, each end
/// on the other's end line, gap up to 4 links: random samplings leave stretches of a crease with no point close
/// enough to be detected). End 2c is chain c's front, 2c + 1 its back.
std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> headOnPairs(const std::vector<FeatureChain>& chains,
                                                                          double link, double tol, double cosTurn) {
  const std::size_t nc = chains.size();
  std::vector<Eigen::Vector3d> pos(2 * nc), out(2 * nc);
  for (std::size_t c = 0; c < nc; ++c) {
    pos[2 * c] = chains[c].points.front();
    out[2 * c] = -chains[c].directions.front();
    pos[2 * c + 1] = chains[c].points.back();
    out[2 * c + 1] = chains[c].directions.back();
  }
  std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> pairs;
  if (nc > 0) {
    KnnIndex endIndex(pos);
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    for (std::uint32_t a = 0; a < 2 * nc; ++a) {
      endIndex.radius(pos[a], 4 * link, idx, d2);
      for (std::uint32_t b : idx) {
        if (b <= a) continue;
        const Eigen::Vector3d gap = pos[b] - pos[a];
        const double len = gap.norm();
        if (-out[a].dot(out[b]) < cosTurn) continue;
        if (len > tol && (out[a].dot(gap) < cosTurn * len || -out[b].dot(gap) < cosTurn * len)) continue;
        const double offA = (gap - out[a] * gap.dot(out[a])).norm();
        const double offB = (gap - out[b] * gap.dot(out[b])).norm();
        if (len > link && std::max(offA, offB) > tol) continue;
        pairs.emplace_back(len, a, b);
      }
    }
  }
  return pairs;
}

/// The ends' partners: @p pairs accepted greedily nearest first, each end once; a group meeting itself only
/// when it is long (a closed loop).
std::vector<std::int64_t> partnerEnds(const std::vector<FeatureChain>& chains,
                                      std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> pairs, double link) {
  const std::size_t nc = chains.size();
  std::sort(pairs.begin(), pairs.end());
  std::vector<std::int64_t> partner(2 * nc, -1);
  Dsu groups(nc);
  std::vector<double> groupLength(nc);
  for (std::size_t c = 0; c < nc; ++c) groupLength[c] = arcLength(chains[c]);
  for (const auto& [len, a, b] : pairs) {
    if (partner[a] >= 0 || partner[b] >= 0) continue;
    const std::uint32_t ga = groups.find(a / 2), gb = groups.find(b / 2);
    if (ga == gb && groupLength[ga] < 3 * link) continue;  // closing a loop: only a long one
    partner[a] = b;
    partner[b] = a;
    if (ga != gb) {
      groups.parent[ga] = gb;
      groupLength[gb] += groupLength[ga] + len;
    }
  }
  return partner;
}

/// The joined chains: each group walked from a free end (or anywhere, for a loop), its chains appended in order.
std::vector<FeatureChain> assembleGroups(const std::vector<FeatureChain>& chains, const std::vector<std::int64_t>& partner) {
  const std::size_t nc = chains.size();
  std::vector<FeatureChain> joined;
  std::vector<char> used(nc, 0);
  auto append = [](FeatureChain& dst, const FeatureChain& src, bool reversed) {
    if (!reversed) {
      dst.points.insert(dst.points.end(), src.points.begin(), src.points.end());
      dst.directions.insert(dst.directions.end(), src.directions.begin(), src.directions.end());
    } else {
      for (std::size_t t = src.points.size(); t-- > 0;) {
        dst.points.push_back(src.points[t]);
        dst.directions.push_back(-src.directions[t]);
      }
    }
  };
  for (std::size_t c0 = 0; c0 < nc; ++c0) {
    if (used[c0]) continue;
    // Find the start: go out through front ends until a free end or back to c0.
    std::uint32_t entry = static_cast<std::uint32_t>(2 * c0);  // the end through which we enter the chain
    bool loop = false;
    for (std::size_t guard = 0; guard <= nc; ++guard) {
      if (partner[entry] < 0) break;
      const std::uint32_t nextExit = static_cast<std::uint32_t>(partner[entry]);
      entry = nextExit ^ 1u;  // enter the neighbour through its other end when walking backwards
      if (entry / 2 == c0) {
        loop = true;
        entry = static_cast<std::uint32_t>(2 * c0);
        break;
      }
    }
    FeatureChain g;
    std::uint32_t e = entry;
    for (;;) {
      const std::uint32_t c = e / 2;
      if (used[c]) break;
      used[c] = 1;
      append(g, chains[c], (e & 1u) != 0);  // entering through the back end: traverse reversed
      const std::int64_t nxt = partner[e ^ 1u];
      if (nxt < 0) break;
      e = static_cast<std::uint32_t>(nxt);
    }
    g.closed = loop;
    joined.push_back(std::move(g));
  }
  return joined;
}

/// Step 4 of finishChains: each open end extended to where its line meets another end's line (a corner) or
/// another chain (a T-junction) within reach.
void extendToCorners(std::vector<FeatureChain>& chains, double h, double link, double trim, double tol) {
  const double reach = 2 * link + trim;
  const auto ends = openEnds(chains);
  std::vector<std::pair<std::size_t, Eigen::Vector3d>> extensions;  // (end index, new tip)
  for (std::size_t a = 0; a < ends.size(); ++a) {
    const ChainEnd& e = ends[a];
    double bestS = reach;
    Eigen::Vector3d tip;
    bool found = false;
    for (std::size_t b = 0; b < ends.size(); ++b) {  // line–line closest approach, both ahead of their ends
      const ChainEnd& f = ends[b];
      if (b == a || f.chain == e.chain || (f.pos - e.pos).norm() > 2 * reach) continue;
      const double bb = e.out.dot(f.out), denom = 1 - bb * bb;
      if (denom < 0.1) continue;  // near-parallel lines: a join, not a corner
      const Eigen::Vector3d w = e.pos - f.pos;
      const double dd = e.out.dot(w), ee = f.out.dot(w);
      const double s = (bb * ee - dd) / denom, t = (ee - bb * dd) / denom;
      if (s < -tol || t < -tol || s > reach || t > reach) continue;
      const Eigen::Vector3d pe = e.pos + s * e.out, pf = f.pos + t * f.out;
      if ((pe - pf).norm() > tol || s >= bestS) continue;
      bestS = s;
      tip = 0.5 * (pe + pf);
      found = true;
    }
    for (std::size_t c = 0; c < chains.size(); ++c) {  // T-junction: the ray hits another chain's vertex
      if (c == e.chain) continue;
      for (const auto& v : chains[c].points) {
        const double s = (v - e.pos).dot(e.out);
        if (s < 0 || s >= bestS || (v - e.pos - s * e.out).norm() > tol) continue;
        bestS = s;
        tip = v;
        found = true;
      }
    }
    if (found && bestS > 1e-9 * h) extensions.emplace_back(a, tip);
  }
  for (const auto& [a, tip] : extensions) {
    FeatureChain& c = chains[ends[a].chain];
    if (ends[a].back) {
      c.points.push_back(tip);
      c.directions.push_back(c.directions.back());
    } else {
      c.points.insert(c.points.begin(), tip);
      c.directions.insert(c.directions.begin(), c.directions.front());
    }
  }
}

/// Step 5 of finishChains: lengths, a deterministic orientation (lexicographically smaller end first) and
/// order (longest first).
void orientAndOrder(std::vector<FeatureChain>& chains) {
  for (auto& c : chains) {
    c.length = arcLength(c);
    if (c.closed) c.length += (c.points.back() - c.points.front()).norm();
    auto lex = [](const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
      return std::tie(p.x(), p.y(), p.z()) < std::tie(q.x(), q.y(), q.z());
    };
    if (lex(c.points.back(), c.points.front())) {
      std::reverse(c.points.begin(), c.points.end());
      std::reverse(c.directions.begin(), c.directions.end());
      for (auto& dd : c.directions) dd = -dd;
    }
  }
  std::stable_sort(chains.begin(), chains.end(),
                   [](const FeatureChain& a, const FeatureChain& b) { return a.length > b.length; });
}

/// Post-processing of the raw chains (paths of crease points):
///  1. local line fits (denoising);
///  2. the ends (where a third surface or a fading crease biases the fit) are trimmed by one
///     neighbourhood radius and re-grown along the end line;
///  3. chains whose ends meet head-on are joined (and a chain meeting itself is closed);
///  4. an end whose line meets another end's line (a corner) or another chain (a T-junction) within reach is
///     extended to the meeting point, so the feature lines reach their corners;
///  5. deterministic orientation and order (longest first).
void finishChains(std::vector<FeatureChain>& chains, double h, const FeatureParams& prm) {
  const double link = prm.chainRadius * h, cosTurn = std::cos(prm.maxChainTurn * kDeg);
  const double trim = prm.radius * h, tol = 2.0 * prm.maxLineDistance * h;
  for (auto& c : chains) {
    fitLocalLines(c, 6);
    trimAndRegrowEnds(c, trim);
  }
  std::vector<FeatureChain> joined =
      assembleGroups(chains, partnerEnds(chains, headOnPairs(chains, link, tol, cosTurn), link));
  // Drop what is still short after joining.
  chains.clear();
  for (auto& g : joined)
    if (g.points.size() >= 2 && arcLength(g) >= prm.minChainLength * h) chains.push_back(std::move(g));
  extendToCorners(chains, h, link, trim, tol);
  orientAndOrder(chains);
}

struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    return static_cast<std::size_t>(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
  }
};


}  // namespace

std::vector<FeatureChain> detail::buildChains(const std::vector<Eigen::Vector3d>& x0,
                                      const std::vector<Eigen::Vector3d>& d0, double h, const FeatureParams& prm,
                                      int threads) {
  std::vector<FeatureChain> chains;
  std::vector<Eigen::Vector3d> x, d;
  const double link = prm.chainRadius * h, cosTurn = std::cos(prm.maxChainTurn * kDeg);
  // Thin the crease points to a minimum separation of h/2 (in index order, deterministic): on a line of
  // well-separated points the minimum spanning tree is a path, not a zigzag with parallel branches.
  {
    KnnIndex all(x0);
    std::vector<char> removed(x0.size(), 0);
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    for (std::size_t i = 0; i < x0.size(); ++i) {
      if (removed[i]) continue;
      all.radius(x0[i], 0.5 * h, idx, d2);
      for (std::uint32_t j : idx)
        if (j > i) removed[j] = 1;
    }
    for (std::size_t i = 0; i < x0.size(); ++i)
      if (!removed[i]) {
        x.push_back(x0[i]);
        d.push_back(d0[i]);
      }
  }
  const std::size_t n = x.size();
  if (n < 2) return chains;
  // Candidate links: within `link`, directions and the link itself along the crease.
  KnnIndex index(x);
  std::vector<std::vector<std::pair<std::uint32_t, double>>> cand(n);
  parallelFor(n, threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.radius(x[i], link, idx, d2);
    for (std::size_t t = 0; t < idx.size(); ++t) {
      const std::uint32_t j = idx[t];
      if (j <= i) continue;
      if (std::abs(d[i].dot(d[j])) < cosTurn) continue;
      const double len = std::sqrt(d2[t]);
      if (len > 1e-12 * h && std::abs((x[j] - x[i]).dot(d[i])) < cosTurn * len) continue;
      cand[i].emplace_back(j, len);
    }
  });
  std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> edges;
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& [j, w] : cand[i]) edges.emplace_back(w, static_cast<std::uint32_t>(i), j);
  std::sort(edges.begin(), edges.end());
  // Minimum spanning forest (Kruskal; ties broken by indices → deterministic).
  Dsu dsu(n);
  std::vector<std::vector<TreeEdge>> g(n);
  for (const auto& [w, a, b] : edges) {
    const std::uint32_t ra = dsu.find(a), rb = dsu.find(b);
    if (ra == rb) continue;
    dsu.parent[ra] = rb;
    g[a].push_back({b, w});
    g[b].push_back({a, w});
  }
  // Peel each tree into longest paths (its diameter, then the diameters of what remains).
  std::vector<char> alive(n, 1);
  std::vector<double> dist(n, 0);
  std::vector<std::int64_t> parent(n, -1);
  std::vector<std::uint32_t> visited;
  std::vector<char> peeled(n, 0);
  const double minLen = prm.minChainLength * h;
  for (std::uint32_t s = 0; s < n; ++s) {
    while (alive[s]) {
      const std::uint32_t a = farthest(g, alive, s, dist, parent, visited);
      const std::uint32_t b = farthest(g, alive, a, dist, parent, visited);
      const double len = dist[b];
      std::vector<std::uint32_t> path;
      for (std::int64_t v = b; v >= 0; v = parent[v]) path.push_back(static_cast<std::uint32_t>(v));
      // A tree's first path (its diameter) is kept however short: chainsJoin may bridge it to others across a
      // sampling gap. Later paths are branches of an already peeled tree: spurs unless long.
      const std::uint32_t tree = dsu.find(s);
      const bool first = !peeled[tree];
      peeled[tree] = 1;
      if (!first && len < minLen) {  // a spur: drop what remains of this piece
        for (std::uint32_t v : visited) alive[v] = 0;
        break;
      }
      for (std::uint32_t v : path) alive[v] = 0;
      FeatureChain c;
      for (std::uint32_t v : path) {
        c.points.push_back(x[v]);
        c.directions.push_back(d[v]);
      }
      chains.push_back(std::move(c));
    }
  }
  finishChains(chains, h, prm);
  return chains;
}

std::vector<Eigen::Vector3d> sampleFeatureChains(const std::vector<FeatureChain>& chains, double spacing,
                                                 std::vector<std::uint32_t>* chainOfSample) {
  if (!(spacing > 0)) throw std::invalid_argument("sampleFeatureChains: spacing must be > 0");
  std::vector<Eigen::Vector3d> out;
  std::vector<std::uint32_t> owner;
  std::unordered_map<CellKey, std::vector<std::uint32_t>, CellHash> grid;
  auto key = [&](const Eigen::Vector3d& p) {
    return CellKey{static_cast<std::int64_t>(std::floor(p.x() / spacing)),
                   static_cast<std::int64_t>(std::floor(p.y() / spacing)),
                   static_cast<std::int64_t>(std::floor(p.z() / spacing))};
  };
  auto crowded = [&](const Eigen::Vector3d& p, std::uint32_t chain) {
    const CellKey k = key(p);
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          auto it = grid.find({k.x + dx, k.y + dy, k.z + dz});
          if (it == grid.end()) continue;
          for (std::uint32_t s : it->second)
            if (owner[s] != chain && (out[s] - p).norm() < 0.5 * spacing) return true;
        }
    return false;
  };
  for (std::uint32_t ci = 0; ci < chains.size(); ++ci) {
    const FeatureChain& c = chains[ci];
    const std::size_t nv = c.points.size();
    if (nv == 0) continue;
    std::vector<Eigen::Vector3d> poly = c.points, dirs = c.directions;
    if (c.closed) {
      poly.push_back(c.points.front());
      dirs.push_back(c.directions.front());
    }
    std::vector<double> arc(poly.size(), 0.0);
    for (std::size_t t = 1; t < poly.size(); ++t) arc[t] = arc[t - 1] + (poly[t] - poly[t - 1]).norm();
    const double len = arc.back();
    std::vector<double> at;  // arc-length positions of this chain's samples
    if (c.closed) {
      const std::size_t m = std::max<std::size_t>(3, static_cast<std::size_t>(std::lround(len / spacing)));
      for (std::size_t s = 0; s < m; ++s) at.push_back(len * static_cast<double>(s) / static_cast<double>(m));
    } else {
      const std::size_t m = static_cast<std::size_t>(std::lround(len / spacing));
      if (m == 0) {
        at.push_back(0.5 * len);
      } else {
        for (std::size_t s = 0; s <= m; ++s) at.push_back(len * static_cast<double>(s) / static_cast<double>(m));
      }
    }
    std::size_t seg = 0;
    for (double a : at) {
      while (seg + 2 < poly.size() && arc[seg + 1] < a) ++seg;
      const std::size_t nxt = std::min(seg + 1, poly.size() - 1);
      const double span = arc[nxt] - arc[seg];
      const double w = span > 0 ? std::clamp((a - arc[seg]) / span, 0.0, 1.0) : 0.0;
      Eigen::Vector3d p = (1 - w) * poly[seg] + w * poly[nxt];
      // Onto the crease line of the nearer vertex (the polyline chord cuts a curved crease slightly).
      const std::size_t v = w < 0.5 ? seg : nxt;
      p = poly[v] + dirs[v] * (p - poly[v]).dot(dirs[v]);
      if (crowded(p, ci)) continue;
      grid[key(p)].push_back(static_cast<std::uint32_t>(out.size()));
      out.push_back(p);
      owner.push_back(ci);
    }
  }
  if (chainOfSample) *chainOfSample = owner;
  return out;
}

}  // namespace iires
