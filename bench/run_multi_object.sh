#!/bin/sh
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Two objects sampled at different densities
# about: `bench/run_multi_object.sh quick|full`: two corpus models side by side (each scaled to a unit diagonal,
# about: the second 1.5× larger and 3 diagonals along x) as one mesh, sampled with 200k points whose density
# about: falls R-fold along x (the first object then holds most points: a scan of a near and a far object), and
# about: resampled to N = 10k by iires and Open3D's farthest-point and voxel down-sampling (`resample_bench`).
# about: cv = nearest-neighbour spacing cv of the output; err = distance to the true mesh, % of the diagonal;
# about: share2 = the output share on the second object (an isotropic output puts it at its area share,
# about: area2 = the share of a uniform 300k sampling of the mesh there). quick: one pair, R = 1 and 100;
# about: full: three pairs, R = 1, 10, 100.
# columns: pair R method cv share2 area2 err_mean_pct err_max_pct time_s
cd "$(dirname "$0")/.."
B=${BUILD:-build-bench}/bin
if [ "${1:-quick}" = full ]; then
  pairs="bunny00+armadillo fandisk+hand joint+knot1" ratios="1 10 100"
else
  pairs="fandisk+hand" ratios="1 100"
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# One OFF of two: each mesh centred and scaled to a unit diagonal, the second 1.5× and moved 3 along x.
combine() {
  awk -v second=0 '
    FNR == 1 { part++; state = 0; if ($1 != "OFF") { print FILENAME ": not an OFF file" > "/dev/stderr"; exit 2 } }
    /^#/ || NF == 0 { next }
    state == 0 && $1 == "OFF" && NF == 1 { next }
    state == 0 { nv[part] = $1 + 0; nf[part] = $2 + 0; if ($1 == "OFF") { nv[part] = $2; nf[part] = $3 } state = 1; k = 0; next }
    state == 1 { k++; x[part, k] = $1; y[part, k] = $2; z[part, k] = $3; if (k == nv[part]) { state = 2; k = 0 } next }
    state == 2 { k++; f[part, k] = $0; if (k == nf[part]) state = 3 }
    END {
      print "OFF"; print nv[1] + nv[2], nf[1] + nf[2], 0
      for (p = 1; p <= 2; p++) {
        lo[1] = hi[1] = x[p, 1]; lo[2] = hi[2] = y[p, 1]; lo[3] = hi[3] = z[p, 1]
        for (k = 1; k <= nv[p]; k++) {
          if (x[p, k] < lo[1]) lo[1] = x[p, k]; if (x[p, k] > hi[1]) hi[1] = x[p, k]
          if (y[p, k] < lo[2]) lo[2] = y[p, k]; if (y[p, k] > hi[2]) hi[2] = y[p, k]
          if (z[p, k] < lo[3]) lo[3] = z[p, k]; if (z[p, k] > hi[3]) hi[3] = z[p, k]
        }
        d = sqrt((hi[1] - lo[1]) ^ 2 + (hi[2] - lo[2]) ^ 2 + (hi[3] - lo[3]) ^ 2)
        s = (p == 1 ? 1 : 1.5) / d; off = p == 1 ? 0 : 3
        for (k = 1; k <= nv[p]; k++)
          printf "%.9g %.9g %.9g\n", (x[p, k] - (lo[1] + hi[1]) / 2) * s + off, (y[p, k] - (lo[2] + hi[2]) / 2) * s,
            (z[p, k] - (lo[3] + hi[3]) / 2) * s
      }
      for (p = 1; p <= 2; p++)
        for (k = 1; k <= nf[p]; k++) {
          n = split(f[p, k], w, " "); line = w[1]
          for (j = 2; j <= w[1] + 1; j++) line = line " " (w[j] + (p == 2 ? nv[1] : 0))
          print line
        }
    }' "$1" "$2"
}
for pair in $pairs; do
  combine "datasets/cache/meshes/${pair%+*}.off" "datasets/cache/meshes/${pair#*+}.off" > "$work/$pair.off" || exit 2
  for r in $ratios; do
    "$B/resample_bench" "$work/$pair.off" 200000 10000 --density-ratio "$r" --threads 2 --split-x 1.5 |
      awk -v pair="$pair" -v r="$r" '/method=/ {
        for (i = 1; i <= NF; i++) { p = index($i, "="); if (p) kv[substr($i, 1, p - 1)] = substr($i, p + 1) }
        printf "pair=%s R=%s method=%s cv=%s share2=%s area2=%s err_mean_pct=%s err_max_pct=%s time_s=%s\n", pair, r,
          kv["method"], kv["cv"], kv["share_beyond"], kv["area_beyond"], kv["err_mean_pct"], kv["err_max_pct"],
          kv["time_s"] }'
  done
done
