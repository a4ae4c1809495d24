"""Shared test helpers: one allclose with explicit tolerances, seeded generators."""

from __future__ import annotations

import numpy as np
import pytest


def assert_close(actual, expected, *, atol: float, rtol: float = 0.0, what: str = "") -> None:
    """The suite's single allclose: explicit tolerances, and the worst deviation on failure."""
    a, e = np.asarray(actual), np.asarray(expected)
    # complex stays complex (spectra): |a - e| then measures both parts
    kind = complex if np.iscomplexobj(a) or np.iscomplexobj(e) else float
    a, e = a.astype(kind), e.astype(kind)
    assert a.shape == e.shape, f"{what}: shape {a.shape} != {e.shape}"
    dev = np.abs(a - e)
    bound = atol + rtol * np.abs(e)
    worst = float(np.max(dev - bound)) if dev.size else -1.0
    assert np.all(dev <= bound), (
        f"{what}: max deviation {float(np.max(dev)):.3e} exceeds atol={atol:g}, rtol={rtol:g} "
        f"(by {worst:.3e})"
    )


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)
