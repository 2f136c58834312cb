#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Turn reconstruct_bench's key=value lines (stdin) into the Markdown table of BENCHMARKS.md (issue 7)."""
import re
import sys

NAMES = {"local": "iires local", "advancing-front": "iires + CGAL advancing front",
         "bpa": "Open3D ball pivoting", "poisson": "Open3D Poisson",
         "input-advancing-front": "CGAL advancing front on the input (no resampling)"}
print("| model | N | method | Q_avg | Q_min | angles < 30° | boundary edges | closed / manifold / oriented "
      "| Euler | Hausdorff % diag | time (s) |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for line in sys.stdin:
    kv = dict(re.findall(r'(\w+)=("[^"]*"|\S+)', line))
    if kv.get("method") == "resample" or "method" not in kv:
        continue
    name = NAMES.get(kv["method"], kv["method"])
    if kv.get("status") != "ok":
        print(f"| {kv['model']} | {kv['n']} | {name} | {kv.get('status')} {kv.get('message', '')} |||||||")
        continue
    manifold = kv["nonmanifold_edges"] == "0" and kv["nonmanifold_vertices"] == "0"
    yn = lambda b: "yes" if b else "no"
    print(f"| {kv['model']} | {kv['n']} | {name} | {float(kv['q_avg']):.3f} | {float(kv['q_min']):.3f} "
          f"| {float(kv['pct_angle_lt30']):.2f} % | {kv['boundary_edges']} "
          f"| {yn(kv['closed'] == '1')} / {yn(manifold)} / {yn(kv['oriented'] == '1')} | {kv['euler']} "
          f"| {float(kv['hausdorff_pct_diag']):.2f} | {float(kv['time_s']):.2f} |")
