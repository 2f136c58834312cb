#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Build the libFuzzer targets with clang (-fsanitize=fuzzer,address,undefined), compiling libiires' sources
# directly (not through the main CMake build), then run each target for SECONDS seconds.
#
#   bash tests/fuzz/run.sh [SECONDS] [TARGET...]     # default: 600 s each, fuzz_readers fuzz_resample
#   IIRES_FUZZ_DIR=/tmp/f bash tests/fuzz/run.sh 60   # build/corpus/artifacts elsewhere (default build-fuzz/)
#
# Crashers land in $IIRES_FUZZ_DIR/artifacts/<target>-crash-*; replay one with
#   $IIRES_FUZZ_DIR/<target> <file>
# Not part of CI. Needs clang, libclang-rt-14-dev and /usr/bin/time (apt-get install -y clang libclang-rt-14-dev libomp-dev).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${IIRES_FUZZ_DIR:-$root/build-fuzz}
seconds=${1:-600}
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(fuzz_readers fuzz_resample)
cxx=${CXX:-clang++}
jobs=${IIRES_FUZZ_JOBS:-2}

common=(-std=c++17 -O1 -g -fno-omit-frame-pointer -fopenmp -fsanitize=address,undefined
        -fno-sanitize-recover=undefined -I"$root/libiires/include" -I/usr/include/eigen3 -DNDEBUG)
mkdir -p "$out/obj" "$out/artifacts"

# Library objects, with coverage instrumentation; rebuilt when their source or a header they include (from the
# compiler's dependency file) is newer.
stale=()
for src in "$root"/libiires/src/*.cpp; do
  obj="$out/obj/$(basename "${src%.cpp}").o"
  deps="${obj%.o}.d"
  if [ ! -f "$obj" ] || [ "$src" -nt "$obj" ]; then stale+=("$src"); continue; fi
  [ -f "$deps" ] || continue
  for dep in $(sed -e 's/^[^:]*://' -e 's/\\$//' "$deps"); do
    if [ "$dep" -nt "$obj" ]; then stale+=("$src"); break; fi
  done
done
if [ ${#stale[@]} -gt 0 ]; then
  echo "compiling ${#stale[@]} library sources with $cxx (ASan+UBSan+fuzzer coverage)..."
  printf '%s\n' "${stale[@]}" | xargs -P "$jobs" -I{} sh -c \
    'src="$1"; shift; o="'"$out"'/obj/$(basename "${src%.cpp}")"; exec "$@" -MMD -MF "$o.d" -c "$src" -o "$o.o"' _ {} \
    "$cxx" "${common[@]}" -fsanitize=fuzzer-no-link
fi
# Objects of sources that no longer exist would break the link.
for obj in "$out"/obj/*.o; do
  [ -f "$root/libiires/src/$(basename "${obj%.o}").cpp" ] || rm -f "$obj" "${obj%.o}.d"
done

# Seeds: a few small valid files, generated here so the repository holds no binary blobs. For fuzz_readers the
# first byte selects the extension (0 .ply, 1 .pcd, 2 .xyz, 3 .xyzn, 4 .pts, 5 .obj, 6 .off, 7 .stl).
seed() {  # seed TARGET NAME PREFIX-BYTE-OCTAL TEXT
  mkdir -p "$out/seeds/$1"
  { printf "\\$3"; printf '%s' "$4"; } > "$out/seeds/$1/$2"
}
seed fuzz_readers ply 000 $'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n'
seed fuzz_readers plyn 000 $'ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\nproperty double nx\nproperty double ny\nproperty double nz\nend_header\n0 0 0 0 0 1\n1 0 0 0 0 1\n'
seed fuzz_readers pcd 001 $'VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n0 0 0\n1 2 3\n'
seed fuzz_readers xyz 002 $'0 0 0\n1 0 0\n0 1 0 \n'
seed fuzz_readers xyzn 003 $'0 0 0 0 0 1\n1 0 0 0 0 1\n'
seed fuzz_readers pts 004 $'2\n0 0 0 7\n1 1 1 7\n'
seed fuzz_readers obj 005 $'v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf -3 -2 -1\n'
seed fuzz_readers off 006 $'NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n'
seed fuzz_readers stl 007 $'solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n'
# fuzz_resample (header layout in resample_input.hpp): a 6x6 grid bent into a paraboloid (or an 8x8 roof with a
# crease), with intrinsic control, pre-processing, curvature mode, sharp edges, fixed samples or a larger N.
mkdir -p "$out/seeds/fuzz_resample"
python3 - "$out/seeds/fuzz_resample" <<'PY'
import struct, sys
d = sys.argv[1]
b = 0x9A  # 2 passes of 2 relaxation iterations, 8 final iterations, 14 ring candidates
for name, code, flags, a, c, roof in (("grid", 19, 0x16, 0x08, 0, False), ("grid_euclid", 49, 0x14, 0x08, 0, False),
                                      ("grid_raw", 9, 0x01, 0x08, 0, False), ("grid_curvature", 39, 0x50, 0x08, 0, False),
                                      ("grid_fixed", 29, 0x12, 0x08, 3, False), ("grid_large", 100, 0x10, 0x0B, 0, False),
                                      ("roof_sharp", 39, 0x90, 0x08, 0, True)):
    body = bytearray([code, flags, a, b, c])
    cells = 8 if roof else 6
    for i in range(cells):
        for j in range(cells):
            x, y = i * 1000 // (cells - 1) - 500, j * 1000 // (cells - 1) - 500
            z = -abs(x) // 2 if roof else (x * x + y * y) // 2000
            body += struct.pack("<3d", x, y, z) if flags & 1 else struct.pack("<3h", x, y, z)
    open(f"{d}/{name}", "wb").write(bytes(body))
PY
status=0
for t in "${targets[@]}"; do
  echo "linking $t..."
  "$cxx" "${common[@]}" -fsanitize=fuzzer "$root/tests/fuzz/$t.cpp" "$out"/obj/*.o -lgmp -lmpfr -o "$out/$t"
  mkdir -p "$out/corpus/$t"
  echo "running $t for $seconds s..."
  max_len=4096
  [ "$t" = fuzz_resample ] && max_len=$((5 + 6 * 2000))  # up to 2,000 int16 points (500 raw)
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0} \
  UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1} \
  OMP_NUM_THREADS=1 \
    /usr/bin/time -f "$t: %e s wall, %U s user CPU" "$out/$t" "$out/corpus/$t" "$out/seeds/$t" -max_total_time="$seconds" -max_len=$max_len -timeout=30 \
      -rss_limit_mb=4096 -print_final_stats=1 -artifact_prefix="$out/artifacts/$t-" 2>&1 |
    tee "$out/$t.log" | grep -E '^#[0-9]+ +(INITED|DONE|pulse)|ERROR|SUMMARY|stat::|Test unit written|==[0-9]+==|^Done|s user CPU' || true
  # Slow units (written when an input takes > 10 s wall, e.g. on a loaded machine) are not failures.
  if grep -qE 'ERROR: (libFuzzer|AddressSanitizer|UndefinedBehaviorSanitizer|LeakSanitizer)|runtime error|deadly signal|Test unit written to .*-(crash|leak|timeout|oom)-' \
      "$out/$t.log"; then
    echo "$t: FAILURE (see $out/$t.log and $out/artifacts/)"
    status=1
  else
    echo "$t: no crashes"
  fi
done
exit $status
