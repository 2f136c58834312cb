# SPDX-License-Identifier: GPL-3.0-or-later
"""Tests of tools/iires-render (headless pictures, histogram, colour-coded PLY)."""

import os
import subprocess
import sys

import numpy as np
import pytest

import iires

# scripts/test.sh installs matplotlib (Debian's python3-matplotlib); a build made by setup.sh alone may lack it.
pytest.importorskip("matplotlib", reason="iires-render needs python3-matplotlib (scripts/test.sh installs it)")

RENDER = os.path.join(os.environ.get("IIRES_BIN_DIR", ""), "iires-render")


def render(*args):
    return subprocess.run([sys.executable, RENDER, *map(str, args)], capture_output=True, text=True,
                          env=dict(os.environ, MPLBACKEND="Agg"))


def is_png(path):
    with open(path, "rb") as f:
        return f.read(8) == b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("render")
    rng = np.random.default_rng(1)
    p = rng.normal(size=(4000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    iires.write_point_cloud(d / "cloud.ply", p, colors=np.round(127.5 * (1 + p)).astype(np.uint8))
    vertices, faces, _ = iires.reconstruct(p, 500)
    iires.write_mesh(d / "mesh.ply", vertices, faces)
    return d


def test_cloud_by_spacing_with_histogram_and_ply(scene):
    r = render(scene / "cloud.ply", scene / "a.png", "--histogram", scene / "a_hist.png", "--ply", scene / "a.ply")
    assert r.returncode == 0, r.stderr
    assert is_png(scene / "a.png") and is_png(scene / "a_hist.png")
    coded = iires.read_point_cloud(scene / "a.ply")
    assert coded.colors.shape == (4000, 3) and coded.colors.dtype == np.uint8
    assert len(np.unique(coded.colors, axis=0)) > 10  # a colour scale, not one colour
    assert np.allclose(coded.attributes["spacing"], iires.nearest_distances(coded.points))


def test_mesh_by_quality_and_distance(scene):
    r = render(scene / "mesh.ply", scene / "b.png", "--ply", scene / "b.ply", "--histogram", scene / "b_hist.png")
    assert r.returncode == 0, r.stderr
    assert is_png(scene / "b.png")
    vertices, faces = iires.read_mesh(scene / "b.ply")
    assert len(faces) > 900 and iires.read_point_cloud(scene / "b.ply").colors is not None
    r = render(scene / "mesh.ply", scene / "c.png", "--color-by", "distance", "--reference", scene / "cloud.ply")
    assert r.returncode == 0, r.stderr
    r = render(scene / "cloud.ply", scene / "d.png", "--color-by", "rgb", "--view", "90,0")
    assert r.returncode == 0, r.stderr


def test_bad_input_is_one_line_and_exit_2(scene):
    for args, message in [((scene / "missing.ply", scene / "e.png"), "missing.ply: no such file"),
                          ((scene / "cloud.ply", scene / "e.png", "--color-by", "quality"), "needs a mesh"),
                          ((scene / "cloud.ply", scene / "e.jpg"), "expected a .png file"),
                          ((scene / "mesh.ply", scene / "e.png", "--color-by", "distance"), "needs --reference")]:
        r = render(*args)
        assert r.returncode == 2, (args, r.stderr)
        assert r.stderr.startswith("iires-render: error: ") and message in r.stderr
        assert r.stderr.count("\n") == 1
    assert not os.path.exists(scene / "e.png")
