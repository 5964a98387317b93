"""doodle: multi-view images → compact 3D strokes → view-consistent vector sketches.

The package is organised by pipeline stage (see ``DESIGN.md`` in the repository):

- :mod:`doodle.strokes`   stroke model (Bézier curves, superquadrics) and the ``.doodle`` file format
- :mod:`doodle.cameras`   pinhole/orthographic cameras and orbits (OpenCV convention)
- :mod:`doodle.scenes`    dataset parsers (NeRF-synthetic, nerfstudio, COLMAP, photos)
- :mod:`doodle.samples`   procedural scenes with ground truth, rendered by an analytic ray caster
- :mod:`doodle.exporters` SVG / PNG / PDF / contact sheets
- :mod:`doodle.cli`       the ``doodle`` command, a thin layer over the above
"""

__version__ = "0.1.0"
