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

import os as _os

# torch's OpenMP threads spin at every barrier by default. On a busy machine (a shared CI runner, a laptop
# with a browser open) a spinning thread waits for one that is not scheduled, and a 17 s fit took 250 s
# beside two busy processes. Sleeping waits cost ~10 % on an idle machine and make a loaded one 3-6x faster
# (benchmarks/bench_soak.py). Only when the user chose nothing, and only before torch loads OpenMP.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
