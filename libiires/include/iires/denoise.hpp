// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file denoise.hpp
/// @brief MLS projection denoising (paper §3.1, eq. 1–3; DESIGN §3 step 3).

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "iires/execution.hpp"
#include "iires/knn.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief The MLS kernel θ(d) = exp(−d²/h²) (paper eq. 2).
inline double mlsKernel(double distance, double h) { return std::exp(-(distance * distance) / (h * h)); }

/// @brief A weighted local plane: the point a(p) it passes through and its unit normal n_a.
struct MlsPlane {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();   ///< a(p), the θ-weighted average (eq. 1)
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< n_a, smallest-eigenvalue direction of the fit
  double weightSum = 0;                               ///< Σ θ_j (0: no neighbour)
};

/// @brief Fit the MLS plane of eq. 1–2 at @p p from the points @p neighbours (indices into @p points).
/// @param h kernel width (> 0)
/// @param normals optional per-point normals: with @p sharpness > 0 each weight is multiplied by the
/// bilateral term exp(−(1 − n_j·n_p)² / sharpness²) where n_p = @p pointNormal; the fitted normal is
/// oriented to agree with @p pointNormal when that is non-zero.
/// @param normalH kernel width of the covariance whose smallest eigenvector is n_a (0 = @p h); a wider one
/// steadies n_a when few points carry most of the θ weight.
/// @note O(|neighbours|). Thread-safe.
MlsPlane fitMlsPlane(const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& points,
                     const std::uint32_t* neighbours, std::size_t count, double h,
                     const std::vector<Eigen::Vector3d>* normals = nullptr,
                     const Eigen::Vector3d& pointNormal = Eigen::Vector3d::Zero(), double sharpness = 0.0,
                     double normalH = 0.0);

/// @brief Eq. (3): move @p p along the plane normal onto the plane, p' = p + n_a n_aᵀ (a − p).
inline Eigen::Vector3d projectOntoPlane(const Eigen::Vector3d& p, const MlsPlane& plane) {
  return p + plane.normal * plane.normal.dot(plane.centre - p);
}

/// @brief Parameters of denoise(). Defaults in brackets are the paper's where it gives one.
struct DenoiseParams {
  /// k nearest neighbours (the point itself included) in each local fit. The paper uses 8; with θ's h from
  /// the 8th neighbour, 24 leaves the kernel unchanged but feeds the quadric (degree 2) enough points —
  /// on bunny00, 100k points, ±0.66·l noise: mean error 0.132·l with 8 (plane), 0.115·l with 24 (quadric).
  int neighbours = 24;
  /// h_i = distance from point i to its kernelNeighbour-th neighbour [8]; noise as wide as that kernel (a first
  /// sweep moving the points by over a fifth of it) restarts the sweeps with 4× the neighbours (at most 64)
  int kernelNeighbour = 8;
  double kernelQuantile = 0.9;  ///< h is clamped to this quantile of all h_i, so outliers cannot inflate it
  int iterations = 3;  ///< projection sweeps (Jacobi: each sweep reads the previous sweep's positions)
  /// 1 = the paper's plane (eq. 3): p moves along n_a onto the plane through a(p);
  /// 2 = the same move along n_a, onto a θ-weighted quadric height field over that plane, which removes the
  /// plane's shrinkage on curved parts (≈ κh²/4 per sweep) so sweeps do not erode the shape (noise-free
  /// bunny00, 100k points, 3 sweeps of 16 neighbours: error 0.077·l with the plane, 0.010·l with the
  /// quadric). The quadric's height at p has several times the plane's variance, so the move onto it is shrunk
  /// towards the plane by how far its lift stands out of the noise (empirical Bayes; denoise()).
  int degree = 2;
  /// Bilateral normal term, so a fit does not average across a sharp edge: every weight of the sweep is
  /// multiplied by exp(−(1 − |n_j·n_p|)² / σ²) with σ = 1 − cos(sharpnessAngle) in the covariance's wide
  /// kernel, and as θ_j = wide_j⁴ that makes σ/2 (≈ 31° here) in the centre's and the quadric's weights.
  /// Normals: the given ones in the first sweep, then each sweep's fitted ones. With given (oriented) normals the
  /// term reads the signed n_j·n_p, so a neighbour facing the other way (another sheet across a gap thinner than
  /// the kernel, e.g. between fingers) gets no weight instead of pulling the two sheets together; without, |n_j·n_p|.
  /// In degrees, in (0, 90]; 0 switches the term off. 45: fandisk (100k points, noise 0.33·l) error within 2·l of the sharp edges 3.95 → 2.75
  /// ×10⁻⁴ diagonal (CGAL bilateral 3.08), mean error 2.00 → 1.85; bunny00 1.70 → 1.71.
  double sharpnessAngle = 45.0;
  /// The bilateral term's angle in the sweeps after the first (0 = sharpnessAngle's), which run only on an input the
  /// first found noisy; the first sweep, which probes the noise and gives a clean input its normals, keeps
  /// sharpnessAngle. resample() with sharp edges sets the feature angle here (FeatureParams::angle): the normals
  /// estimated across a crease blend its faces', and at 45° the faces of a 30° crease keep 43 % of their weight in
  /// each other's fits, so the sweeps round off the creases the feature stage is to hold.
  double laterSharpnessAngle = 0.0;
  /// Noise probe: when the first sweep's fits (the quadric's in full, before its shrinkage) lie less than this many
  /// input spacings (mean distance to the nearest neighbour) from the points on average, the input is already
  /// clean; its positions are kept (the fitted normals are still returned) and no further sweep runs, since
  /// smoothing a clean cloud only erodes tight curvature. 0 = off.
  double cleanDisplacement = 0.0;
  /// Normals given with the input are data: a clean input (see cleanDisplacement) keeps them as given. false:
  /// they were estimates (the sheet rule's PCA over 16 neighbours): a probe sweep without the bilateral term
  /// decides whether to trust their sign. Below 0.3 spacings moved the sweeps read them as given ones (and a
  /// clean input returns the fits oriented like them); above, where noise flips an estimate's sign in places,
  /// the sweeps go on from the probe as without normals.
  bool keepGivenNormals = true;
  bool orientNormals = true;  ///< input without normals: orient the fitted normals (MST over the k-NN graph)
  int orientNeighbours = 8;   ///< k of the k-NN graph the orientation propagates over (≤ neighbours)

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief What denoise() produced.
struct DenoiseResult {
  PointCloud cloud;             ///< same size and order as the input, with unit normals from the fit
  int iterations = 0;           ///< sweeps whose moves were kept (0 when the noise probe found the input clean)
  bool cleanInput = false;      ///< the noise probe found the input clean (positions kept)
  double meanDisplacement = 0;  ///< mean |p_out − p_in|, input units
  double maxDisplacement = 0;   ///< max |p_out − p_in|
  double kernelWidth = 0;       ///< median h over the points (input units)
  double neighbourSeconds = 0;  ///< wall time of the k-NN search (once, on the input)
  double sweepSeconds = 0;      ///< wall time of the projection sweeps
  double orientSeconds = 0;     ///< wall time of the normal orientation (0 when normals were given)
  double seconds = 0;           ///< wall time, all stages
};

/// @brief Neighbours per point denoise() finds (the point itself included): what a table must hold.
std::size_t denoiseNeighbours(const DenoiseParams& params);

/// @brief Denoise a cloud by repeated projection onto its MLS surface (paper eq. 1–3).
///
/// For each point p with neighbours p_j (its k nearest, itself included, found once on the input):
/// θ_j = exp(−|p_j − p|² / h²) (eq. 2, h = the robust kernel width of p), a(p) = Σ θ_j p_j / Σ θ_j (eq. 1),
/// n_a = the eigenvector of the smallest eigenvalue of the weighted covariance around a (weights with width
/// 2h, for a steady normal), and p' = p + n_a n_aᵀ (a(p) − p) (eq. 3): the point moves along n_a only, onto
/// the local weighted plane (degree 1) or towards the θ-weighted quadric height field over it (degree 2), by the
/// share b²/(b² + c σ² v) of the quadric's lift d above the plane: σ² the median residual variance of the fits,
/// σ² v the lift's variance, b² ≈ d² − σ² v its squared bias averaged over the neighbours, c the share of the
/// sweep's noise variance the later sweeps let through (σ² = 0 keeps the full quadric).
/// The normals of the output come out of the last sweep's fit (n_a, or the quadric's normal at p'),
/// oriented like the input normals when given, else by minimum-spanning-tree propagation over the k-NN graph
/// already found (orientNormals()). Internally the points are processed in Morton order (cache locality).
/// @throws InputError when the cloud is empty, holds NaN/Inf, or has fewer than neighbours + 1 points;
/// std::invalid_argument for bad parameters.
/// @param table (optional) neighbour lists of exactly input.points with k ≥ denoiseNeighbours(params),
/// borrowed, to save the neighbour search
/// @note O(n k log n) for the neighbour search plus O(n k) per sweep. Deterministic: every sweep reads the
/// previous positions only, so the output does not depend on the thread count.
DenoiseResult denoise(const PointCloud& input, const DenoiseParams& params = {}, const Execution& exec = {},
                      const NeighbourTable* table = nullptr);

}  // namespace iires
