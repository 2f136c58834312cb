#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Run the three tools on a fixed input set (scripts/make_identity_inputs.py) and print the sha256 of every
# output, with the timing fields of the JSON reports zeroed. Same build -> same list; a refactoring that claims
# "no behaviour change" keeps the list byte-identical:
#
#   bash scripts/check_identical.sh [BIN_DIR] > before.txt     (BIN_DIR defaults to build/bin)
#   ... change, rebuild ...
#   bash scripts/check_identical.sh [BIN_DIR] > after.txt && diff before.txt after.txt
#
# Also: --keep DIR keeps the inputs and outputs in DIR (default: a temporary directory, removed).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin="$root/build/bin"
keep=""
while (($#)); do
  case "$1" in
    --keep) keep="$2"; shift 2 ;;
    -h|--help) sed -n '3,10s/^# \{0,1\}//p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) bin="$(cd "$1" && pwd)"; shift ;;
  esac
done
python=/usr/bin/python3
[[ -x "$python" ]] || python=python3

if [[ -n "$keep" ]]; then
  mkdir -p "$keep"; work="$(cd "$keep" && pwd)"
else
  work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
fi
cd "$work"
"$python" "$root/scripts/make_identity_inputs.py" .

run() { "$@" -q --seed 3 --threads 2 || { echo "check_identical.sh: failed: $*" >&2; exit 1; }; }
R="$bin/iires-resample"
G="$bin/iires-register"
C="$bin/iires-reconstruct"

# resample: isotropic (with the geodesic export), curvature-adaptive, sharp edges, attributes, text outputs
run "$R" torus.xyz iso.ply -n 1500 --report iso.json --export-geodesic iso_geodesic.ply
run "$R" torus.xyz iso.xyzn -n 700 --outliers remove --no-intrinsic
run "$R" torus.xyz curvature.ply -n 1500 --mode curvature --report curvature.json
run "$R" torus.xyz curvature3.xyz -n 900 --mode curvature --ratios 2 1 0.5 --report curvature3.json
run "$R" box.xyz sharp.ply -n 1200 --sharp-edges --report sharp.json
run "$R" box.xyz sharp_edge.ply -n 800 --sharp-edges --edge-ratio 1 --mode curvature
run "$R" torus_attr.xyz attr.ply -n 1000 --columns x,y,z,red,green,blue,intensity,label:int --report attr.json
run "$R" torus.xyz denoised.ply --denoise-only --report denoised.json
# register: similarity (default), rigid, with the mapped cloud and the matrix
run "$G" torus_moved.xyz torus.xyz -o registered.ply --transform registered.txt --report registered.json
run "$G" torus_moved.xyz torus.xyz --no-scale -m 400 --grid euler --report rigid.json -o rigid.xyz
# reconstruct: meshes in three formats, holes, quality of an existing mesh, mesh files read back as clouds
run "$C" torus.xyz mesh.ply -n 1200 --report mesh.json --uncovered uncovered.xyz
run "$C" box.xyz mesh.obj -n 900 --report mesh_box.json
# (not --method advancing-front: CGAL orders equal-priority edges by address, so its mesh varies with --threads 2)
run "$C" torus_moved.xyz mesh.off -n 800 --report mesh_moved.json
run "$C" torus.xyz --quality-only mesh.off --report quality.json
run "$C" torus_attr.xyz mesh_attr.ply -n 600 --columns x,y,z,red,green,blue,intensity,label:int
run "$R" mesh.obj from_obj.xyz -n 300 --no-denoise
run "$R" mesh.off from_off.ply -n 300 --no-denoise
run "$R" mesh.ply from_ply.xyz -n 300 --no-denoise

# Timing fields vary from run to run: zero every number under a key that names a time.
"$python" - *.json <<'PY'
import re, sys
key = re.compile(r'"([A-Za-z0-9_]*tim(?:e|ing)[A-Za-z0-9_]*)"\s*:\s*')
num = re.compile(r'-?(?:[0-9.]+(?:[eE][-+]?[0-9]+)?|nan|inf)')
for path in sys.argv[1:]:
    text, out, i = open(path).read(), [], 0
    for m in key.finditer(text):
        if m.start() < i:
            continue
        j = m.end()
        if text[j] == '{':
            depth, k = 0, j
            while True:
                depth += {'{': 1, '}': -1}.get(text[k], 0)
                k += 1
                if depth == 0:
                    break
        else:
            k = num.match(text, j).end()
        out.append(text[i:j] + num.sub('0', text[j:k]))
        i = k
    out.append(text[i:])
    open(path, 'w').write(''.join(out))
PY
rm -f torus.xyz torus_attr.xyz box.xyz torus_moved.xyz
sha256sum -- * | sort -k2
