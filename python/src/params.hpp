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
/// input_per_sample, seed, threads (targetCount is set by the caller).
ResampleParams resampleParams(const pybind11::dict& kwargs);

/// iires-register's flags: samples (or m), grid, overlap, no_scale, full_resample, seed, threads.
reg::RegistrationParams registrationParams(const pybind11::dict& kwargs);

/// iires-reconstruct's flags: method, no_resample, no_hole_filling, max_hole_edges, max_hole_extent, seed,
/// threads (targetCount is set by the caller).
ReconstructParams reconstructParams(const pybind11::dict& kwargs);

/// The quality report's settings: seed, threads.
MeshQualityParams meshQualityParams(const pybind11::dict& kwargs);

}  // namespace iires::python
