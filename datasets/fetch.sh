#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Extract models of CGAL's data archive into datasets/cache/ (see datasets/README.md).
#
#   bash datasets/fetch.sh                  the default set used by the tests and benchmarks
#   bash datasets/fetch.sh meshes/fandisk.off points_3/kitten.xyz ...   named files (paths inside data/)
#   bash datasets/fetch.sh --list           every file the archive holds
#
# The archive comes from Debian's libcgal-demo package (usr/share/doc/libcgal-dev/data.tar.gz), fetched with
# `apt-get download` and kept in the cache. Idempotent: files already in the cache are skipped.
set -euo pipefail

readonly PACKAGE=libcgal-demo
readonly MEMBER=usr/share/doc/libcgal-dev/data.tar.gz
readonly DEFAULTS=(
  meshes/bunny00.off meshes/armadillo.off meshes/fandisk.off meshes/hand.off
  meshes/knot1.off meshes/joint.off meshes/anchor.off meshes/fold.off meshes/3torus.off meshes/tripod.off
  points_3/kitten.xyz points_3/kitten.off points_3/hippo1.ply points_3/hippo2.ply points_3/sphere_20k.xyz
  points_3/oni.ply points_3/radar.xyz
)
cache="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/cache"

die() { echo "fetch.sh: error: $*" >&2; exit 1; }
for tool in apt-get dpkg-deb tar; do
  command -v "$tool" >/dev/null || die "'$tool' not found (Debian/Ubuntu only)"
done

list=0
names=()
for arg in "$@"; do
  case "$arg" in
    -h|--help) sed -n '2,9s/^# \{0,1\}//p' "${BASH_SOURCE[0]}"; exit 0 ;;
    --list) list=1 ;;
    -*) die "unknown option '$arg' (try --help)" ;;
    /*|*..*) die "'$arg': give a path inside the archive's data/ directory, e.g. meshes/bunny00.off" ;;
    *) names+=("${arg#data/}") ;;
  esac
done
((list || ${#names[@]})) || names=("${DEFAULTS[@]}")

missing=()
for name in "${names[@]}"; do
  if [[ -f "$cache/$name" ]]; then echo "present   $name"; else missing+=("$name"); fi
done
((list || ${#missing[@]})) || { echo "all ${#names[@]} files present in $cache"; exit 0; }

mkdir -p "$cache"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# The .deb is kept in the cache so that later calls with other names need no network.
deb="$(find "$cache" -maxdepth 1 -name "${PACKAGE}_*.deb" | sort | tail -n 1)"
if [[ -z "$deb" ]]; then
  mkdir "$tmp/download"
  # As root, apt drops to the _apt user for downloads: let it write the directory.
  if ((EUID == 0)) && id _apt >/dev/null 2>&1; then chmod 755 "$tmp" && chown _apt "$tmp/download"; fi
  download() { (cd "$tmp/download" && apt-get download -q "$PACKAGE"); }
  echo "download  $PACKAGE (apt-get download)"
  if ! download; then
    ((EUID == 0)) || die "apt-get download $PACKAGE failed; run 'sudo apt-get update' and retry"
    echo "retry     after apt-get update"
    apt-get update -q >/dev/null || die "apt-get update failed (no network or no Debian repository?)"
    download || die "apt-get download $PACKAGE failed after apt-get update"
  fi
  fetched=("$tmp/download/${PACKAGE}"_*.deb)
  [[ -f "${fetched[0]}" ]] || die "apt-get download produced no ${PACKAGE} .deb"
  deb="$cache/$(basename "${fetched[0]}")"
  cp "${fetched[0]}" "$deb.part" && mv -f "$deb.part" "$deb"
  echo "cached    $deb ($(du -h "$deb" | cut -f1))"
fi

dpkg-deb -x "$deb" "$tmp/pkg" || die "cannot unpack $deb (corrupt? delete it and rerun)"
data="$tmp/pkg/$MEMBER"
[[ -f "$data" ]] || die "$deb has no $MEMBER"
if ((list)); then
  tar -tzf "$data" | sed -n 's|^data/\(.*[^/]\)$|\1|p'
  exit 0
fi

mapfile -t contents < <(tar -tzf "$data")
declare -A present=()
for entry in "${contents[@]}"; do present["$entry"]=1; done
absent=()
for name in "${missing[@]}"; do [[ -n "${present[data/$name]:-}" ]] || absent+=("$name"); done
((${#absent[@]} == 0)) || die "not in CGAL's data archive: ${absent[*]} (see: bash datasets/fetch.sh --list)"

mkdir "$tmp/out"
tar -xzf "$data" -C "$tmp/out" "${missing[@]/#/data/}" || die "extracting from $data failed"
for name in "${missing[@]}"; do
  mkdir -p "$(dirname "$cache/$name")"
  cp "$tmp/out/data/$name" "$cache/$name.part" && mv -f "$cache/$name.part" "$cache/$name"
  echo "extracted $name ($(du -h "$cache/$name" | cut -f1))"
done
