#!/bin/sh
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Scanner samplings: scan lines and rings
# about: `bench/run_scan_lines.sh quick|full`: `scan_line_bench CASE N ... [--mesh]` — generated scanner samplings
# about: (tests/shapes.hpp), positions only, resampled (and meshed) with the library's defaults: lines = 50
# about: parallel lines 0.02 apart, points 0.002 apart along them (25k points); rings = a rotating scanner's rings
# about: on the ground, 0.15 apart near the sensor and 1.1 apart at the outer ones (20.4k points); slices:M = a
# about: profile scanner's 60 slices of corpus mesh M (contours, points a tenth of the slices' distance apart);
# about: floor = a floor seen from one scanner above its corner (60k points, 14 times more sparsely spaced at the
# about: far corner than at the median). cv = spacing cv;
# about: components = parts found (truth 1); outer_share_err = the share of the points beyond radius 7 against
# about: that band's share of the area (%); mesh rows: mesh_parts, q_avg, q_min, lt30 (% of angles under 30°).
# columns: case seed input N points cv components mesh_parts q_avg q_min lt30 outer_share_err time_s status
# quick: seed 1, one count per case; full: seeds 1–3 and several counts, meshes too, the slices of four models
# (meshed at 3000 too) and the floor.
cd "$(dirname "$0")/.."
B=${BUILD:-build-bench}/bin/scan_line_bench
if [ "${1:-quick}" = full ]; then
  for seed in 1 2 3; do
    "$B" lines 2000 5000 10000 --seed $seed --threads 2
    "$B" lines 5000 --mesh --seed $seed --threads 2
    "$B" rings 2000 5000 10000 --seed $seed --threads 2
    "$B" rings 2000 --mesh --seed $seed --threads 2
  done
  for m in bunny00 armadillo hand fandisk; do
    "$B" "slices:datasets/cache/meshes/$m.off" 3000 10000 --threads 2
    "$B" "slices:datasets/cache/meshes/$m.off" 3000 --mesh --threads 2
  done
  "$B" floor 5000 10000 20000 --seed 5 --threads 2
else
  "$B" lines 10000 --threads 2
  "$B" rings 2000 --threads 2
fi
