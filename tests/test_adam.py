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


def _steps(opt, params, count: int) -> None:
    for _ in range(count):
        opt.zero_grad(set_to_none=True)
        ((params[0].sin() ** 2).sum() + (params[1] ** 3).abs().sum()).backward()
        opt.step()


def _resumed(first, second) -> torch.Tensor:
    """Parameters after 20 steps of ``first``, its state dict through a save and load into ``second``, 20 more."""
    import io

    torch.manual_seed(1)
    params = [torch.nn.Parameter(torch.randn(4, 3)), torch.nn.Parameter(torch.randn(5))]
    opt = first(params, lr=0.05)
    _steps(opt, params, 20)
    buffer = io.BytesIO()
    torch.save(opt.state_dict(), buffer)  # as a checkpoint holds it
    buffer.seek(0)
    again = second(params, lr=0.5)  # the saved rate wins, as torch's load does
    again.load_state_dict(torch.load(buffer, weights_only=True))
    _steps(again, params, 20)
    return torch.cat([p.detach().flatten() for p in params])


def test_a_saved_state_resumes_as_torchs_in_either_class():
    """The gradient stage's checkpoints hold the optimiser's state: one written by ``torch.optim.Adam`` (an
    earlier release) or by the fit's Adam resumes in the other to the same parameters, bit for bit."""
    truth = _resumed(torch.optim.Adam, torch.optim.Adam)
    assert torch.equal(_resumed(Adam, Adam), truth)
    assert torch.equal(_resumed(torch.optim.Adam, Adam), truth)
    assert torch.equal(_resumed(Adam, torch.optim.Adam), truth)
    params = [torch.nn.Parameter(torch.ones(2))]
    try:
        Adam([{"params": params}, {"params": [torch.nn.Parameter(torch.ones(1))]}]).load_state_dict(
            Adam(params).state_dict())
    except ValueError as exc:
        assert "other parameter groups" in str(exc)
    else:
        raise AssertionError("a state for other groups was loaded")
