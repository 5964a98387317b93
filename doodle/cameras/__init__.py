"""Cameras (OpenCV convention) and orbit generation."""

from .camera import Camera, Projection, look_at, project_points
from .orbit import azimuth_basis, azimuth_elevation, orbit_cameras, orbit_position

__all__ = ["Camera", "Projection", "look_at", "project_points", "azimuth_basis", "azimuth_elevation",
           "orbit_cameras", "orbit_position"]
