#!/bin/sh
# SPDX-License-Identifier: GPL-3.0-or-later
# title: Thin parts and near-contact surfaces meshed (issue 19)
# about: `bench/run_thin_meshes.sh quick|full`: the generated cases of the thin-parts benchmark (tests/shapes.hpp,
# about: seed 19, positions only, 100k points) meshed by `iires-reconstruct -n N` with its defaults: a closed box
# about: 3 input spacings thick (plate: one closed part of genus 0), two spheres 2.5 input spacings apart (spheres)
# about: and a sphere 3 spacings inside another (nested: two closed parts of genus 0 each). parts / genus: truth →
# about: ours (genus summed over the parts); bands = thin rims closed by a band (closeRimBands); si =
# about: self-intersecting face pairs. misses = parts, genus, closed or si against the truth. quick: N = 2000;
# about: full: N = 1000, 2000, 5000, 10000 (output spacing from about 10 down to 3 input spacings).
# columns: case input gap_spacings N parts_truth parts genus_truth genus closed si q_min q_avg bands misses
cd "$(dirname "$0")/.."
BIN=${BUILD:-build-bench}/bin
counts=2000
[ "${1:-quick}" = full ] && counts="1000 2000 5000 10000"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
for spec in "plate 3 1 0" "spheres 2.5 2 0" "nested 3 2 0"; do
  set -- $spec
  "$BIN/thin_parts_bench" "$1" 100000 "$2" 0 --seed 19 --write-input "$dir/in.xyz" >/dev/null
  for n in $counts; do
    "$BIN/iires-reconstruct" "$dir/in.xyz" "$dir/out.ply" -n "$n" -q --report "$dir/r.json"
    python3 - "$dir/r.json" "$1" "$2" "$n" "$3" "$4" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); q = r["quality"]
case, gap, n, parts_truth, genus_truth = sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]), int(sys.argv[6])
genus = sum(p["genus"] for p in q["parts"] if p["closed"])
si = q["self_intersecting_face_pairs"]
misses = [m for m, bad in (("parts", q["components"] != parts_truth), ("genus", genus != genus_truth),
                           ("closed", not q["closed"]), ("si", si > 0)) if bad]
print(f"case={case} input={r['input_points']} gap_spacings={gap} N={n} parts_truth={parts_truth} "
      f"parts={q['components']} genus_truth={genus_truth} genus={genus} closed={int(q['closed'])} si={si} "
      f"q_min={q['quality']['min']:.3f} q_avg={q['quality']['mean']:.3f} bands={r['rim_bands']['bands']} "
      f"misses={','.join(misses) or 'none'}")
PY
  done
done
