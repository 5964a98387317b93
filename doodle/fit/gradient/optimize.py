"""One optimisation stage: Adam over a module's parameters with progress, best-state tracking, checkpoints
and clean interruption (Ctrl-C ends the stage and keeps the best state)."""

from __future__ import annotations

import copy
import math
import sys
import time
from dataclasses import dataclass, fields
from typing import Callable

import torch
from tqdm import tqdm

from ..adam import Adam
from .objectives import Terms


@dataclass
class StageState:
    """Everything needed to continue a stage later (stored in checkpoints)."""

    step: int = 0
    optimizer: dict | None = None
    best: dict | None = None
    best_loss: float = float("inf")
    ema: float | None = None

    def to_dict(self) -> dict:
        """Plain types and tensors only (checkpoints are read with ``weights_only``)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, d: dict) -> "StageState":
        return cls(**{f.name: d[f.name] for f in fields(cls) if f.name in d})


def run_stage(
    name: str,
    module: torch.nn.Module,
    terms_fn: Callable[[torch.Tensor], Terms],
    iterations: int,
    lr: float,
    n_views: int,
    views_per_step: int,
    generator: torch.Generator,
    state: StageState | None = None,
    on_checkpoint: Callable[[StageState], None] | None = None,
    checkpoint_every: int = 200,
    on_preview: Callable[[int], None] | None = None,
    preview_every: int = 0,
    progress: bool = True,
) -> tuple[StageState, bool]:
    """Run (or continue) a stage; returns its state and whether it was interrupted.

    At the end (or on interruption) ``module`` holds the best parameters seen, judged by an exponential
    moving average of the total loss (single steps are too noisy with random views and pixels).
    """
    state = state or StageState()
    opt = Adam(module.parameters(), lr=lr)
    if state.optimizer:
        opt.load_state_dict(state.optimizer)

    def set_lr(step: int) -> None:
        # cosine decay to 10 %: large steps to find the lines, small ones to settle on them
        frac = step / max(iterations, 1)
        for group in opt.param_groups:
            group["lr"] = lr * (0.1 + 0.45 * (1 + math.cos(math.pi * min(frac, 1.0))))
    interrupted = False
    tty = sys.stderr.isatty()
    # A live bar on terminals; in logs (CI, pipes) a plain line every 10 % instead of carriage returns.
    bar = tqdm(total=iterations, initial=state.step, desc=name, unit="it", disable=not (progress and tty),
               mininterval=0.3, dynamic_ncols=True, leave=False)
    log_every = max(1, iterations // 10) if progress and not tty else 0
    started, start_step = time.perf_counter(), state.step
    try:
        while state.step < iterations:
            set_lr(state.step)
            views = torch.randperm(n_views, generator=generator, device=generator.device)[:views_per_step]
            terms = terms_fn(views)
            opt.zero_grad(set_to_none=True)
            terms["total"].backward()
            opt.step()
            state.step += 1
            values = {k: float(v.detach()) for k, v in terms.items()}
            state.ema = values["total"] if state.ema is None else 0.95 * state.ema + 0.05 * values["total"]
            if state.step % 10 == 0 or state.step == iterations:
                if state.ema < state.best_loss and state.step >= min(50, iterations // 2):
                    state.best_loss = state.ema
                    state.best = copy.deepcopy(module.state_dict())
                bar.set_postfix({k: f"{v:.4f}" for k, v in values.items()}, refresh=False)
            bar.update(1)
            if log_every and (state.step % log_every == 0 or state.step == iterations):
                rate = (state.step - start_step) / max(time.perf_counter() - started, 1e-9)
                eta = (iterations - state.step) / max(rate, 1e-9)
                terms_s = " ".join(f"{k} {v:.4f}" for k, v in values.items())
                print(f"{name} {state.step}/{iterations} {rate:.1f} it/s {terms_s} eta {eta:.0f} s",
                      file=sys.stderr, flush=True)
            if on_checkpoint and state.step % checkpoint_every == 0 and state.step < iterations:
                state.optimizer = opt.state_dict()
                on_checkpoint(state)
            if on_preview and preview_every and state.step % preview_every == 0:
                on_preview(state.step)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
    state.optimizer = opt.state_dict()
    if state.best is not None:
        module.load_state_dict(state.best)
    return state, interrupted


