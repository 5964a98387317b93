"""Orbits: cameras evenly spaced in azimuth around the scene's ``up`` axis (DESIGN.md "Orbit")."""

from __future__ import annotations

import math

import numpy as np

from ..strokes.model import SceneFrame
from .camera import Camera, Projection, look_at


def azimuth_basis(up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``e1, e2`` spanning the plane perpendicular to ``up``; azimuth 0 is ``e1``.

    ``e1`` is world x projected onto the plane (world y when ``up`` is close to x), ``e2 = up × e1``.
    For ``up = +z`` this is the usual azimuth from +x towards +y.
    """
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    ref = np.array([1.0, 0, 0]) if abs(up[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = ref - (ref @ up) * up
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(up, e1)


def azimuth_elevation(position: np.ndarray, frame: SceneFrame) -> tuple[float, float, float]:
    """``(azimuth_deg, elevation_deg, distance)`` of a world point seen from the frame's centre."""
    d = np.asarray(position, dtype=np.float64) - frame.center
    dist = float(np.linalg.norm(d))
    e1, e2 = azimuth_basis(frame.up)
    up = frame.up / np.linalg.norm(frame.up)
    el = math.degrees(math.asin(np.clip(d @ up / max(dist, 1e-12), -1, 1)))
    return math.degrees(math.atan2(d @ e2, d @ e1)), el, dist


def orbit_position(frame: SceneFrame, azimuth_deg: float, elevation_deg: float, distance: float) -> np.ndarray:
    """World position at the given spherical coordinates around ``frame.center``."""
    e1, e2 = azimuth_basis(frame.up)
    up = frame.up / np.linalg.norm(frame.up)
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    return frame.center + distance * (math.cos(el) * (math.cos(az) * e1 + math.sin(az) * e2) + math.sin(el) * up)


def orbit_cameras(
    frame: SceneFrame,
    views: int,
    width: int | None = None,
    height: int | None = None,
    projection: Projection = "perspective",
    elevation_deg: float | None = None,
    elevation_bob_deg: float = 0.0,
) -> list[Camera]:
    """``views`` cameras evenly spaced in azimuth, looking at ``frame.center`` (:func:`orbit_camera` for
    ``step = 0 .. views - 1``).

    View 0 sits at ``frame.camera.azimuth_deg``; the distance, field of view and elevation come from
    ``frame.camera`` unless overridden. ``elevation_bob_deg`` adds a seamless ``sin`` up-down motion over the
    loop. Orthographic cameras frame the same extent as the perspective ones at the orbit distance.

    Raises:
        ValueError: if ``views < 1`` or the camera would sit at the centre or on the ``up`` axis.
    """
    if views < 1:
        raise ValueError(f"views must be at least 1, got {views}")
    return [orbit_camera(frame, i, views, width, height, projection, elevation_deg, elevation_bob_deg)
            for i in range(views)]


def orbit_camera(frame: SceneFrame, step: int, views: int, width: int | None = None, height: int | None = None,
                 projection: Projection = "perspective", elevation_deg: float | None = None,
                 elevation_bob_deg: float = 0.0) -> Camera:
    """The camera ``step`` of an orbit of ``views`` (see :func:`orbit_cameras`). Any whole ``step`` is allowed: the
    azimuth and the bob are periodic in it, so step ``views`` is step 0 again (up to rounding), which is what
    makes a turntable loop seamlessly."""
    if views < 1:
        raise ValueError(f"views must be at least 1, got {views}")
    dc = frame.camera
    width = width or dc.width
    height = height or round(width * dc.height / dc.width)
    if dc.distance <= 0:
        raise ValueError("orbit distance must be positive")
    elevation = elevation_deg if elevation_deg is not None else dc.elevation_deg
    if abs(elevation) + abs(elevation_bob_deg) >= 90:
        raise ValueError("elevation must stay strictly between -90 and 90 degrees")
    # Square pixels: the field of view applies to the larger image side.
    f = 0.5 * max(width, height) / math.tan(math.radians(dc.fov_deg) / 2)
    phase = 2 * math.pi * step / views
    el = elevation + elevation_bob_deg * math.sin(phase)
    az = dc.azimuth_deg + 360.0 * step / views
    eye = orbit_position(frame, az, el, dc.distance)
    R, t = look_at(eye, frame.center, frame.up)
    fx = f if projection == "perspective" else f / dc.distance
    if projection == "orthographic":
        t = t.copy()  # keep the eye at the orbit distance so depths stay positive
    return Camera(fx, fx, width / 2, height / 2, width, height, R, t, projection, name=f"orbit_{step % views:03d}")
