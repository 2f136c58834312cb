#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Tiled (out-of-core, DESIGN §9) vs in-memory resampling of a generated large scene; one row per line:
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
# Usage: bench/run_tiled.sh [BUILD_DIR] [WORK_DIR]   (env: POINTS=5000000 N=1000000 MEMORY=1.5 THREADS=2)
set -euo pipefail
BUILD=${1:-build-bench}
WORK=${2:-/tmp/iires_tiled_bench}
POINTS=${POINTS:-5000000}
N=${N:-1000000}
MEMORY=${MEMORY:-1.5}
THREADS=${THREADS:-2}
mkdir -p "$WORK"
SCENE="$WORK/scene_${POINTS}.ply"
[ -f "$SCENE" ] || "$BUILD/bin/scene_generator" --points "$POINTS" --out "$SCENE" > /dev/null

run() {  # mode memory_gb extra-args...
  local mode=$1 gb=$2
  shift 2
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

run memory 0 --tiles off
run tiled "$MEMORY" --tiles auto --memory "$MEMORY" --scratch "$WORK"
