"""Shared fixtures: small procedural scenes rendered once per session, and the optional real data."""

from __future__ import annotations

from pathlib import Path

import pytest


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
