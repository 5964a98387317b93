"""Shared fixtures: small procedural scenes rendered once per session, and the optional real data."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

# xdist's workers share the cores: each gets its share of them for torch's and OpenMP's threads (two workers
# with two threads each on two cores made a fit 29 s instead of 21 s), and so do the `doodle` subprocesses
# the tests start. Set before torch is imported (this conftest is loaded before anything is collected).
if "PYTEST_XDIST_WORKER_COUNT" in os.environ:
    from doodle.workers import cpu_count  # standard library only: torch is not loaded by it

    _threads = str(max(1, cpu_count() // int(os.environ["PYTEST_XDIST_WORKER_COUNT"])))
    for _var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ.setdefault(_var, _threads)


SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
LEGO = SHARED_DATA / "nerf_synthetic" / "lego"


@pytest.fixture(scope="session")
def lego_dir() -> Path:
    if not (LEGO / "transforms_train.json").exists():
        pytest.skip("real Lego data (../shared/data/nerf_synthetic/lego) not present")
    return LEGO


@pytest.fixture(scope="session")
def chair_dir(tmp_path_factory) -> Path:
    from doodle.samples import write_sample

    return write_sample("chair", tmp_path_factory.mktemp("scenes") / "chair", n_train=12, n_test=4, size=128)


@pytest.fixture(scope="session")
def snowman_dir(tmp_path_factory) -> Path:
    from doodle.samples import write_sample

    return write_sample("snowman", tmp_path_factory.mktemp("scenes") / "snowman", n_train=12, n_test=4, size=128)


@pytest.fixture(scope="session")
def tripod_dir(tmp_path_factory) -> Path:
    from doodle.samples import write_sample

    return write_sample("tripod", tmp_path_factory.mktemp("scenes") / "tripod", n_train=20, n_test=4, size=160)
