"""irgrid: irregular grids for fast ray casting on the CPU and NVIDIA GPUs.

Build a scene from numpy arrays and cast millions of rays at it::

    import numpy as np, irgrid
    scene = irgrid.Scene(vertices, triangles)          # (V, 3) floats, (T, 3) ints
    hits = scene.cast_rays(rays)                       # rays: (..., 6) origin and direction
    hits["t_hit"], hits["primitive_ids"], hits["primitive_uvs"], hits["primitive_normals"]

The grid is Pérard-Gayot, Kalojanov and Slusallek's (Eurographics 2017); docs/python.md is the
reference.
"""

from __future__ import annotations

import math

import numpy as np

from . import _gpu, _irgrid
from ._irgrid import Error

__all__ = ["Scene", "Error", "load", "backends", "structures", "version", "MISS"]
__version__ = _irgrid.version()

#: primitive_ids of a ray that hits nothing.
MISS = np.uint32(0xFFFFFFFF)


def version() -> str:
    """irgrid's version, "MAJOR.MINOR.PATCH"."""
    return _irgrid.version()


def backends() -> list[str]:
    """The backends that can run here: "cpu", and "cuda" where a usable GPU is visible."""
    return _irgrid.backends()


def structures() -> list[str]:
    """The acceleration structures of this build, fastest first ("irregular" is the default)."""
    return _irgrid.structures()


def load(path) -> tuple[np.ndarray, np.ndarray]:
    """Reads an OBJ or PLY file (also .gz / .xz compressed).

    Returns (vertices float32 (V, 3), triangles uint32 (T, 3)); polygons are fan-triangulated
    and invalid triangles (bad index, NaN vertex, zero area) dropped. Raises irgrid.Error naming
    the path and line for a missing or malformed file.
    """
    return _irgrid.load(str(path))


def _vertices(vertices) -> np.ndarray:
    array = np.asarray(vertices)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"vertices: expected shape (V, 3), got {array.shape}")
    if array.dtype not in (np.float32, np.float64):
        raise ValueError(f"vertices: expected float32 or float64, got {array.dtype}")
    array = np.ascontiguousarray(array, dtype=np.float32)  # no copy when already so
    if not np.isfinite(array).all():
        bad = int(np.count_nonzero(~np.isfinite(array).all(axis=1)))
        raise ValueError(f"vertices: {bad} of {len(array)} have a NaN or infinite coordinate "
                         "(or one beyond float32's range)")
    return array


def _triangles(triangles, vertex_count: int) -> np.ndarray:
    array = np.asarray(triangles)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"triangles: expected shape (T, 3), got {array.shape}")
    if array.dtype not in (np.int32, np.uint32, np.int64, np.uint64):
        raise ValueError(f"triangles: expected int32, uint32 or int64, got {array.dtype}")
    if array.size and (array.min() < 0 or array.max() >= vertex_count):
        raise ValueError(f"triangles: indices must lie in [0, {vertex_count}), found "
                         f"{array.min()}..{array.max()}")
    return np.ascontiguousarray(array, dtype=np.uint32)


def _rays(rays) -> tuple[np.ndarray, tuple[int, ...]]:
    array = np.asarray(rays)
    if array.ndim < 1 or array.shape[-1] != 6:
        raise ValueError(f"rays: expected shape (..., 6) (origin, direction), got {array.shape}")
    if not np.issubdtype(array.dtype, np.floating):
        raise ValueError(f"rays: expected float32, got {array.dtype}")
    leading = array.shape[:-1]
    return np.ascontiguousarray(array.reshape(-1, 6), dtype=np.float32), leading


def _interval(tmin, tmax, leading: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """tmin and tmax (numbers, or arrays broadcastable to the rays' leading shape) as float32
    arrays of one value for every ray, or of one value per ray."""
    bounds = []
    for name, value in (("tmin", tmin), ("tmax", tmax)):
        array = np.asarray(value, dtype=np.float32)
        if np.isnan(array).any():
            raise ValueError(f"{name}: NaN is not a distance")
        try:
            broadcast = np.broadcast_to(array, leading)
        except ValueError:
            raise ValueError(f"{name}: shape {array.shape} does not broadcast to the rays' "
                             f"{leading}") from None
        bounds.append(array.reshape(1) if array.size == 1 else
                      np.ascontiguousarray(broadcast.reshape(-1)))
    return bounds[0], bounds[1]


class Scene:
    """A triangle mesh with an acceleration structure built over it.

    vertices: (V, 3) float32 or float64; triangles: (T, 3) int32, uint32 or int64 indices.
    structure: "irregular" (default), "two-level", "uniform", "brute", "embree",
    "embree-packets", "cwbvh" (see irgrid.structures()). backend: "auto" (CUDA when a GPU is visible),
    "cpu" or "cuda". build_options: the grid's construction parameters (lambda1, lambda2,
    min_cells, split_refs, alpha, cost_ratio, empty_aspect, expansion_passes,
    partial_expansion, skip_empty, compress, huge_pages, memory_budget).

    The arrays are copied: they may change after the call. Building and tracing release the
    GIL and use every core; one Scene may be traced from several threads at once, but not while
    rebuild() runs.
    """

    def __init__(self, vertices, triangles, structure: str = "irregular", backend: str = "auto",
                 **build_options):
        self._vertices = _vertices(vertices)
        self._triangles = _triangles(triangles, len(self._vertices))
        config = _irgrid.BuildConfig()
        for name, value in build_options.items():
            if name.startswith("_") or not hasattr(config, name):
                raise ValueError(f"unknown build option {name!r}; expected one of "
                                 + ", ".join(n for n in dir(config) if not n.startswith("_")))
            try:
                setattr(config, name, value)
            except TypeError as e:
                raise ValueError(f"build option {name}={value!r}: {e}") from None
        self._accelerator = _irgrid.Accelerator(self._vertices, self._triangles, structure,
                                                backend, config)

    @classmethod
    def from_file(cls, path, **kwargs) -> "Scene":
        """Scene(*irgrid.load(path), **kwargs)."""
        return cls(*load(path), **kwargs)

    @property
    def vertices(self) -> np.ndarray:
        """The vertices as the scene holds them (float32, read-only view)."""
        view = self._vertices.view()
        view.flags.writeable = False
        return view

    @property
    def triangles(self) -> np.ndarray:
        """The triangles as the scene holds them (uint32, read-only view)."""
        view = self._triangles.view()
        view.flags.writeable = False
        return view

    @property
    def structure(self) -> str:
        return self._accelerator.structure

    @property
    def backend(self) -> str:
        """"cpu" or "cuda": where the structure was built and traces."""
        return self._accelerator.backend

    @property
    def stats(self) -> dict:
        """Figures of the last build: build_ms, build_phases_ms, memory_bytes, and for grids
        cells, references, voxel_map_entries, top_dims, depth, lambda2_used, ..."""
        return self._accelerator.stats

    @property
    def memory_bytes(self) -> int:
        """Bytes of the acceleration structure, its copy of the triangles included."""
        return self._accelerator.memory_bytes

    def cast_rays(self, rays, tmin=0.0, tmax=math.inf, stream=None, out=None) -> dict:
        """The closest hit of every ray in [tmin, tmax] (numbers, or arrays of the rays' leading
        shape).

        rays: (..., 6) float32 (origin xyz, direction xyz; directions need not be unit length,
        t is in units of |direction|). Returns a dict of arrays shaped like the rays' leading
        dimensions: t_hit float32 (inf on a miss), primitive_ids uint32 (irgrid.MISS on a
        miss), primitive_uvs (..., 2) float32 (p = (1-u-v) v0 + u v1 + v v2) and
        primitive_normals (..., 3) float32 (unit geometric normals, zero on a miss).

        On the CUDA backend, rays may be a GPU array (PyTorch, CuPy, JAX, Numba; tmin and tmax
        then numbers or float32 GPU arrays): the results are new GPU arrays of that framework,
        or go into `out` (a dict of GPU arrays with the four names; primitive_ids uint32 or
        int32), computed on `stream` (default: the framework's current stream; docs/python.md).
        """
        if _gpu.is_gpu_array(rays):
            return _gpu.cast_rays(self._accelerator, rays, tmin, tmax, stream, out)
        if out is not None:
            raise ValueError("out: only for GPU rays (numpy rays get new numpy results)")
        flat, leading = _rays(rays)
        tmin, tmax = _interval(tmin, tmax, leading)
        t, prim, uv, normals = self._accelerator.cast_rays(flat, tmin, tmax)
        return {"t_hit": t.reshape(leading), "primitive_ids": prim.reshape(leading),
                "primitive_uvs": uv.reshape(leading + (2,)),
                "primitive_normals": normals.reshape(leading + (3,))}

    def test_occlusions(self, rays, tmin=0.0, tmax=math.inf, stream=None,
                        out=None) -> np.ndarray:
        """Whether each ray hits anything in [tmin, tmax] (bool array, the rays' leading shape).
        GPU rays give a GPU bool array, or fill `out` (bool or uint8), as in cast_rays."""
        if _gpu.is_gpu_array(rays):
            return _gpu.test_occlusions(self._accelerator, rays, tmin, tmax, stream, out)
        if out is not None:
            raise ValueError("out: only for GPU rays (numpy rays get new numpy results)")
        flat, leading = _rays(rays)
        tmin, tmax = _interval(tmin, tmax, leading)
        return self._accelerator.test_occlusions(flat, tmin, tmax).reshape(leading)

    def count_intersections(self, rays, tmin=0.0, tmax=math.inf) -> np.ndarray:
        """How many times each ray crosses the mesh in [tmin, tmax] (int32, the rays' leading
        shape). From outside a closed mesh, odd means the end point is inside. Watertight: a
        ray through a shared edge or vertex counts one crossing there."""
        if _gpu.is_gpu_array(rays):
            raise ValueError(f"rays: count_intersections takes numpy arrays, got "
                             f"{_gpu.describe(rays)} (GPU arrays: cast_rays, test_occlusions)")
        flat, leading = _rays(rays)
        tmin, tmax = _interval(tmin, tmax, leading)
        return self._accelerator.count_intersections(flat, tmin, tmax).reshape(leading)

    def rebuild(self, vertices) -> None:
        """Rebuilds the structure over new positions of the same vertices (an animation frame),
        reusing its memory where the backend can."""
        new = _vertices(vertices)
        if new.shape != self._vertices.shape:
            raise ValueError(f"rebuild: expected vertices of shape {self._vertices.shape}, "
                             f"got {new.shape}")
        self._accelerator.rebuild(new)
        self._vertices = new

    def __repr__(self) -> str:
        return (f"irgrid.Scene({len(self._vertices)} vertices, {len(self._triangles)} triangles, "
                f"{self.structure} on {self.backend})")
