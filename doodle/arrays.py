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
