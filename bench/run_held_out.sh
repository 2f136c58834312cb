#!/bin/sh
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Models outside the corpus (held out)
# about: `bench/run_held_out.sh quick|full`: files of CGAL's data archive that DEVELOPERS.md's corpus does not list
# about: (fetched by datasets/fetch.sh), run through the corpus benchmarks with their defaults, nothing tuned on them.
# about: mesh rows: `reconstruct_bench --dense 200000 --counts 10000,30000 --density-ratio 1 --seed 1 --methods local`
# about: (genus against the true mesh's, na where it is not a closed 2-manifold); scan rows: `reconstruct_bench
# about: --points F --point-counts 5000,10000`; misses = issue 19's genus/closure and issue 20's validity and
# about: quality bounds (closure not asked of the scans). quick: 6 meshes and 3 scans; full: 26 meshes and 9 scans
# about: (a run the resampler refuses: misses=failed).
# columns: model n genus_truth genus components closed si nm q_avg q_min lt30 uncov cv misses
cd "$(dirname "$0")/.." || exit 1
B=${BUILD:-build-bench}/bin/reconstruct_bench
if [ "${1:-quick}" = full ]; then
  meshes="bear blade bull camel cow dino elephant elk femur homer man pig pinion rotor turbine triceratops
double-torus-3-holes cheese bones mannequin-devil diplodocus ChineseDragon-10kv blobby torus_quad star cylinder"
  scans="oni.ply radar.xyz poste_france.xyz ball.ply b9_training.ply spheres.ply circles.ply fin90_with_PCA_normals.xyz
blobby.xyz"
else
  meshes="bear camel cow elephant man pinion"
  scans="oni.ply radar.xyz b9_training.ply"
fi
# The lists split into words on purpose (one name each).
# shellcheck disable=SC2086
comma() { printf '%s\n' $1 | paste -sd, -; }
files=""
for m in $meshes; do files="$files meshes/$m.off"; done
for s in $scans; do files="$files points_3/$s"; done
# shellcheck disable=SC2086
bash datasets/fetch.sh $files >/dev/null || exit 1
{
  "$B" --models "$(comma "$meshes")" --dense 200000 --counts 10000,30000 --density-ratio 1 --seed 1 --methods local
  "$B" --models none --points "$(comma "$scans")" --point-counts 5000,10000 --seed 1 --methods local
} | awk "$(cat bench/mesh_misses.awk)"'
  /method=resample/ {
    parse(kv)
    cv = kv["spacing_cv"]
    if (kv["status"] == "error")
      printf "model=%s n=%s genus_truth=%s misses=failed\n", kv["model"], kv["n"], kv["genus_truth"]
    next
  }
  /method=local/ {
    parse(kv)
    printf "model=%s n=%s genus_truth=%s genus=%s components=%s closed=%s si=%s nm=%s q_avg=%.4f q_min=%.3f " \
      "lt30=%.2f uncov=%s cv=%s misses=%s\n", kv["model"], kv["n"], kv["genus_truth"], kv["genus"],
      kv["components"], kv["closed"], kv["self_intersections"], kv["nonmanifold_edges"] + kv["nonmanifold_vertices"],
      kv["q_avg"], kv["q_min"], kv["pct_angle_lt30"], kv["uncovered_pct"], cv,
      misses(kv, "si,nm,closed,q_avg,q_min,lt30,genus")
  }'
