# SPDX-License-Identifier: GPL-3.0-or-later
# Shared by the meshing runners (run_genus.sh, run_mesh_validity.sh, run_held_out.sh), prepended to their awk
# programs: a reconstruct_bench row's key=value pairs, and the bounds of issues 19 and 20 it misses.
function parse(kv,    i, p) {
  split("", kv)
  for (i = 1; i <= NF; i++) { p = index($i, "="); if (p) kv[substr($i, 1, p - 1)] = substr($i, p + 1) }
}
# The bounds among @p checks (comma-separated: si nm oriented closed q_avg q_min lt30 genus) the row misses, in
# that order, comma-separated; "none" when it meets them all. closed where the true mesh is closed, genus where
# its genus is known (closed and not intersecting itself).
function misses(kv, checks,    want, known, m) {
  want = "," checks ","
  known = kv["genus_truth"] != "na"
  m = ""
  if (index(want, ",si,") && kv["self_intersections"] > 0) m = m ",si"
  if (index(want, ",nm,") && kv["nonmanifold_edges"] + kv["nonmanifold_vertices"] > 0) m = m ",nm"
  if (index(want, ",oriented,") && kv["oriented"] != 1) m = m ",oriented"
  if (index(want, ",closed,") && kv["truth_closed"] == 1 && kv["closed"] != 1) m = m ",closed"
  if (index(want, ",q_avg,") && kv["q_avg"] < 0.90) m = m ",q_avg"
  if (index(want, ",q_min,") && kv["q_min"] < 0.40) m = m ",q_min"
  if (index(want, ",lt30,") && kv["pct_angle_lt30"] >= 1) m = m ",lt30"
  if (index(want, ",genus,") && known && kv["genus"] != kv["genus_truth"]) m = m ",genus"
  return m == "" ? "none" : substr(m, 2)
}
