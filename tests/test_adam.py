"""The fit's Adam: torch's update, without torch.optim's import of the compiler."""

from __future__ import annotations

import subprocess
import sys

import torch

from doodle.fit.adam import Adam


def _trajectory(make) -> torch.Tensor:
    torch.manual_seed(0)
    a, b = torch.nn.Parameter(torch.randn(5, 3)), torch.nn.Parameter(torch.randn(4))
    idle = torch.nn.Parameter(torch.randn(2))  # never gets a gradient: skipped, as torch skips it
    opt = make([{"params": [a, b], "lr": 0.03}, {"params": [idle], "lr": 0.1}])
    for _ in range(60):
        for group in opt.param_groups:
            group["lr"] *= 0.98  # a schedule set between steps
        opt.zero_grad()
        ((a.sin() ** 2).sum() + (b**3).abs().sum() + a.sum() * b.sum()).backward()
        opt.step()
    return torch.cat([a.detach().flatten(), b.detach(), idle.detach()])


def test_the_fits_adam_steps_as_torchs_bit_for_bit():
    assert torch.equal(_trajectory(Adam), _trajectory(torch.optim.Adam))


def test_the_fits_adam_does_not_import_the_compiler():
    code = ("import sys, torch; from doodle.fit.adam import Adam; p = torch.nn.Parameter(torch.ones(3)); "
            "o = Adam([p], lr=0.1); p.sum().backward(); o.step(); "
            "print('torch._dynamo' in sys.modules, float(p[0]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out[0] == "False"  # no compiler loaded
    assert abs(float(out[1]) - 0.9) < 1e-6  # one step of lr 0.1 from 1.0
