#!/bin/sh
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Valid meshes over the closed corpus (issue 20)
# about: `bench/run_mesh_validity.sh quick|full`: `reconstruct_bench --seed 1` on 200k-point samplings of the closed
# about: corpus meshes (density ratio 1 and a 4× gradient along the longest axis) reconstructed to N, and the corpus's
# about: real point sets to 5k, 10k and 30k; local = iires-reconstruct, the peers mesh the same resampled points (input-AF: CGAL's
# about: advancing front on the dense input). si = self-intersecting face pairs, nm = non-manifold edges + vertices,
# about: loops = boundary loops, lt30 = % of angles under 30°, H→ / H← = Hausdorff distance mesh → truth / truth →
# about: mesh in % of the diagonal (real sets: to the input), uncov = % of the input farther than 2 spacings from the
# about: mesh, checks = the validity stage (checks and repairs) in % of the rest of the meshing time (local only).
# about: misses = the bounds of issue 20 a row does not meet (si, nm, oriented, closed where the true mesh is closed,
# about: Q_avg ≥ 0.90, Q_min ≥ 0.40, lt30 < 1 %; genus against the truth, which issue 19 owns; boeing's true mesh is
# about: 122 open pieces that intersect, so neither closure nor genus is asked of it). quick: 8 models, N = 10k, local
# about: only; full: every closed model, N = 10k and 30k, with the peers.
# columns: model density_ratio n method si nm genus_truth genus loops q_avg q_min lt30 h_to h_from uncov time_s checks misses
cd "$(dirname "$0")/.." || exit 1
B=${BUILD:-build-bench}/bin/reconstruct_bench
mode=${1:-quick}
if [ "$mode" = full ]; then
  models=closed counts=10000,30000 methods=local,advancing-front,bpa,poisson,input-advancing-front
else
  models=bunny00,hand,knot1,eight,3torus,double-torus-example,boeing,fandisk counts=10000 methods=local
fi
{
  for r in 1 4; do
    "$B" --models "$models" --dense 200000 --counts "$counts" --density-ratio $r --seed 1 --methods "$methods"
  done
  "$B" --models none --points real --point-counts 5000,10000,30000 --methods "$methods"
} | awk "$(cat bench/mesh_misses.awk)"'
  /method=/ && !/method=resample/ {
    parse(kv)
    if (kv["status"] != "ok") { print; next }
    printf "%s si=%s nm=%d loops=%s lt30=%s h_to=%s h_from=%s uncov=%s checks=%s misses=%s\n", $0,
      kv["self_intersections"], kv["nonmanifold_edges"] + kv["nonmanifold_vertices"], kv["boundary_loops"],
      kv["pct_angle_lt30"], kv["mesh_to_truth_pct_diag"], kv["truth_to_mesh_pct_diag"], kv["uncovered_pct"],
      kv["method"] == "local" ? kv["validity_pct_of_meshing"] : "",
      misses(kv, "si,nm,oriented,closed,q_avg,q_min,lt30,genus")
  }'
