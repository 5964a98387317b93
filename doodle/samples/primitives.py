"""Analytic primitives for the procedural scenes: ray intersection, inside test and feature edges.

Each primitive lives in a local frame (``p_world = R p_local + center``) whose z axis is its axis.
``intersect`` takes world rays ``(K, 3)`` and returns the nearest hit distance (``inf`` on a miss) and the
unit world normal there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

INF = np.inf


def _quadratic_roots(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both roots of ``a t² + b t + c`` (``nan`` where none are real); ``t0 ≤ t1``."""
    disc = b * b - 4 * a * c
    ok = (disc >= 0) & (np.abs(a) > 1e-12)
    sq = np.sqrt(np.where(ok, disc, 0.0))
    safe_a = np.where(ok, a, 1.0)
    r0, r1 = (-b - sq) / (2 * safe_a), (-b + sq) / (2 * safe_a)
    t0, t1 = np.minimum(r0, r1), np.maximum(r0, r1)
    return np.where(ok, t0, np.nan), np.where(ok, t1, np.nan)


def _stripes(p: np.ndarray) -> np.ndarray:
    """Diagonal bands 0.08 wide every 0.24 (local units), like tape or a printed label crossing every face."""
    return (p @ np.array([1.0, 0.6, 0.8]) / 0.24) % 1.0 < 0.33


def _gores(p: np.ndarray) -> np.ndarray:
    """Six dark gores of a beach ball (by longitude about local z) and a band round its equator."""
    lon = np.arctan2(p[:, 1], p[:, 0])
    r = np.linalg.norm(p, axis=1)
    return (np.sin(6 * lon) > 0.55) ^ (np.abs(p[:, 2]) < 0.12 * r)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _spots(p: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """``(K,)`` points ``(K, 3)`` whose direction from the local origin lies within ``radii`` (radians) of one
    of the unit directions ``centres`` ``(C, 3)``: round spots painted on a round part."""
    cos = _unit(p) @ centres.T
    return (cos > np.cos(radii)[None]).any(axis=1)


# a face looking along local +x: two eyes up on its sides, a muzzle over its front with two nostrils in it
_EYES = _unit([[0.75, 0.5, 0.45], [0.75, -0.5, 0.45]])
_NOSTRILS = _unit([[1.0, 0.25, -0.3], [1.0, -0.25, -0.3]])
# a hide's patches: spots of different sizes, some overlapping into one irregular patch
_PATCHES = _unit([[0.35, 0.75, 0.55], [0.15, 0.85, 0.2], [-0.55, 0.55, 0.6], [-0.4, -0.8, 0.45], [0.3, -0.85, 0.35],
                  [-0.1, -0.4, 0.9]])
_PATCH_RADII = np.radians([24.0, 16.0, 22.0, 26.0, 17.0, 14.0])


def _face(p: np.ndarray) -> np.ndarray:
    """A cartoon face on a head looking along local +x: two eyes, and a muzzle round its front whose two
    nostrils are left unpainted (each a closed boundary a person draws first)."""
    eyes = _spots(p, _EYES, np.radians([15.0, 15.0]))
    muzzle = (_unit(p) @ _unit([1.0, 0.0, -0.35])) > math.cos(math.radians(32.0))
    nostrils = _spots(p, _NOSTRILS, np.radians([8.0, 8.0]))
    return eyes | (muzzle & ~nostrils)


def _patches(p: np.ndarray) -> np.ndarray:
    """Irregular dark patches on a hide (see :data:`_PATCHES`)."""
    return _spots(p, _PATCHES, _PATCH_RADII)


def _mouse(p: np.ndarray) -> np.ndarray:
    """A computer mouse's shell looking along local +x: the seam between its two buttons and the one behind
    them (thin dark lines over its top), and dark rubber grips on its sides."""
    u = _unit(p)
    top = u[:, 2] > 0.25
    seam = top & (u[:, 0] > 0.2) & (np.abs(u[:, 1]) < 0.035)
    back = top & (np.abs(u[:, 0] - 0.2) < 0.025)
    grips = (np.abs(u[:, 1]) > 0.72) & (u[:, 2] < 0.3) & (np.abs(u[:, 0]) < 0.6)
    return seam | back | grips


#: Printed patterns by name: ``f(local points (K, 3)) → (K,)`` True where ink is.
PRINTS = {"stripes": _stripes, "gores": _gores, "face": _face, "patches": _patches, "mouse": _mouse}
#: The colour factor of printed ink: dark on any colour, a strong edge (as a decal or label is).
PRINT_INK = 0.3


def bounding_sphere_hits(primitives: list["Primitive"], o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``bool (K, P)``: whether ray ``k`` (origin ``o``, unit direction ``d``, ``(K, 3)``) meets primitive ``p``'s
    bounding sphere not wholly behind its origin. All parts at once: ``(o − c)·d = o·d − c·d`` and
    ``|o − c|² = |o|² − 2 o·c + |c|²`` are two matrix products instead of a pass over the rays per part."""
    spheres = [p.bounding_sphere() for p in primitives]
    c = np.array([centre for centre, _ in spheres], float).reshape(-1, 3)
    r = np.array([radius for _, radius in spheres], float)
    b = np.einsum("ij,ij->i", o, d)[:, None] - d @ c.T
    oc2 = np.einsum("ij,ij->i", o, o)[:, None] - 2 * (o @ c.T) + (c * c).sum(axis=1)
    return (b * b - (oc2 - r * r) >= 0) & (b < r)


@dataclass
class Primitive:
    """Base: pose and colour. Subclasses define the shape in the local frame."""

    center: np.ndarray
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    color: tuple[float, float, float] = (0.8, 0.8, 0.8)
    print: str = ""
    """A pattern printed on the surface (:data:`PRINTS`; ``""``: plain): texture, which is not structure."""

    kind = "primitive"

    def printed(self, points: np.ndarray) -> np.ndarray:
        """``(K,)`` colour factor of the print at world surface points ``(K, 3)`` (1 where nothing is printed)."""
        if not self.print:
            return np.ones(len(points))
        return np.where(PRINTS[self.print]((points - self.center) @ self.R), PRINT_INK, 1.0)

    def to_local(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (o - self.center) @ self.R, d @ self.R

    def intersect(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nearest hits of world rays ``(K, 3)`` (unit directions): distance ``(K,)`` (``inf`` on a miss) and
        world normal ``(K, 3)``."""
        t = np.full(len(o), INF)
        n = np.zeros_like(o)
        # Only rays that meet the bounding sphere can hit: most pixels are background or other parts.
        near = bounding_sphere_hits([self], o, d)[:, 0]
        if near.any():
            t[near], n[near] = self.intersect_near(o[near], d[near])
        return t, n

    def intersect_near(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`intersect` of rays already known to meet the bounding sphere (no culling)."""
        ol, dl = self.to_local(o, d)
        t, n = self._intersect_local(ol, dl)
        return t, n @ self.R.T

    def bounding_radius(self) -> float:
        """Radius of a sphere around ``center`` that holds the primitive."""
        raise NotImplementedError

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        """World centre ``(3,)`` and radius of a small sphere that holds the primitive (the rays' cull)."""
        return np.asarray(self.center, float), self.bounding_radius()

    def contains(self, p: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Points within the primitive grown by ``margin`` (world units)."""
        return self._contains_local((p - self.center) @ self.R, margin)

    def feature_edges(self) -> np.ndarray:
        """Sharp edges as world segments ``(K, 2, 3)``."""
        local = self._edges_local()
        return local @ self.R.T + self.center if len(local) else np.zeros((0, 2, 3))

    def _edges_local(self) -> np.ndarray:
        return np.zeros((0, 2, 3))

    def to_dict(self) -> dict:
        return {"type": self.kind, "center": self.center.tolist(), "rotation_matrix": self.R.tolist(),
                "color": list(self.color), **({"print": self.print} if self.print else {})}


@dataclass
class Sphere(Primitive):
    radius: float = 0.5
    kind = "sphere"

    def _intersect_local(self, o, d):
        t0, t1 = _quadratic_roots((d * d).sum(-1), 2 * (o * d).sum(-1), (o * o).sum(-1) - self.radius**2)
        t = np.where(t0 > 1e-9, t0, np.where(t1 > 1e-9, t1, np.nan))
        t = np.nan_to_num(t, nan=INF)
        p = o + np.where(np.isfinite(t), t, 0)[:, None] * d
        return t, p / self.radius

    def _contains_local(self, p, margin):
        return np.linalg.norm(p, axis=-1) <= self.radius + margin

    def bounding_radius(self):
        return self.radius

    def to_dict(self):
        return {**super().to_dict(), "radius": self.radius}


@dataclass
class Ellipsoid(Primitive):
    """Semi-axes ``axes`` along the local x, y, z: a body, a head, a teapot's belly. Smooth: no feature edges."""

    axes: np.ndarray = field(default_factory=lambda: np.full(3, 0.5))
    kind = "ellipsoid"

    def _intersect_local(self, o, d):
        a = np.asarray(self.axes, float)
        os_, ds = o / a, d / a  # the unit sphere in scaled coordinates; t is unchanged
        t0, t1 = _quadratic_roots((ds * ds).sum(-1), 2 * (os_ * ds).sum(-1), (os_ * os_).sum(-1) - 1.0)
        t = np.nan_to_num(np.where(t0 > 1e-9, t0, np.where(t1 > 1e-9, t1, np.nan)), nan=INF)
        p = o + np.where(np.isfinite(t), t, 0)[:, None] * d
        n = p / a**2
        return t, n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)

    def _contains_local(self, p, margin):
        return np.linalg.norm(p / (np.asarray(self.axes, float) + margin), axis=-1) <= 1.0

    def bounding_radius(self):
        return float(np.max(self.axes))

    def to_dict(self):
        return {**super().to_dict(), "axes": np.asarray(self.axes, float).tolist()}


@dataclass
class Box(Primitive):
    half: np.ndarray = field(default_factory=lambda: np.full(3, 0.5))
    kind = "box"

    def _intersect_local(self, o, d):
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / np.where(np.abs(d) < 1e-15, 1e-15, d)
            ta, tb = (-self.half - o) * inv, (self.half - o) * inv
        tmin, tmax = np.minimum(ta, tb), np.maximum(ta, tb)
        t_near, axis = tmin.max(-1), tmin.argmax(-1)
        t_far = tmax.min(-1)
        hit = (t_near <= t_far) & (t_near > 1e-9)
        n = np.zeros_like(o)
        rows = np.arange(len(o))
        n[rows, axis] = -np.sign(d[rows, axis])
        return np.where(hit, t_near, INF), n

    def _contains_local(self, p, margin):
        return (np.abs(p) <= self.half + margin).all(-1)

    def bounding_radius(self):
        return float(np.linalg.norm(self.half))

    def _edges_local(self):
        h = self.half
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float) * h
        edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1]
        return np.array([[corners[i], corners[j]] for i, j in edges])

    def to_dict(self):
        return {**super().to_dict(), "half_size": self.half.tolist()}


def _circle(radius: float, z: float, segments: int = 48) -> np.ndarray:
    a = np.linspace(0, 2 * math.pi, segments + 1)
    pts = np.stack([radius * np.cos(a), radius * np.sin(a), np.full_like(a, z)], -1)
    return np.stack([pts[:-1], pts[1:]], axis=1)


def _caps(o, d, t_best, n_best, z_plane, radius, normal_z):
    """Update the nearest hit with a disk cap at height ``z_plane``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        tc = (z_plane - o[:, 2]) / d[:, 2]
    p = o + np.nan_to_num(tc, nan=0, posinf=0, neginf=0)[:, None] * d
    ok = np.isfinite(tc) & (tc > 1e-9) & ((p[:, 0] ** 2 + p[:, 1] ** 2) <= radius**2) & (tc < t_best)
    t_best = np.where(ok, tc, t_best)
    n_best = np.where(ok[:, None], np.array([0.0, 0.0, normal_z]), n_best)
    return t_best, n_best


@dataclass
class Cylinder(Primitive):
    """Capped cylinder from local z = 0 to z = height."""

    radius: float = 0.2
    height: float = 1.0
    kind = "cylinder"

    def _intersect_local(self, o, d):
        a = d[:, 0] ** 2 + d[:, 1] ** 2
        b = 2 * (o[:, 0] * d[:, 0] + o[:, 1] * d[:, 1])
        c = o[:, 0] ** 2 + o[:, 1] ** 2 - self.radius**2
        t0, t1 = _quadratic_roots(a, b, c)
        t_best = np.full(len(o), INF)
        n_best = np.zeros_like(o)
        for tr in (t1, t0):  # t0 last so the nearer valid root wins
            z = o[:, 2] + np.nan_to_num(tr) * d[:, 2]
            ok = np.isfinite(tr) & (tr > 1e-9) & (z >= 0) & (z <= self.height) & (tr < t_best)
            p = o + np.nan_to_num(tr)[:, None] * d
            t_best = np.where(ok, tr, t_best)
            n_best = np.where(ok[:, None], np.stack([p[:, 0], p[:, 1], 0 * p[:, 2]], -1) / self.radius, n_best)
        t_best, n_best = _caps(o, d, t_best, n_best, 0.0, self.radius, -1.0)
        return _caps(o, d, t_best, n_best, self.height, self.radius, 1.0)

    def _contains_local(self, p, margin):
        return (np.hypot(p[..., 0], p[..., 1]) <= self.radius + margin) & (p[..., 2] >= -margin) & (p[..., 2] <= self.height + margin)

    def _edges_local(self):
        return np.concatenate([_circle(self.radius, 0.0), _circle(self.radius, self.height)])

    def bounding_radius(self):
        return math.hypot(self.radius, self.height)

    def bounding_sphere(self):
        # about the axis' middle: a leg's sphere about its foot covered twice the pixels
        return self.center + self.R[:, 2] * (self.height / 2), math.hypot(self.radius, self.height / 2)

    def to_dict(self):
        return {**super().to_dict(), "radius": self.radius, "height": self.height}


@dataclass
class Cone(Primitive):
    """Cone with its base disk at local z = 0 (radius ``radius``) and apex at z = ``height``."""

    radius: float = 0.3
    height: float = 0.6
    kind = "cone"

    def _intersect_local(self, o, d):
        k2 = (self.radius / self.height) ** 2
        hz = self.height - o[:, 2]
        a = d[:, 0] ** 2 + d[:, 1] ** 2 - k2 * d[:, 2] ** 2
        b = 2 * (o[:, 0] * d[:, 0] + o[:, 1] * d[:, 1] + k2 * hz * d[:, 2])
        c = o[:, 0] ** 2 + o[:, 1] ** 2 - k2 * hz**2
        t0, t1 = _quadratic_roots(a, b, c)
        t_best = np.full(len(o), INF)
        n_best = np.zeros_like(o)
        for tr in (t1, t0):
            p = o + np.nan_to_num(tr)[:, None] * d
            ok = np.isfinite(tr) & (tr > 1e-9) & (p[:, 2] >= 0) & (p[:, 2] <= self.height) & (tr < t_best)
            g = np.stack([p[:, 0], p[:, 1], k2 * (self.height - p[:, 2])], -1)
            g /= np.maximum(np.linalg.norm(g, axis=-1, keepdims=True), 1e-12)
            t_best = np.where(ok, tr, t_best)
            n_best = np.where(ok[:, None], g, n_best)
        return _caps(o, d, t_best, n_best, 0.0, self.radius, -1.0)

    def _contains_local(self, p, margin):
        z = p[..., 2]
        r = self.radius * (1 - np.clip(z, 0, self.height) / self.height)
        return (np.hypot(p[..., 0], p[..., 1]) <= r + margin) & (z >= -margin) & (z <= self.height + margin)

    def _edges_local(self):
        return _circle(self.radius, 0.0)

    def bounding_radius(self):
        return max(self.radius, self.height)

    def bounding_sphere(self):
        # the smallest about the axis holding the base's rim and the apex: sqrt(r² + z²) = h − z, or about the
        # base's centre for a cone wider than tall
        z = max(0.0, (self.height**2 - self.radius**2) / (2 * self.height))
        return self.center + self.R[:, 2] * z, max(self.height - z, math.hypot(self.radius, z))

    def to_dict(self):
        return {**super().to_dict(), "radius": self.radius, "height": self.height}


@dataclass
class Torus(Primitive):
    """Ring about the local z axis: tube of radius ``minor`` around the circle of radius ``major`` in z = 0
    (a cable loop, a mug's handle). Smooth: no feature edges."""

    major: float = 0.3
    minor: float = 0.03
    kind = "torus"

    def _sdf(self, p: np.ndarray) -> np.ndarray:
        """Exact signed distance to the tube, points ``(..., 3)`` → ``(...)``."""
        return np.hypot(np.hypot(p[..., 0], p[..., 1]) - self.major, p[..., 2]) - self.minor

    def _intersect_local(self, o, d, steps: int = 160):
        # Sphere tracing on the exact distance field, from where the ray enters the bounding sphere; a
        # quartic solve per ray would be no faster in numpy and is touchier near grazing hits.
        b = (o * d).sum(-1)
        c = (o * o).sum(-1) - self.bounding_radius() ** 2
        disc = b * b - c
        root = np.sqrt(np.maximum(disc, 0.0))
        t = np.where(disc >= 0, np.maximum(-b - root, 0.0), INF)
        t_out = np.where(disc >= 0, -b + root, -INF)
        live = np.flatnonzero(disc >= 0)
        eps = 1e-5 * self.minor
        for _ in range(steps):
            if len(live) == 0:
                break
            dist = self._sdf(o[live] + t[live, None] * d[live])
            done = dist < eps
            t[live] += np.where(done, 0.0, dist)
            gone = t[live] > t_out[live]
            t[live[gone & ~done]] = INF
            live = live[~done & ~gone]
        t[live] = INF  # not converged: a grazing miss
        p = o + np.where(np.isfinite(t), t, 0.0)[:, None] * d
        ring = np.hypot(p[:, 0], p[:, 1])
        centre = np.stack([p[:, 0], p[:, 1], 0 * p[:, 2]], -1) * (self.major / np.maximum(ring, 1e-12))[:, None]
        n = p - centre
        n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
        return t, n

    def _contains_local(self, p, margin):
        return self._sdf(p) <= margin

    def bounding_radius(self):
        return self.major + self.minor

    def to_dict(self):
        return {**super().to_dict(), "major": self.major, "minor": self.minor}
