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
