#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Out-of-core tiled resampling vs in-memory (issue 23)
# about: `bench/run_tiled.sh quick|full`: a scene from `build-bench/bin/scene_generator` (ground, walls, scaled corpus
# about: models) resampled by `iires-resample` once in memory (`--tiles off`) and once tiled (`--tiles auto --memory GB`),
# about: 2 threads; peak RSS from GNU time. quick: 1M → 200k at 0.3 GB; full: 5M → 1M at 1.5 GB and 50M → 5M at 4 GB.
# columns: case mode memory_gb tiles output_points wall_s peak_rss_mb cv survey_s spill_s colours_s
# One row per line, keys:
#   case=<input>_to_<N>        the run: input points → N output points
#   mode=memory|tiled          iires-resample --tiles off, or --tiles auto --memory <GB>
#   memory_gb=<GB>             the --memory budget of a tiled run (0 for in-memory)
#   input_points=<n> n=<N>     input and requested points
#   output_points=<n>          points written (must equal N)
#   tiles=<x>x<y>x<z>          the tile grid (1x1x1 in memory)
#   wall_s=<s>                 wall time of the whole command (read, resample, write)
#   peak_rss_mb=<MB>           peak resident memory (/usr/bin/time -f %M)
#   cv=<cv> mean_spacing=<l>   nearest-neighbour spacing of the output (coefficient of variation, mean)
#   survey_s spill_s colours_s stage times of the tiled run: pass 1, pass 2, all colour rounds
# Usage: bench/run_tiled.sh [quick|full]   (env: BUILD=build-bench WORK=/tmp/iires_tiled_bench THREADS=2)
set -euo pipefail
cd "$(dirname "$0")/.."
MODE=${1:-quick}
BUILD=${BUILD:-build-bench}
WORK=${WORK:-/tmp/iires_tiled_bench}
THREADS=${THREADS:-2}
mkdir -p "$WORK"
# The corpus models scene_generator scatters over the scene (its default --models).
bash datasets/fetch.sh meshes/bunny00.off meshes/fandisk.off meshes/armadillo.off meshes/eight.off meshes/anchor.off \
  meshes/knot1.off > /dev/null

run() {  # points N mode memory_gb extra-args...
  local POINTS=$1 N=$2 mode=$3 gb=$4
  shift 4
  local SCENE="$WORK/scene_${POINTS}.ply"
  [ -f "$SCENE" ] || "$BUILD/bin/scene_generator" --points "$POINTS" --out "$SCENE" > /dev/null
  local report="$WORK/report_$mode.json" out="$WORK/out_$mode.ply"
  local start end
  start=$(date +%s.%N)
  /usr/bin/time -f %M -o "$WORK/rss_$mode" "$BUILD/bin/iires-resample" "$SCENE" "$out" -n "$N" --threads "$THREADS" \
    --report "$report" -q "$@"
  end=$(date +%s.%N)
  python3 - "$report" "$mode" "$gb" "$POINTS" "$N" "$(cat "$WORK/rss_$mode")" "$start" "$end" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
mode, gb, points, n, rss, start, end = sys.argv[2:]
grid = r.get("grid", [1, 1, 1])
t = r["time_s"]
row = {"case": f"{points}_to_{n}", "mode": mode, "memory_gb": gb, "input_points": r["input_points"], "n": n,
       "output_points": r["output_points"], "tiles": "x".join(map(str, grid)),
       "wall_s": f"{float(end) - float(start):.1f}", "peak_rss_mb": int(rss) // 1024,
       "cv": f"{r['spacing']['cv']:.4f}", "mean_spacing": f"{r['spacing']['mean']:.5g}"}
if mode == "tiled":
    row["survey_s"] = f"{t['survey']:.1f}"
    row["spill_s"] = f"{t['spill']:.1f}"
    row["colours_s"] = f"{sum(v for k, v in t.items() if k.startswith('colour_')):.1f}"
print(" ".join(f"{k}={v}" for k, v in row.items()))
PY
  rm -f "$out"
}

# One case: the in-memory run (skipped where it would not fit this machine) and the tiled run.
case_pair() {  # points N memory_gb in_memory(0|1)
  [ "$4" = 1 ] && run "$1" "$2" memory 0 --tiles off
  run "$1" "$2" tiled "$3" --tiles auto --memory "$3" --scratch "$WORK"
}
if [ "$MODE" = full ]; then
  case_pair 5000000 1000000 1.5 1
  case_pair 50000000 5000000 4 0
else
  case_pair 1000000 200000 0.3 1
fi
