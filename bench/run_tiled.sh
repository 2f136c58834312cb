#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Out-of-core tiled resampling vs in-memory, one process and MPI ranks (issue 23)
# about: `bench/run_tiled.sh quick|full`: a scene from `build-bench/bin/scene_generator` (ground, walls, scaled
# about: corpus models) resampled by `iires-resample` in memory (`--tiles off`, 2 threads), tiled (`--tiles auto
# about: --memory GB`, 1 process × 2 threads) and by `mpirun -n R iires-resample-mpi` (R ranks × 1 thread, same
# about: tiles; R = 4 oversubscribes the 2 cores); peak RSS from GNU time (the largest process). vs = wall time /
# about: the in-memory run's (tiled) or the one-process tiled run's (mpi); same = the MPI output is byte-identical
# about: to the one-process output; busy = per rank, the summed time of the tiles it resampled. Seams: the cv of
# about: the nearest-neighbour distance of the output points within 2 mean spacings of an interior tile face
# about: against the rest's; the smallest nearest-neighbour distance between points of different tiles / the mean
# about: (min_across), the same over pairs offset along their sheet (min_across_sheet: a seam's duplicates, not two
# about: sheets of a model closer than the spacing, which the in-memory run keeps too); the % of points whose
# about: nearest neighbour is nearer than half the mean, near seams and elsewhere (the scene's models stand on the
# about: ground, whose samples under a model's flat base are such pairs in any run). quick: 1M → 200k at 0.3 GB.
# about: full: 5M → 1M at 1.5 GB (2 and 4 ranks) and at 0.5 GB, 50M → 5M at 4 GB (one process: in memory it would
# about: not fit the budget); then an estimate (mode=estimate, not measured) for 10⁹ → 10⁸ points on R ranks of 2
# about: threads from the 50M run's costs: every rank streams the input twice (survey, spill), the tiles' work is
# about: shared evenly.
# plot: tiled.png each tile's time against its points in the 50M-point run (full mode)
# columns: case mode ranks memory_gb tiles output_points wall_s vs peak_rss_mb cv seam_cv interior_cv min_across min_across_sheet close_seam_pct close_interior_pct survey_s spill_s colours_s busy_s same
# One row per line, keys:
#   case=<input>_to_<N>        the run: input points → N output points
#   mode=memory|tiled|mpi      --tiles off; --tiles auto --memory <GB>; the same under mpirun
#   ranks=<R> threads=<T>      processes and threads per process
#   memory_gb=<GB>             the --memory budget of a tiled run (0 for in-memory)
#   input_points=<n> n=<N>     input and requested points
#   output_points=<n>          points written (must equal N)
#   tiles=<x>x<y>x<z>          the tile grid (1x1x1 in memory)
#   wall_s=<s> vs=<ratio>      wall time of the whole command (read, resample, write) and its ratio (see above)
#   peak_rss_mb=<MB>           peak resident memory (/usr/bin/time -f %M)
#   cv=<cv> mean_spacing=<l>   nearest-neighbour spacing of the output (coefficient of variation, mean)
#   seam_cv interior_cv min_across   see above (tiled and mpi rows)
#   min_across_sheet           min_across over the pairs whose offset lies mostly along their sheet (|n·(q − p)| <
#                              |q − p| / 2): a seam's duplicates, not two sheets of a model closer than the spacing
#   close_seam_pct close_interior_pct  % of the points within 2 spacings of a seam (and of the others) whose
#                              nearest neighbour is nearer than half the mean spacing (the in-memory run has such
#                              pairs too: two sheets of a model closer than the spacing each keep their samples)
#   survey_s spill_s colours_s stage times of the tiled run (rank 0): pass 1, pass 2, all colour rounds
#   busy_s=<a/b/..>            per rank: the summed wall time of the tiles it resampled
#   same=yes|no                mpi rows: output identical to the one-process tiled run's
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
# The seam figures need numpy and scipy of Debian's python (/usr/bin/python3).
# mpirun as root and with more ranks than cores (OpenMPI's switches; other MPIs ignore them).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1

# One run; prints its row. Its output stays in $WORK/out_<mode>.ply until the case is done.
run() {  # points N mode memory_gb reference_wall extra-args...
  local POINTS=$1 N=$2 mode=$3 gb=$4 ref=$5
  shift 5
  local SCENE="$WORK/scene_${POINTS}.ply"
  [ -f "$SCENE" ] || "$BUILD/bin/scene_generator" --points "$POINTS" --out "$SCENE" > /dev/null
  local report="$WORK/report_$mode.json" out="$WORK/out_$mode.ply" ranks=1 threads=$THREADS
  local -a cmd=("$BUILD/bin/iires-resample")
  if [ "$mode" = mpi ]; then
    ranks=${RANKS:-2} threads=1
    cmd=(mpirun -n "$ranks" "$BUILD/bin/iires-resample-mpi")
  fi
  local start end
  start=$(date +%s.%N)
  /usr/bin/time -f %M -o "$WORK/rss_$mode" "${cmd[@]}" "$SCENE" "$out" -n "$N" --threads "$threads" \
    --report "$report" -q "$@"
  end=$(date +%s.%N)
  local same=""
  [ "$mode" = mpi ] && { cmp -s "$out" "$WORK/out_tiled.ply" && same=yes || same=no; }
  /usr/bin/python3 - "$report" "$out" "$mode" "$gb" "$POINTS" "$N" "$(cat "$WORK/rss_$mode")" "$start" "$end" "$ranks" \
    "$threads" "$ref" "$same" <<'PY'
import json, sys
import numpy as np
from scipy.spatial import cKDTree

def read_ply(path):
    """Positions and normals (None without them) of a binary little-endian PLY whose vertex properties are all
    float or double."""
    with open(path, "rb") as f:
        types, count = [], 0
        while True:
            line = f.readline().decode("ascii").split()
            if line[:2] == ["element", "vertex"]:
                count = int(line[2])
            elif line and line[0] == "property":
                types.append((line[2], {"double": "<f8", "float": "<f4"}[line[1]]))
            elif line == ["end_header"]:
                break
        v = np.fromfile(f, dtype=np.dtype(types), count=count)
    columns = lambda names: np.stack([v[k] for k in names], axis=1).astype(np.float64)
    return columns("xyz"), columns(("nx", "ny", "nz")) if "nx" in v.dtype.names else None

def cv(d):
    return d.std() / d.mean()

r = json.load(open(sys.argv[1]))
out, mode, gb, points, n, rss, start, end, ranks, threads, ref, same = sys.argv[2:]
wall = float(end) - float(start)
grid = r.get("grid", [1, 1, 1])
row = {"case": f"{points}_to_{n}", "mode": mode, "ranks": ranks, "threads": threads, "memory_gb": gb,
       "input_points": r["input_points"], "n": n, "output_points": r["output_points"],
       "tiles": "x".join(map(str, grid)), "wall_s": f"{wall:.1f}",
       "vs": f"{wall / float(ref):.2f}" if float(ref) > 0 else "", "peak_rss_mb": int(rss) // 1024,
       "cv": f"{r['spacing']['cv']:.4f}", "mean_spacing": f"{r['spacing']['mean']:.5g}"}
p, nrm = read_ply(out)
d, nn = cKDTree(p).query(p, k=2)
d, nn = d[:, 1], nn[:, 1]
close = d < 0.5 * d.mean()  # near pairs: a seam's duplicates, or two sheets closer than the spacing
row["close_interior_pct"] = f"{100 * close.mean():.3f}"  # in memory: all points
if mode != "memory":
    origin, size = np.array(r["origin"]), r["tile_size"]
    # a point's tile; points the surface puts just outside the tiled box (below the ground) are in the edge tile
    cell = np.clip(np.floor((p - origin) / size).astype(np.int64), 0, np.array(grid) - 1)
    seam = np.full(len(p), np.inf)  # distance to the nearest interior tile face
    for a in range(3):
        for k in range(1, grid[a]):
            seam = np.minimum(seam, np.abs(p[:, a] - (origin[a] + k * size)))
    near = seam < 2 * d.mean()
    across = np.any(cell != cell[nn], axis=1)
    row["seam_cv"] = f"{cv(d[near]):.4f}" if near.any() else ""
    row["interior_cv"] = f"{cv(d[~near]):.4f}"
    row["min_across"] = f"{d[across].min() / d.mean():.3f}" if across.any() else ""
    # the same over pairs on one sheet (their offset mostly along it, not along the normal): a seam's duplicates,
    # not two sheets of a model closer than the spacing
    gap = p[nn] - p
    along = np.abs(np.einsum("ij,ij->i", nrm, gap)) < 0.5 * d
    sheet = across & along
    row["min_across_sheet"] = f"{d[sheet].min() / d.mean():.3f}" if sheet.any() else ""
    row["close_seam_pct"] = f"{100 * close[near].mean():.3f}" if near.any() else ""
    row["close_interior_pct"] = f"{100 * close[~near].mean():.3f}"
    t = r["time_s"]
    row["survey_s"] = f"{t['survey']:.1f}"
    row["spill_s"] = f"{t['spill']:.1f}"
    row["colours_s"] = f"{sum(v for k, v in t.items() if k.startswith('colour_')):.1f}"
    busy = [0.0] * int(ranks)
    for tile in r["tiles"]:
        busy[tile["rank"]] += tile["time_s"]
    row["busy_s"] = "/".join(f"{b:.1f}" for b in busy)
if same:
    row["same"] = same
print(" ".join(f"{k}={v}" for k, v in row.items()))
PY
  awk -v s="$start" -v e="$end" 'BEGIN { print e - s }' > "$WORK/wall_$mode"
}

# One case: the in-memory run (skipped where it would not fit this machine), the tiled run and the MPI run.
case_runs() {  # points N memory_gb in_memory(0|1) "mpi rank counts" (may be empty)
  local ref=0
  if [ "$4" = 1 ]; then
    run "$1" "$2" memory 0 0 --tiles off
    ref=$(cat "$WORK/wall_memory")
  fi
  run "$1" "$2" tiled "$3" "$ref" --tiles auto --memory "$3" --scratch "$WORK"
  for ranks in $5; do
    RANKS=$ranks run "$1" "$2" mpi "$3" "$(cat "$WORK/wall_tiled")" --tiles auto --memory "$3" --scratch "$WORK"
  done
  rm -f "$WORK"/out_*.ply
}
# An estimate, not a measurement: 10⁹ points → 10⁸ on R ranks of 2 threads, from a run's report: every rank
# streams the whole input twice (survey and spill, scaled by the input size), and the tiles' resampling (the sum
# of the measured tile times, 2 threads each, scaled by the input size) is shared evenly by the ranks, the colour
# rounds' imbalance left out.
estimate() {  # report of the measured run
  /usr/bin/python3 - "$1" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
points, t = r["input_points"], r["time_s"]
tiles = sum(tile["time_s"] for tile in r["tiles"])
target = 10**9
for ranks in (1, 16, 64, 256):
    stream = (t["survey"] + t["spill"]) * target / points
    work = tiles * target / points / ranks
    print(f"case={target}_to_{target // 10} mode=estimate ranks={ranks} threads=2 wall_s={stream + work:.0f} "
          f"survey_s={t['survey'] * target / points:.0f} spill_s={t['spill'] * target / points:.0f} "
          f"colours_s={work:.0f}")
PY
}

# The plot: each tile's resampling time against its points, from a run's report (the per-tile cost the estimate
# scales).
plot_tiles() {  # report png
  /usr/bin/python3 -c 'import json, sys
for t in json.load(open(sys.argv[1]))["tiles"]:
    if t["loaded_points"]: print(t["loaded_points"], t["time_s"])' "$1" > "$WORK/tiles.dat"
  gnuplot <<GP
set terminal png size 900,560
set output "$2"
set xlabel "points resampled by the tile (core and margin)"
set ylabel "tile time (s), 2 threads"
set grid
set key off
plot "$WORK/tiles.dat" using 1:2 with points pointtype 7
GP
}

if [ "$MODE" = full ]; then
  case_runs 5000000 1000000 1.5 1 "2 4"
  case_runs 5000000 1000000 0.5 0 2
  case_runs 50000000 5000000 4 0 ""
  estimate "$WORK/report_tiled.json"
  plot_tiles "$WORK/report_tiled.json" bench/results/tiled.png
else
  case_runs 1000000 200000 0.3 1 2
fi
