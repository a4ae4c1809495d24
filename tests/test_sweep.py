"""Sweeps: order, per-item failures, executors, process pools and a dask LocalCluster."""

from __future__ import annotations

import concurrent.futures as cf
import importlib.util
import os

import numpy as np
import pytest

from workbench.core.errors import ParameterError
from workbench.simulation._sweep import (
    InlineExecutor,
    ItemStatus,
    MissingDependencyError,
    OnError,
    StartMethod,
    SweepError,
    grid,
    local_cluster,
    sweep,
)


def power(*, x: float, k: int = 2) -> float:
    return float(x) ** k


def fails_on_three(*, x: int) -> int:
    if x == 3:
        raise ValueError(f"x = {x} is not allowed")
    return x


def seeded_mean(*, seed: int, n: int) -> float:
    return float(np.random.default_rng(seed).standard_normal(n).mean())


def pid(*, x: int) -> int:
    return os.getpid()


def orbit_crossings(*, c: float) -> np.ndarray:
    """A real workload: 5 section crossings of the Routh orbit for c."""
    from models import pendulum3d as p3
    from workbench.global_dynamics._poincare import poincare_map, turning_section

    body = {"J": np.diag([0.13, 0.28, 0.17]), "rho": np.array([0.0, 0.0, 0.3])}
    full = p3.full(**body)
    x0, mu = p3.routh_state_from_full(full, full.state(R=np.eye(3), omega=c * np.ones(3)))
    orb = poincare_map(p3.routh(**body, mu=mu), x0, turning_section(), n_crossings=5,
                       t_max=100.0, stabilization=10.0)
    return orb.x


def test_grid_is_the_cartesian_product():
    g = grid(x=[1, 2, 3], k=[1, 2])
    assert len(g) == 6 and g[0] == {"x": 1, "k": 1} and g[-1] == {"x": 3, "k": 2}
    with pytest.raises(ParameterError, match="sequence"):
        grid(x=3)


def test_inline_results_in_item_order():
    items = grid(x=list(range(10)), k=[3])
    res = sweep(power, items, executor=InlineExecutor())
    assert res.values() == [float(x) ** 3 for x in range(10)]
    assert [o.index for o in res] == list(range(10))
    assert res.cost["n_failed"] == 0


def test_failures_are_reported_per_item_not_swallowed():
    items = grid(x=[1, 2, 3, 4])
    with pytest.raises(SweepError, match="item 2") as info:
        sweep(fails_on_three, items, executor=InlineExecutor())
    result = info.value.result
    assert [o.status for o in result] == [ItemStatus.OK] * 2 + [ItemStatus.FAILED, ItemStatus.OK]
    assert result.outcomes[3].value == 4                        # later items still ran
    rep = sweep(fails_on_three, items, executor=InlineExecutor(), on_error=OnError.REPORT)
    (fail,) = rep.failures
    assert fail.index == 2 and fail.error.startswith("ValueError: x = 3")
    assert "fails_on_three" in fail.traceback
    with pytest.raises(SweepError):
        rep.values()


def test_process_pool_default_matches_inline_and_uses_workers():
    items = grid(seed=list(range(6)), n=[1000])
    a = sweep(seeded_mean, items, workers=2)
    b = sweep(seeded_mean, items, executor=InlineExecutor())
    assert a.values() == b.values()                             # seeded: identical numbers
    assert "process pool (2 workers, spawn)" == a.cost["backend"]
    pids = sweep(pid, grid(x=list(range(8))), workers=2, start_method=StartMethod.FORK)
    assert os.getpid() not in pids.values()


def test_process_pool_failure_and_real_workload():
    res = sweep(fails_on_three, grid(x=[3, 5]), workers=2, on_error=OnError.REPORT,
                start_method=StartMethod.FORK)
    assert [o.ok for o in res] == [False, True]
    out = sweep(orbit_crossings, grid(c=[1.0, 10.0]), workers=2,
                start_method=StartMethod.FORK).values()
    inline = sweep(orbit_crossings, grid(c=[1.0, 10.0]), executor=InlineExecutor()).values()
    for a, b in zip(out, inline):
        np.testing.assert_array_equal(a, b)                     # deterministic across processes
        assert np.max(np.abs(a[:, 5])) < 1e-12                  # on the section


def test_caller_owned_executor_is_not_shut_down():
    with cf.ThreadPoolExecutor(max_workers=2) as pool:
        r1 = sweep(power, grid(x=[1, 2]), executor=pool)
        r2 = sweep(power, grid(x=[3]), executor=pool)           # still usable
    assert r1.values() == [1.0, 4.0] and r2.values() == [9.0]


def test_bad_input_raises():
    with pytest.raises(ParameterError, match="picklable"):
        sweep(lambda x: x, grid(x=[1]), workers=1)
    with pytest.raises(ParameterError, match="items"):
        sweep(power, {"x": 1})
    with pytest.raises(ParameterError, match=r"items\[1\]"):
        sweep(power, [{"x": 1}, 5], executor=InlineExecutor())
    with pytest.raises(ParameterError, match="workers"):
        sweep(power, grid(x=[1]), workers=0)
    with pytest.raises(ParameterError, match="workers applies only"):
        sweep(power, grid(x=[1]), executor=InlineExecutor(), workers=2)
    with pytest.raises(ParameterError, match="executor"):
        sweep(power, grid(x=[1]), executor="dask")
    with pytest.raises(ParameterError, match="callable"):
        sweep(3, grid(x=[1]))


HAVE_DASK = importlib.util.find_spec("distributed") is not None


@pytest.mark.skipif(not HAVE_DASK, reason="dask.distributed not installed (extra 'sweep')")
def test_dask_local_cluster():
    with local_cluster(workers=2) as client:
        try:
            res = sweep(power, grid(x=list(range(8)), k=[2]), executor=client)
            assert res.values() == [float(x) ** 2 for x in range(8)]
            assert res.cost["backend"].startswith("dask.distributed")
            bad = sweep(fails_on_three, grid(x=[2, 3]), executor=client,
                        on_error=OnError.REPORT)
            assert [o.ok for o in bad] == [True, False]
            assert "ValueError" in bad.failures[0].error
            # a closure is fine for dask (cloudpickle), the results are in order
            scale = 3.0
            res2 = sweep(lambda *, x: scale * x, grid(x=[1, 2, 3]), executor=client)
            assert res2.values() == [3.0, 6.0, 9.0]
        finally:
            client.cluster.close()


def test_missing_dask_is_a_clear_error(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # import now fails
    with pytest.raises(MissingDependencyError, match=r"\[sweep\]"):
        local_cluster()
