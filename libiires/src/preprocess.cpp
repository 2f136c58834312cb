#include "iires/preprocess.hpp"

#include <chrono>
#include <sstream>
#include <stdexcept>

namespace iires {

void PreprocessParams::validate() const {
  if (threads < 0) throw std::invalid_argument("PreprocessParams: threads must be >= 0 (0 = all cores)");
  outliers.validate();
  if (runDenoise) denoise.validate();
}

std::string PreprocessResult::toJson() const {
  std::ostringstream s;
  s.precision(10);
  s << "{\"input_points\": " << inputPoints << ", \"output_points\": " << outputPoints
    << ", \"outliers_found\": " << outliersFound << ", \"outliers_pulled\": " << outliersPulled
    << ", \"outliers_removed\": " << outliersRemoved << ", \"denoise_iterations\": " << denoiseIterations
    << ", \"mean_displacement\": " << meanDisplacement << ", \"outlier_time_s\": " << outlierSeconds
    << ", \"denoise_time_s\": " << denoiseSeconds << ", \"time_s\": " << seconds << "}";
  return s.str();
}

PreprocessResult preprocess(const PointCloud& input, const PreprocessParams& params) {
  params.validate();
  const auto start = std::chrono::steady_clock::now();
  OutlierParams op = params.outliers;
  DenoiseParams dp = params.denoise;
  if (params.threads > 0) op.threads = dp.threads = params.threads;

  PreprocessResult result;
  result.inputPoints = input.size();
  OutlierResult outliers = processOutliers(input, op);  // eq. (4)–(5)
  result.outliersFound = outliers.found;
  result.outliersPulled = outliers.pulled;
  result.outliersRemoved = outliers.removed;
  result.outlierSeconds = outliers.seconds;
  if (params.runDenoise) {
    DenoiseResult denoised = denoise(outliers.cloud, dp);  // eq. (1)–(3)
    result.cloud = std::move(denoised.cloud);
    result.denoiseIterations = denoised.iterations;
    result.meanDisplacement = denoised.meanDisplacement;
    result.denoiseSeconds = denoised.seconds;
  } else {
    result.cloud = std::move(outliers.cloud);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.outputPoints = result.cloud.size();
  return result;
}

}  // namespace iires
