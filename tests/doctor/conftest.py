"""Shared fixtures of the LUT doctor tests: one exact table of ours, baked once per session."""

from __future__ import annotations

import numpy as np
import pytest

import bsdf_tab

N = 24


def unit(n: int = N) -> np.ndarray:
    """Endpoint nodes i / (n - 1)."""
    return np.arange(n) / (n - 1)


def dfg_table(mu=None, roughness=None, **spec) -> bsdf_tab.Table:
    """A split-sum table on explicit axes (GGX, correlated unless ``spec`` says otherwise)."""
    mu = unit() if mu is None else mu
    roughness = unit() if roughness is None else roughness
    full = {"table": "dfg", "distribution": "ggx", "shadowing": "correlated", "tolerance": 1e-6,
            "axes": {"mu": [float(x) for x in mu], "roughness": [float(x) for x in roughness]}}
    full.update(spec)
    return bsdf_tab.tabulate(full)


def image_of(table: bsdf_tab.Table, channels=("A", "B")) -> np.ndarray:
    """The table as a (rows, columns, channels) float64 image."""
    return np.stack([np.asarray(table.channels[c], dtype=np.float64) for c in channels], axis=-1)


@pytest.fixture(scope="session")
def ours() -> bsdf_tab.Table:
    """GGX, correlated, 24 x 24 [mu, roughness], endpoints, the exact split-sum table."""
    return dfg_table()
