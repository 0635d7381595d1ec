"""GPU arrays (CuPy, PyTorch) in cast_rays and test_occlusions, on a CUDA scene: the results
must equal the numpy path's bit for bit. Skips without a GPU or without the framework; with
IRGRID_REQUIRE_GPU set (the GPU bundle's run.sh, where a GPU is present) a missing GPU fails."""

import os
import secrets

import numpy as np
import pytest

import irgrid


def no_gpu(reason):
    """Skips, or fails where a GPU must be there."""
    if os.environ.get("IRGRID_REQUIRE_GPU"):
        pytest.fail(f"IRGRID_REQUIRE_GPU is set but {reason}")
    pytest.skip(reason)


class Framework:
    """The few operations the tests need, for one GPU array library."""

    def __init__(self, name):
        self.name = name
        if name == "torch":
            torch = pytest.importorskip("torch")
            if not torch.cuda.is_available():
                no_gpu("torch sees no CUDA device")
            self.module = torch
        else:
            cupy = pytest.importorskip("cupy")
            try:
                if cupy.cuda.runtime.getDeviceCount() == 0:
                    no_gpu("cupy sees no CUDA device")
            except cupy.cuda.runtime.CUDARuntimeError as e:
                no_gpu(f"cupy sees no CUDA device: {e}")
            self.module = cupy

    def to_device(self, array):
        if self.name == "torch":
            return self.module.from_numpy(np.ascontiguousarray(array)).to("cuda:0")
        return self.module.asarray(array)

    def to_host(self, array):
        if self.name == "torch":
            self.module.cuda.synchronize()
            if array.dtype == self.module.uint32:  # .numpy() of uint32 is recent in torch
                return array.view(self.module.int32).cpu().numpy().view(np.uint32)
            return array.cpu().numpy()
        return self.module.asnumpy(array)

    def array_type(self):
        return self.module.Tensor if self.name == "torch" else self.module.ndarray

    def new_stream(self):
        return self.module.cuda.Stream()

    def on_stream(self, stream):
        return self.module.cuda.stream(stream) if self.name == "torch" else stream


@pytest.fixture(params=["cupy", "torch"])
def fw(request):
    return Framework(request.param)


@pytest.fixture(scope="module")
def cuda_scene():
    if "cuda" not in irgrid.backends():
        no_gpu(f"irgrid has no usable GPU: {irgrid._irgrid.cuda_status()}")
    return irgrid.Scene(*irgrid.load("builtin:cornell"), backend="cuda")


def random_rays(scene, shape, seed):
    """Rays from inside and around the scene's box in random directions (hits and misses);
    the tests draw a new seed each run and name it when they fail."""
    rng = np.random.default_rng(seed)
    low, high = scene.vertices.min(axis=0), scene.vertices.max(axis=0)
    margin = 0.2 * (high - low)
    origins = rng.uniform(low - margin, high + margin, size=shape + (3,))
    directions = rng.normal(size=shape + (3,))
    return np.concatenate([origins, directions], axis=-1).astype(np.float32)


def bits(array):
    """The array's bytes as unsigned integers: equal bits, not merely equal values."""
    array = np.ascontiguousarray(array)
    return array.view({1: np.uint8, 4: np.uint32}[array.dtype.itemsize])


def assert_same_hits(gpu, cpu, seed):
    for key in ("t_hit", "primitive_ids", "primitive_uvs", "primitive_normals"):
        assert gpu[key].shape == cpu[key].shape, key
        assert gpu[key].dtype == cpu[key].dtype, key
        different = np.count_nonzero(bits(gpu[key]) != bits(cpu[key]))
        assert different == 0, f"{key}: {different} values differ (seed {seed})"


def trace_misses_first(scene, fw, count):
    """Traces `count` rays that all miss and drops the results, so that memory handed out
    next holds misses: a result the GPU path failed to write shows as a wrong miss."""
    rays = np.zeros((count, 6), np.float32)
    rays[:, :3] = 1e6
    rays[:, 3] = 1
    scene.cast_rays(fw.to_device(rays))
    if fw.name == "torch":
        fw.module.cuda.synchronize()
    else:
        fw.module.cuda.runtime.deviceSynchronize()


def test_cast_rays_matches_numpy_bit_for_bit(cuda_scene, fw):
    seed = secrets.randbits(32)
    rays = random_rays(cuda_scene, (96, 70), seed)
    expected = cuda_scene.cast_rays(rays)
    assert np.count_nonzero(expected["primitive_ids"] != irgrid.MISS) > 1000, "too few hits"
    trace_misses_first(cuda_scene, fw, rays.shape[0] * rays.shape[1])
    hits = cuda_scene.cast_rays(fw.to_device(rays))
    for value in hits.values():
        assert isinstance(value, fw.array_type())
    assert_same_hits({k: fw.to_host(v) for k, v in hits.items()}, expected, seed)


def poison(shape, dtype):
    """An array whose every element is the NaN bit pattern 0x7FA5A5A5 (0xA5 bytes for 1-byte
    types): a result the trace failed to write cannot match."""
    dtype = np.dtype(dtype)
    if dtype.itemsize == 1:
        return np.full(shape, 0xA5, np.uint8).view(dtype)
    return np.full(shape, 0x7FA5A5A5, np.uint32).view(dtype)


def test_cast_rays_into_poisoned_arrays(cuda_scene, fw):
    seed = secrets.randbits(32)
    rays = random_rays(cuda_scene, (50, 61), seed)
    expected = cuda_scene.cast_rays(rays)
    ids = np.int32 if fw.name == "torch" else np.uint32  # torch's uint32 is barely usable
    out = {"t_hit": fw.to_device(poison((50, 61), np.float32)),
           "primitive_ids": fw.to_device(poison((50, 61), ids)),
           "primitive_uvs": fw.to_device(poison((50, 61, 2), np.float32)),
           "primitive_normals": fw.to_device(poison((50, 61, 3), np.float32))}
    assert cuda_scene.cast_rays(fw.to_device(rays), out=out) is out
    got = {k: fw.to_host(v) for k, v in out.items()}
    got["primitive_ids"] = got["primitive_ids"].view(np.uint32)
    assert_same_hits(got, expected, seed)
    occluded = fw.to_device(poison((50, 61), np.uint8))
    cuda_scene.test_occlusions(fw.to_device(rays), tmax=2.0, out=occluded)
    flags = fw.to_host(occluded)
    assert set(np.unique(flags)) <= {0, 1}, f"unwritten flags (seed {seed})"
    assert np.array_equal(flags.astype(bool), cuda_scene.test_occlusions(rays, tmax=2.0))


def test_per_ray_intervals_on_the_gpu(cuda_scene, fw):
    seed = secrets.randbits(32)
    rays = random_rays(cuda_scene, (5000,), seed)
    rng = np.random.default_rng(seed + 1)
    tmin = rng.uniform(0, 0.5, size=5000).astype(np.float32)
    tmax = (tmin + rng.uniform(0, 3, size=5000)).astype(np.float32)
    expected = cuda_scene.cast_rays(rays, tmin, tmax)
    hits = cuda_scene.cast_rays(fw.to_device(rays), fw.to_device(tmin), fw.to_device(tmax))
    assert_same_hits({k: fw.to_host(v) for k, v in hits.items()}, expected, seed)
    expected = cuda_scene.cast_rays(rays, tmin=0.25, tmax=2.0)
    hits = cuda_scene.cast_rays(fw.to_device(rays), tmin=0.25, tmax=2.0)
    assert_same_hits({k: fw.to_host(v) for k, v in hits.items()}, expected, seed)


def test_occlusions_match_numpy(cuda_scene, fw):
    seed = secrets.randbits(32)
    rays = random_rays(cuda_scene, (40, 100), seed)
    expected = cuda_scene.test_occlusions(rays, tmax=1.5)
    occluded = fw.to_host(cuda_scene.test_occlusions(fw.to_device(rays), tmax=1.5))
    assert occluded.dtype == np.bool_ and occluded.shape == (40, 100)
    assert np.array_equal(occluded, expected), f"seed {seed}"


def test_rays_made_on_another_stream(cuda_scene, fw):
    """Rays written on a side stream and traced there (the framework's current stream), then
    read on it: no synchronisation by hand is needed."""
    seed = secrets.randbits(32)
    rays = random_rays(cuda_scene, (20000,), seed)
    expected = cuda_scene.cast_rays(rays)
    stream = fw.new_stream()
    with fw.on_stream(stream):
        device_rays = fw.to_device(rays) * 1  # a kernel on the side stream produces them
        hits = cuda_scene.cast_rays(device_rays)
        t = hits["t_hit"] + 0  # consumed on the same stream
    assert_same_hits({"t_hit": fw.to_host(t), "primitive_ids": fw.to_host(hits["primitive_ids"]),
                      "primitive_uvs": fw.to_host(hits["primitive_uvs"]),
                      "primitive_normals": fw.to_host(hits["primitive_normals"])},
                     expected, seed)


def test_explicit_stream_argument(cuda_scene, fw):
    seed = secrets.randbits(32)
    rays = random_rays(cuda_scene, (3000,), seed)
    expected = cuda_scene.cast_rays(rays)
    device_rays = fw.to_device(rays)
    stream = fw.new_stream()
    hits = cuda_scene.cast_rays(device_rays, stream=stream)
    stream.synchronize()
    assert_same_hits({k: fw.to_host(v) for k, v in hits.items()}, expected, seed)


def test_no_rays(cuda_scene, fw):
    hits = cuda_scene.cast_rays(fw.to_device(np.zeros((0, 6), np.float32)))
    assert tuple(hits["t_hit"].shape) == (0,) and tuple(hits["primitive_uvs"].shape) == (0, 2)


def test_gpu_errors_name_the_argument(cuda_scene, fw):
    rays = random_rays(cuda_scene, (10,), 1)
    with pytest.raises(ValueError, match="rays: expected float32.*float64"):
        cuda_scene.cast_rays(fw.to_device(rays.astype(np.float64)))
    with pytest.raises(ValueError, match=r"rays: expected shape \(\.\.\., 6\).*\(10, 5\)"):
        cuda_scene.cast_rays(fw.to_device(rays[:, :5]))
    wide = fw.to_device(np.concatenate([rays, rays], axis=1))
    with pytest.raises(ValueError, match="rays: expected a C-contiguous array"):
        cuda_scene.cast_rays(wide[:, :6])
    with pytest.raises(ValueError, match=r"tmin: expected shape \(10,\)"):
        cuda_scene.cast_rays(fw.to_device(rays), tmin=fw.to_device(np.zeros(3, np.float32)))
    with pytest.raises(ValueError, match="tmax: with GPU rays, expected a number or a GPU array"):
        cuda_scene.cast_rays(fw.to_device(rays), tmax=np.ones(10, np.float32))
    with pytest.raises(ValueError, match="rays: count_intersections takes numpy arrays"):
        cuda_scene.count_intersections(fw.to_device(rays))
    cpu_scene = irgrid.Scene(*irgrid.load("builtin:cornell"), backend="cpu")
    with pytest.raises(ValueError, match="rays: a GPU array .* needs a Scene on the CUDA backend"):
        cpu_scene.cast_rays(fw.to_device(rays))


def test_array_on_another_gpu(cuda_scene):
    torch = pytest.importorskip("torch")
    if not torch.cuda.is_available() or torch.cuda.device_count() < 2:
        pytest.skip("needs two GPUs")
    rays = torch.zeros((4, 6), dtype=torch.float32, device="cuda:1")
    with pytest.raises(irgrid.Error, match="rays: the array is in cuda:1, the Scene is on cuda:0"):
        cuda_scene.cast_rays(rays)
