"""The fitting core: scene → stroke set by optimisation through differentiable projections.

- :mod:`.config`      :class:`FitConfig`
- :mod:`.targets`     per-view masks, line maps and distance fields; batched projection
- :mod:`.init`        visual hull and farthest-point initialisation
- :mod:`.params`      torch parameterisation of curves and superquadrics
- :mod:`.objectives`  pluggable objectives (``edges``: the weight-free default)
- :mod:`.optimize`    one Adam stage with progress, checkpoints and Ctrl-C
- :mod:`.pipeline`    :func:`fit`: the stages end to end
"""

from .config import FitConfig
from .pipeline import FitResult, fit

__all__ = ["FitConfig", "FitResult", "fit"]
