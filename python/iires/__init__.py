# SPDX-License-Identifier: GPL-3.0-or-later
"""iires: exactly-N isotropic resampling, registration and meshing of 3-D point clouds, on numpy arrays.

Every function takes (n, 3) coordinate arrays and keyword parameters named after the command-line tools'
flags (``mode="curvature"``, ``sharp_edges=True``, ``outliers="remove"``, ``seed=3``, ``threads=2``, ...).
Bad input raises ValueError with the tools' messages, an unknown parameter TypeError. The computation runs
without the GIL, so other Python threads keep running.
"""

import operator
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from . import _iires

__version__ = _iires.__version__
__all__ = ["resample", "register", "reconstruct", "mesh_quality", "read_point_cloud", "write_point_cloud",
           "read_mesh", "write_mesh", "nearest_distances", "triangle_qualities", "Cloud", "ResampleResult"]


@dataclass
class Cloud:
    """A point cloud: positions and what came with them."""

    points: np.ndarray  #: (n, 3) float64
    normals: Optional[np.ndarray] = None  #: (n, 3) float64, or None
    colors: Optional[np.ndarray] = None  #: (n, 3|4), uint8 (0-255) or float, or None
    attributes: dict = field(default_factory=dict)  #: name -> (n,) array (intensity, labels, ...)


@dataclass
class ResampleResult(Cloud):
    """What :func:`resample` returns: exactly N points with unit normals, the input's colours and attributes
    carried over (colours in the input's dtype), and the report iires-resample prints."""

    report: dict = field(default_factory=dict)  #: input_points, output_points, spacing, time_s, ...


def resample(points, n, normals=None, colors=None, attributes=None, **params) -> ResampleResult:
    """Resample a cloud to exactly ``n`` points, uniformly spaced on its surface.

    points: (m, 3) array; normals: optional (m, 3); colors: optional (m, 3) or (m, 4), uint8 (0-255) or float,
    averaged from the input neighbours on the same sheet; attributes: optional dict of (m,) arrays (integer
    arrays are labels: the neighbours' majority; float arrays are averaged).
    params: mode ("isotropic" | "curvature"), levels, ratios, sharp_edges, edge_ratio, outliers ("pull" |
    "remove" | "keep"), no_denoise, no_intrinsic, input_per_sample, seed, threads.
    """
    pts, nrm, col, attrs, report = _iires.resample(points, operator.index(n), normals, colors, attributes, params)
    return ResampleResult(pts, nrm, col, attrs, report)


def register(source, target, **params):
    """Align ``source`` to ``target`` (any rotation, scale, translation, density).

    Returns (T, report): T the 4x4 similarity T_target_source (source -> target coordinates, float64) and the
    report dict of iires-register. params: samples (or m), grid ("so3" | "euler"), overlap, no_scale,
    full_resample, seed, threads.
    """
    return _iires.register(source, target, params)


def reconstruct(points, n=10000, normals=None, **params):
    """Mesh a cloud with near-equilateral triangles: resample to exactly ``n`` vertices, triangulate, close holes.

    Returns (vertices (n, 3) float64, faces (f, 3) int32, report dict of iires-reconstruct).
    params: method ("local" | "advancing-front"), no_resample, no_hole_filling, max_hole_edges,
    max_hole_extent, seed, threads.
    """
    return _iires.reconstruct(points, operator.index(n), normals, params)


def mesh_quality(vertices, faces, reference=None, **params):
    """Quality report of a triangle mesh (triangle quality Q, angles, topology; with ``reference``, an
    (m, 3) cloud, the two-sided distance to it) as a dict. params: seed, threads."""
    return _iires.mesh_quality(vertices, faces, reference, params)


def read_point_cloud(path, columns=None) -> Cloud:
    """Read a cloud (.ply .pcd .xyz .xyzn .pts, or a mesh's vertices) as the tools do. ``columns`` names the
    columns of a .xyz file, e.g. ["x", "y", "z", "red", "green", "blue", "intensity", "label:int"]."""
    points, normals, colors, attributes = _iires.read_point_cloud(str(path), list(columns or []))
    return Cloud(points, normals, colors, attributes)


def write_point_cloud(path, points, normals=None, colors=None, attributes=None, ascii=False):
    """Write a cloud: .ply (binary unless ``ascii``, with normals, colours and attributes), .xyz, .xyzn."""
    _iires.write_point_cloud(str(path), points, normals, colors, attributes, bool(ascii))


def read_mesh(path):
    """Read a triangle mesh (.ply .obj .off .stl): (vertices (n, 3) float64, faces (f, 3) int32)."""
    return _iires.read_mesh(str(path))


def write_mesh(path, vertices, faces, colors=None):
    """Write a triangle mesh: .ply (binary, with per-vertex colours when given), .obj, .off."""
    _iires.write_mesh(str(path), vertices, faces, colors)


def nearest_distances(points, queries=None):
    """Distance from each of ``queries`` to its nearest point of ``points`` ((q,) float64); without queries,
    from each point to its nearest other point (the cloud's spacing)."""
    return _iires.nearest_distances(points, queries)


def triangle_qualities(vertices, faces):
    """Triangle quality Q_t of each face ((f,) float64; 1 = equilateral, 0 = degenerate), as in the reports."""
    return _iires.triangle_qualities(vertices, faces)
