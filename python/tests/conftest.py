"""Shared helpers: a double-precision brute force in numpy, and small meshes."""

import numpy as np
import pytest


def brute_force(vertices, triangles, rays, tmin=0.0, tmax=np.inf):
    """Closest hits by Möller-Trumbore in float64 over every triangle: (t, prim, u, v, margin)
    per ray, prim -1 on a miss; margin is how far the hit lies inside its triangle's edges and
    interval (small margins are where float and double may legitimately disagree)."""
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles)
    p0, p1, p2 = v[tri[:, 0]], v[tri[:, 1]], v[tri[:, 2]]
    e1, e2 = p1 - p0, p2 - p0
    o = np.asarray(rays, dtype=np.float64)[:, None, :3]
    d = np.asarray(rays, dtype=np.float64)[:, None, 3:]
    pvec = np.cross(d, e2)
    det = np.einsum("rtk,tk->rt", pvec, e1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - p0
        u = np.einsum("rtk,rtk->rt", s, pvec) * inv
        q = np.cross(s, e1)
        w = np.einsum("rtk,rtk->rt", d, q) * inv
        t = np.einsum("tk,rtk->rt", e2, q) * inv
    ok = (det != 0) & (u >= 0) & (w >= 0) & (u + w <= 1) & (t >= tmin) & (t <= tmax)
    t = np.where(ok, t, np.inf)
    prim = np.argmin(t, axis=1)
    rows = np.arange(len(t))
    best = t[rows, prim]
    hit = np.isfinite(best)
    margin = np.minimum.reduce([u[rows, prim], w[rows, prim], 1 - u[rows, prim] - w[rows, prim]])
    return (best, np.where(hit, prim, -1), u[rows, prim], w[rows, prim], margin)


def cube():
    """The closed cube [-1, 1]^3, 12 triangles with shared vertices, outward windings."""
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float32)
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    t = []
    for a, b, c, d in faces:
        t += [(a, b, c), (a, c, d)]
    return v, np.array(t, dtype=np.int32)


@pytest.fixture
def unit_square():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)
    t = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)
    return v, t
