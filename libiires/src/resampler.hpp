// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The resampler's core (DESIGN §3 steps 7–8): the working sample set and the loop of relaxation, splits,
// collapses and elimination that brings it to exactly N isotropic (or size-graded) samples.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "iires/knn.hpp"
#include "iires/mls.hpp"
#include "iires/neighbourhood.hpp"
#include "iires/resample.hpp"

namespace iires::detail {

/// The working sample set S.
struct Samples {
  std::vector<Eigen::Vector3d> pos, nrm;
  std::vector<char> fixed;  // 0 free, kHeld (fixed samples, features) or kContext (ResampleParams::contextSamples)
  std::vector<MlsCache> cache;  // each sample's last MLS neighbourhood (saves most k-NN searches in relaxation)
  std::size_t size() const { return pos.size(); }
  static constexpr char kHeld = 1, kContext = 2;
  void add(const Eigen::Vector3d& p, const Eigen::Vector3d& n, char fixedKind, MlsCache c = {}) {
    pos.push_back(p);
    nrm.push_back(n);
    fixed.push_back(fixedKind);
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
  std::vector<std::uint32_t> candidates;  // per sample the stride + 1 nearest samples its ring was built from
  std::vector<char> open;                 // the sample's cell reaches its bounding disc (boundary, sparse region)
};

/// What one round of splits and collapses did to the sample indices.
struct EditMap {
  std::vector<std::uint32_t> newIndex;  // old index → new index, kNone for a removed sample
  std::vector<std::uint32_t> touched;   // old indices of removed samples, moved collapse ends and split ends
  std::size_t added = 0;                // split samples, appended after the kept ones
};

/// Lloyd relaxation state carried across iterations on one sample set (no splits or collapses in between).
struct Relaxation {
  std::optional<Rings> rings;  // the last iteration's rings
  std::vector<char> active;    // samples whose cell may have changed since (they or a ring neighbour moved)
  int sinceQuery = 0;          // iterations since the candidate lists came from a k-d tree
  std::vector<char> stale;     // samples whose candidate lists an edit made stale: queried anew next iteration
};

struct Edge {
  double length;  // in units of the local target size (s_a + s_b) / 2: the plain length in isotropic mode
  std::uint32_t a, b;
};

class Resampler {
 public:
  /// @param size per input point target-size factor (curvature mode), or null (isotropic)
  Resampler(const std::vector<Eigen::Vector3d>& pts, const std::vector<Eigen::Vector3d>& normals,
            const MlsSurface& surface, const ResampleParams& params, const Execution& exec, NeighbourRule& rule,
            const std::vector<double>* size)
      : pts_(pts), normals_(normals), surface_(surface), params_(params), exec_(exec), rule_(rule), size_(size) {}

  /// @p chosen: the input points to start from (initialCandidates()).
  Samples initialise(const std::vector<std::uint32_t>& chosen, ResampleResult& result);
  void run(Samples& s, ResampleResult& result);

 private:
  /// @p built (optional): a k-d tree over s.pos already at hand, used instead of building one.
  Rings computeRings(const Samples& s, double cellRadius, Relaxation* relaxation = nullptr,
                     bool requery = true, const KnnIndex* built = nullptr) const;
  /// The stride nearest samples to sample i in @p index that the rule accepts (i itself among them), nearest
  /// first.
  void acceptedNearest(const KnnIndex& index, const Samples& s, std::size_t i, std::size_t stride,
                       std::vector<std::uint32_t>& idx, std::vector<double>& d2) const;
  std::vector<Edge> edges(const Samples& s, const Rings& r) const;
  /// @p projectionSteps: MLS projection steps per move (0 = MlsParams::iterations).
  double relax(Samples& s, double l, int iterations, Relaxation& state, int projectionSteps = 0);
  EditMap splitAndCollapse(Samples& s, const std::vector<Edge>& sorted, std::size_t splits, double minSplit,
                           std::size_t collapses, double maxCollapse, ResampleResult& result);
  void carry(Relaxation& state, const EditMap& edits, std::size_t count) const;
  Rings edgeRings(const Samples& s, double l, const Relaxation& state) const;
  void eliminate(Samples& s, std::size_t count);
  std::size_t sparseDeficit(std::size_t count) const;
  void forceCount(Samples& s, Relaxation& relaxation);
  /// The neighbour rule's update after a change of the sample set (or a drift, see relax()).
  void updateRule(const Samples& s);
  /// The size of the sample set to reach: N plus the context samples (held, not counted in N).
  std::size_t total() const { return params_.targetCount + params_.contextSamples.size(); }

  const std::vector<Eigen::Vector3d>& pts_;
  const std::vector<Eigen::Vector3d>& normals_;
  const MlsSurface& surface_;
  const ResampleParams& params_;
  const Execution& exec_;
  NeighbourRule& rule_;
  const std::vector<double>* size_;
  std::vector<Eigen::Vector3d> rulePos_;  // the samples' positions at the rule's last update
};

/// The input points the initialisation starts from: about candidateFactor·N voxel cells' worth (all points of
/// a cloud not that much denser than the output).
std::vector<std::uint32_t> initialCandidates(const PointCloud& cloud, const MlsSurface& surface,
                                             const ResampleParams& params, int threads);

}  // namespace iires::detail
