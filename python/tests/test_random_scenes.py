"""Random scenes and rays (hypothesis) against the numpy double-precision brute force."""

import numpy as np
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

import irgrid
from conftest import brute_force

coordinates = st.floats(-10, 10, allow_nan=False, width=32)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), triangles=st.integers(1, 60),
       structure=st.sampled_from(["irregular", "two-level", "uniform"]),
       lambda2=st.sampled_from([0.5, 2.4, 8.0]))
def test_random_soups_match_the_brute_force(seed, triangles, structure, lambda2):
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-5, 5, (triangles, 1, 3))
    vertices = (centres + rng.normal(scale=rng.uniform(0.05, 3), size=(triangles, 3, 3)))
    vertices = vertices.reshape(-1, 3).astype(np.float32)
    faces = np.arange(3 * triangles, dtype=np.int64).reshape(-1, 3)
    origins = rng.uniform(-8, 8, (300, 3))
    rays = np.concatenate([origins, rng.normal(size=(300, 3))], axis=1).astype(np.float32)
    scene = irgrid.Scene(vertices, faces, structure=structure, backend="cpu", lambda2=lambda2)
    hits = scene.cast_rays(rays)
    t_ref, prim_ref, u_ref, v_ref, margin = brute_force(vertices, faces, rays)
    # Where the double answer is robust (the hit well inside its triangle, or a clear miss),
    # the grid must give the same triangle and t, u, v to float precision.
    robust = margin > 1e-3
    hit_ref = np.isfinite(t_ref)
    assert np.array_equal(np.isfinite(hits["t_hit"])[robust], hit_ref[robust])
    both = robust & hit_ref
    np.testing.assert_allclose(hits["t_hit"][both], t_ref[both], rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(hits["primitive_uvs"][both, 0], u_ref[both], atol=1e-3)
    np.testing.assert_allclose(hits["primitive_uvs"][both, 1], v_ref[both], atol=1e-3)
    # Any hit agrees with closest hit on every ray.
    assert np.array_equal(scene.test_occlusions(rays), hits["primitive_ids"] != irgrid.MISS)


@settings(max_examples=30, deadline=None)
@given(rays=arrays(np.float32, (50, 6), elements=coordinates))
def test_arbitrary_rays_never_crash_and_hits_lie_on_their_triangles(rays):
    rng = np.random.default_rng(1)
    vertices = rng.uniform(-5, 5, (90, 3)).astype(np.float32)
    faces = np.arange(90).reshape(-1, 3)
    hits = irgrid.Scene(vertices, faces).cast_rays(rays)
    hit = hits["primitive_ids"] != irgrid.MISS
    tri = vertices[faces[hits["primitive_ids"][hit]]].astype(np.float64)
    u, v = hits["primitive_uvs"][hit, 0:1], hits["primitive_uvs"][hit, 1:2]
    on_triangle = (1 - u - v) * tri[:, 0] + u * tri[:, 1] + v * tri[:, 2]
    on_ray = rays[hit, :3] + hits["t_hit"][hit, None].astype(np.float64) * rays[hit, 3:]
    scale = 1 + np.abs(on_ray).max(axis=1, initial=0)
    assert (np.abs(on_triangle - on_ray).max(axis=1, initial=0) <= 1e-3 * scale).all()
