"""A drop-in ray-mesh intersector for trimesh users.

    import trimesh, irgrid.trimesh
    mesh = trimesh.load("bunny.ply")
    mesh.ray = irgrid.trimesh.RayMeshIntersector(mesh)   # the one line that switches
    index_tri = mesh.ray.intersects_first(origins, directions)

It answers like trimesh's own intersectors (trimesh.ray.ray_pyembree / ray_triangle):
directions are normalised, a miss is index -1, and with multiple_hits every crossing along a
ray is reported, nearest first. trimesh itself is not needed to import this module: any object
with `vertices` and `faces` arrays will do.
"""

from __future__ import annotations

import numpy as np

from . import Scene

__all__ = ["RayMeshIntersector"]


def _unit_rays(ray_origins, ray_directions) -> tuple[np.ndarray, np.ndarray]:
    origins = np.asarray(ray_origins, dtype=np.float64).reshape(-1, 3)
    directions = np.asarray(ray_directions, dtype=np.float64).reshape(-1, 3)
    if origins.shape != directions.shape:
        raise ValueError(f"ray_origins {origins.shape} and ray_directions {directions.shape} "
                         "must have the same shape")
    lengths = np.linalg.norm(directions, axis=1)
    lengths[lengths == 0] = 1.0
    directions = directions / lengths[:, None]
    return origins, directions


class RayMeshIntersector:
    """Ray queries on a trimesh.Trimesh (or anything with `vertices` and `faces`), answered by
    an irgrid Scene built once over the mesh. scene_options go to irgrid.Scene (structure,
    backend, build options)."""

    def __init__(self, mesh, **scene_options):
        self.mesh = mesh
        self._scene = Scene(np.asarray(mesh.vertices, dtype=np.float64),
                            np.asarray(mesh.faces, dtype=np.int64), **scene_options)

    @property
    def scene(self) -> Scene:
        return self._scene

    def _rays(self, origins, directions) -> np.ndarray:
        return np.concatenate([origins, directions], axis=1).astype(np.float32)

    def intersects_first(self, ray_origins, ray_directions, **kwargs) -> np.ndarray:
        """The index of the first triangle each ray hits, -1 where it hits none."""
        origins, directions = _unit_rays(ray_origins, ray_directions)
        ids = self._scene.cast_rays(self._rays(origins, directions))["primitive_ids"]
        out = ids.astype(np.int64)
        out[ids == 0xFFFFFFFF] = -1
        return out

    def intersects_any(self, ray_origins, ray_directions, **kwargs) -> np.ndarray:
        """Whether each ray hits any triangle."""
        origins, directions = _unit_rays(ray_origins, ray_directions)
        return self._scene.test_occlusions(self._rays(origins, directions))

    def intersects_id(self, ray_origins, ray_directions, multiple_hits: bool = True,
                      max_hits: int = 20, return_locations: bool = False, **kwargs):
        """(index_tri, index_ray[, locations]) of the hits: the first hit of each ray, or with
        multiple_hits up to max_hits crossings per ray, nearest first (triangles met at the
        same distance, such as both sides of an edge, count once)."""
        origins, directions = _unit_rays(ray_origins, ray_directions)
        rays = self._rays(origins, directions)
        index_tri, index_ray, distances = [], [], []
        wanted = max(max_hits if multiple_hits else 1, 0)
        active = np.arange(len(rays)) if wanted else np.zeros(0, np.int64)
        tmin = np.zeros(len(rays), dtype=np.float32)
        found = np.zeros(len(rays), dtype=np.int64)
        last_prim = np.full(len(rays), 0xFFFFFFFF, dtype=np.uint32)
        last_t = np.full(len(rays), -np.inf, dtype=np.float32)
        while len(active):
            hits = self._scene.cast_rays(rays[active], tmin=tmin[active])
            prim, t = hits["primitive_ids"], hits["t_hit"]
            hit = prim != 0xFFFFFFFF
            active, prim, t = active[hit], prim[hit], t[hit]
            # As irgrid.Scene.count_intersections: the same triangle again (rounding of t) or
            # a hit within 2^-20 of the distance of the last one (the other side of a shared
            # edge) is the same crossing.
            new = (prim != last_prim[active]) & (t > last_t[active] * np.float32(1 + 2**-20))
            index_tri.append(prim[new].astype(np.int64))
            index_ray.append(active[new])
            distances.append(t[new])
            last_prim[active[new]], last_t[active[new]] = prim[new], t[new]
            found[active[new]] += 1
            tmin[active] = np.nextafter(np.maximum(t, tmin[active]), np.float32(np.inf))
            active = active[(found[active] < wanted) & np.isfinite(tmin[active])]
        index_tri = np.concatenate(index_tri) if index_tri else np.zeros(0, np.int64)
        index_ray = np.concatenate(index_ray) if index_ray else np.zeros(0, np.int64)
        if not return_locations:
            return index_tri, index_ray
        t = np.concatenate(distances).astype(np.float64) if distances else np.zeros(0)
        locations = origins[index_ray] + directions[index_ray] * t[:, None]
        return index_tri, index_ray, locations

    def intersects_location(self, ray_origins, ray_directions, multiple_hits: bool = True,
                            **kwargs):
        """(locations, index_ray, index_tri) of the hits, as intersects_id."""
        index_tri, index_ray, locations = self.intersects_id(
            ray_origins, ray_directions, multiple_hits=multiple_hits, return_locations=True,
            **kwargs)
        return locations, index_ray, index_tri

    def contains_points(self, points) -> np.ndarray:
        """Whether each point lies inside the (closed) mesh: an odd number of crossings along
        a ray from the point."""
        points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        direction = np.array([0.4395064455, 0.617598629942, 0.652231566745], dtype=np.float32)
        rays = np.concatenate([points, np.broadcast_to(direction, points.shape)], axis=1)
        return self._scene.count_intersections(rays) % 2 == 1

    def _cast_from(self, rays: np.ndarray, tmin: np.ndarray) -> dict:
        return self._scene.cast_rays(rays, tmin=tmin)
