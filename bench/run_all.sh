#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Run the benchmark suite and write BENCHMARKS.md from its output (not part of CI).
# Usage: bash bench/run_all.sh [quick|full|tables]
#   quick (≈ 40 min on 2 cores): the tables below on a subset of the corpus;
#   full: every model of the corpus, 50 registration trials, the 5M-point grid (and each runner's full mode);
#   tables: no runs, BENCHMARKS.md again from the results of the last run.
# Raw key=value lines, the plots and the generated file go to bench/results/; BENCHMARKS.md is that file.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-quick}
case "$mode" in quick | full | tables) ;; *) echo "usage: bash bench/run_all.sh [quick|full|tables]" >&2; exit 2 ;; esac
out=bench/results
bin=build-bench/bin
data=datasets/cache/meshes
mkdir -p "$out"
if [ "$mode" = tables ]; then
  [ -f "$out/run_info.txt" ] || { echo "run_all.sh: no earlier run in $out (run quick or full first)" >&2; exit 2; }
  mode=$(sed -n 's/^mode=//p' "$out/run_info.txt"); tables_only=1
else
  tables_only=0
fi
full() { [ "$mode" = full ]; }

# What each mode runs.
resample_models="bunny00 armadillo fandisk"
full && resample_models="$resample_models hand knot1 joint"
reg_models=bunny00,armadillo,fandisk,hand,kitten,knot1,joint,anchor,cactus,head,lion-head,nefertiti
# Models the registration was never tuned on (symmetric ones scored by surface error).
unseen_models=helmet,retinal,part,itemb,couplingdown,pipe,u,knot2
unseen_symmetric=itemb,pipe,knot2
trials=5
full && trials=50
peer_trials=5  # Open3D's pipelines take 3-4x iires's time per pair
cad="fandisk joint anchor"
full && cad="fandisk joint anchor couplingdown part dragknob spool cross tripod cube beam boeing mech-holes-shark"
# The corpus models the tables use (DEVELOPERS.md); `full` adds the rest of the closed and CAD corpus.
corpus="bunny00 armadillo fandisk hand knot1 joint anchor eight double-torus-example cactus head lion-head nefertiti"
full && corpus="$corpus knot2 3torus couplingdown part dragknob spool cross tripod cube beam handle
  helmet retinal boeing pipe itemb u sphere ellipsoid larger_sphere mech-holes-shark"

# Registration: one configuration, its name, models, symmetric models and trials per model, then register_bench's
# options; the summary lines (model=all) get config=NAME.
register_config() {
  local name="$1" models="$2" symmetric="$3" count="$4"; shift 4
  OMP_NUM_THREADS=1 "$bin/register_bench" --models "$models" --trials "$count" --threads 1 --symmetric "$symmetric" "$@" |
    awk -v c="$name" '/^model=all / { print "config=" c " " $0 }' >> "$out/register.txt"
}
# The real pair: CGAL's two hippo scans, default flags and the hinted run (rigid, overlap 0.7) as the reference.
hippo() {
  local name="$1"; shift
  /usr/bin/time -f "%e" -o "$out/hippo.time" "$bin/iires-register" datasets/cache/points_3/hippo1.ply \
    datasets/cache/points_3/hippo2.ply -q --threads 2 --report "$out/hippo.json" "$@"
  python3 -c 'import json, sys; r = json.load(open(sys.argv[1])); print("config=hippo1-hippo2 method=%s rotation_deg=%.2f scale=%.4f rmse=%.4g overlap_median=%s time_s_mean=%s" % (
    sys.argv[2], r["rotation_angle_deg"], r["scale"], r["rmse"], r["overlap_share"], sys.argv[3]))' \
    "$out/hippo.json" "$name" "$(tail -1 "$out/hippo.time")" >> "$out/register.txt"
  rm -f "$out/hippo.json" "$out/hippo.time"
}

# Benchmarks with a runner of their own: bench/run_NAME.sh MODE prints key=value lines; its comment lines
# "# title: ", "# about: " and "# columns: " give its section's heading, text and table columns, "# plot: " the
# plots it wrote.
runners() {
  for runner in bench/run_*.sh; do
    name=$(basename "$runner" .sh); name=${name#run_}
    [ "$name" != all ] && [ -e "$runner" ] && echo "$name"
  done
  return 0
}

run_benchmarks() {
  # The benchmarks' own set-up: the libraries' packages, Open3D (the peers) and gnuplot (the plots).
  bash scripts/setup.sh --install-only
  bash scripts/install_packages.sh libopen3d-dev gnuplot-nox python3-scipy
  bash datasets/fetch.sh >/dev/null
  bash datasets/fetch.sh $(printf 'meshes/%s.off ' $corpus) points_3/building.ply points_3/before_upsample.xyz >/dev/null
  cmake -S . -B build-bench -DCMAKE_BUILD_TYPE=Release -DIIRES_BUILD_TESTS=OFF -DIIRES_BUILD_BENCH=ON -DIIRES_WITH_MPI=ON \
    >/dev/null
  cmake --build build-bench -j"$(nproc)" >/dev/null
  local load_start started commit
  load_start=$(cut -d' ' -f1-3 /proc/loadavg)
  started=$(date -u +"%Y-%m-%d %H:%M")
  commit=$(git rev-parse --short HEAD)

  # ---------------------------------------------------------------------------------------------------------------
  # Runs: each benchmark writes key=value lines to $out/NAME.txt.

  echo "resampling vs Open3D ..."
  : > "$out/resample.txt"
  for m in $resample_models; do
    for n in 100000 550000; do "$bin/resample_bench" "$data/$m.off" "$n" 10000 >> "$out/resample.txt"; done
  done
  "$bin/resample_bench" "$data/armadillo.off" 1000000 100000 --fps-limit 0 >> "$out/resample.txt"

  echo "scale grid ..."
  inputs="50000 100000 500000 1000000"
  full && inputs="$inputs 5000000"
  : > "$out/grid.txt"
  for n in $inputs; do
    for N in 1000 10000 100000 1000000; do
      [ "$N" -lt "$n" ] || continue
      full || [ "$N" -le 100000 ] || continue
      line=$(/usr/bin/time -f "%M" -o "$out/.peak" "$bin/resample_bench" "$data/armadillo.off" "$n" "$N" --fps-limit 0 --no-peers)
      echo "$line peak_mb=$(awk '{ printf "%.0f", $1 / 1024 }' "$out/.peak")" >> "$out/grid.txt"
    done
  done
  rm -f "$out/.peak"

  echo "pre-processing vs CGAL ..."
  "$bin/denoise_bench" > "$out/denoise.txt"

  echo "registration ..."
  : > "$out/register.txt"
  register_config whole "$reg_models" knot1 "$trials" --methods iires
  register_config whole "$reg_models" knot1 "$peer_trials" --methods o3d-fpfh,o3d-fpfh-norm,o3d-icp
  register_config source-cut-25% "$reg_models" knot1 "$trials" --cut 0.25 --methods iires
  register_config source-cut-25% "$reg_models" knot1 "$peer_trials" --cut 0.25 --methods o3d-fpfh,o3d-fpfh-norm
  register_config source-cut-40% "$reg_models" knot1 "$trials" --cut 0.4 --methods iires
  register_config both-cut-20% "$reg_models" knot1 "$trials" --cut 0.2 --target-cut 0.2 --methods iires
  register_config unseen-source-cut-25% "$unseen_models" "$unseen_symmetric" "$trials" --cut 0.25 --methods iires
  register_config unseen-source-cut-40% "$unseen_models" "$unseen_symmetric" "$trials" --cut 0.4 --methods iires
  register_config unseen-both-cut-20% "$unseen_models" "$unseen_symmetric" "$trials" --cut 0.2 --target-cut 0.2 \
    --methods iires
  hippo iires-default
  hippo iires-hinted --no-scale --overlap 0.7

  echo "reconstruction ..."
  : > "$out/reconstruct.txt"
  "$bin/reconstruct_bench" --models bunny00,fandisk,hand,knot1,eight,double-torus-example --dense 100000 \
    --counts 10000 --seed 1 --methods local,advancing-front,bpa,poisson >> "$out/reconstruct.txt" || true
  "$bin/reconstruct_bench" --models none --points kitten.xyz,hippo1.ply,building.ply --point-counts 5000 \
    --methods local,advancing-front,bpa,poisson >> "$out/reconstruct.txt" || true

  echo "sharp edges vs CGAL WLOP / EAR-style ..."
  : > "$out/sharp_edges.txt"
  for m in $cad; do
    for r in 1 5; do
      "$bin/sharp_edge_bench" "$data/$m.off" 100000 10000 20000 --density-ratio "$r" >> "$out/sharp_edges.txt"
    done
    "$bin/sharp_edge_bench" "$data/$m.off" 100000 10000 --noise 0.2 --methods iires,iires_sharp >> "$out/sharp_edges.txt"
  done

  echo "geodesic coordinates ..."
  "$bin/geodesic_bench" "" 1000000 2 > "$out/geodesic.txt"

  # Benchmarks with a runner of their own.
  for name in $(runners); do
    echo "$name ..."
    bash "bench/run_$name.sh" "$mode" > "$out/$name.txt"
  done
  printf 'mode=%s\nstarted=%s\ncores=%s\nload_start=%s\nload_end=%s\ncommit=%s\n' "$mode" "$started" "$(nproc)" \
    "$load_start" "$(cut -d' ' -f1-3 /proc/loadavg)" "$commit" > "$out/run_info.txt"
}
if [ "$tables_only" != 1 ]; then run_benchmarks; fi
info() { sed -n "s/^$1=//p" "$out/run_info.txt"; }

# ---------------------------------------------------------------------------------------------------------------
# Tables: key=value lines → Markdown.

# table "COLUMNS" FILE [FILTER]: one row per line that has the first column's key (and matches the awk regex
# FILTER); a column "a:b" prints key a under the heading b.
table() {
  local cols="$1" file="$2" filter="${3:-.}"
  awk -v cols="$cols" -v filter="$filter" '
    BEGIN { n = split(cols, c, " "); h = "|"; s = "|"
            for (i = 1; i <= n; i++) { split(c[i], kh, ":"); key[i] = kh[1]; head[i] = (2 in kh) ? kh[2] : kh[1]
                                       h = h " " head[i] " |"; s = s "---|" }
            print h; print s }
    /=/ && $0 ~ filter { delete kv; for (i = 1; i <= NF; i++) { p = index($i, "="); if (p) kv[substr($i, 1, p - 1)] = substr($i, p + 1) }
             if (!(key[1] in kv)) next; line = "|"
             for (i = 1; i <= n; i++) line = line " " (key[i] in kv ? kv[key[i]] : "") " |"; print line }' "$file"
}
# ratio FILE GROUPKEYS: appends time_vs_iires= (time_s over the iires line's time_s of the same group).
ratio() {
  awk -v keys="$2" '
    { delete kv; for (i = 1; i <= NF; i++) { p = index($i, "="); if (p) kv[substr($i, 1, p - 1)] = substr($i, p + 1) }
      g = ""; n = split(keys, k, " "); for (i = 1; i <= n; i++) g = g "|" kv[k[i]]
      line[NR] = $0; group[NR] = g; t[NR] = kv["time_s"]; if (kv["method"] ~ /^iires$/) base[g] = kv["time_s"] }
    END { for (r = 1; r <= NR; r++) {
            x = ""
            if (group[r] in base && base[group[r]] > 0 && t[r] != "") x = sprintf(" time_vs_iires=%.2f", t[r] / base[group[r]])
            print line[r] x } }' "$1"
}
# plot DAT PNG XLABEL YLABEL: one log-log line per distinct first column of DAT (columns: series x y).
plot() {
  gnuplot <<GP
set terminal png size 900,560
set output "$2"
set logscale xy
set xlabel "$3"
set ylabel "$4"
set key left top
set grid
series = system("cut -d' ' -f1 $1 | sort -un | tr '\\n' ' '")
plot for [s in series] "$1" using (\$1 == s ? \$2 : 1/0):3 with linespoints title sprintf("input %s", s)
GP
}

tmp=$(mktemp -d)  # intermediate tables
trap 'rm -rf "$tmp"' EXIT
awk '/method=iires/ { for (i = 1; i <= NF; i++) { split($i, p, "="); kv[p[1]] = p[2] } print kv["input"], kv["N"], kv["time_s"] }' \
  "$out/grid.txt" > "$out/grid.dat"
plot "$out/grid.dat" "$out/grid.png" "output points N" "time (s), 2 cores"

{
  cat <<EOF
# Benchmarks

Generated by \`bash bench/run_all.sh $mode\` at commit $(info commit) ($(info started) UTC, $(info cores) cores;
load average at the start: $(info load_start); at the end: $(info load_end)); do not edit by hand.
Every table compares methods **in one run on the same inputs**; absolute seconds depend on the machine's load, the ratios (\`time_vs_iires\`) much less. Raw key=value lines:
bench/results/. Errors are distances in % of the bounding-box diagonal unless a column says otherwise; cv =
std/mean of the nearest-neighbour distance (lower is more uniform).

## Resampling to N points vs Open3D farthest-point and voxel down-sampling

\`$bin/resample_bench MESH INPUT N\` on $resample_models: a non-uniform (5× density gradient) sampling of the
mesh, positions only, the same points for every method. cov99 = 99th percentile of the distance from the true
surface to the nearest output point, in output spacings (holes show here). Open3D's voxel size is bisected until
it gives N within 2 %.

EOF
  grep -v 'skipped=' "$out/resample.txt" | ratio /dev/stdin "model input N" > "$tmp/resample_ratio.txt"
  table "model input N method time_s time_vs_iires cv err_mean_pct err_max_pct cov99_per_spacing" "$tmp/resample_ratio.txt"
  cat <<EOF

## Scale grid (armadillo, isotropic, iires only)

\`$bin/resample_bench $data/armadillo.off INPUT N --fps-limit 0 --no-peers\` under GNU time (peak memory).

EOF
  table "input N time_s cv err_mean_pct err_max_pct cov99_per_spacing peak_mb" "$out/grid.txt"
  cat <<EOF

![time against output size, one line per input size](bench/results/grid.png)

## Pre-processing (outliers + MLS denoising) vs CGAL jet and bilateral smoothing

\`$bin/denoise_bench\`: dense samplings of the models, offsets along the true normal uniform in [0, noise·l]
(l = input spacing), optionally outliers; normals estimated from the noisy cloud. mean_err_l = mean distance of
the output to the true mesh in units of l, per method (input = the noisy cloud itself); after the slash the same near
sharp edges (dihedral > 45°); then each method's time (s).

EOF
  # One row per case: each method's mean (and near-edge) error side by side, and its time.
  awk '/ method=/ { delete kv; for (i = 1; i <= NF; i++) { p = index($i, "="); kv[substr($i, 1, p - 1)] = substr($i, p + 1) }
                    key = "model=" kv["model"] " noise=" kv["noise"] " outliers=" kv["outliers"]
                    if (!(key in row)) { order[++n] = key; row[key] = key }
                    m = kv["method"]; e = kv["mean_err_l"]; if ("edge_err_l" in kv) e = e "/" kv["edge_err_l"]
                    row[key] = row[key] " " m "=" e; if (m != "input") row[key] = row[key] " " m "_s=" kv["time_s"] }
       END { for (i = 1; i <= n; i++) print row[order[i]] }' "$out/denoise.txt" > "$tmp/denoise_rows.txt"
  table "model noise outliers input iires cgal_jet cgal_bilateral iires_s cgal_jet_s cgal_bilateral_s" "$tmp/denoise_rows.txt"
  echo
  echo "Speed (200k points): \`$(grep '^speed' "$out/denoise.txt" | head -1)\`"
  cat <<EOF

## Registration vs Open3D FPFH + RANSAC (raw and normalised) and ICP

\`OMP_NUM_THREADS=1 $bin/register_bench --models $reg_models --trials T --threads 1 --symmetric knot1 [--cut F]
[--target-cut F] --methods ...\` (the trials column counts pairs: T per model, Open3D's pipelines at T = $peer_trials as they
take 3–4× iires's time per pair): source and target sampled independently at different densities, noise 0.33 spacings, the source under a
random rotation, scale in [0.2, 5] and translation; \`--cut F\` removes the share F of the source by a random plane,
\`--target-cut\` another share of the target. No overlap hint. Success: rotation < 5°, centroid < 2 % of the
diagonal, scale < 2 % (symmetric models: surface error < 1 % of the diagonal against a dense clean sample). The
unseen rows: \`--models $unseen_models --symmetric $unseen_symmetric\`, corpus models the registration was never
tuned on. Times per pair, 1 thread.
Second table: CGAL's two real hippo scans (\`iires-register hippo1.ply hippo2.ply\`), default flags and the
hinted run \`--no-scale --overlap 0.7\` as the reference pose.

EOF
  table "config method trials success_scored rot_err_deg_median scale_err_median overlap_median time_s_mean cpu_s_mean" "$out/register.txt" "trials="
  echo
  table "config method rotation_deg scale rmse overlap_median:overlap time_s_mean:time_s" "$out/register.txt" "hippo"
  cat <<EOF

## Reconstruction vs CGAL advancing front, Open3D ball pivoting and Poisson

\`$bin/reconstruct_bench\` ($([ "$mode" = full ] && echo "closed corpus, 200k uniform and 4× gradient samplings, N = 10k and 30k; real point sets at 5k" || echo "--models bunny00,fandisk,hand,knot1,eight,double-torus-example --dense 100000 --counts 10000; real point sets kitten, hippo1, building at 5k")):
every method meshes the same resampled points (local = iires-reconstruct; input-advancing-front meshes the dense
input). si = self-intersecting face pairs, nm = non-manifold edges + vertices, genus truth/ours (closed
components), loops = boundary loops, lt30 = % of angles under 30°, H = Hausdorff distance mesh → truth and truth →
mesh, uncov = % of the input farther than 2 spacings from the mesh, checks = the validity stage (self-intersection and
non-manifold checks and their repairs) in % of the rest of the meshing time (local only).

EOF
  awk '{ for (i = 1; i <= NF; i++) { split($i, p, "="); kv[p[1]] = p[2] }
         if ($0 ~ /status=ok/) print $0 " nm=" kv["nonmanifold_edges"] + kv["nonmanifold_vertices"]; else print }' \
    "$out/reconstruct.txt" > "$tmp/reconstruct_nm.txt"
  table "model:model density_ratio:density n method self_intersections:si nm genus_truth:genus_truth genus:genus boundary_loops:loops q_avg q_min pct_angle_lt30:lt30 mesh_to_truth_pct_diag:H_mesh→truth truth_to_mesh_pct_diag:H_truth→mesh uncovered_pct:uncov time_s validity_pct_of_meshing:checks" \
    "$tmp/reconstruct_nm.txt" "status="
  cat <<EOF

## Sharp edges: iires isotropic and --sharp-edges vs CGAL WLOP and an EAR-style pipeline

\`$bin/sharp_edge_bench MESH 100000 10000 20000 --density-ratio R\` on $cad, and \`MESH 100000 10000 --noise 0.2
--methods iires,iires_sharp\` (Gaussian noise of 0.2 input spacings along the normal): edge_max / edge_mean = distance
from the mesh's sharp edges (dihedral > 30°) to the nearest output point, in output spacings; cv_sheet = spacing cv
along the surface (a neighbour on a facing sheet of the true mesh, as across a plate thinner than the spacing, passed
over); free_cv = cv_sheet of the samples not held on a feature line.

EOF
  ratio "$out/sharp_edges.txt" "model density_ratio noise N" > "$tmp/sharp_ratio.txt"
  table "model density_ratio noise N method time_s time_vs_iires cv cv_sheet free_cv err_mean_pct err_max_pct edge_max_per_spacing:edge_max edge_mean_per_spacing:edge_mean" \
    "$tmp/sharp_ratio.txt"
  cat <<EOF

## Geodesic coordinates

\`$bin/geodesic_bench "" 1000000 2\`: a 1M-point sampling of armadillo, 2 threads, without and with input
normals.

EOF
  table "points normals threads time_s graph_s components_s fields_s edges components" "$out/geodesic.txt"
  for name in $(runners); do
    runner=bench/run_$name.sh
    echo
    echo "## $(sed -n 's/^# title: //p' "$runner")"
    echo
    sed -n 's/^# about: //p' "$runner"
    echo
    if [ -s "$out/$name.txt" ]; then table "$(sed -n 's/^# columns: //p' "$runner")" "$out/$name.txt"
    else echo "Not measured in this run."; fi
    # "# plot: FILE CAPTION": a plot the runner wrote to bench/results/FILE
    sed -n 's/^# plot: //p' "$runner" | while read -r png caption; do
      if [ -f "$out/$png" ]; then printf '\n![%s](bench/results/%s)\n' "$caption" "$png"; fi
    done
  done
} > "$tmp/BENCHMARKS.md"
mv "$tmp/BENCHMARKS.md" BENCHMARKS.md
echo "wrote BENCHMARKS.md ($(wc -l < BENCHMARKS.md) lines)"
