// SPDX-License-Identifier: GPL-3.0-or-later
// Crease tracing: continuing chain ends along the crease, into corners and across the detector's gaps.
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


namespace iires::detail {

namespace {

/// traceChainEnds() in steps: the chains' runs (split where samples were dropped), a job per run end, each job
/// traced on along its crease (into corners, whose other creases become branch runs and jobs), then the stray
/// lone samples dropped.
class CreaseTracer {
 public:
  CreaseTracer(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params)
      : cloud_(cloud), index_(index), h_(h), params_(params), cosTurn_(std::cos(params.maxChainTurn * kDeg)) {}

  void run(std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
    splitRuns(out, owner);
    makeJobs();
    all_ = out;  // every sample placed so far (brute-force proximity: a few thousand)
    // Never more crease samples than input points (they are spaced at least a chain step apart): past that, no
    // job steps on. Bounds the work on degenerate input (branches spawning branches along a crease of tiny
    // steps) and nearPlaced()'s brute force.
    budget_ = out.size() + cloud_.points.size() + 64;
    inputRuns_ = runs_.size();  // the runs after it are corners' branches
    tracedFrom_.assign(runs_.size(), 0);
    for (std::size_t jb = 0; jb < jobs_.size() && all_.size() <= budget_; ++jb) trace(jobs_[jb]);
    tracedFrom_.resize(runs_.size(), 0);
    write(strays(), out, owner);
  }

 private:
  struct Run {
    std::uint32_t chain;
    std::vector<Eigen::Vector3d> front, pts;  // front: traced off the first sample, outward order
  };
  struct Job {
    std::size_t run;
    bool back;  // appends to the run's back (else to its front list)
    Eigen::Vector3d tip, dir;
    double step;
  };
  /// The job being traced: its tip and direction so far, its step, the samples it added.
  struct Trace {
    Eigen::Vector3d tip, dir;
    double step;
    std::vector<Eigen::Vector3d> added;
  };

  /// A chain's run is split where samples were dropped (a gap over 1.6 × its median spacing): the pieces' ends
  /// are traced like the chain's, so the gap is filled from both sides.
  void splitRuns(const std::vector<Eigen::Vector3d>& out, const std::vector<std::uint32_t>& owner) {
    for (const auto& [a, b] : ownerRuns(owner)) {
      nextChain_ = std::max(nextChain_, owner[a] + 1);
      std::vector<double> gaps;
      for (std::size_t t = a; t < b; ++t) gaps.push_back((out[t + 1] - out[t]).norm());
      double median = 0;
      if (!gaps.empty()) {
        std::vector<double> sorted(gaps);
        std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
        median = sorted[sorted.size() / 2];
      }
      std::size_t first = a;
      for (std::size_t t = a; t <= b; ++t)
        if (t == b || gaps[t - a] > 1.6 * median) {
          runs_.push_back({owner[a], {}, std::vector<Eigen::Vector3d>(out.begin() + static_cast<long>(first), out.begin() + static_cast<long>(t + 1))});
          first = t + 1;
        }
    }
  }

  /// A job per run end, outward at the run's end spacing; a lone sample's two jobs along its own crease at the
  /// runs' median end spacing (typicalStep_).
  void makeJobs() {
    std::vector<double> steps;
    for (const Run& run : runs_)
      if (run.pts.size() >= 2) steps.push_back((run.pts[1] - run.pts[0]).norm());
    if (!steps.empty()) {
      std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
      typicalStep_ = steps[steps.size() / 2];
    }
    for (std::size_t r = 0; r < runs_.size(); ++r) {
      const auto& p = runs_[r].pts;
      if (p.size() == 1 && typicalStep_ > 0) {
        // A lone sample (a piece of a chain between two gaps): traced both ways along its own crease.
        std::vector<std::uint32_t> idx;
        std::vector<double> d2;
        const double hs = localSpacing(index_, p[0], h_);
        Crease c;
        if (snapFit(cloud_, index_, p[0], hs, params_, params_, c, idx, d2)) {
          jobs_.push_back({r, false, p[0], -c.direction, typicalStep_});
          jobs_.push_back({r, true, p[0], c.direction, typicalStep_});
        }
        continue;
      }
      if (p.size() < 2) continue;
      for (int side = 0; side < 2; ++side) {
        const Eigen::Vector3d tip = side ? p.back() : p.front(), prev = side ? p[p.size() - 2] : p[1];
        const double step = (tip - prev).norm();
        if (step > 1e-9 * h_) jobs_.push_back({r, side == 1, tip, (tip - prev) / step, step});
      }
    }
  }

  bool nearPlaced(const Eigen::Vector3d& y, const Eigen::Vector3d& except, double step) const {
    for (const auto& q : all_)
      if ((q - y).squaredNorm() < 0.5625 * step * step && (q - except).squaredNorm() > 1e-24) return true;
    return false;
  }

  /// The regular stepped fit at y (full ball, else the half-ball behind along dir); sets hl_.
  bool fitAt(Eigen::Vector3d& y, const Eigen::Vector3d& dir, Crease& c, bool& oneSided) {
    bool ok = true;
    oneSided = false;
    hl_ = localSpacing(index_, y, h_);
    for (int it = 0; it < 2 && ok; ++it) {  // fitted at the prediction, then re-centred on the crease
      ok = creaseAlong(cloud_, index_, y, dir, hl_, params_, c, idx_, d2_, behind_, oneSided);
      if (ok) y = c.point;
    }
    return ok;
  }

  void add(Trace& tr, const Eigen::Vector3d& q) {
    tr.added.push_back(q);
    all_.push_back(q);
  }

  /// Traces one job on, step by step along its crease, until it bridges to a placed sample, meets a corner,
  /// or the crease ends; the samples go to the job's end of its run.
  void trace(const Job job) {
    const std::size_t runsBefore = runs_.size();
    Trace tr{job.tip, job.dir, job.step, {}};
    const double step = job.step;
    Crease last;  // the planes at the tip (the last full fit)
    {
      Eigen::Vector3d y = tr.tip;
      bool one = false;
      if (!fitAt(y, tr.dir, last, one) || one) last.valid = false;
    }
    for (int guard = 0; guard < 100000 && all_.size() <= budget_; ++guard) {
      const Eigen::Vector3d predicted = tr.tip + step * tr.dir;
      Eigen::Vector3d y = predicted;
      Crease c;
      bool oneSided = false;
      // The prediction lies on the crease but for its bend over one step: a fit far off it found another line.
      bool ok = fitAt(y, tr.dir, c, oneSided);
      if (ok) {
        // One step on along the fitted line (the nearest point of the line to the prediction slides along it
        // where the crease bends; a sample a few steps ahead would leave a gap behind it).
        const double cd = c.direction.dot(tr.dir);
        const double t = (step - (y - tr.tip).dot(tr.dir)) / cd;
        if (std::abs(cd) > 0.95 && std::abs(t) <= step) y += t * c.direction;
        ok = (y - tr.tip).dot(tr.dir) >= 0.5 * step &&  // the crease leads on
             (y - predicted).norm() <= 0.5 * step + 0.25 * hl_;  // far off the prediction: another line
      }
      if (ok && nearPlaced(y, tr.tip, step)) break;  // bridged to a sample already placed
      if (!ok || oneSided) {
        // Near a corner: fitted on the half-ball behind, or not at all (then the tip's planes go on).
        Crease bent;
        const int found = ok ? cornerAhead(tr, c, y - step * tr.dir, &bent)
                             : (last.valid ? cornerAhead(tr, last, tr.tip, &bent) : 0);
        if (found == 1) break;
        if (found == 2) {
          if (nearPlaced(bent.point, tr.tip, step)) break;  // bridged
          y = bent.point;
          c = bent;
          ok = true;
          oneSided = false;
        }
        if (!ok && !resume(tr, y, c)) break;
        if (!ok) oneSided = false;
      }
      // Off the input (its fits' ball, a few local spacings read at y, grows as y leaves the surface): the line
      // followed has run past the input's end.
      if (offInput(cloud_, index_, y, h_) > 2.0 * params_.maxOffCrease || pastInput(y, tr.dir)) break;
      add(tr, y);
      if (!oneSided) last = c;
      tr.dir = (c.direction.dot(tr.dir) < 0 ? -c.direction : c.direction);
      tr.tip = y;
    }
    tracedFrom_.resize(runs_.size(), 0);
    if (!tr.added.empty() || runs_.size() > runsBefore) tracedFrom_[job.run] = 1;
    Run& run = runs_[job.run];
    (job.back ? run.pts : run.front).insert(job.back ? run.pts.end() : run.front.end(), tr.added.begin(), tr.added.end());
  }

  /// Whether @p y lies past the input's end along @p dir: no input point within 2 local spacings of it reaches to
  /// within half a local spacing behind it. The planes fitted on the points behind an open end (a part's edge, a
  /// hole's rim) go on past it, and the off-input test alone lets a sample stand up to 2 spacings out.
  bool pastInput(const Eigen::Vector3d& y, const Eigen::Vector3d& dir) {
    const double hl = localSpacing(index_, y, h_);
    index_.radius(y, 2.0 * hl, idx_, d2_);
    return std::none_of(idx_.begin(), idx_.end(),
                        [&](std::uint32_t j) { return (cloud_.points[j] - y).dot(dir) >= -0.5 * hl; });
  }

  /// Whether the input points just ahead of @p y (within 2 local spacings, on the side @p dir points to) include
  /// points of both sheets of @p c (each within 3·maxResidual local spacings of its plane): a sample placed on a
  /// line fitted elsewhere (along planes known from behind it) is on the crease only while both sheets go on
  /// around it. Where one of them has ended (a corner or a tip passed), the line leaves the surface.
  bool bothSheetsAhead(const Eigen::Vector3d& y, const Crease& c, const Eigen::Vector3d& dir) {
    const double hl = localSpacing(index_, y, h_), tol = 3.0 * params_.maxResidual * hl;
    index_.radius(y, 2.0 * hl, idx_, d2_);
    bool onA = false, onB = false;
    for (std::uint32_t j : idx_) {
      const Eigen::Vector3d& q = cloud_.points[j];
      if ((q - y).dot(dir) <= 0) continue;
      const double da = std::abs(c.normalA.dot(q) - c.offsetA), db = std::abs(c.normalB.dot(q) - c.offsetB);
      if (std::min(da, db) <= tol) (da <= db ? onA : onB) = true;
    }
    return onA && onB;
  }

  /// A fit fails now and then on a random sampling (a lopsided neighbourhood): the crease goes on if the full
  /// fit holds one or two steps further; the skipped samples go on the straight line to it (@p y, @p c: the
  /// fit there). False when it does not.
  bool resume(Trace& tr, Eigen::Vector3d& y, Crease& c) {
    const double step = tr.step;
    for (int skip = 2; skip <= 3; ++skip) {
      Eigen::Vector3d z = tr.tip + (skip * step) * tr.dir;
      Crease cz;
      bool one = false;
      if (!fitAt(z, tr.dir, cz, one) || one || (z - tr.tip).dot(tr.dir) < (skip - 0.5) * step) continue;
      if (nearPlaced(z, tr.tip, step)) return false;
      for (int k = 1; k < skip; ++k) add(tr, tr.tip + (z - tr.tip) * (static_cast<double>(k) / skip));
      y = z;
      c = cz;
      return true;
    }
    return false;
  }

  /// A corner ahead of @p o on the crease of @p c: points ahead of o (in the ball half a step on, radius + half
  /// a step) that neither plane explains belong to a third sheet (off both planes by 3·maxResidual, a normal
  /// unlike both, off the rounded crease); its plane is fitted, the corner refined as the three planes'
  /// intersection. On success the gap from the tip is filled, the corner placed and its two other creases
  /// followed (1). A third plane within the detector's angle of one sheet but not of the other is no corner but
  /// the crease bending on (a faceted or small cylinder beside a plane): @p bend gets the next sample, one step
  /// on along the other sheet ∩ the third plane (2). Else 0.
  int cornerAhead(Trace& tr, const Crease& c, const Eigen::Vector3d& o, Crease* bend) {
    const Eigen::Vector3d& dir = tr.dir;
    const double step = tr.step;
    const Eigen::Vector3d y = o + 0.5 * step * dir;
    const double hc = localSpacing(index_, y, h_), tolc = 3.0 * params_.maxResidual * hc;
    const double reachC = params_.radius * hc + 0.5 * step;
    // A third sheet's point: off both planes, with a normal unlike both, and not on the (rounded) crease.
    const double cosSheet = std::cos(0.5 * params_.angle * kDeg);
    auto unexplained = [&](std::uint32_t j) {
      const Eigen::Vector3d& q = cloud_.points[j];
      const Eigen::Vector3d& nq = cloud_.normals[j];
      const Eigen::Vector3d off = q - c.point - c.direction * (q - c.point).dot(c.direction);
      return std::abs(c.normalA.dot(q) - c.offsetA) > tolc && std::abs(c.normalB.dot(q) - c.offsetB) > tolc &&
             std::abs(nq.dot(c.normalA)) < cosSheet && std::abs(nq.dot(c.normalB)) < cosSheet && off.norm() > hc;
    };
    index_.radius(y, reachC, idx_, d2_);
    if (idx_.size() > 400) idx_.resize(400);
    behind_.clear();
    for (std::uint32_t j : idx_)
      if ((cloud_.points[j] - o).dot(dir) <= 0) behind_.push_back(j);
    ahead_.clear();
    for (std::uint32_t j : idx_)
      if ((cloud_.points[j] - o).dot(dir) > 0 && unexplained(j)) ahead_.push_back(j);  // ahead of the tip
    if (ahead_.size() < 6) return 0;
    Eigen::Vector3d n3;
    double o3 = 0, r3 = 0, along = 0;
    Eigen::Vector3d corner = c.point;
    // The third sheet's plane, refitted to the unexplained points around the corner estimate.
    for (int it = 0; it < 3; ++it) {
      if (ahead_.size() < 6) break;
      r3 = fitPlane(cloud_.points, ahead_, y, 0, dir, n3, o3);
      along = n3.dot(c.direction);
      if (std::abs(along) <= 0.3) break;
      corner = c.point + ((o3 - n3.dot(c.point)) / along) * c.direction;  // the crease line meets it
      if (it == 2) break;
      std::vector<std::uint32_t> around;
      std::vector<double> ad2;
      index_.radius(corner, params_.radius * hc, around, ad2);
      ahead_.clear();
      for (std::uint32_t j : around)
        if (unexplained(j)) ahead_.push_back(j);
    }
    if (!(r3 <= 2.0 * params_.maxResidual * hc && std::abs(along) > 0.3)) return 0;
    const Crease cc = refineCorner(c, hc, tolc, corner, n3, o3);
    // A sheet curving on (a small cylinder beside a plane): its points ahead fit a "third plane" within the
    // detector's angle of it, while the other sheet meets that plane at a crease. No corner then: the crease
    // bends; the next sample goes one step on along the other sheet ∩ the third plane.
    const double cosSharp = std::cos(params_.angle * kDeg);
    const bool smoothA = std::abs(cc.normalA.dot(n3)) > cosSharp, smoothB = std::abs(cc.normalB.dot(n3)) > cosSharp;
    if (smoothA != smoothB) return bendOn(tr, cc, smoothA, n3, o3, bend);
    const double ahead3 = (corner - tr.tip).dot(dir);
    double nearest = 0;
    index_.nearest(corner, &nearest);
    if (!(ahead3 > 0 && ahead3 < step + params_.radius * hc && std::sqrt(nearest) <= params_.maxOffCrease * hc))
      return 0;
    // Fill tip → corner at ≤ step spacing (the corner itself unless a placed sample is there). A traced tip
    // closer than half a step to the corner moves onto it; an original one stands for it.
    bool cornerTaken = false;
    if ((corner - tr.tip).norm() < 0.5 * step) {
      if (!tr.added.empty() && all_.back() == tr.added.back()) {
        tr.added.back() = corner;
        all_.back() = corner;
        tr.tip = corner;
      }
      cornerTaken = true;
    }
    const bool takenByOther = nearPlaced(corner, tr.tip, step);  // its branches are followed already
    cornerTaken = cornerTaken || takenByOther;
    const double gap = (corner - tr.tip).norm();
    const int pieces = std::max(1, static_cast<int>(std::ceil(gap / step - 0.25)));
    for (int k = 1; k <= pieces; ++k) {
      const Eigen::Vector3d q = tr.tip + (corner - tr.tip) * (static_cast<double>(k) / pieces);
      if (k == pieces ? cornerTaken : nearPlaced(q, tr.tip, step)) break;
      add(tr, q);
    }
    if (!takenByOther) followBranches(tr, cc, n3, o3, corner, y, hc, tolc);
    return 1;
  }

  /// The corner as the three sheets' common point: the points around it go to the nearest of the three planes,
  /// each plane is refitted to its points (twice), and the planes are intersected. Returns @p c with the
  /// refitted sheets and direction; @p corner, @p n3, @p o3 refined in place.
  Crease refineCorner(const Crease& c, double hc, double tolc, Eigen::Vector3d& corner, Eigen::Vector3d& n3,
                      double& o3) const {
    Crease cc = c;
    Eigen::Vector3d pn[3] = {c.normalA, c.normalB, n3};
    double po[3] = {c.offsetA, c.offsetB, o3};
    std::vector<std::uint32_t> around, part[3];
    std::vector<double> ad2;
    index_.radius(corner, params_.radius * hc, around, ad2);
    for (int it = 0; it < 2; ++it) {
      partitionByPlanes(cloud_.points, around, pn, po, tolc, part);
      Eigen::Vector3d tn[3];
      double to[3];
      bool fitted = true;
      for (int k = 0; k < 3 && fitted; ++k)
        fitted = part[k].size() >= 5 &&
                 fitPlane(cloud_.points, part[k], corner, 0, pn[k], tn[k], to[k]) <= 2.0 * params_.maxResidual * hc;
      if (!fitted) break;
      Eigen::Matrix3d m;
      m << tn[0].transpose(), tn[1].transpose(), tn[2].transpose();
      if (std::abs(m.determinant()) < 0.1) break;
      const Eigen::Vector3d k3 = m.inverse() * Eigen::Vector3d(to[0], to[1], to[2]);
      if ((k3 - corner).norm() > hc) break;
      for (int k = 0; k < 3; ++k) pn[k] = tn[k], po[k] = to[k];
      corner = k3;
    }
    cc.normalA = pn[0];
    cc.normalB = pn[1];
    cc.offsetA = po[0];
    cc.offsetB = po[1];
    const Eigen::Vector3d d = pn[0].cross(pn[1]);
    if (d.norm() > 1e-6) cc.direction = d.normalized() * (d.dot(c.direction) < 0 ? -1.0 : 1.0);
    n3 = pn[2];
    o3 = po[2];
    return cc;
  }

  /// The crease bending on: the next sample one step on along the other sheet (not @p smoothA's) ∩ the third
  /// plane (n3, o3), in @p bend (2); 0 when that line turns too far or is off the surface.
  int bendOn(const Trace& tr, const Crease& cc, bool smoothA, const Eigen::Vector3d& n3, double o3,
             Crease* bend) const {
    const Eigen::Vector3d& dir = tr.dir;
    const Eigen::Vector3d& tip = tr.tip;
    const double step = tr.step;
    const Eigen::Vector3d nO = smoothA ? cc.normalB : cc.normalA;
    const double oO = smoothA ? cc.offsetB : cc.offsetA;
    Eigen::Vector3d d = nO.cross(n3);
    if (d.norm() < 0.3) return 0;
    d.normalize();
    if (d.dot(dir) < 0) d = -d;
    if (d.dot(dir) < cosTurn_) return 0;
    // The line's point nearest the tip, then one step on along it.
    const Eigen::Vector3d foot = lineNearest(nO, oO, n3, o3, tip);
    if ((foot - tip).norm() > 0.5 * step) return 0;
    const Eigen::Vector3d yb = foot + (step - (foot - tip).dot(dir)) / d.dot(dir) * d;
    if (offInput(cloud_, index_, yb, h_) > params_.maxOffCrease) return 0;
    bend->valid = true;
    bend->point = yb;
    bend->direction = d;
    bend->normalA = nO;
    bend->offsetA = oO;
    bend->normalB = n3;
    bend->offsetB = o3;
    return 2;
  }

  /// The corner's other two creases: third plane ∩ each sheet, leaving on the side where the sheet lies (its
  /// points' offset from the crease line, within its plane, among the half-ball behind_ around @p y). Each is
  /// followed along the known planes while its neighbourhood stays explained, as a new run; where the regular
  /// fit takes over, a job traces it on.
  void followBranches(const Trace& tr, const Crease& cc, const Eigen::Vector3d& n3, double o3,
                      const Eigen::Vector3d& corner, const Eigen::Vector3d& y, double hc, double tolc) {
    const double step = tr.step;
    const std::vector<std::uint32_t> halfBall = behind_;  // fitAt below reuses behind_
    for (int sheet = 0; sheet < 2; ++sheet) {
      const Eigen::Vector3d nS = sheet ? cc.normalB : cc.normalA;
      const double oS = sheet ? cc.offsetB : cc.offsetA;
      const Eigen::Vector3d nO = sheet ? cc.normalA : cc.normalB;
      const double oO = sheet ? cc.offsetA : cc.offsetB;
      Eigen::Vector3d u = nS.cross(n3);
      if (u.norm() < 0.3) continue;
      // No crease between the sheet and the third one by the detector's angle (a sheet curving on, as a small
      // cylinder beside a plane: its points ahead fit a "third plane" a few tens of degrees off): no branch.
      if (std::abs(nS.dot(n3)) > std::cos(params_.angle * kDeg)) continue;
      u.normalize();
      Eigen::Vector3d side = Eigen::Vector3d::Zero();
      for (std::uint32_t j : halfBall) {
        const Eigen::Vector3d& q = cloud_.points[j];
        const double dS = std::abs(nS.dot(q) - oS), dO = std::abs(nO.dot(q) - oO);
        if (dS <= tolc && dS < dO) side += q - y;
      }
      const Eigen::Vector3d w = nS.cross(cc.direction);  // in the sheet, across the crease
      const double sgn = side.dot(w);
      if (std::abs(sgn) < 1e-12 * h_) continue;
      if (u.dot(w) * sgn < 0) u = -u;
      // Follow the branch along the known planes while its neighbourhood stays explained.
      Run branch{nextChain_++, {}, {}};
      Eigen::Vector3d bt = corner;
      bool handOver = false;
      Crease bc;
      for (int k = 1; k * step <= 3.0 * params_.radius * hc && all_.size() <= budget_; ++k) {
        Eigen::Vector3d by = corner + (k * step) * u;
        if (nearPlaced(by, bt, step)) break;
        double nb = 0;
        index_.nearest(by, &nb);
        if (std::sqrt(nb) > 1.5 * hc) break;  // past the surface (a random sampling leaves ~h gaps)
        std::vector<std::uint32_t> bidx;
        std::vector<double> bd2;
        index_.radius(by, params_.radius * hc, bidx, bd2);
        std::size_t unexplained = 0;
        for (std::uint32_t j : bidx) {
          const Eigen::Vector3d& q = cloud_.points[j];
          if (std::abs(nS.dot(q) - oS) > tolc && std::abs(n3.dot(q) - o3) > tolc && std::abs(nO.dot(q) - oO) > tolc)
            ++unexplained;
        }
        if (unexplained * 6 > bidx.size()) break;
        Crease known;  // the branch: the sheet and the third plane
        known.normalA = nS, known.offsetA = oS, known.normalB = n3, known.offsetB = o3;
        if (!bothSheetsAhead(by, known, u)) break;
        Eigen::Vector3d fy = by;
        bool bOne = false;
        if (fitAt(fy, u, bc, bOne) && !bOne && (fy - by).norm() <= params_.maxLineDistance * hc) {
          handOver = !nearPlaced(fy, bt, step);
          if (handOver) by = fy;
        }
        branch.pts.push_back(by);
        all_.push_back(by);
        bt = by;
        if (handOver) break;
      }
      if (branch.pts.empty()) continue;
      runs_.push_back(std::move(branch));
      if (handOver) {
        const Eigen::Vector3d bd = bc.direction.dot(u) < 0 ? -bc.direction : bc.direction;
        jobs_.push_back({runs_.size() - 1, true, bt, bd, step});
      }
    }
  }

  /// A lone sample of the input runs that nothing was traced from (its crease fit fails, or it leads at once
  /// into samples placed already), within one chain step of another chain's sample and within maxLineDistance
  /// (local) spacings of that chain's line there (the line through the sample's two neighbours), is a stray: a
  /// chain piece on a crease another chain (or its trace) holds, snapped onto a fit biased by a nearby corner
  /// (fandisk: 0.18 output spacings off the crease, 0.1–0.7 h off the other chain's line). It is dropped: the
  /// crease is held without it. A lone sample off that line (on another crease leaving a corner) stays.
  std::vector<char> strays() const {
    std::vector<char> stray(runs_.size(), 0);
    for (std::size_t r = 0; r < inputRuns_ && typicalStep_ > 0; ++r) {
      const Run& run = runs_[r];
      if (run.pts.size() != 1 || !run.front.empty() || tracedFrom_[r]) continue;
      double nearest = 1e300, lateral = 1e300;
      for (std::size_t s = 0; s < runs_.size(); ++s) {
        // Against samples that stay: another chain's run of several samples or one traced from.
        if (runs_[s].chain == run.chain || (runs_[s].pts.size() + runs_[s].front.size() < 2 && !tracedFrom_[s]))
          continue;
        // The other run's samples in order (front reversed, then pts).
        std::vector<Eigen::Vector3d> seq(runs_[s].front.rbegin(), runs_[s].front.rend());
        seq.insert(seq.end(), runs_[s].pts.begin(), runs_[s].pts.end());
        for (std::size_t k = 0; k < seq.size(); ++k) {
          const double d = (seq[k] - run.pts[0]).norm();
          if (d >= nearest) continue;
          nearest = d;
          const Eigen::Vector3d dir = (seq[std::min(k + 1, seq.size() - 1)] - seq[k > 0 ? k - 1 : 0]).normalized();
          const Eigen::Vector3d off = run.pts[0] - seq[k];
          lateral = (off - dir * off.dot(dir)).norm();
        }
      }
      stray[r] = nearest < typicalStep_ && lateral <= params_.maxLineDistance * localSpacing(index_, run.pts[0], h_);
    }
    return stray;
  }

  /// The runs but the strays, each in order (front reversed, then pts), with their chains.
  void write(const std::vector<char>& stray, std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) const {
    out.clear();
    owner.clear();
    for (std::size_t r = 0; r < runs_.size(); ++r) {
      const Run& run = runs_[r];
      if (stray[r]) continue;
      for (std::size_t t = run.front.size(); t-- > 0;) out.push_back(run.front[t]), owner.push_back(run.chain);
      for (const auto& q : run.pts) out.push_back(q), owner.push_back(run.chain);
    }
  }

  const PointCloud& cloud_;
  const KnnIndex& index_;
  const double h_;
  const FeatureParams& params_;
  const double cosTurn_;
  std::vector<Run> runs_;
  std::vector<Job> jobs_;  ///< grows while traced: corners' branches
  std::uint32_t nextChain_ = 0;
  double typicalStep_ = 0;
  std::vector<Eigen::Vector3d> all_;
  std::size_t budget_ = 0;
  std::size_t inputRuns_ = 0;
  std::vector<char> tracedFrom_;  ///< a job of the run added a sample or a corner's branch
  double hl_ = 0;                 ///< the local spacing at the last fit (fitAt)
  std::vector<std::uint32_t> idx_, behind_, ahead_;
  std::vector<double> d2_;
};

}  // namespace

void traceChainEnds(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                    std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
  CreaseTracer(cloud, index, h, params).run(out, owner);
}
}  // namespace iires::detail
