"""The fitting core: scene → stroke set by optimisation through differentiable projections.

- :mod:`.config`      :class:`FitConfig` and the detail levels
- :mod:`.discovery`   stroke discovery (a room of its own)
- :mod:`.volume`      the volume: superquadric abstraction, outlines, hulls (a room of its own)
- :mod:`.hiding`      which curves the views see from every side (after the choice)
- :mod:`.targets`     per-view masks, line maps and distance fields; batched projection
- :mod:`.init`        visual hull and farthest-point initialisation
- :mod:`.params`      torch parameterisation of curves and superquadrics
- :mod:`.objectives`  pluggable objectives (``edges``: the weight-free default)
- :mod:`.optimize`    one Adam stage with progress, checkpoints and Ctrl-C
- :mod:`.pipeline`    :func:`fit`: the stages end to end
"""

from typing import TYPE_CHECKING, Any

from .config import DETAIL_LEVELS, FitConfig

if TYPE_CHECKING:
    from .pipeline import FitResult, fit

__all__ = ["DETAIL_LEVELS", "FitConfig", "FitResult", "fit"]


def __getattr__(name: str) -> Any:
    # The pipeline (and torch) load on first use: the CLI reads the detail levels without them.
    if name in ("FitResult", "fit"):
        from . import pipeline

        return getattr(pipeline, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
