"""Helpers shared by the math modules: one code path for numpy and torch, and shape checks.

Math functions are written once in torch. :func:`numpy_in_numpy_out` lets them take numpy arrays too:
numpy inputs are converted to float64 tensors and the results converted back, so exporters (numpy,
float64) and the fitting core (torch, autograd) call the same function.
"""

from __future__ import annotations

import functools
from typing import Any, Callable, Sequence, TypeVar

import numpy as np
import torch

F = TypeVar("F", bound=Callable[..., Any])


def _to_numpy(value: Any) -> Any:
    if isinstance(value, torch.Tensor):
        return value.detach().cpu().numpy()
    if isinstance(value, tuple):
        return tuple(_to_numpy(v) for v in value)
    return value


def numpy_in_numpy_out(fn: F) -> F:
    """Decorate a torch function so numpy array arguments give numpy results (float64)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        uses_numpy = any(isinstance(a, np.ndarray) for a in (*args, *kwargs.values()))
        if not uses_numpy:
            return fn(*args, **kwargs)
        conv = lambda a: torch.from_numpy(np.ascontiguousarray(a, dtype=np.float64)) if isinstance(a, np.ndarray) else a
        out = fn(*(conv(a) for a in args), **{k: conv(v) for k, v in kwargs.items()})
        return _to_numpy(out)

    return wrapper  # type: ignore[return-value]


def check_shape(x: Any, trailing: Sequence[int | None], name: str) -> None:
    """Raise ``ValueError`` unless ``x`` has at least ``len(trailing)`` dims ending in ``trailing``.

    ``None`` in ``trailing`` matches any size.

    >>> check_shape(np.zeros((5, 4, 3)), (4, 3), "control_points")
    >>> check_shape(np.zeros((5, 3)), (4, 3), "control_points")
    Traceback (most recent call last):
    ...
    ValueError: control_points: expected shape (..., 4, 3), got (5, 3)
    """
    shape = tuple(x.shape)
    ok = len(shape) >= len(trailing) and all(
        want is None or have == want for have, want in zip(shape[len(shape) - len(trailing):], trailing)
    )
    if not ok:
        want_s = ", ".join("*" if t is None else str(t) for t in trailing)
        raise ValueError(f"{name}: expected shape (..., {want_s}), got {shape}")


class _NumpyOps:
    """The few operations whose numpy and torch spellings differ, numpy side."""

    stack = staticmethod(lambda xs, axis: np.stack(xs, axis=axis))
    clip_min = staticmethod(lambda x, lo: np.maximum(x, lo))
    clip_max = staticmethod(lambda x, hi: np.minimum(x, hi))
    sigmoid = staticmethod(lambda x: 0.5 * (1.0 + np.tanh(0.5 * x)))
    norm = staticmethod(lambda x, axis, keepdims=False: np.linalg.norm(x, axis=axis, keepdims=keepdims))
    min = staticmethod(lambda x, axis: x.min(axis=axis))
    transpose = staticmethod(lambda x: np.swapaxes(x, -1, -2))
    full = staticmethod(lambda shape, value, like: np.full(shape, value, dtype=like.dtype))


class _TorchOps:
    """Torch side of :class:`_NumpyOps`."""

    stack = staticmethod(lambda xs, axis: torch.stack(xs, dim=axis))
    clip_min = staticmethod(lambda x, lo: x.clamp_min(lo))
    clip_max = staticmethod(lambda x, hi: x.clamp(max=hi))
    sigmoid = staticmethod(torch.sigmoid)
    norm = staticmethod(lambda x, axis, keepdims=False: x.norm(dim=axis, keepdim=keepdims))
    min = staticmethod(lambda x, axis: x.min(dim=axis).values)
    transpose = staticmethod(lambda x: x.transpose(-1, -2))
    full = staticmethod(lambda shape, value, like: torch.full(shape, value, dtype=like.dtype, device=like.device))


def ops(x: Any) -> Any:
    """Namespace with ``xp``-style helpers for ``x``'s library, plus the shared ufuncs.

    Math written against it runs natively in numpy (exporters: float64, many small arrays, fork-safe worker
    processes) and in torch (fitting: autograd, GPU) from one source.
    """
    return _TORCH_NS if isinstance(x, torch.Tensor) else _NUMPY_NS


class _Namespace:
    def __init__(self, lib: Any, extra: Any) -> None:
        self._lib, self._extra = lib, extra

    def __getattr__(self, name: str) -> Any:
        return getattr(self._extra, name) if hasattr(self._extra, name) else getattr(self._lib, name)


_NUMPY_NS = _Namespace(np, _NumpyOps)
_TORCH_NS = _Namespace(torch, _TorchOps)
