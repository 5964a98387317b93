"""The fitting core: scene → stroke set, as stages (:mod:`.stages`) that :func:`fit` runs in order.

- :mod:`.config`      :class:`FitConfig`: every option, in groups, with its help text (the CLI derives from it)
- :mod:`.pipeline`    :func:`fit`: the stages end to end, the ``--outline auto`` fallback, checkpoints, Ctrl-C
- :mod:`.state`       :class:`~.state.FitState`, what the stages share, and its checkpoint form
- :mod:`.stages`      prepare → volume → discover → superquadrics → curves → assemble, one module each
- :mod:`.discovery`   stroke discovery: curves from the multi-view edge evidence (a room of its own)
- :mod:`.volume`      the carved hull, the superquadric abstraction, outlines, silhouettes (a room of its own)
- :mod:`.gradient`    the gradient optimiser (Adam on image objectives) for the paths that need it
- :mod:`.hiding`      which curves the views see from every side (after the choice)
- :mod:`.preview`     ``--preview`` contact sheets during the gradient stages
"""

from typing import TYPE_CHECKING, Any

from .config import DETAIL_LEVELS, FitConfig

if TYPE_CHECKING:
    from .pipeline import FitResult, fit

__all__ = ["DETAIL_LEVELS", "FitConfig", "FitResult", "fit"]


def __getattr__(name: str) -> Any:
    # The pipeline (and torch) load on first use: the CLI reads the options without them.
    if name in ("FitResult", "fit"):
        from . import pipeline

        return getattr(pipeline, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
