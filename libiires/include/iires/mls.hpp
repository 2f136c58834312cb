// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file mls.hpp
/// @brief The moving-least-squares surface of a dense cloud: the surface every resampled point lies on.

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <vector>

#include "iires/execution.hpp"
#include "iires/knn.hpp"

namespace iires {

struct MlsParams {
  int k = 16;           ///< neighbours in each local fit (paper: 8 for the weights' kernel width)
  int degree = 2;       ///< 1 = weighted tangent plane (paper eq. 1–3), 2 = plane + quadric height field
  int iterations = 2;   ///< projection steps per query (each re-centres the fit on the last estimate)
  /// Sheet rule (sheets.hpp, acrossGap) in every fit: input points on a near-parallel sheet at least sheetGap
  /// local spacings off the query's get no weight (0 = off: the normals' sign test only).
  double sheetGap = 1.25;
  /// > 0: each neighbour's weight is also multiplied by exp(−|n_j − n|²/σ²), n the normal the sign test compares
  /// with (the hint or the nearest input point's at the first step, then the estimate's; robust implicit MLS,
  /// Öztireli et al. 2009): a fit near a crease follows the query's own sheet and does not round the crease off.
  /// 0 = off (the normals' sign test only). `--sharp-edges` sets 0.5 unless given.
  double normalSigma = 0.0;
};

/// @brief The input neighbourhood of a previous projection, kept by a caller that projects the same moving
/// point again and again (a sample during relaxation): project() reuses it while the query stays within a
/// quarter kernel width of where it was gathered, and refreshes it otherwise.
struct MlsCache {
  std::vector<std::uint32_t> indices;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double h = 0;  ///< kernel width there; 0 = empty
};

/// @brief Projection onto the MLS surface of a cloud with oriented normals.
/// The kernel is θ(d) = exp(−d²/h²) (paper eq. 2) with h per input point = its distance to its 8th
/// neighbour, clamped to the 90th percentile so an outlier cannot inflate it (DESIGN §3.3) — times the point's
/// sampling scale when given (a separate object sampled more coarsely keeps its own widths). On scan lines
/// (a lidar's sampling: rows the table widened across the lines) the 8th entry of the point's row, and each
/// projection's neighbours include the nearest input point's row, so fits reach the next lines.
/// @note Holds a k-d tree over the input (or borrows @p index, a tree over exactly these points, which must
/// then outlive the surface); the cloud must outlive the surface. project() is thread-safe.
class MlsSurface {
 public:
  /// Neighbours per point (itself included) the kernel widths read: h = the distance to the 8th [paper].
  static constexpr std::size_t kWidthNeighbours = 9;

  /// @param table (optional) neighbour lists of exactly these points (k ≥ kWidthNeighbours), borrowed while
  /// constructing, to save the kernel widths' k-NN search
  /// @param nearSheets (optional) per point, 1 where the sheet rule found another sheet near (separateSheets):
  /// the sheet gate (MlsParams::sheetGap) applies only there; without it, everywhere
  /// @param samplingScale (optional) per point, how much more coarsely its part is sampled than the cloud
  /// (GeodesicCoordinates::samplingScales): the widths' clamp grows by it
  MlsSurface(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
             const MlsParams& params = {}, const Execution& exec = {}, const KnnIndex* index = nullptr,
             const NeighbourTable* table = nullptr, std::vector<std::uint8_t> nearSheets = {},
             const std::vector<float>* samplingScale = nullptr);
  ~MlsSurface();

  /// @brief Project @p x onto the surface. @p normal (optional) receives the surface normal there,
  /// oriented like the input normals. @p offSurface (optional) receives the distance from the projected
  /// point to the nearest input point divided by that point's kernel width: about ≤ 0.5 on the surface,
  /// growing past 1 where the point has left the cloud (across an open boundary).
  /// @p hint (optional) is the normal the caller expects there (e.g. the sample's normal before a small move):
  /// input points whose normals face away from it (another sheet: across a thin gap, between fingers) get no
  /// weight. Without a hint the nearest input point's normal is used.
  /// @p cache (optional) saves the k-NN search when the point was projected from nearby before.
  /// @p iterations (optional, > 0) overrides MlsParams::iterations: one step is enough for a point that was on
  /// the surface before a small move (a relaxation step), the full count for a point from anywhere.
  /// @p beyond (optional) receives how far the projected point lies outside the input's local extent: its
  /// distance to the convex hull of the input neighbours of the last step (those of its sheet), divided by their
  /// mean kernel width, the larger of the distances in the quadric's tangent plane and in the plane of the
  /// neighbours' averaged normal (which does not tilt where the quadric extrapolates past a rim) — 0 inside the
  /// cloud, even in a sampling hole, and growing from 0 right at an open boundary, where offSurface only measures
  /// the distance to the nearest input point.
  Eigen::Vector3d project(const Eigen::Vector3d& x, Eigen::Vector3d* normal = nullptr, double* offSurface = nullptr,
                          const Eigen::Vector3d* hint = nullptr, MlsCache* cache = nullptr, int iterations = 0,
                          double* beyond = nullptr) const;

  const KnnIndex& index() const { return *index_; }
  /// @brief Mean distance from an input point to its nearest neighbour (the input spacing).
  double meanSpacing() const { return meanSpacing_; }
  /// @brief The median kernel width: the distance to which the input resolves its surface (past its points the
  /// surface is known only to about that).
  double resolution() const { return resolution_; }
  /// @brief Estimated surface area: Σ over points of the area each represents (π r₈² / 8).
  double area() const { return area_; }
  /// @brief Kernel width h at input point i.
  double kernelWidth(std::size_t i) const { return h_[i]; }
  /// The area input point i stands for, over π/8: h² (its kernel width holds its 8 nearest); on a scan line, where
  /// the width reaches the next lines, h² times 8 over the points it holds.
  double pointArea(std::size_t i) const {
    return within_.empty() ? h_[i] * h_[i] : h_[i] * h_[i] * static_cast<double>(kWidthNeighbours - 1) / within_[i];
  }

 private:
  /// The constructor's part on scan lines: within_ and the rows of acrossStart_ / acrossRows_.
  void readScanLines(const NeighbourTable& table, int threads);

  const std::vector<Eigen::Vector3d>& points_;
  const std::vector<Eigen::Vector3d>& normals_;
  MlsParams params_;
  std::optional<KnnIndex> own_;
  const KnnIndex* index_;
  std::vector<double> h_;
  std::vector<std::uint8_t> nearSheets_;  // empty: the sheet gate everywhere
  // Points on scan lines (a row of the table widened across the lines): their rows, which every projection whose
  // nearest input point is one of them adds to its k nearest (all on that line); empty when no row was widened.
  std::vector<std::size_t> acrossStart_;
  std::vector<std::uint32_t> acrossRows_;
  std::vector<double> within_;  // points within each kernel width (8 off scan lines); empty when no row was widened
  double meanSpacing_ = 0;
  double resolution_ = 0;
  double area_ = 0;
};

}  // namespace iires
