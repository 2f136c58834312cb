#!/bin/sh
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Thin parts and near-contact surfaces (issue 19)
# about: `bench/run_thin_parts.sh quick|full`: generated cases (tests/shapes.hpp, seed 19), positions only, resampled
# about: with the library's defaults; off_sheet = output points farther than 0.1·gap from the truth (fold and rim
# about: excepted), share_err_pct = one side's share of the points against its share of the area.
# columns: case input gap_spacings noise_spacings N off_sheet max_dist_per_gap share_err_pct cv components time_s status
# Thin parts and near-contact surfaces (issue 19): generated cases (tests/shapes.hpp, seed 19), positions only,
# resampled with the library's defaults (the CLI's). Usage: bench/run_thin_parts.sh [quick|full]
# (env BUILD, default build-bench: a build with -DIIRES_BUILD_BENCH=ON). One key=value line per (case, input, gap, noise, N), and one per
# --denoise-only run (mode=denoise-only):
#   case            folded-sheets | plate | two-spheres | nested-spheres
#   input           input points;  gap_spacings / noise_spacings: gap and Gaussian noise σ in input spacings
#   N, points       requested and written points;  time_s: wall time of resample();  working: working-cloud points
#   status          failed when the resampling threw (error: its message); absent otherwise
#   off_sheet / of  output points farther than 0.1·gap from the truth / points on the near parts (fold and rim
#                   excepted);  max_dist_per_gap, mean_dist_per_gap: distance to the truth over the gap
#   side0, side1    points on either near surface;  share_err_pct: side 1's share against its share of the area
#   cv              nearest-neighbour spacing cv, each near surface among its own points
#   components      connected components found;  clean, sweeps: the clean-input probe and denoising sweeps
#   out_spacing_per_gap  mean output spacing over the gap
#   sheets_near, sheets_zones, sheets_s  the sheet rule on the working cloud: points with another sheet near,
#                   near-contact zones, seconds
#   (denoise-only)  mean_dist_per_gap of the cleaned input, input_mean_dist_per_gap of the raw one
cd "$(dirname "$0")/.."
B=${BUILD:-build-bench}/bin/thin_parts_bench
export THIN_PARTS_NO_DENOISE_ONLY=1
for g in 2.5 3 4 6; do
  for noise in 0 0.2; do
    "$B" sheets 100000 $g $noise 500 2000 20000
  done
done
"$B" sheets 500000 2.5 0 1000
"$B" plate 100000 3 0 2000
"$B" spheres 100000 2.5 0 2000
"$B" nested 100000 3 0 2000
unset THIN_PARTS_NO_DENOISE_ONLY
"$B" sheets 50000 2.5 0.2  # the --denoise-only line only
