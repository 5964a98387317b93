"""Cameras (OpenCV convention) and orbit generation."""

from .camera import OUTPUT_CAP, Camera, Projection, look_at, output_size, project_points
from .orbit import azimuth_basis, azimuth_elevation, orbit_camera, orbit_cameras, orbit_position

__all__ = ["OUTPUT_CAP", "Camera", "Projection", "look_at", "output_size", "project_points", "azimuth_basis", "azimuth_elevation",
           "orbit_camera", "orbit_cameras", "orbit_position"]
