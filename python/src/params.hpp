// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Keyword parameters of the Python functions → the libraries' Params structs. Names are the command-line
// flags with dashes as underscores (mode, sharp_edges, outliers, no_denoise, seed, threads, ...); an unknown
// name raises TypeError, a bad value ValueError with the tools' wording.
#include <pybind11/pybind11.h>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/reconstruct.hpp"
#include "iires/register/registration.hpp"
#include "iires/resample.hpp"

namespace iires::python {

/// iires-resample's flags: mode, levels, ratios, sharp_edges, edge_ratio, outliers, no_denoise, no_intrinsic,
/// input_per_sample, seed (targetCount is set by the caller); threads into @p exec.
ResampleParams resampleParams(const pybind11::dict& kwargs, Execution& exec);

/// iires-register's flags: samples (or m), grid, overlap, no_scale, full_resample, seed; threads into
/// @p exec.
reg::RegistrationParams registrationParams(const pybind11::dict& kwargs, Execution& exec);

/// iires-reconstruct's flags: method, no_resample, no_hole_filling, max_hole_edges, max_hole_extent, seed
/// (targetCount is set by the caller); threads into @p exec.
ReconstructParams reconstructParams(const pybind11::dict& kwargs, Execution& exec);

/// The quality report's settings: seed; threads into @p exec.
MeshQualityParams meshQualityParams(const pybind11::dict& kwargs, Execution& exec);

}  // namespace iires::python
