#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Write the fixed inputs of scripts/check_identical.sh into a directory (same bytes on every run).

Only Python's `random.Random(seed)` and fixed '%.9g' formatting: no numpy, no network."""
import math
import random
import sys


def torus(rng, n, R=1.0, r=0.35, noise=0.004, outliers=20):
    pts = []
    while len(pts) < n:
        u, v = rng.uniform(0, 2 * math.pi), rng.uniform(0, 2 * math.pi)
        # non-uniform density: denser on the outer rim
        if rng.random() > 0.35 + 0.65 * (1 + math.cos(v)) / 2:
            continue
        d = rng.gauss(0, noise)
        rr = r + d
        pts.append(((R + rr * math.cos(v)) * math.cos(u), (R + rr * math.cos(v)) * math.sin(u), rr * math.sin(v)))
    for _ in range(outliers):
        i = rng.randrange(len(pts))
        x, y, z = pts[i]
        pts[i] = (x, y, z + rng.choice((-1, 1)) * rng.uniform(0.08, 0.15))
    return pts


def box(rng, n, size=(1.0, 0.7, 0.5)):
    sx, sy, sz = size
    areas = [sy * sz, sy * sz, sx * sz, sx * sz, sx * sy, sx * sy]
    total = sum(areas)
    pts = []
    for _ in range(n):
        t, f = rng.random() * total, 0
        while t > areas[f]:
            t -= areas[f]
            f += 1
        a, b = rng.random(), rng.random()
        if f < 2:
            p = ((f % 2) * sx, a * sy, b * sz)
        elif f < 4:
            p = (a * sx, (f % 2) * sy, b * sz)
        else:
            p = (a * sx, b * sy, (f % 2) * sz)
        pts.append(p)
    return pts


def similarity(pts, s, axis, angle, t):
    ax = [c / math.sqrt(sum(a * a for a in axis)) for c in axis]
    c, s_, C = math.cos(angle), math.sin(angle), 1 - math.cos(angle)
    x, y, z = ax
    R = [[c + x * x * C, x * y * C - z * s_, x * z * C + y * s_],
         [y * x * C + z * s_, c + y * y * C, y * z * C - x * s_],
         [z * x * C - y * s_, z * y * C + x * s_, c + z * z * C]]
    return [tuple(s * sum(R[i][j] * p[j] for j in range(3)) + t[i] for i in range(3)) for p in pts]


def write_xyz(path, pts, extra=None):
    with open(path, "w") as f:
        for i, p in enumerate(pts):
            line = "%.9g %.9g %.9g" % p
            if extra:
                line += " " + " ".join(str(v) for v in extra(i, p))
            f.write(line + "\n")


def main(out):
    rng = random.Random(25)
    tor = torus(rng, 6000)
    write_xyz(out + "/torus.xyz", tor)
    # attributes: a colour and an integer label per point
    write_xyz(out + "/torus_attr.xyz", tor,
              lambda i, p: (int(128 + 127 * math.tanh(p[0])), int(128 + 127 * math.tanh(p[1])), 200, "%.4g" % (0.5 + 0.5 * p[2]), i % 5))
    write_xyz(out + "/box.xyz", box(rng, 6000))
    part = [p for p in torus(random.Random(7), 4000, noise=0.002, outliers=0) if p[0] > -0.6]
    write_xyz(out + "/torus_moved.xyz", similarity(part, 2.5, (0.3, -1.0, 0.4), 0.9, (3.0, -1.0, 0.5)))


if __name__ == "__main__":
    main(sys.argv[1])
