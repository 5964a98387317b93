"""Style geometry: turn one 2D path (cubic pieces in pixels) into the SVG path data a style draws.

Randomness is seeded from the style's seed, the path id and the pass number (hashlib, stable across runs
and processes), and noise is a function of the *relative arc length* along the stroke, so a stroke keeps its
wobble from frame to frame of a turntable instead of flickering.
"""

from __future__ import annotations

import hashlib

import numpy as np

from ..strokes.bezier import bernstein
from .style import Style


def stroke_rng(style: Style, path_id: str, subpath: int, pass_index: int) -> np.random.Generator:
    digest = hashlib.sha256(f"{style.seed}|{path_id}|{subpath}|{pass_index}".encode()).digest()
    return np.random.default_rng(int.from_bytes(digest[:8], "little"))


def sample_polyline(pieces: np.ndarray, spacing: float = 1.5) -> np.ndarray:
    """Dense polyline ``(P, 2)`` along consecutive cubic pieces ``(K, 4, 2)``."""
    out = []
    for k, seg in enumerate(pieces):
        length = np.abs(np.diff(seg, axis=0)).sum()
        n = max(2, int(length / spacing) + 1)
        t = np.linspace(0, 1, n)
        pts = bernstein(t) @ seg
        out.append(pts if k == 0 else pts[1:])
    return np.concatenate(out)


def _normals(p: np.ndarray) -> np.ndarray:
    d = np.gradient(p, axis=0)
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
    return np.stack([-d[:, 1], d[:, 0]], 1)


def _noise(s: np.ndarray, rng: np.random.Generator, waves: float, terms: int = 3) -> np.ndarray:
    """Smooth noise in [-1, 1] over relative arc length ``s``: a few sinusoids of random phase."""
    out = np.zeros_like(s)
    for _ in range(terms):
        f = waves * rng.uniform(0.5, 1.5)
        out += rng.uniform(0.5, 1.0) * np.sin(2 * np.pi * f * s + rng.uniform(0, 2 * np.pi))
    return out / terms


def format_number(v: float, digits: int = 2) -> str:
    """Shortest SVG number with ``digits`` decimals: trailing zeros cut, ``-0`` written ``0``."""
    s = f"{v:.{digits}f}".rstrip("0").rstrip(".") if digits else f"{v:.0f}"
    return "0" if s in ("-0", "") else s


def polyline_d(p: np.ndarray, closed: bool = False) -> str:
    return "M" + " L".join(f"{format_number(x)} {format_number(y)}" for x, y in p) + ("Z" if closed else "")


def styled_path_data(pieces_list: list[np.ndarray], closed: list[bool], style: Style, path_id: str, width: float,
                     outline: bool) -> list[str]:
    """Path data strings (one per pass) for a path with the given subpaths.

    Args:
        width: line width in px (used for filled outlines).
        outline: draw tapered / swelling filled outlines instead of stroked centre lines.
    """
    ln = style.line
    out = []
    for pass_index in range(ln.passes):
        parts = []
        for sub, (pieces, is_closed) in enumerate(zip(pieces_list, closed)):
            rng = stroke_rng(style, path_id, sub, pass_index)
            p = sample_polyline(pieces)
            if len(p) < 2:
                continue
            seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
            L = float(seg.sum())
            if L < 1e-6:
                continue
            loop = is_closed and not ln.overshoot
            if ln.overshoot and not loop:
                a, b = ln.overshoot * rng.uniform(0.3, 1.0), ln.overshoot * rng.uniform(0.3, 1.0)
                t0 = (p[0] - p[1]) / max(seg[0], 1e-9)
                t1 = (p[-1] - p[-2]) / max(seg[-1], 1e-9)
                p = np.vstack([p[0] + a * t0, p, p[-1] + b * t1])
                seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
                L = float(seg.sum())
            s = np.r_[0.0, np.cumsum(seg)] / L
            n = _normals(p)
            offset = np.zeros(len(p))
            if ln.jitter:
                offset += ln.jitter * _noise(s, rng, ln.jitter_waves)
            if ln.roughness:
                offset += ln.roughness * _noise(s, rng, max(8.0, L / 6.0), terms=4)
            if loop:  # keep closed outlines closed: fade the wobble to a common value at the seam
                offset -= np.interp(s, [0, 1], [offset[0], offset[-1]]) - 0.5 * (offset[0] + offset[-1])
            q = p + offset[:, None] * n
            if outline:
                w = np.full(len(q), 0.5 * width)
                if ln.taper:
                    w *= np.sqrt(np.clip(np.minimum(s, 1 - s) / ln.taper, 0.05, 1.0)) if not loop else 1.0
                if ln.width_variation:
                    w *= 1 + ln.width_variation * _noise(s, rng, 1.5)
                nq = _normals(q)
                left, right = q + w[:, None] * nq, q - w[:, None] * nq
                parts.append(polyline_d(np.vstack([left, right[::-1]]), closed=True))
            else:
                parts.append(polyline_d(q, closed=loop))
        if parts:
            out.append("".join(parts))
    return out
