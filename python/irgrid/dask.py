"""Casting a Dask array of rays on many machines.

    import dask.array as da, irgrid.dask
    from distributed import Client
    client = Client("scheduler:8786")        # or distributed.LocalCluster() on one machine
    rays = da.from_zarr("rays.zarr")         # (..., 6) float32, chunked along the leading axes
    hits = irgrid.dask.cast_rays(vertices, triangles, rays)
    t = hits["t_hit"].compute()

The geometry goes into the task graph once, as one piece of data: each worker fetches it once
and builds its Scene once, then reuses it for every chunk it is given (per process, keyed by a
hash of the geometry and options). Each chunk of rays maps to Scene.cast_rays. The results are
Dask arrays shaped like the rays' leading dimensions.
"""

from __future__ import annotations

import math
import threading

import dask
import dask.array as da
import numpy as np

from . import Scene

__all__ = ["cast_rays", "scenes_built"]

_scenes: dict[str, Scene] = {}
_lock = threading.Lock()
_builds = 0


def scenes_built() -> int:
    """How many Scenes this process has built for cast_rays (to check that a worker reuses
    its Scene: run it on the workers with Client.run)."""
    return _builds


def _scene(token: str, geometry, options: dict) -> Scene:
    global _builds
    with _lock:  # a worker's threads share the one Scene
        scene = _scenes.get(token)
        if scene is None:
            vertices, triangles = geometry
            scene = Scene(vertices, triangles, **options)
            _scenes[token] = scene
            _builds += 1
        return scene


def _cast_block(block: np.ndarray, geometry, token: str, options: dict, tmin: float,
                tmax: float) -> np.ndarray:
    """One chunk of rays to one packed float32 array: t, primitive id (its bits), u, v, normal."""
    hits = _scene(token, geometry, options).cast_rays(block, tmin=tmin, tmax=tmax)
    packed = np.empty(block.shape[:-1] + (7,), dtype=np.float32)
    packed[..., 0] = hits["t_hit"]
    packed[..., 1] = hits["primitive_ids"].view(np.float32)
    packed[..., 2:4] = hits["primitive_uvs"]
    packed[..., 4:7] = hits["primitive_normals"]
    return packed


def cast_rays(vertices, triangles, rays, tmin: float = 0.0, tmax: float = math.inf,
              **scene_options) -> dict:
    """irgrid.Scene(vertices, triangles, **scene_options).cast_rays(rays) over a Dask array of
    rays ((..., 6), chunked along the leading axes), as a dict of Dask arrays: t_hit,
    primitive_ids, primitive_uvs, primitive_normals (see Scene.cast_rays)."""
    vertices = np.asarray(vertices)
    triangles = np.asarray(triangles)
    rays = da.asarray(rays)
    if rays.ndim < 1 or rays.shape[-1] != 6:
        raise ValueError(f"rays: expected shape (..., 6), got {rays.shape}")
    if len(rays.chunks[-1]) > 1:
        rays = rays.rechunk(rays.chunks[:-1] + (6,))
    token = dask.base.tokenize(vertices, triangles, sorted(scene_options.items()))
    # One key for the geometry: the scheduler sends it to each worker once.
    geometry = dask.delayed((vertices, triangles), pure=True, traverse=False)
    packed = da.map_blocks(_cast_block, rays, geometry, token, scene_options, float(tmin),
                           float(tmax), dtype=np.float32, chunks=rays.chunks[:-1] + ((7,),))
    return {
        "t_hit": packed[..., 0],
        "primitive_ids": packed[..., 1].map_blocks(lambda b: b.view(np.uint32), dtype=np.uint32),
        "primitive_uvs": packed[..., 2:4],
        "primitive_normals": packed[..., 4:7],
    }
