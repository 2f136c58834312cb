// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file preprocess.hpp
/// @brief The paper's pre-processing in one call (§3.1): outliers (eq. 4–5), then MLS denoising (eq. 1–3).

#include <string>

#include "iires/denoise.hpp"
#include "iires/execution.hpp"
#include "iires/outliers.hpp"
#include "iires/sheets.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Parameters of preprocess().
struct PreprocessParams {
  OutlierParams outliers;  ///< mode pull | remove | keep (`--outliers`)
  DenoiseParams denoise;   ///< MLS projection sweeps
  bool runDenoise = true;  ///< false: outliers only (`--no-denoise`)
  /// Denoising stops after its first sweep when that sweep moved points by less than this many input spacings
  /// on average: the input is clean, and smoothing it further would only erode tight curvature. Overrides
  /// denoise.cleanDisplacement (whose default, 0, is off for denoise() on its own).
  double cleanDisplacement = 0.07;
  /// Sheet rule (sheets.hpp): both stages take their neighbours on the point's own sheet only, so sheets a few
  /// spacings apart (thin parts, near contact) are not pulled together; an input without normals gets normals
  /// estimated and oriented over the same-sheet graph first. false = straight-line neighbourhoods.
  bool sheets = true;
  SheetParams sheet;       ///< tolerances of the sheet rule

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief The cleaned cloud and what each stage did.
struct PreprocessResult {
  PointCloud cloud;             ///< pull/keep: input size and order; remove: outliers dropped
  std::size_t inputPoints = 0;  ///< points given
  std::size_t outputPoints = 0;  ///< points returned (fewer than given only with outliers removed)
  std::size_t outliersFound = 0, outliersPulled = 0, outliersRemoved = 0;
  int denoiseIterations = 0;    ///< 0 when denoising was skipped or found the input clean
  bool cleanInput = false;      ///< the first sweep's probe found no noise to remove (positions kept)
  double meanDisplacement = 0;  ///< mean move of the denoising sweeps, input units
  double outlierSeconds = 0, denoiseSeconds = 0, seconds = 0;  ///< wall times
  SheetReport sheets;           ///< what the sheet rule found (all zero when it did not run here)
  /// without a table: the input's normals did not describe its surface and were estimated instead
  /// (givenNormalsDescribeSurface())
  bool givenNormalsReplaced = false;

  /// @brief The report as a one-line JSON object (keys as the fields, snake_case).
  std::string toJson() const;
  /// @brief The output's positions are the input's (no outlier found, no denoising sweep applied).
  bool positionsKept() const { return outliersFound == 0 && denoiseIterations == 0; }
};

/// @brief Neighbours per point that preprocess() reads from a NeighbourTable (the point itself included).
std::size_t preprocessNeighbours(const PreprocessParams& params);

/// @brief processOutliers() then (unless runDenoise is false) denoise() on its output.
/// @throws InputError for an unusable cloud (empty, NaN/Inf, fewer points than the stages need);
/// std::invalid_argument for bad parameters.
/// @param table (optional) neighbour lists of exactly input.points with k ≥ preprocessNeighbours(params),
/// borrowed, already filtered by the sheet rule when params.sheets (and then input has its normals);
/// without it preprocess() finds them itself (once for both stages) and applies the rule
/// @note O(n k log n). Deterministic for any thread count.
PreprocessResult preprocess(const PointCloud& input, const PreprocessParams& params = {}, const Execution& exec = {},
                            const NeighbourTable* table = nullptr);

}  // namespace iires
