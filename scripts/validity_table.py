#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Turn reconstruct_bench's key=value lines (files or stdin) into issue 20's Markdown table: validity, topology,
shape, both Hausdorff directions, uncovered input, time; then a summary of the acceptance checks per method."""
import fileinput
import re

NAMES = {"local": "iires", "advancing-front": "iires pts + CGAL AF", "bpa": "Open3D BPA",
         "poisson": "Open3D Poisson", "input-advancing-front": "CGAL AF on input"}


def row(kv):
    yn = lambda b: "yes" if b else "no"
    truth = "closed" if kv["reference"] == "mesh" else "scan"
    genus = f"{kv['genus_truth']} / {kv['genus']}" if truth == "closed" else kv["genus"]
    extra = ""
    if kv["method"] == "local" and "validity_pct_of_meshing" in kv:
        extra = f"{float(kv['validity_pct_of_meshing']):.0f} %"
    return (f"| {kv['model']} | {kv['density_ratio']} | {kv['n']} | {NAMES.get(kv['method'], kv['method'])} "
            f"| {kv['self_intersections']} | {kv['nonmanifold_edges']} / {kv['nonmanifold_vertices']} "
            f"| {yn(kv['oriented'] == '1')} | {yn(kv['closed'] == '1')} | {genus} | {kv['boundary_loops']} "
            f"| {float(kv['q_avg']):.3f} | {float(kv['q_min']):.3f} | {float(kv['pct_angle_lt30']):.2f} "
            f"| {float(kv['mesh_to_truth_pct_diag']):.2f} | {float(kv['truth_to_mesh_pct_diag']):.2f} "
            f"| {float(kv['uncovered_pct']):.2f} | {float(kv['time_s']):.2f} | {extra} |")


def meets(kv):
    """Issue 20's acceptance for one row (closure only where the true mesh is closed)."""
    ok = (kv["self_intersections"] == "0" and kv["nonmanifold_edges"] == "0" and kv["nonmanifold_vertices"] == "0"
          and kv["oriented"] == "1" and float(kv["q_avg"]) >= 0.90 and float(kv["q_min"]) >= 0.40
          and float(kv["pct_angle_lt30"]) < 1.0)
    closed_truth = kv["reference"] == "mesh" and kv["genus_truth"] != "na"  # the true mesh is a closed manifold
    return ok and (not closed_truth or kv["closed"] == "1")


print("| model | density | N | method | self-int. pairs | non-manifold e / v | oriented | closed "
      "| genus (truth / ours) | boundary loops | Q_avg | Q_min | % angles < 30° | mesh→truth % diag "
      "| truth→mesh % diag | uncovered % | time (s) | validity stage / rest of meshing |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
summary = {}
for line in fileinput.input():
    kv = dict(re.findall(r'(\w+)=("[^"]*"|\S+)', line))
    if "method" not in kv or kv["method"] == "resample":
        continue
    name = NAMES.get(kv["method"], kv["method"])
    if kv.get("status") != "ok":
        print(f"| {kv.get('model')} | {kv.get('density_ratio')} | {kv.get('n')} | {name} "
              f"| {kv.get('status')} {kv.get('message', '')} ||||||||||||||")
        continue
    print(row(kv))
    s = summary.setdefault(name, [0, 0, []])
    s[0] += 1
    if meets(kv):
        s[1] += 1
    else:
        s[2].append(f"{kv['model']}/{kv['density_ratio']}/{kv['n']}")
print()
for name, (rows, good, bad) in summary.items():
    print(f"- {name}: {good} of {rows} rows meet every check" + (f" (not: {', '.join(bad)})" if bad else ""))
