"""Adam for the fit's short optimisations (the superquadrics' parts and union, discovery's polish).

torch's own update (its functional form, ``torch.optim.adam.adam``) with the defaults of
``torch.optim.Adam``, stepped through parameter groups as the class does, so the trajectories are the same
bit for bit. Not the class itself: constructing any ``torch.optim.Optimizer`` imports ``torch._dynamo`` (its
methods are wrapped to keep the compiler out), 1.9-2.6 s of every ``doodle fit`` on this project's 2-core
machine, for optimisations that take seconds. The gradient stage, which checkpoints its optimiser's state,
keeps ``torch.optim.Adam``: it runs for minutes.
"""

from __future__ import annotations

from typing import Iterable

import torch
from torch.optim.adam import adam as _adam_update


class Adam:
    """``torch.optim.Adam(groups)`` with its defaults (betas 0.9, 0.999; eps 1e-8; no weight decay) for the
    ``param_groups`` it keeps (each a dict with ``params`` and ``lr``; set ``lr`` between steps for a schedule),
    ``zero_grad`` (to ``None``) and ``step``. Parameters without a gradient are skipped, as torch's are."""

    def __init__(self, groups: Iterable[dict] | Iterable[torch.Tensor], lr: float = 1e-3) -> None:
        groups = list(groups)
        if groups and isinstance(groups[0], torch.Tensor):
            groups = [{"params": groups}]
        self.param_groups = [{"lr": lr, **g, "params": list(g["params"])} for g in groups]
        self._state: dict[int, tuple[torch.Tensor, torch.Tensor, torch.Tensor]] = {}

    def zero_grad(self) -> None:
        for group in self.param_groups:
            for p in group["params"]:
                p.grad = None

    @torch.no_grad()
    def step(self) -> None:
        for group in self.param_groups:
            params = [p for p in group["params"] if p.grad is not None]
            if not params:
                continue
            state = [self._state.setdefault(id(p), (torch.zeros_like(p), torch.zeros_like(p), torch.tensor(0.0)))
                     for p in params]
            _adam_update(params, [p.grad for p in params], [s[0] for s in state], [s[1] for s in state], [],
                         [s[2] for s in state], foreach=False, amsgrad=False, beta1=0.9, beta2=0.999,
                         lr=group["lr"], weight_decay=0.0, eps=1e-8, maximize=False)
