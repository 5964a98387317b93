"""Objectives, by name. ``edges`` (weight-free, the default) is always available."""

from __future__ import annotations

from typing import Callable

from ....errors import DoodleError
from .base import Objective, Terms
from .edges import EdgesObjective

OBJECTIVES: dict[str, Callable[[], Objective]] = {"edges": EdgesObjective}


def make_objective(name: str) -> Objective:
    if name not in OBJECTIVES:
        raise DoodleError(f"unknown objective {name!r} (available: {', '.join(sorted(OBJECTIVES))})")
    return OBJECTIVES[name]()


__all__ = ["OBJECTIVES", "Objective", "Terms", "make_objective"]
