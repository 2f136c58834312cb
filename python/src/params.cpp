// SPDX-License-Identifier: GPL-3.0-or-later
#include "params.hpp"

#include <pybind11/stl.h>

#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "iires/outliers.hpp"

namespace py = pybind11;

namespace iires::python {
namespace {

/// Whether @p value is an integer (Python int, numpy integer: anything with __index__).
bool hasIndex(const py::handle& value) { return py::hasattr(value, "__index__"); }

/// The keyword arguments of one call: take() reads and consumes a name, finish() rejects what is left.
class Kwargs {
 public:
  Kwargs(const py::dict& kwargs, const char* function) : kwargs_(kwargs), function_(function) {}

  template <class T>
  bool take(const char* name, T& out) {
    if (!kwargs_.contains(name)) return false;
    used_.insert(name);
    const py::handle value = kwargs_[name];
    if constexpr (std::is_same_v<T, bool>) {
      if (!py::isinstance<py::bool_>(value))
        throw py::type_error(std::string(name) + " must be True or False");
    } else if constexpr (std::is_integral_v<T>) {
      if (py::isinstance<py::bool_>(value) || !hasIndex(value))
        throw py::type_error(std::string(name) + " must be an integer");
      const long long v = py::module_::import("operator").attr("index")(value).cast<long long>();
      if (std::is_unsigned_v<T> && v < 0)
        throw py::value_error(std::string(name) + " must not be negative (got " + std::to_string(v) + ")");
    }
    try {
      out = value.cast<T>();
    } catch (const py::cast_error&) {
      throw py::type_error(std::string(name) + ": unexpected type " +
                           std::string(py::str(py::type::handle_of(value).attr("__name__"))));
    }
    return true;
  }

  void finish() const {
    for (const auto& item : kwargs_) {
      const std::string name = py::str(item.first);
      if (!used_.count(name)) throw py::type_error(function_ + "() got an unexpected keyword argument '" + name + "'");
    }
  }

 private:
  const py::dict& kwargs_;
  std::string function_;
  std::set<std::string> used_;
};

/// One of @p allowed, as the tools' CLI11 checks do.
void checkChoice(const char* name, const std::string& value, std::initializer_list<const char*> allowed) {
  std::string list;
  for (const char* a : allowed) {
    if (value == a) return;
    list += (list.empty() ? "'" : ", '") + std::string(a) + "'";
  }
  throw py::value_error(std::string(name) + " must be one of " + list + " (got '" + value + "')");
}

/// The threads keyword, into @p exec (0 = all cores).
void takeThreads(Kwargs& args, Execution& exec) {
  args.take("threads", exec.threads);
  if (exec.threads < 0) throw py::value_error("threads must be >= 0 (0 = all cores)");
}

}  // namespace

ResampleParams resampleParams(const py::dict& kwargs, Execution& exec) {
  Kwargs args(kwargs, "resample");
  ResampleParams params;
  std::string mode = "isotropic", outliers = "pull";
  int levels = 0;
  std::vector<double> ratios;
  bool noDenoise = false, noIntrinsic = false;
  args.take("mode", mode);
  checkChoice("mode", mode, {"isotropic", "curvature"});
  args.take("levels", levels);
  args.take("ratios", ratios);
  args.take("sharp_edges", params.sharpEdges);
  args.take("edge_ratio", params.edgeRatio);
  args.take("outliers", outliers);
  checkChoice("outliers", outliers, {"pull", "remove", "keep"});
  args.take("no_denoise", noDenoise);
  args.take("no_intrinsic", noIntrinsic);
  args.take("input_per_sample", params.maxInputPerSample);
  args.take("seed", params.seed);
  takeThreads(args, exec);
  args.finish();
  if (!(params.edgeRatio > 0)) throw py::value_error("edge_ratio must be positive");
  params.preprocessing.outliers.mode = parseOutlierMode(outliers);
  params.preprocessing.runDenoise = !noDenoise;
  params.intrinsic = !noIntrinsic;
  if (mode == "curvature") {
    params.mode = ResampleMode::kCurvature;
    if (!ratios.empty()) {
      params.curvature.ratios = ratios;
    } else if (levels != 0) {  // iires-resample's --levels: a geometric ramp from 2 (flattest) to 0.6 (most curved)
      if (levels < 2 || levels > 16) throw py::value_error("levels must be in [2, 16] (got " + std::to_string(levels) + ")");
      params.curvature.ratios.clear();
      for (int q = 0; q < levels; ++q) params.curvature.ratios.push_back(2.0 * std::pow(0.3, q / (levels - 1.0)));
    }
  } else if (levels != 0 || !ratios.empty()) {
    throw py::value_error("levels and ratios need mode='curvature'");
  }
  return params;
}

reg::RegistrationParams registrationParams(const py::dict& kwargs, Execution& exec) {
  Kwargs args(kwargs, "register");
  reg::RegistrationParams params;
  long long samples = static_cast<long long>(params.samples);
  std::string grid = "so3";
  bool noScale = false, fullResample = false;
  args.take("samples", samples);
  args.take("m", samples);
  args.take("grid", grid);
  checkChoice("grid", grid, {"so3", "euler"});
  const bool overlapGiven = args.take("overlap", params.overlap);  // not given: estimated (0)
  args.take("no_scale", noScale);
  args.take("full_resample", fullResample);
  args.take("seed", params.seed);
  takeThreads(args, exec);
  args.finish();
  if (samples < 50) throw py::value_error("samples must be at least 50 (got " + std::to_string(samples) + ")");
  if (overlapGiven && !(params.overlap > 0.0 && params.overlap <= 1.0))
    throw py::value_error("overlap must be in (0, 1] (got " + std::to_string(params.overlap) + ")");
  params.samples = static_cast<std::size_t>(samples);
  params.grid = reg::parseRotationGridType(grid);
  params.estimateScale = !noScale;
  if (fullResample) params.resample = ResampleParams{};
  return params;
}

ReconstructParams reconstructParams(const py::dict& kwargs, Execution& exec) {
  Kwargs args(kwargs, "reconstruct");
  ReconstructParams params;
  std::string method = "local";
  bool noResample = false, noHoles = false;
  args.take("method", method);
  checkChoice("method", method, {"local", "advancing-front"});
  args.take("no_resample", noResample);
  args.take("no_hole_filling", noHoles);
  args.take("max_hole_edges", params.holes.maxEdges);
  args.take("max_hole_extent", params.holes.maxRefinedExtent);
  args.take("seed", params.seed);
  takeThreads(args, exec);
  args.finish();
  if (!(params.holes.maxRefinedExtent >= 0 && params.holes.maxRefinedExtent <= 1))
    throw py::value_error("max_hole_extent must be in [0, 1]");
  params.method = parseReconstructMethod(method);
  params.resample = !noResample;
  params.fillHoles = !noHoles;
  return params;
}

MeshQualityParams meshQualityParams(const py::dict& kwargs, Execution& exec) {
  Kwargs args(kwargs, "mesh_quality");
  MeshQualityParams params;
  std::uint64_t seed = 0;
  args.take("seed", seed);
  takeThreads(args, exec);
  args.finish();
  params.seed = seed + 1;  // as iires-reconstruct --quality-only
  return params;
}

}  // namespace iires::python
