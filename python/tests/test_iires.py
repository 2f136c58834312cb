# SPDX-License-Identifier: GPL-3.0-or-later
"""Tests of the iires Python package (run by ctest as python_tests; PYTHONPATH=build/python)."""

import os
import threading
import time

import numpy as np
import pytest

import iires

DATA = os.environ.get("IIRES_DATA_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "datasets", "cache"))


def sphere(n, seed=1, radius=1.0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    return radius * p / np.linalg.norm(p, axis=1, keepdims=True)


def data(relative):
    path = os.path.join(DATA, relative)
    assert os.path.exists(path), f"{path} is missing: run datasets/fetch.sh"
    return path


# ------------------------------------------------------------------------------------------------ resample

def test_resample_random_sphere_gives_exactly_n():
    # The README's one-liner: random points on a unit sphere.
    p = np.random.default_rng(0).normal(size=(20000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    r = iires.resample(p, 1000)
    assert r.points.shape == (1000, 3)
    assert r.normals.shape == (1000, 3)
    assert r.colors is None and r.attributes == {}
    assert np.all(np.isfinite(r.points))
    assert r.report["output_points"] == 1000


def test_resample_sphere_is_uniform_on_the_surface():
    r = iires.resample(sphere(20000), 2000, seed=3)
    assert r.points.shape == (2000, 3) and r.points.dtype == np.float64
    assert np.max(np.abs(np.linalg.norm(r.points, axis=1) - 1)) < 1e-3
    assert np.allclose(np.linalg.norm(r.normals, axis=1), 1)
    assert r.report["spacing"]["cv"] < 0.1
    assert r.report["requested_points"] == 2000


def test_resample_same_seed_same_output_for_any_thread_count():
    p = sphere(8000, seed=2)
    a = iires.resample(p, 500, seed=7, threads=1)
    b = iires.resample(p, 500, seed=7, threads=2)
    assert np.array_equal(a.points, b.points)


def test_resample_accepts_float32_lists_and_normals():
    p = sphere(5000, seed=4)
    r = iires.resample(p.astype(np.float32), 300, normals=p)
    assert r.points.shape == (300, 3)
    r = iires.resample(p.tolist(), 300)
    assert r.points.shape == (300, 3)


def test_resample_params_by_the_cli_flag_names():
    p = sphere(10000, seed=5)
    r = iires.resample(p, 800, mode="curvature", levels=3, outliers="remove", no_denoise=True, no_intrinsic=True,
                       input_per_sample=0, seed=1, threads=2)
    assert r.points.shape == (800, 3)
    assert len(r.report["points_per_level"]) == 3


# ------------------------------------------------------------------------------------------------ register

def test_register_recovers_a_known_similarity():
    vertices, _ = iires.read_mesh(data("meshes/bunny00.off"))
    angle = 0.7
    axis = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    scale, shift = 2.5, np.array([0.3, -1.0, 4.0])
    target = scale * vertices @ rotation.T + shift
    T, report = iires.register(vertices, target, seed=1)
    assert T.shape == (4, 4)
    assert report["scale"] == pytest.approx(scale, rel=0.01)
    moved = vertices @ T[:3, :3].T + T[:3, 3]
    diagonal = np.linalg.norm(target.max(0) - target.min(0))
    assert np.sqrt(np.mean(np.sum((moved - target) ** 2, axis=1))) < 0.01 * diagonal


# ------------------------------------------------------------------------------------------------ reconstruct

def test_reconstruct_sphere_is_closed_and_well_shaped():
    vertices, faces, report = iires.reconstruct(sphere(20000, seed=6), 1000, seed=2)
    assert vertices.shape == (1000, 3)
    assert faces.dtype == np.int32 and faces.shape[1] == 3
    assert faces.min() >= 0 and faces.max() < 1000
    assert report["quality"]["closed"] is True
    assert report["quality"]["quality"]["mean"] > 0.8


# ------------------------------------------------------------------------------------------------ quality

def test_mesh_quality_of_a_tetrahedron():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    q = iires.mesh_quality(v, f)
    assert q["faces"] == 4 and q["closed"] is True and q["genus"] == 0
    with_reference = iires.mesh_quality(v, f, reference=v)
    assert with_reference["distance"]["hausdorff"] >= 0


def test_mesh_quality_of_a_reconstruction_against_its_input():
    p = sphere(10000, seed=8)
    vertices, faces, _ = iires.reconstruct(p, 800)
    q = iires.mesh_quality(vertices, faces, reference=p)
    assert q["distance"]["hausdorff"] < 0.1


# ------------------------------------------------------------------------------------------------ errors

@pytest.mark.parametrize("points, message", [
    (np.zeros((0, 3)), "points: the cloud is empty"),
    (np.array([[0, 0, 0], [1, 0, 0], [np.nan, 0, 0], [0, 1, 0], [0, 0, 1]], float), "non-finite coordinate"),
    (np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3], [4, 4, 4]], float), "collinear"),
    (np.zeros((10, 2)), "points: expected an (n, 3) array"),
    (np.random.default_rng(0).random((20000, 3)), "the points fill a volume rather than sample a surface"),
])
def test_bad_clouds_raise_value_error(points, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        iires.resample(points, 10)


def test_bad_parameters():
    p = sphere(2000)
    with pytest.raises(ValueError, match=r"n must be at least 1 \(got 0\)"):
        iires.resample(p, 0)
    with pytest.raises(ValueError, match="exceeds the limit"):
        iires.resample(p, 10**9)
    with pytest.raises(TypeError):
        iires.resample(p, 10.5)
    with pytest.raises(TypeError, match="unexpected keyword argument 'bogus'"):
        iires.resample(p, 10, bogus=1)
    with pytest.raises(ValueError, match="mode must be one of"):
        iires.resample(p, 10, mode="fast")
    with pytest.raises(ValueError, match="need mode='curvature'"):
        iires.resample(p, 10, levels=3)
    with pytest.raises(TypeError, match="seed must be an integer"):
        iires.resample(p, 10, seed=1.5)
    with pytest.raises(ValueError, match="samples must be at least 50"):
        iires.register(p, p, samples=10)
    with pytest.raises(ValueError, match=r"overlap must be in \(0, 1\]"):
        iires.register(p, p, overlap=0)
    with pytest.raises(ValueError, match="source: the cloud is empty"):
        iires.register(np.zeros((0, 3)), p)
    with pytest.raises(ValueError, match=r"n must be at least 4 \(got 3\)"):
        iires.reconstruct(p, 3)
    with pytest.raises(ValueError, match="refers to vertex 7"):
        iires.mesh_quality(np.zeros((3, 3)), np.array([[0, 1, 7]]))
    with pytest.raises(ValueError, match="colors: expected an"):
        iires.resample(p, 10, colors=np.zeros((5, 3), np.uint8))
    with pytest.raises(ValueError, match="no such file"):
        iires.read_point_cloud("/nonexistent/cloud.ply")


def test_gil_is_released_while_computing():
    p = sphere(30000, seed=9)
    done = threading.Event()
    ticks = []

    def work():
        iires.resample(p, 6000, threads=1)
        done.set()

    worker = threading.Thread(target=work)
    start = time.perf_counter()
    worker.start()
    while not done.is_set():
        ticks.append(time.perf_counter())
        time.sleep(0.005)
    worker.join()
    elapsed = time.perf_counter() - start
    gaps = np.diff([start] + ticks)
    assert elapsed > 0.2, "the run is too short to tell"
    assert gaps.max() < 0.5 * elapsed  # the main thread kept running: the GIL was not held throughout


# ------------------------------------------------------------------------------------------------ attributes

def test_colours_follow_a_smooth_field():
    p = sphere(30000, seed=10)
    colours = np.round(127.5 * (1 + p)).astype(np.uint8)  # a smooth function of position
    r = iires.resample(p, 3000, colors=colours)
    assert r.colors.dtype == np.uint8 and r.colors.shape == (3000, 3)
    error = np.abs(r.colors.astype(float) - 127.5 * (1 + r.points)).mean() / 255
    assert error < 0.02


def test_float_colours_labels_and_scalars():
    p = sphere(20000, seed=11)
    colours = np.column_stack([(p[:, 0] + 1) / 2, np.full(len(p), 0.5), np.ones(len(p)), np.ones(len(p))])
    labels = (p[:, 2] > 0).astype(np.int32) + 10
    intensity = p[:, 1].astype(np.float32)
    r = iires.resample(p, 1500, colors=colours, attributes={"label": labels, "intensity": intensity})
    assert r.colors.dtype == np.float64 and r.colors.shape == (1500, 4)
    assert np.abs(r.colors[:, 0] - (r.points[:, 0] + 1) / 2).mean() < 0.02
    assert set(np.unique(r.attributes["label"])) <= {10, 11}
    away = np.abs(r.points[:, 2]) > 0.1  # away from the border between the labels
    assert np.all(r.attributes["label"][away] == (r.points[away, 2] > 0) + 10)
    assert r.attributes["label"].dtype == np.int64
    assert np.abs(r.attributes["intensity"] - r.points[:, 1]).mean() < 0.02


def test_point_cloud_files_keep_colours_and_attributes(tmp_path):
    p = sphere(100, seed=12)
    colours = np.arange(300, dtype=np.uint8).reshape(100, 3)
    labels = np.arange(100, dtype=np.int32)
    for ascii in (False, True):
        path = tmp_path / f"c{int(ascii)}.ply"
        iires.write_point_cloud(path, p, normals=p, colors=colours, attributes={"label": labels}, ascii=ascii)
        back = iires.read_point_cloud(path)
        assert np.allclose(back.points, p) and np.allclose(back.normals, p)
        assert back.colors.dtype == np.uint8 and np.array_equal(back.colors, colours)
        assert np.array_equal(back.attributes["label"], labels)
    xyz = tmp_path / "c.xyz"
    np.savetxt(xyz, np.column_stack([p, colours, labels]), fmt="%.17g")
    back = iires.read_point_cloud(xyz, columns=["x", "y", "z", "red", "green", "blue", "label:int"])
    assert np.array_equal(back.colors, colours) and np.array_equal(back.attributes["label"], labels)


def test_meshes_round_trip_with_colours(tmp_path):
    vertices, faces, _ = iires.reconstruct(sphere(5000, seed=13), 200)
    colours = np.round(127.5 * (1 + vertices)).astype(np.uint8)
    iires.write_mesh(tmp_path / "m.ply", vertices, faces, colors=colours)
    v, f = iires.read_mesh(tmp_path / "m.ply")
    assert np.allclose(v, vertices) and np.array_equal(f, faces)
    assert np.array_equal(iires.read_point_cloud(tmp_path / "m.ply").colors, colours)
