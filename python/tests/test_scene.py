"""irgrid.Scene: the API, its arrays and its errors."""

import math

import numpy as np
import pytest

import irgrid
from conftest import brute_force, cube


def test_backends_structures_and_version():
    assert "cpu" in irgrid.backends()
    assert irgrid.structures()[0] == "irregular"
    assert irgrid.version().count(".") == 2


def test_closest_hit_t_uv_normal_and_misses(unit_square):
    scene = irgrid.Scene(*unit_square)
    rays = np.array([[0.25, 0.75, 2, 0, 0, -1],    # triangle 1 = (0, 2, 3), t = 2
                     [0.75, 0.25, 2, 0, 0, -2],    # triangle 0, t = 1 in units of |dir|
                     [2.0, 2.0, 2, 0, 0, -1]],     # beside the square
                    dtype=np.float32)
    hits = scene.cast_rays(rays)
    assert hits["primitive_ids"].tolist() == [1, 0, irgrid.MISS]
    assert hits["t_hit"][0] == 2 and hits["t_hit"][1] == 1 and math.isinf(hits["t_hit"][2])
    # p = (1-u-v) v0 + u v1 + v v2: on (0, 2, 3), (0.25, 0.75) is u = 0.25, v = 0.5.
    np.testing.assert_allclose(hits["primitive_uvs"][0], [0.25, 0.5], atol=1e-6)
    np.testing.assert_allclose(hits["primitive_normals"][:2], [[0, 0, 1], [0, 0, 1]], atol=1e-7)
    assert hits["primitive_normals"][2].tolist() == [0, 0, 0]
    assert hits["t_hit"].dtype == np.float32 and hits["primitive_ids"].dtype == np.uint32


def test_results_keep_the_rays_leading_shape(unit_square):
    scene = irgrid.Scene(*unit_square)
    rays = np.zeros((4, 5, 6), dtype=np.float32)
    rays[..., :2] = 0.5
    rays[..., 2] = 1
    rays[..., 5] = -1
    hits = scene.cast_rays(rays)
    assert hits["t_hit"].shape == (4, 5)
    assert hits["primitive_uvs"].shape == (4, 5, 2)
    assert hits["primitive_normals"].shape == (4, 5, 3)
    assert scene.test_occlusions(rays).shape == (4, 5)
    assert scene.count_intersections(rays).shape == (4, 5)
    assert scene.cast_rays(np.zeros((0, 6), np.float32))["t_hit"].shape == (0,)


def test_interval_per_ray_and_occlusion(unit_square):
    scene = irgrid.Scene(*unit_square)
    rays = np.tile(np.array([0.5, 0.25, 1, 0, 0, -1], np.float32), (3, 1))
    hits = scene.cast_rays(rays, tmin=np.array([0, 1.5, 0], np.float32),
                           tmax=np.array([np.inf, np.inf, 0.5], np.float32))
    assert hits["primitive_ids"].tolist() == [0, irgrid.MISS, irgrid.MISS]
    assert scene.test_occlusions(rays, tmax=0.99).tolist() == [False] * 3
    assert scene.test_occlusions(rays, tmax=1.0).tolist() == [True] * 3


def test_inputs_of_every_documented_dtype_give_the_same_hits():
    v, t = cube()
    rays = np.random.default_rng(3).normal(size=(500, 6)).astype(np.float32)
    expected = irgrid.Scene(v, t).cast_rays(rays)
    for vertices in (v.astype(np.float64), v):
        for triangles in (t.astype(np.uint32), t.astype(np.int64), t):
            hits = irgrid.Scene(vertices, triangles).cast_rays(rays)
            assert np.array_equal(hits["primitive_ids"], expected["primitive_ids"])


def test_a_grid_left_on_small_pages_gives_the_same_hits():
    v, t = cube()
    rays = np.random.default_rng(5).normal(size=(500, 6)).astype(np.float32)
    expected = irgrid.Scene(v, t).cast_rays(rays)
    hits = irgrid.Scene(v, t, huge_pages=False).cast_rays(rays)
    for key in ("t_hit", "primitive_ids", "primitive_uvs"):
        assert np.array_equal(hits[key], expected[key]), key


@pytest.mark.parametrize("structure", irgrid.structures())
def test_every_structure_matches_the_brute_force(structure):
    v, t = cube()
    rng = np.random.default_rng(5)
    rays = np.concatenate([rng.uniform(-3, 3, (400, 3)), rng.normal(size=(400, 3))], axis=1)
    rays = rays.astype(np.float32)
    hits = irgrid.Scene(v, t, structure=structure, backend="cpu").cast_rays(rays)
    t_ref, prim_ref, _, _, margin = brute_force(v, t, rays)
    robust = margin > 1e-4
    assert np.array_equal(np.isfinite(hits["t_hit"])[robust], np.isfinite(t_ref)[robust])
    both = robust & np.isfinite(t_ref)
    np.testing.assert_allclose(hits["t_hit"][both], t_ref[both], rtol=1e-5, atol=1e-6)


def test_counting_crossings_tells_inside_from_outside():
    v, t = cube()
    rng = np.random.default_rng(7)
    points = rng.uniform(-2, 2, (2000, 3)).astype(np.float32)
    directions = rng.normal(size=(2000, 3)).astype(np.float32)
    scene = irgrid.Scene(v, t)
    counts = scene.count_intersections(np.concatenate([points, directions], axis=1))
    inside = (np.abs(points) < 1).all(axis=1)
    assert counts.dtype == np.int32
    assert np.array_equal(counts % 2 == 1, inside)


def test_a_ray_through_a_shared_edge_or_vertex_counts_one_crossing():
    v, t = cube()
    scene = irgrid.Scene(v, t)
    # Through the diagonal edge the two triangles of the face x = 1 share, and through corner
    # vertices: each enters and leaves the cube once.
    rays = np.array([[3, 0.3, 0.3, -1, 0, 0],          # crosses faces x = 1, x = -1
                     [3, 0, 0, -1, 0, 0],              # through both faces' diagonals
                     [2, 2, 2, -1, -1, -1],            # through the corners (1,1,1), (-1,-1,-1)
                     [3, 1, 0, -1, 0, 0]],             # along the edge y = 1 of both faces
                    dtype=np.float32)
    counts = scene.count_intersections(rays)
    assert counts[:3].tolist() == [2, 2, 2]
    assert counts[3] % 2 == 0  # grazing an edge: in and out, or not at all


def test_rebuild_equals_a_fresh_scene():
    v, t = cube()
    rays = np.random.default_rng(9).normal(size=(300, 6)).astype(np.float32)
    scene = irgrid.Scene(v, t)
    moved = v * np.float32(2) + np.float32(0.5)
    scene.rebuild(moved)
    fresh = irgrid.Scene(moved, t)
    a, b = scene.cast_rays(rays), fresh.cast_rays(rays)
    assert all(np.array_equal(a[k], b[k]) for k in a)
    with pytest.raises(ValueError, match="rebuild"):
        scene.rebuild(v[:5])


def test_stats_and_memory():
    v, t = cube()
    scene = irgrid.Scene(v, t, lambda2=3.0)
    stats = scene.stats
    assert stats["structure"] == "irregular" and stats["triangles"] == 12
    assert stats["cells"] > 0 and stats["memory_bytes"] == scene.memory_bytes > 0
    assert "top grid" in stats["build_phases_ms"]
    assert stats["build_phase_peak_bytes"].keys() == stats["build_phases_ms"].keys()
    assert max(stats["build_phase_peak_bytes"].values()) == stats["peak_build_bytes"]
    assert stats["lambda2_used"] >= 3.0


def test_load_reads_obj_files(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    vertices, triangles = irgrid.load(path)
    assert vertices.shape == (4, 3) and vertices.dtype == np.float32
    assert triangles.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert irgrid.Scene.from_file(path).cast_rays(
        np.array([[0.5, 0.5, 1, 0, 0, -1]], np.float32))["t_hit"][0] == 1


@pytest.mark.parametrize("vertices, triangles, message", [
    (np.zeros((4, 2), np.float32), [[0, 1, 2]], "vertices: expected shape"),
    (np.zeros((4, 3), np.int32), [[0, 1, 2]], "vertices: expected float32"),
    (np.full((4, 3), np.nan, np.float32), [[0, 1, 2]], "NaN"),
    (np.zeros((4, 3), np.float32), [[0, 1, 4]], r"indices must lie in \[0, 4\)"),
    (np.zeros((4, 3), np.float32), [[0, 1, -1]], "indices"),
    (np.zeros((4, 3), np.float32), [[0.0, 1.0, 2.0]], "triangles: expected int32"),
])
def test_bad_geometry_raises_value_error(vertices, triangles, message):
    with pytest.raises(ValueError, match=message):
        irgrid.Scene(vertices, np.asarray(triangles))


def test_bad_rays_options_and_files_raise_clear_errors(unit_square, tmp_path):
    scene = irgrid.Scene(*unit_square)
    with pytest.raises(ValueError, match=r"rays: expected shape \(\.\.\., 6\)"):
        scene.cast_rays(np.zeros((3, 5), np.float32))
    with pytest.raises(ValueError, match="tmin"):
        scene.cast_rays(np.zeros((3, 6), np.float32), tmin=np.nan)
    with pytest.raises(ValueError, match="unknown build option 'lambda3'"):
        irgrid.Scene(*unit_square, lambda3=1)
    with pytest.raises(irgrid.Error, match="lambda2"):
        irgrid.Scene(*unit_square, lambda2=-1.0)
    with pytest.raises(irgrid.Error, match="unknown structure 'kd-tree'"):
        irgrid.Scene(*unit_square, structure="kd-tree")
    with pytest.raises(irgrid.Error, match="missing.obj"):
        irgrid.load(tmp_path / "missing.obj")
    if "cuda" not in irgrid.backends():
        with pytest.raises(irgrid.Error, match="cuda"):
            irgrid.Scene(*unit_square, backend="cuda")


def test_a_large_batch_answers_each_ray_in_its_place():
    """cast_rays traces a large batch in chunks per thread: every ray's hit must come back at
    its own place, whatever the order and size of the batch."""
    vertices, triangles = irgrid.load("builtin:cornell")
    scene = irgrid.Scene(vertices, triangles, backend="cpu")
    rng = np.random.default_rng(7)
    count = 200_003  # several chunks per thread, and a ragged last one
    origins = rng.uniform(vertices.min(axis=0), vertices.max(axis=0), (count, 3))
    directions = rng.normal(size=(count, 3))
    rays = np.concatenate([origins, directions], axis=1).astype(np.float32)
    tmax = rng.uniform(0.1, 10, count).astype(np.float32)
    whole = scene.cast_rays(rays, tmax=tmax)
    occluded = scene.test_occlusions(rays, tmax=tmax)
    order = rng.permutation(count)  # every ray in another chunk, at another place in it
    shuffled = scene.cast_rays(rays[order], tmax=tmax[order])
    for key, value in shuffled.items():
        np.testing.assert_array_equal(whole[key][order], value, err_msg=key)
    np.testing.assert_array_equal(occluded[order],
                                  scene.test_occlusions(rays[order], tmax=tmax[order]))
    small = scene.cast_rays(rays[:1000], tmax=tmax[:1000])  # one chunk, one thread
    np.testing.assert_array_equal(whole["primitive_ids"][:1000], small["primitive_ids"])
    assert np.isfinite(whole["t_hit"]).any() and not np.isfinite(whole["t_hit"]).all()
    np.testing.assert_array_equal(occluded, np.isfinite(whole["t_hit"]))
