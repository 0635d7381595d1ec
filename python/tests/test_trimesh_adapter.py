"""irgrid.trimesh.RayMeshIntersector answers like trimesh's own intersector."""

import numpy as np
import pytest

import irgrid.trimesh

trimesh = pytest.importorskip("trimesh")


@pytest.fixture(scope="module")
def mesh():
    return trimesh.creation.icosphere(subdivisions=3)


@pytest.fixture(scope="module")
def rays():
    rng = np.random.default_rng(4)
    origins = rng.uniform(-2, 2, (1000, 3))
    directions = rng.normal(size=(1000, 3))
    return origins, directions


def test_first_and_any_match_trimesh(mesh, rays):
    pytest.importorskip("rtree")  # trimesh's own intersector needs it
    ours = irgrid.trimesh.RayMeshIntersector(mesh)
    theirs = trimesh.ray.ray_triangle.RayMeshIntersector(mesh)
    first = ours.intersects_first(*rays)
    assert first.dtype.kind == "i" and (first >= -1).all()
    assert np.array_equal(ours.intersects_any(*rays), theirs.intersects_any(*rays))
    assert np.array_equal(first >= 0, theirs.intersects_any(*rays))
    # The first hit's location equals trimesh's nearest location, ray by ray.
    locations, index_ray, _ = theirs.intersects_location(*rays, multiple_hits=True)
    origins, directions = rays
    for ray in np.nonzero(first >= 0)[0][:200]:
        mine = ours.intersects_location(origins[ray:ray + 1], directions[ray:ray + 1],
                                        multiple_hits=False)[0][0]
        candidates = locations[index_ray == ray]
        nearest = candidates[np.argmin(np.linalg.norm(candidates - origins[ray], axis=1))]
        np.testing.assert_allclose(mine, nearest, atol=1e-5)


def test_multiple_hits_count_every_crossing(mesh, rays):
    ours = irgrid.trimesh.RayMeshIntersector(mesh)
    index_tri, index_ray, locations = ours.intersects_id(*rays, multiple_hits=True,
                                                         return_locations=True)
    per_ray = np.bincount(index_ray, minlength=len(rays[0]))
    radius = np.linalg.norm(rays[0], axis=1)
    inside, outside = radius < 0.99, radius > 1.0  # the faces lie between radius 0.995 and 1
    # A ray from inside the closed sphere leaves once; from outside it crosses 0 or 2 times.
    assert (per_ray[inside] == 1).all()
    assert np.isin(per_ray[outside], [0, 2]).all()
    np.testing.assert_allclose(np.linalg.norm(locations, axis=1), 1.0, atol=0.02)
    contains = ours.contains_points(rays[0])
    assert contains[inside].all() and not contains[outside].any()
