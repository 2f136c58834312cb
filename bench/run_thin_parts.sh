#!/bin/sh
# Thin parts and near-contact surfaces (issue 19): the rows of BENCHMARKS.md's table.
# Usage: bench/run_thin_parts.sh [BUILD_DIR]   (key=value lines on stdout)
B=${1:-build}/bin/thin_parts_bench
export THIN_PARTS_NO_DENOISE_ONLY=1
"$B" sheets 80000 2.6 0 1000
"$B" sheets 50000 2.5 0.2 1000
"$B" sheets 50000 3 0 500 5000
"$B" sheets 50000 4 0.2 1000
"$B" sheets 50000 6 0 1000
"$B" sheets 200000 3 0 1000
"$B" sheets 500000 2.5 0 1000
"$B" plate 100000 3 0 2000
"$B" spheres 100000 2.5 0 2000
"$B" nested 100000 3 0 2000
unset THIN_PARTS_NO_DENOISE_ONLY
"$B" sheets 50000 2.5 0.2 1000  # with the --denoise-only line
