// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file cell_layers.hpp
/// @brief Voxel thinning's intrinsic control: which cells of the thinning grid lie near two sheets.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "iires/detail/radix_sort.hpp"

namespace iires::detail {

/// Per run of @p byCell (a cell and normal class, sorted by key = cell key × 8 + class; @p runs: where each run
/// starts, then n): whether it lies in a block of 3 × 3 × 3 cells (one about every other cell of the grid) whose
/// points form two layers (layers.hpp) at least @p gap apart, each holding a fair share of them — two sheets
/// within about a cell of each other, all of whose points thinning keeps. Testing a cell alone sees the second
/// sheet only where the grid happens to put both in one cell; thinning the rest leaves the gap narrower, in the
/// thinned cloud's spacings, than the sheet rule resolves.
/// @param lo, shift, cell the grid: cell coordinates are ⌊(p − lo) / cell + shift⌋
/// @param spacing the input spacing (the layers' thinness is measured in it)
/// @note Deterministic for any thread count.
std::vector<char> twoSheetCells(const std::vector<Eigen::Vector3d>& pts, const std::vector<KeyedIndex>& byCell,
                                const std::vector<std::size_t>& runs, const Eigen::Vector3d& lo,
                                const Eigen::Vector3d& shift, double cell, double gap, double spacing, int threads);

}  // namespace iires::detail
