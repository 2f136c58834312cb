#!/bin/sh
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Genus of the closed corpus at 10k and 20k (issue 19)
# about: `bench/run_genus.sh quick|full`: `reconstruct_bench --models M --dense 200000 --counts N --density-ratio 1
# about: --seed 1 --methods local` — a uniform 200k sampling of each closed corpus model (thin parts and parts that
# about: nearly touch included: hand's fingers, armadillo's claws, knots, the tori) meshed by iires-reconstruct to N.
# about: genus against the true mesh's (boeing has none: its mesh is not a closed 2-manifold); si = self-intersecting
# about: face pairs. misses = genus, closed or si. quick: 6 models at 10k; full: the 29 closed models at 10k and 20k.
# columns: model n genus_truth genus closed si q_min misses
cd "$(dirname "$0")/.." || exit 1
B=${BUILD:-build-bench}/bin/reconstruct_bench
if [ "${1:-quick}" = full ]; then
  models=closed counts=10000,20000
else
  models=hand,armadillo,knot2,eight,3torus,couplingdown counts=10000
fi
"$B" --models "$models" --dense 200000 --counts "$counts" --density-ratio 1 --seed 1 --methods local |
  awk "$(cat bench/mesh_misses.awk)"'
  /method=local/ {
    parse(kv)
    printf "model=%s n=%s genus_truth=%s genus=%s closed=%s si=%s q_min=%s misses=%s\n", kv["model"], kv["n"],
      kv["genus_truth"], kv["genus"], kv["closed"], kv["self_intersections"], kv["q_min"], misses(kv, "si,closed,genus")
  }'
