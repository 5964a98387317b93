"""Helpers shared by the math modules: one code path for numpy and torch, and shape checks.

Math functions are written once against :func:`ops` (``xp``-style: numpy or torch), so exporters (numpy,
float64) and the fitting core (torch, autograd) call the same function. torch is never imported here: a
process that only draws (export and animation workers) does not load torch or start its OpenMP pool.
"""

from __future__ import annotations

import sys
from typing import Any, Callable, Sequence

import numpy as np


def is_tensor(x: Any) -> bool:
    """Whether ``x`` is a torch tensor, without importing torch (no tensor can exist before it is imported)."""
    torch = sys.modules.get("torch")
    return torch is not None and isinstance(x, torch.Tensor)


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
    cat = staticmethod(lambda xs, axis: np.concatenate(xs, axis=axis))
    atan2 = staticmethod(np.arctan2)
    clip_min = staticmethod(lambda x, lo: np.maximum(x, lo))
    clip_max = staticmethod(lambda x, hi: np.minimum(x, hi))
    sigmoid = staticmethod(lambda x: 0.5 * (1.0 + np.tanh(0.5 * x)))
    norm = staticmethod(lambda x, axis, keepdims=False: np.linalg.norm(x, axis=axis, keepdims=keepdims))
    min = staticmethod(lambda x, axis: x.min(axis=axis))
    transpose = staticmethod(lambda x: np.swapaxes(x, -1, -2))
    full = staticmethod(lambda shape, value, like: np.full(shape, value, dtype=like.dtype))
    asarray = staticmethod(lambda v, like: np.asarray(v, dtype=like.dtype))


class _TorchOps:
    """Torch side of :class:`_NumpyOps` (built on first use, when torch is already imported)."""

    def __init__(self) -> None:
        import torch

        self.stack = lambda xs, axis: torch.stack(xs, dim=axis)
        self.cat = lambda xs, axis: torch.cat(xs, dim=axis)
        self.clip_min = lambda x, lo: x.clamp_min(lo)
        self.clip_max = lambda x, hi: x.clamp(max=hi)
        self.sigmoid = torch.sigmoid
        self.norm = lambda x, axis, keepdims=False: x.norm(dim=axis, keepdim=keepdims)
        self.min = lambda x, axis: x.min(dim=axis).values
        self.transpose = lambda x: x.transpose(-1, -2)
        self.full = lambda shape, value, like: torch.full(shape, value, dtype=like.dtype, device=like.device)
        self.asarray = lambda v, like: torch.as_tensor(v, dtype=like.dtype, device=like.device)


def ops(x: Any) -> Any:
    """Namespace with ``xp``-style helpers for ``x``'s library, plus the shared ufuncs.

    Math written against it runs natively in numpy (exporters: float64, many small arrays, worker
    processes without torch) and in torch (fitting: autograd, GPU) from one source.
    """
    global _TORCH_NS
    if not is_tensor(x):
        return _NUMPY_NS
    if _TORCH_NS is None:
        import torch

        _TORCH_NS = _Namespace(torch, _TorchOps())
    return _TORCH_NS


class _Namespace:
    def __init__(self, lib: Any, extra: Any) -> None:
        self._lib, self._extra = lib, extra

    def __getattr__(self, name: str) -> Any:
        return getattr(self._extra, name) if hasattr(self._extra, name) else getattr(self._lib, name)


_NUMPY_NS = _Namespace(np, _NumpyOps)
_TORCH_NS: _Namespace | None = None


def spread_indices(n: int, k: int) -> np.ndarray:
    """``min(k, n)`` indices into ``range(n)``, evenly spread and ending at both ends (views to sample).

    >>> spread_indices(10, 4).tolist(), spread_indices(3, 8).tolist()
    ([0, 3, 6, 9], [0, 1, 2])
    """
    return np.unique(np.linspace(0, n - 1, min(k, n)).round().astype(int))


def along_polyline(points: np.ndarray, n: int, closed: bool = False) -> np.ndarray:
    """``n`` points ``(n, D)`` evenly spaced by arc length along a polyline ``(P, D)`` of positive length, from
    its first point to its last; ``closed``: around the loop back to the first point, which is not repeated.

    >>> along_polyline(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]]), 5).tolist()
    [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [2.0, 2.0]]
    """
    loop = np.vstack([points, points[:1]]) if closed else points
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(loop, axis=0), axis=1))]
    at = np.linspace(0.0, arc[-1], n, endpoint=not closed)
    return np.stack([np.interp(at, arc, loop[:, d]) for d in range(loop.shape[1])], axis=1)


def nearest_voxels(padded: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """The values ``(...)`` of a voxel grid at the voxels nearest to ``coords (..., 3)``, given in the grid's
    voxel coordinates (voxel centres at integers). ``padded`` is the grid with one empty voxel on every side
    (``np.pad(grid, 1)``, made once by the caller): every coordinate outside the grid lands there."""
    ijk = np.rint(coords).astype(np.intp) + 1
    for axis in range(3):
        np.clip(ijk[..., axis], 0, padded.shape[axis] - 1, out=ijk[..., axis])
    return padded[ijk[..., 0], ijk[..., 1], ijk[..., 2]]


def free_space(occupied: np.ndarray) -> np.ndarray:
    """The chessboard distance of every voxel of ``occupied`` padded with one empty voxel on every side to the
    nearest occupied voxel (0 on them), as :func:`first_occupied` reads it: the padding is where every
    coordinate outside the grid lands (as in :func:`nearest_voxels`)."""
    from scipy import ndimage

    return ndimage.distance_transform_cdt(~np.pad(occupied, 1), metric="chessboard")


def first_occupied(free: np.ndarray, at: Callable[[np.ndarray, np.ndarray], np.ndarray], reach: np.ndarray,
                   n: np.ndarray) -> np.ndarray:
    """Along each of ``R`` rays sampled at ``at(rows, j)`` (voxel coordinates ``(len(rows), 3)`` of sample
    ``j`` of each ray in ``rows``, ``j = 0 … n[r] − 1``), the first sample whose nearest voxel is occupied,
    ``(R,)``; ``-1`` where none is.

    ``free``: :func:`free_space` of the grid, read as :func:`nearest_voxels` reads the padded grid.
    ``reach (R,)``: how far a ray moves along its steepest axis
    from one sample to the next, in voxels. Empty space is skipped: where a sample's nearest voxel is ``k``
    voxels from any occupied one, the next ``m`` samples with ``m · reach < k − 1`` have empty nearest voxels
    too (rounding to the nearest voxel moves a point by less than one), so they are not looked at. The
    answer is exactly that of testing every sample.
    """
    first = np.full(len(n), -1, np.intp)
    rows = np.flatnonzero(n > 0)
    j = np.zeros(len(rows), np.intp)
    while len(rows):
        k = nearest_voxels(free, at(rows, j))
        hit = k == 0
        first[rows[hit]] = j[hit]
        # the largest m with m · reach < k − 1: samples j + 1 … j + m are empty too
        skip = np.maximum(np.ceil((k - 1) / np.maximum(reach[rows], 1e-12)).astype(np.intp) - 1, 0)
        j = j + skip + 1
        go = ~hit & (j < n[rows])
        rows, j = rows[go], j[go]
    return first


def silhouette_boundary(mask: np.ndarray) -> np.ndarray:
    """The pixels of ``mask`` ``bool (H, W)`` next to its background: its outline, without the frame's edge
    where the object runs out of the photo (a cut the camera made, not an outline of the object).

    >>> m = np.zeros((4, 5), bool); m[1:, 1:4] = True  # touches the bottom edge
    >>> silhouette_boundary(m).astype(int)
    array([[0, 0, 0, 0, 0],
           [0, 1, 1, 1, 0],
           [0, 1, 0, 1, 0],
           [0, 1, 0, 1, 0]])
    """
    from scipy import ndimage

    return mask & ~ndimage.binary_erosion(mask, border_value=1)


def ink_box(image: np.ndarray, margin: int = 1) -> tuple[slice, slice] | None:
    """The box of ``image``'s set pixels (``bool (H, W)``) grown by ``margin`` and clipped to the image, or
    ``None`` when none is set. A stroke's ink covers a few hundred of a view's pixels: dilating and counting
    it on its box, grown by the dilation's reach, gives the whole frame's answer at a small part of its cost
    (and a view's line maps are computed on its mask's box, grown by their filters' reach).

    >>> m = np.zeros((5, 6), bool); m[1, 2] = m[2, 4] = True
    >>> ink_box(m)
    (slice(0, 4, None), slice(1, 6, None))
    """
    rows = np.flatnonzero(image.any(axis=1))
    if not len(rows):
        return None
    cols = np.flatnonzero(image.any(axis=0))
    return (slice(max(int(rows[0]) - margin, 0), int(rows[-1]) + margin + 1),
            slice(max(int(cols[0]) - margin, 0), int(cols[-1]) + margin + 1))
