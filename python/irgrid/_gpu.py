"""Rays in GPU memory for Scene.cast_rays and Scene.test_occlusions.

Arrays come in through DLPack (``__dlpack__``: PyTorch, CuPy, JAX) or, for objects without it,
``__cuda_array_interface__`` (Numba). The trace runs on one CUDA stream, chosen here:

* the ``stream`` argument when given (a ``torch.cuda.Stream``, ``cupy.cuda.Stream``, Numba
  stream or a raw ``cudaStream_t`` as an int; 0 is the legacy default stream);
* else the framework's current stream for PyTorch and CuPy arrays;
* else the stream the array's ``__cuda_array_interface__`` names, else the legacy default stream.

Inputs are ordered before the trace the way each protocol asks: ``__dlpack__(stream=s)`` makes
the producer's pending work precede stream s; a ``__cuda_array_interface__`` stream other than
s gets an event that s waits on. The results are new device arrays of the rays' framework,
ready when the stream reaches the trace (at once for work on the framework's current stream).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import _irgrid

_DLPACK_CUDA_DEVICES = (2, 13)  # kDLCUDA, kDLCUDAManaged


class _View(NamedTuple):
    """A device array's memory: pointer, shape, strides in elements (None: C order), dtype."""
    data: int
    shape: tuple
    strides: tuple | None
    dtype: str


def _interface(array):
    """__cuda_array_interface__ of `array`, or None (torch raises on access for a CPU tensor,
    and for one that requires grad, whose __dlpack__ then says what to do)."""
    try:
        return array.__cuda_array_interface__
    except (AttributeError, RuntimeError):
        return None


def _dlpack_device(array):
    try:
        return tuple(array.__dlpack_device__())
    except (AttributeError, TypeError, ValueError, RuntimeError, BufferError):
        return None


def is_gpu_array(array) -> bool:
    """Whether `array` lives in CUDA memory (and so never goes through numpy)."""
    if isinstance(array, np.ndarray):
        return False
    if _interface(array) is not None:
        return True
    device = _dlpack_device(array)
    return device is not None and device[0] in _DLPACK_CUDA_DEVICES


def describe(array) -> str:
    """"torch.Tensor on cuda:0" and the like, for messages."""
    device = _dlpack_device(array)
    where = f" on cuda:{device[1]}" if device and device[0] in _DLPACK_CUDA_DEVICES else ""
    return f"{type(array).__module__}.{type(array).__name__}{where}"


def _framework(array) -> str:
    return type(array).__module__.split(".")[0]


def _stream_handle(stream) -> int:
    """A cudaStream_t as an int from a framework's stream object or an int."""
    for attribute in ("cuda_stream", "ptr", "handle"):  # torch, cupy, numba
        value = getattr(stream, attribute, None)
        if value is not None:
            stream = getattr(value, "value", value)  # numba's handle is a ctypes pointer
            break
    try:
        handle = int(stream or 0)
    except (TypeError, ValueError):
        raise ValueError(f"stream: expected a CUDA stream (torch.cuda.Stream, cupy.cuda.Stream, "
                         f"an int cudaStream_t), got {stream!r}") from None
    if handle < 0:
        raise ValueError(f"stream: expected a cudaStream_t, got {handle}")
    return handle


def _current_stream(array) -> int:
    """The stream the rays' framework queues work on now (see the module's docstring)."""
    framework = _framework(array)
    if framework == "torch":
        import torch
        return torch.cuda.current_stream(array.device).cuda_stream
    if framework == "cupy":
        import cupy
        return cupy.cuda.get_current_stream().ptr
    interface = _interface(array)
    if interface is not None and interface.get("stream") is not None:
        return int(interface["stream"])
    return 0


def _same_stream(a: int, b: int) -> bool:
    """Whether two cudaStream_t values name one stream (0 and 1: the legacy default stream)."""
    return a == b or (a in (0, 1) and b in (0, 1))


def _view(name: str, array, stream: int) -> _View:
    """The memory of `array`, ordered before `stream` as its protocol asks."""
    if hasattr(array, "__dlpack__"):
        # DLPack: 0 is ambiguous there; the legacy default stream is 1.
        try:
            capsule = array.__dlpack__(stream=stream or 1)
        except TypeError:  # a producer that predates the stream argument
            capsule = array.__dlpack__()
        data, shape, strides, dtype, device_type, _ = _irgrid.dlpack_layout(capsule)
        if device_type not in _DLPACK_CUDA_DEVICES:
            raise ValueError(f"{name}: expected a CUDA array, got {describe(array)} "
                             f"(DLPack device type {device_type})")
        return _View(data, tuple(shape), strides, dtype)
    interface = _interface(array)
    if interface is None:
        raise ValueError(f"{name}: expected a GPU array like the rays "
                         f"(__dlpack__ or __cuda_array_interface__), got {type(array).__name__}")
    if interface.get("mask") is not None:
        raise ValueError(f"{name}: masked arrays are not supported")
    producer = interface.get("stream")
    if producer is not None and not _same_stream(int(producer), stream):
        _irgrid.stream_wait(stream, int(producer))
    dtype = np.dtype(interface["typestr"])
    strides = interface.get("strides")
    if strides is not None:
        strides = tuple(s // dtype.itemsize if s % dtype.itemsize == 0 else math.nan
                        for s in strides)
    return _View(int(interface["data"][0]), tuple(interface["shape"]), strides, dtype.name)


def _require_c_order(name: str, view: _View) -> None:
    if view.strides is None:
        return
    expected = 1
    for extent, stride in zip(reversed(view.shape), reversed(view.strides)):
        if extent != 1 and stride != expected:
            raise ValueError(f"{name}: expected a C-contiguous array, got strides "
                             f"{view.strides} (elements) for shape {view.shape}; "
                             "make it contiguous first (.contiguous() / cupy.ascontiguousarray)")
        expected *= extent


def _rays(rays, stream: int) -> tuple[_View, tuple]:
    view = _view("rays", rays, stream)
    if len(view.shape) < 1 or view.shape[-1] != 6:
        raise ValueError(f"rays: expected shape (..., 6) (origin, direction), got {view.shape}")
    if view.dtype != "float32":
        raise ValueError(f"rays: expected float32 on the GPU, got {view.dtype} "
                         "(convert with .float() / .astype('float32'))")
    _require_c_order("rays", view)
    return view, view.shape[:-1]


def _bound(name: str, value, leading: tuple, stream: int) -> tuple[int, float]:
    """(device pointer, 0.0) for a per-ray array, (0, value) for one number."""
    if not is_gpu_array(value):
        if np.ndim(value) != 0:
            raise ValueError(f"{name}: with GPU rays, expected a number or a GPU array of shape "
                             f"{leading}, got {type(value).__name__} of shape {np.shape(value)}")
        number = float(value)
        if math.isnan(number):
            raise ValueError(f"{name}: NaN is not a distance")
        return 0, number
    view = _view(name, value, stream)
    if view.dtype != "float32":
        raise ValueError(f"{name}: expected float32, got {view.dtype}")
    if view.shape != leading and view.shape != (math.prod(leading),):
        raise ValueError(f"{name}: expected shape {leading} (one value per ray), got "
                         f"{view.shape}")
    _require_c_order(name, view)
    return view.data, 0.0


def _as_framework(like, array):
    """A result (nanobind's DLPack array) as an array of the rays' framework where it imports
    DLPack, else as it is (any DLPack consumer takes it)."""
    framework = _framework(like)
    if framework == "torch":
        import torch
        return torch.from_dlpack(array)
    if framework == "cupy":
        import cupy
        return cupy.from_dlpack(array)
    namespace = getattr(like, "__array_namespace__", None)  # JAX and other array-API arrays
    if namespace is not None:
        return namespace().from_dlpack(array)
    return array


def _shaped(array, shape: tuple):
    """`array` reshaped where it can be; nanobind's own DLPack arrays stay flat."""
    return array.reshape(shape) if hasattr(array, "reshape") else array


def _arguments(accelerator, rays, tmin, tmax, stream) -> tuple[tuple, tuple]:
    """The arguments of Accelerator.*_on_device, and the rays' leading shape."""
    if accelerator.backend != "cuda":
        reason = ("this irgrid was built without CUDA" if not _irgrid.has_cuda()
                  else "this Scene traces on the CPU; build it with backend='cuda'")
        raise ValueError(f"rays: a GPU array ({describe(rays)}) needs a Scene on the CUDA "
                         f"backend: {reason}, or pass numpy arrays")
    handle = _current_stream(rays) if stream is None else _stream_handle(stream)
    view, leading = _rays(rays, handle)
    tmin_data, tmin_value = _bound("tmin", tmin, leading, handle)
    tmax_data, tmax_value = _bound("tmax", tmax, leading, handle)
    count = math.prod(leading)
    return (view.data, count, tmin_data, tmin_value, tmax_data, tmax_value, handle), leading


#: cast_rays' results: name, the dtypes an `out` array may have, trailing shape.
_HITS = (("t_hit", ("float32",), ()), ("primitive_ids", ("uint32", "int32"), ()),
         ("primitive_uvs", ("float32",), (2,)), ("primitive_normals", ("float32",), (3,)))


def _output(name: str, array, shape: tuple, dtypes: tuple, stream: int) -> int:
    """The device pointer of a caller-given result array, after checking it."""
    if not is_gpu_array(array):
        raise ValueError(f"{name}: expected a GPU array of shape {shape}, got "
                         f"{type(array).__name__}")
    view = _view(name, array, stream)
    if view.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {view.shape}")
    if view.dtype not in dtypes:
        raise ValueError(f"{name}: expected {' or '.join(dtypes)}, got {view.dtype}")
    _require_c_order(name, view)
    return view.data


def cast_rays(accelerator, rays, tmin, tmax, stream, out=None) -> dict:
    arguments, leading = _arguments(accelerator, rays, tmin, tmax, stream)
    if out is not None:
        names = [name for name, _, _ in _HITS]
        if not isinstance(out, dict) or sorted(out) != sorted(names):
            raise ValueError(f"out: expected a dict of GPU arrays named {', '.join(names)}, got "
                             f"{sorted(out) if isinstance(out, dict) else type(out).__name__}")
        pointers = [_output(f"out['{name}']", out[name], leading + trailing, dtypes,
                            arguments[-1]) for name, dtypes, trailing in _HITS]
        accelerator.cast_rays_into(*arguments, *pointers)
        return out
    t, prim, uv, normals = accelerator.cast_rays_on_device(*arguments)
    return {"t_hit": _shaped(_as_framework(rays, t), leading),
            "primitive_ids": _shaped(_as_framework(rays, prim), leading),
            "primitive_uvs": _shaped(_as_framework(rays, uv), leading + (2,)),
            "primitive_normals": _shaped(_as_framework(rays, normals), leading + (3,))}


def test_occlusions(accelerator, rays, tmin, tmax, stream, out=None):
    arguments, leading = _arguments(accelerator, rays, tmin, tmax, stream)
    if out is not None:
        pointer = _output("out", out, leading, ("bool", "uint8"), arguments[-1])
        accelerator.test_occlusions_into(*arguments, pointer)
        return out
    occluded = accelerator.test_occlusions_on_device(*arguments)
    return _shaped(_as_framework(rays, occluded), leading)
