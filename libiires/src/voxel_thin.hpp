// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace iires::detail {

/// Voxel thinning (DESIGN §3.5): cells sized by secant steps on the cell size (from @p cell) so that about
/// @p target (−15 % to +20 %) are occupied; per cell the point nearest its centre, indices ascending. With
/// normals, the normal's dominant signed axis is part of the cell key, so facing sheets of a thin part that
/// share a cell (a gap narrower than the cell) each keep a point.
/// @param sheetHeight > 0 (with normals): per cell one point per sheet — the cell's points off the planes of
/// the points picked so far by more than this (another sheet a gap away, e.g. facing the same way) are picked
/// too, nearest the centre first
/// @param layerGap > 0: a cell in a block of cells whose points form two layers at least this many input
/// spacings apart (the sheet rule's layer test; cell_layers.hpp) lies near two sheets: all of its points are kept
std::vector<std::uint32_t> voxelThin(const std::vector<Eigen::Vector3d>& pts, const std::vector<Eigen::Vector3d>& normals,
                                     std::size_t target, double cell, std::uint64_t seed, int threads,
                                     double sheetHeight = 0, double layerGap = 0);

}  // namespace iires::detail
