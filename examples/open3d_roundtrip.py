#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""From an Open3D point cloud to iires and back (not run in CI: Open3D's Python package, Debian's
python3-open3d, is optional).

    PYTHONPATH=build/python python3 examples/open3d_roundtrip.py SCAN.ply 5000 out/

reads SCAN with Open3D, resamples it with iires to exactly N points (colours and normals carried over),
meshes it, and hands both back to Open3D, which writes out/resampled.ply and out/mesh.ply.
"""

import os
import sys

import numpy as np
import open3d as o3d

import iires


def to_iires(pcd):
    """numpy views of an Open3D cloud's arrays (no copy here; iires copies each once)."""
    points = np.asarray(pcd.points)
    normals = np.asarray(pcd.normals) if pcd.has_normals() else None
    colors = np.asarray(pcd.colors) if pcd.has_colors() else None  # floats in [0, 1]
    return points, normals, colors


def to_open3d(points, normals=None, colors=None):
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    if normals is not None:
        pcd.normals = o3d.utility.Vector3dVector(normals)
    if colors is not None:
        pcd.colors = o3d.utility.Vector3dVector(np.clip(colors[:, :3], 0, 1))
    return pcd


def main(path, n, out):
    scan = o3d.io.read_point_cloud(path)
    points, normals, colors = to_iires(scan)
    result = iires.resample(points, n, normals=normals, colors=colors, seed=0)
    print(f"{len(points)} -> {len(result.points)} points, spacing cv {result.report['spacing']['cv']:.3f}")
    resampled = to_open3d(result.points, result.normals, result.colors)

    vertices, faces, report = iires.reconstruct(points, n, seed=0)
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices), o3d.utility.Vector3iVector(faces))
    mesh.compute_vertex_normals()
    print(f"mesh: {len(faces)} triangles, Q mean {report['quality']['quality']['mean']:.3f}")

    os.makedirs(out, exist_ok=True)
    o3d.io.write_point_cloud(os.path.join(out, "resampled.ply"), resampled)
    o3d.io.write_triangle_mesh(os.path.join(out, "mesh.ply"), mesh)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3])
