// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/preprocess.hpp"

#include "iires/detail/json.hpp"
#include "iires/normals.hpp"

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>


namespace iires {

void PreprocessParams::validate() const {
  if (!(cleanDisplacement >= 0)) throw std::invalid_argument("PreprocessParams: cleanDisplacement must be >= 0");
  if (sheets) sheet.validate();
  outliers.validate();
  if (runDenoise) denoise.validate();
}

std::string PreprocessResult::toJson() const {
  detail::JsonWriter j;
  j.beginObject().member("input_points", inputPoints).member("output_points", outputPoints);
  j.member("outliers_found", outliersFound).member("outliers_pulled", outliersPulled);
  j.member("outliers_removed", outliersRemoved).member("denoise_iterations", denoiseIterations);
  j.member("clean_input", cleanInput).member("mean_displacement", meanDisplacement);
  j.member("given_normals_replaced", givenNormalsReplaced);
  j.member("outlier_time_s", outlierSeconds).member("denoise_time_s", denoiseSeconds).member("time_s", seconds);
  j.key("sheets").embed(sheets.toJson());
  return j.endObject().str();
}

std::size_t preprocessNeighbours(const PreprocessParams& params) {
  const std::size_t k = outlierNeighbours(params.outliers);
  return params.runDenoise ? std::max(k, denoiseNeighbours(params.denoise)) : k;
}

PreprocessResult preprocess(const PointCloud& input, const PreprocessParams& params, const Execution& exec,
                            const NeighbourTable* table) {
  params.validate();
  const auto start = std::chrono::steady_clock::now();
  DenoiseParams dp = params.denoise;
  const SheetParams& sp = params.sheet;

  PreprocessResult result;
  result.inputPoints = input.size();
  // One k-NN search for both stages, unless the outlier stage moved or removed points. Without a table the
  // sheet rule runs here: it filters the table and gives the input normals (the denoising's bilateral term
  // then reads them oriented), so both stages see each point's own sheet only.
  std::optional<KnnIndex> index;
  std::optional<NeighbourTable> own;
  std::optional<PointCloud> withNormals;
  const PointCloud* cloud = &input;
  if (!table) {
    if (input.empty()) throw InputError("preprocess: the cloud is empty");
    index.emplace(input.points);
    table = &own.emplace(*index, input.points, preprocessNeighbours(params), exec.threads);
    // Given normals that do not describe the points' surface are estimated like absent ones (as in resample()).
    result.givenNormalsReplaced =
        input.hasNormals() && !givenNormalsDescribeSurface(input.points, input.normals, *own, exec.threads);
    const bool given = input.hasNormals() && !result.givenNormalsReplaced;
    if (params.sheets && input.size() > static_cast<std::size_t>(sp.pcaNeighbours)) {
      withNormals.emplace();
      withNormals->points = input.points;
      result.sheets = separateSheets(input.points, *own, withNormals->normals, sp, exec,
                                     given ? &input.normals : nullptr);
      // the rule's estimates give way to the denoiser's fits (as in resample())
      dp.keepGivenNormals = dp.keepGivenNormals && given;
      cloud = &*withNormals;
    } else if (result.givenNormalsReplaced) {
      withNormals.emplace(input);
      withNormals->normals.clear();
      cloud = &*withNormals;
    }
  }
  OutlierResult outliers = processOutliers(*cloud, params.outliers, exec, table);  // eq. (4)–(5)
  // Pulled or kept outliers leave the indices as they were: the table still serves the denoising (only the
  // pulled points' own rows are out of date). Removed ones renumber the points: a new table, filtered again.
  const bool sameIndices = outliers.cloud.size() == cloud->size();
  result.outliersFound = outliers.found;
  result.outliersPulled = outliers.pulled;
  result.outliersRemoved = outliers.removed;
  result.outlierSeconds = outliers.seconds;
  // Denoising needs k + 1 points; removed outliers can leave fewer in a tiny cloud, which then stays as it is.
  if (params.runDenoise && outliers.cloud.size() > static_cast<std::size_t>(dp.neighbours)) {
    // eq. (1)–(3). The first sweep doubles as a noise probe: when it moves points by less than
    // cleanDisplacement input spacings on average, the cloud is already clean and further sweeps would only
    // erode tight curvature (folds, thin parts, sparse clouds) — denoise() keeps the positions then.
    dp.cleanDisplacement = params.cleanDisplacement;
    std::optional<KnnIndex> renumbered;
    std::optional<NeighbourTable> renumberedTable;
    const NeighbourTable* denoiseTable = sameIndices && (outliers.found == 0 || params.sheets) ? table : nullptr;
    if (!denoiseTable && params.sheets && outliers.cloud.hasNormals() &&
        outliers.cloud.size() > static_cast<std::size_t>(sp.pcaNeighbours)) {
      renumbered.emplace(outliers.cloud.points);
      denoiseTable = &renumberedTable.emplace(*renumbered, outliers.cloud.points, preprocessNeighbours(params),
                                              exec.threads);
      std::vector<Eigen::Vector3d> normals;
      separateSheets(outliers.cloud.points, *renumberedTable, normals, sp, exec, &outliers.cloud.normals);
    }
    DenoiseResult denoised = denoise(outliers.cloud, dp, exec, denoiseTable);
    result.denoiseSeconds = denoised.seconds;
    result.cleanInput = denoised.cleanInput;
    result.denoiseIterations = denoised.iterations;
    result.meanDisplacement = denoised.meanDisplacement;
    result.cloud = std::move(denoised.cloud);
  } else {
    result.cloud = std::move(outliers.cloud);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.outputPoints = result.cloud.size();
  return result;
}

}  // namespace iires
