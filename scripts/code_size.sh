#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Report source files over 800 lines and functions over 150 lines in the libraries, tools and tests (the
# project's size limits, CONVENTIONS.md). Prints a warning list; exits 0 (CI shows it, nothing fails on it).
# Usage: bash scripts/code_size.sh [--max-file N] [--max-function N]
set -euo pipefail
cd "$(dirname "$0")/.."
maxFile=800
maxFunction=150
while [ $# -gt 0 ]; do
  case "$1" in
    --max-file) maxFile=$2; shift 2 ;;
    --max-function) maxFunction=$2; shift 2 ;;
    *) echo "code_size.sh: error: unknown option '$1'" >&2; exit 2 ;;
  esac
done
mapfile -t files < <(git ls-files 'libiires/*.cpp' 'libiires/*.hpp' 'libregister/*.cpp' 'libregister/*.hpp' \
                                   'libreconstruct/*.cpp' 'libreconstruct/*.hpp' 'tools/*.cpp' 'tools/*.hpp' \
                                   'python/*.cpp' 2>/dev/null)
echo "code size: ${#files[@]} files; limits: files ${maxFile} lines, functions ${maxFunction} lines"
for f in "${files[@]}"; do
  lines=$(wc -l < "$f")
  [ "$lines" -gt "$maxFile" ] && echo "warning: $f: $lines lines (over $maxFile)"
done
if command -v ctags >/dev/null 2>&1; then
  ctags --c++-kinds=f --fields=+ne -o - "${files[@]}" 2>/dev/null |
    awk -F'\t' -v max="$maxFunction" '{
      start = ""; end = "";
      for (i = 4; i <= NF; i++) { if ($i ~ /^line:/) start = substr($i, 6); if ($i ~ /^end:/) end = substr($i, 5) }
      if (start != "" && end != "" && end - start + 1 > max)
        printf "warning: %s:%s: function %s is %d lines (over %d)\n", $2, start, $1, end - start + 1, max
    }' | sort -u
else
  echo "code size: ctags not found (apt-get install universal-ctags): function lengths not checked"
fi
