#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Set everything up, then resample a real scan: a dense, deliberately non-uniform 200k-point sampling of
# the Stanford bunny (CGAL's bunny00) to exactly 10,000 isotropic points, written to out/bunny_10k.ply.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh -DIIRES_BUILD_TESTS=OFF
bash datasets/fetch.sh meshes/bunny00.off
mkdir -p out
./build/bin/iires-sample-mesh datasets/cache/meshes/bunny00.off out/bunny_dense.ply -n 200000 \
  --density-ratio 5 --seed 1
./build/bin/iires-resample out/bunny_dense.ply out/bunny_10k.ply -n 10000 --report out/bunny_10k.json
echo "wrote out/bunny_10k.ply (report: out/bunny_10k.json)"
