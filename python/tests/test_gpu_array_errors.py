"""GPU arrays where they cannot be traced, and the checks made before any GPU memory is touched:
runs on every machine, with stand-ins that only describe GPU memory."""

import numpy as np
import pytest

import irgrid
from irgrid import _gpu


class CudaArrayInterface:
    """Describes device memory through __cuda_array_interface__ (as Numba arrays do); the
    pointer is never read by these tests."""

    def __init__(self, shape, typestr="<f4", strides=None):
        self.__cuda_array_interface__ = {"shape": shape, "typestr": typestr, "strides": strides,
                                         "data": (0x7F0000000000, False), "version": 3,
                                         "stream": None}


class DLPackOnCuda:
    """Says it is on cuda:0 through __dlpack_device__ (as JAX arrays do) and exports nothing."""

    def __dlpack_device__(self):
        return (2, 0)

    def __dlpack__(self, **kwargs):
        raise AssertionError("a CPU scene must refuse the array before exporting it")


def test_gpu_arrays_are_recognised():
    assert _gpu.is_gpu_array(CudaArrayInterface((4, 6)))
    assert _gpu.is_gpu_array(DLPackOnCuda())
    assert not _gpu.is_gpu_array(np.zeros((4, 6), np.float32))
    assert not _gpu.is_gpu_array([[0, 0, 0, 1, 0, 0]])


@pytest.mark.parametrize("rays", [CudaArrayInterface((4, 6)), DLPackOnCuda()])
def test_a_cpu_scene_refuses_gpu_rays(unit_square, rays):
    scene = irgrid.Scene(*unit_square, backend="cpu")
    reason = "built without CUDA" if not irgrid._irgrid.has_cuda() else "traces on the CPU"
    with pytest.raises(ValueError, match=f"rays: a GPU array .*CUDA backend: .*{reason}"):
        scene.cast_rays(rays)
    with pytest.raises(ValueError, match="rays: a GPU array"):
        scene.test_occlusions(rays)
    with pytest.raises(ValueError, match="rays: count_intersections takes numpy arrays"):
        scene.count_intersections(rays)


def test_dtype_shape_and_layout_are_checked_first():
    with pytest.raises(ValueError, match="rays: expected float32 on the GPU, got float64"):
        _gpu._rays(CudaArrayInterface((4, 6), "<f8"), 0)
    with pytest.raises(ValueError, match=r"rays: expected shape \(\.\.\., 6\).*\(4, 3\)"):
        _gpu._rays(CudaArrayInterface((4, 3)), 0)
    with pytest.raises(ValueError, match=r"rays: expected a C-contiguous array.*\(12, 1\)"):
        _gpu._rays(CudaArrayInterface((4, 6), strides=(48, 4)), 0)
    view, leading = _gpu._rays(CudaArrayInterface((2, 3, 6), strides=(72, 24, 4)), 0)
    assert leading == (2, 3) and view.dtype == "float32"


def test_intervals_with_gpu_rays():
    assert _gpu._bound("tmin", 0.5, (4,), 0) == (0, 0.5)
    assert _gpu._bound("tmax", np.float32(2), (4,), 0) == (0, 2.0)
    with pytest.raises(ValueError, match="tmin: NaN is not a distance"):
        _gpu._bound("tmin", float("nan"), (4,), 0)
    with pytest.raises(ValueError, match=r"tmax: with GPU rays, expected a number or a GPU array "
                                         r"of shape \(4,\), got ndarray of shape \(4,\)"):
        _gpu._bound("tmax", np.ones(4, np.float32), (4,), 0)
    with pytest.raises(ValueError, match=r"tmin: expected shape \(4,\).*\(3,\)"):
        _gpu._bound("tmin", CudaArrayInterface((3,)), (4,), 0)
    with pytest.raises(ValueError, match="tmin: expected float32, got int32"):
        _gpu._bound("tmin", CudaArrayInterface((4,), "<i4"), (4,), 0)
    assert _gpu._bound("tmin", CudaArrayInterface((2, 2)), (2, 2), 0)[0] == 0x7F0000000000


def test_stream_arguments():
    class TorchLike:
        cuda_stream = 1234

    class CupyLike:
        ptr = 5678

    assert _gpu._stream_handle(TorchLike()) == 1234
    assert _gpu._stream_handle(CupyLike()) == 5678
    assert _gpu._stream_handle(0) == 0
    with pytest.raises(ValueError, match="stream: expected a CUDA stream"):
        _gpu._stream_handle("fast")


class RecordingAccelerator:
    """Stands for a Scene's accelerator on the CUDA backend: records what the GPU path hands
    over instead of tracing."""

    backend = "cuda"

    def __init__(self):
        self.calls = []

    def cast_rays_on_device(self, *arguments):
        self.calls.append(("cast_rays_on_device", arguments))
        count = arguments[1]
        return (np.zeros(count, np.float32), np.zeros(count, np.uint32),
                np.zeros((count, 2), np.float32), np.zeros((count, 3), np.float32))

    def cast_rays_into(self, *arguments):
        self.calls.append(("cast_rays_into", arguments))

    def test_occlusions_into(self, *arguments):
        self.calls.append(("test_occlusions_into", arguments))


def test_what_the_gpu_path_hands_over(monkeypatch):
    waits = []
    monkeypatch.setattr(_gpu._irgrid, "stream_wait", lambda *streams: waits.append(streams))
    accelerator = RecordingAccelerator()
    rays = CudaArrayInterface((2, 3, 6))
    rays.__cuda_array_interface__["stream"] = 77  # where the rays were made
    hits = _gpu.cast_rays(accelerator, rays, 0.5, CudaArrayInterface((2, 3)), None, None)
    name, arguments = accelerator.calls[-1]
    # rows, count, tmin array, tmin value, tmax array, tmax value, stream: the rays' own stream
    assert name == "cast_rays_on_device"
    assert arguments == (0x7F0000000000, 6, 0, 0.5, 0x7F0000000000, 0.0, 77)
    assert hits["t_hit"].shape == (2, 3) and hits["primitive_normals"].shape == (2, 3, 3)
    assert waits == []
    _gpu.cast_rays(accelerator, rays, 0.0, 1.0, 5, None)  # another stream waits for the rays'
    assert accelerator.calls[-1][1][-1] == 5 and waits == [(5, 77)]


def test_caller_given_outputs(monkeypatch):
    accelerator = RecordingAccelerator()
    rays = CudaArrayInterface((4, 6))
    out = {"t_hit": CudaArrayInterface((4,)), "primitive_ids": CudaArrayInterface((4,), "<i4"),
           "primitive_uvs": CudaArrayInterface((4, 2)),
           "primitive_normals": CudaArrayInterface((4, 3))}
    assert _gpu.cast_rays(accelerator, rays, 0.0, 1.0, None, out) is out
    name, arguments = accelerator.calls[-1]
    assert name == "cast_rays_into" and len(arguments) == 7 + 4
    occluded = CudaArrayInterface((4,), "|b1")
    assert _gpu.test_occlusions(accelerator, rays, 0.0, 1.0, None, occluded) is occluded
    with pytest.raises(ValueError, match=r"out\['primitive_uvs'\]: expected shape \(4, 2\), got "
                                         r"\(4, 3\)"):
        _gpu.cast_rays(accelerator, rays, 0.0, 1.0, None,
                       dict(out, primitive_uvs=CudaArrayInterface((4, 3))))
    with pytest.raises(ValueError, match=r"out\['t_hit'\]: expected float32, got float64"):
        _gpu.cast_rays(accelerator, rays, 0.0, 1.0, None,
                       dict(out, t_hit=CudaArrayInterface((4,), "<f8")))
    with pytest.raises(ValueError, match=r"out\['primitive_ids'\]: expected a GPU array"):
        _gpu.cast_rays(accelerator, rays, 0.0, 1.0, None,
                       dict(out, primitive_ids=np.zeros(4, np.uint32)))
    with pytest.raises(ValueError, match="out: expected a dict of GPU arrays named t_hit"):
        _gpu.cast_rays(accelerator, rays, 0.0, 1.0, None, {"t_hit": out["t_hit"]})
    with pytest.raises(ValueError, match="out: expected bool or uint8, got float32"):
        _gpu.test_occlusions(accelerator, rays, 0.0, 1.0, None, CudaArrayInterface((4,)))


def test_out_needs_gpu_rays(unit_square):
    scene = irgrid.Scene(*unit_square)
    rays = np.zeros((2, 6), np.float32)
    with pytest.raises(ValueError, match="out: only for GPU rays"):
        scene.cast_rays(rays, out={})
    with pytest.raises(ValueError, match="out: only for GPU rays"):
        scene.test_occlusions(rays, out=np.zeros(2, bool))


def test_the_legacy_default_stream_has_two_names(monkeypatch):
    waits = []
    monkeypatch.setattr(_gpu._irgrid, "stream_wait", lambda *streams: waits.append(streams))
    rays = CudaArrayInterface((1, 6))
    rays.__cuda_array_interface__["stream"] = 1  # the interface's name for it
    _gpu.cast_rays(RecordingAccelerator(), rays, 0.0, 1.0, 0, None)
    assert waits == []
