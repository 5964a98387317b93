"""Adam for every optimisation of the fit (the superquadrics' parts and union, discovery's polish, the
gradient stages).

torch's own update (its functional form, ``torch.optim.adam.adam``) with the defaults of
``torch.optim.Adam``, stepped through parameter groups as the class does, so the trajectories are the same
bit for bit, and its state saved and loaded in the class's ``state_dict`` format (a checkpoint written by
either resumes in the other). Not the class itself: constructing any ``torch.optim.Optimizer`` imports
``torch._dynamo`` (its methods are wrapped to keep the compiler out), 1.9-2.6 s of every process that fits,
on this project's 2-core machine.
"""

from __future__ import annotations

from typing import Any, Iterable

import torch
from torch.optim.adam import adam as _adam_update


class Adam:
    """``torch.optim.Adam(groups)`` with its defaults (betas 0.9, 0.999; eps 1e-8; no weight decay) for the
    ``param_groups`` it keeps (each a dict with ``params`` and ``lr``; set ``lr`` between steps for a schedule),
    ``zero_grad`` (to ``None``), ``step``, ``state_dict`` and ``load_state_dict``. Parameters without a gradient
    are skipped, as torch's are."""

    #: the hyper-parameters ``torch.optim.Adam`` writes in each group of its state dict (its defaults)
    DEFAULTS = {"betas": (0.9, 0.999), "eps": 1e-8, "weight_decay": 0, "amsgrad": False, "maximize": False,
                "foreach": None, "capturable": False, "differentiable": False, "fused": None,
                "decoupled_weight_decay": False}

    def __init__(self, groups: Iterable[dict] | Iterable[torch.Tensor], lr: float = 1e-3) -> None:
        groups = list(groups)
        if groups and isinstance(groups[0], torch.Tensor):
            groups = [{"params": groups}]
        self.param_groups = [{"lr": lr, **g, "params": list(g["params"])} for g in groups]
        self._state: dict[int, tuple[torch.Tensor, torch.Tensor, torch.Tensor]] = {}

    def zero_grad(self, set_to_none: bool = True) -> None:  # noqa: ARG002 (torch's signature; always None)
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
            # foreach=None: torch's choice for the device, as the class makes it (off on the CPU)
            _adam_update(params, [p.grad for p in params], [s[0] for s in state], [s[1] for s in state], [],
                         [s[2] for s in state], foreach=None, amsgrad=False, beta1=0.9, beta2=0.999,
                         lr=group["lr"], weight_decay=0.0, eps=1e-8, maximize=False)

    def _params(self) -> list[torch.Tensor]:
        return [p for group in self.param_groups for p in group["params"]]

    def state_dict(self) -> dict[str, Any]:
        """``torch.optim.Adam.state_dict()``'s form: per parameter (numbered through the groups) its ``step``,
        ``exp_avg`` and ``exp_avg_sq`` (the live tensors, as torch gives them); per group its hyper-parameters and
        parameter numbers."""
        numbers = {id(p): k for k, p in enumerate(self._params())}
        state = {numbers[key]: {"step": step, "exp_avg": m, "exp_avg_sq": v}
                 for key, (m, v, step) in self._state.items() if key in numbers}
        groups, start = [], 0
        for group in self.param_groups:
            count = len(group["params"])
            groups.append({"lr": group["lr"], **self.DEFAULTS, "params": list(range(start, start + count))})
            start += count
        return {"state": dict(sorted(state.items())), "param_groups": groups}

    def load_state_dict(self, saved: dict[str, Any]) -> None:
        """Take the moments, steps and rates of ``saved`` (this class's or ``torch.optim.Adam``'s
        :meth:`state_dict` for the same parameters in the same groups), copied onto the parameters' devices."""
        params = self._params()
        if [len(g["params"]) for g in saved["param_groups"]] != [len(g["params"]) for g in self.param_groups]:
            raise ValueError("the saved optimiser state is for other parameter groups")
        numbered = [k for g in saved["param_groups"] for k in g["params"]]
        for k, p in zip(numbered, params):
            if k in saved["state"]:
                s = saved["state"][k]
                self._state[id(p)] = (s["exp_avg"].detach().clone().to(p), s["exp_avg_sq"].detach().clone().to(p),
                                      s["step"].detach().clone().float().cpu())
        for group, old in zip(self.param_groups, saved["param_groups"]):
            group["lr"] = old["lr"]
