"""Shared test configuration."""

from __future__ import annotations

import os

import matplotlib
import pytest
from hypothesis import HealthCheck, settings

matplotlib.use("Agg")

settings.register_profile(
    "default",
    deadline=None,
    max_examples=60,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "ci",
    deadline=None,
    max_examples=40,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("ci" if os.environ.get("CI") else "default")


@pytest.fixture
def seed001():
    """The example of Hou, Wen & Chen (2011), §4."""
    import geomfdi as gf

    A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
    B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
    C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
    return gf.Plant(A, B, C)


@pytest.fixture
def c_cache(tmp_path_factory, monkeypatch):
    """Compiled libraries (simulation kernels, monitors) built into one cache folder of
    the test session, and the simulation backend left at its default."""
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "gfcache"))
    monkeypatch.delenv("GEOMFDI_SIM_BACKEND", raising=False)
