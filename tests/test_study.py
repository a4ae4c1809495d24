"""The study room's shared comparisons and figures (workbench.study)."""

from __future__ import annotations

import numpy as np
import pytest

from workbench.core.errors import ParameterError
from workbench.linear import Stability, eigenstructure
from workbench.study import (
    Panel,
    Result,
    compare_counts,
    compare_rows,
    compare_spectrum,
    compare_stability,
    decay_rate,
    line_figure,
    match_spectrum,
    sign_pattern,
    spectrum_figure,
)

RNG = np.random.default_rng(14)


def _spectrum(n_pairs: int, n_real: int) -> np.ndarray:
    z = RNG.standard_normal(n_pairs) + 1j * (0.5 + RNG.random(n_pairs))
    return np.concatenate([z, z.conj(), RNG.standard_normal(n_real)])


@pytest.mark.parametrize("trial", range(5))
def test_match_recovers_a_permutation_exactly(trial):
    ref = _spectrum(3, 2)
    perm = RNG.permutation(ref.size)
    m = match_spectrum(ref[perm], ref)
    assert m.max_deviation == 0.0
    np.testing.assert_array_equal(perm[m.index], np.arange(ref.size))


def test_match_of_a_perturbed_spectrum_deviates_by_the_perturbation():
    ref = _spectrum(4, 3)
    eps = 1e-7 * (RNG.standard_normal(ref.size) + 1j * RNG.standard_normal(ref.size))
    perm = RNG.permutation(ref.size)
    m = match_spectrum((ref + eps)[perm], ref)
    np.testing.assert_allclose(m.deviations, np.abs(eps), rtol=0, atol=1e-15)
    assert m.max_part_deviation <= m.max_deviation <= np.sqrt(2) * m.max_part_deviation


def test_conjugate_pairs_are_matched_to_their_own_half_plane():
    # a pair +-i w with w close to another pair: each value takes its own conjugate
    ref = np.array([1j, -1j, 1.001j, -1.001j])
    got = np.array([-1.001j, 1j + 1e-12, 1.001j, -1j])
    m = match_spectrum(got, ref)
    np.testing.assert_array_equal(np.sign(m.computed.imag), np.sign(ref.imag))
    assert m.max_deviation <= 1e-12


def test_repeated_values_take_distinct_computed_values():
    # greedy nearest-first would pair both references with the first 0.5 when the
    # reference order is unlucky; the assignment pairs one to one
    m = match_spectrum([0.5, 0.5 + 1e-9, 3.0], [0.5, 0.5])
    assert sorted(m.index.tolist()) == [0, 1]
    assert m.max_deviation <= 1e-9


def test_optimal_assignment_beats_greedy_nearest_first():
    # references (0, 0.15), computed (0.1, -0.2): nearest-first in reference order pairs
    # 0 -> 0.1 and leaves 0.15 -> -0.2 (worst 0.35); the assignment pairs 0 -> -0.2,
    # 0.15 -> 0.1 (worst 0.2, total 0.25 < 0.45)
    m = match_spectrum([0.1, -0.2], [0.0, 0.15])
    assert m.computed.real.tolist() == [-0.2, 0.1]
    assert np.isclose(m.max_deviation, 0.2) and np.isclose(m.deviations.sum(), 0.25)


def test_reference_may_be_a_subset_and_must_be_finite():
    m = match_spectrum([0.0, 0.0, 2j, -2j], [2j, -2j])
    assert m.max_deviation == 0.0 and set(m.index.tolist()) == {2, 3}
    with pytest.raises(ParameterError, match="more than"):
        match_spectrum([1.0], [1.0, 2.0])
    with pytest.raises(ParameterError, match="finite"):
        match_spectrum([np.nan, 1.0], [1.0])


def test_compare_spectrum_records_worst_or_each():
    res = Result("t", "t")
    ref = np.array([-1 + 2j, -1 - 2j, -3.0])
    compare_spectrum(res, "case", ref[::-1] + 1e-6, ref, tolerance=1e-5, source="closed form")
    (c,) = res.comparisons
    assert c.ok and np.isclose(c.workbench, 1e-6) and "3 eigenvalues" in c.quantity
    compare_spectrum(res, "each", ref + 1e-3, ref, tolerance=1e-4, source="s", each=True)
    assert len(res.comparisons) == 4 and not any(c.ok for c in res.comparisons[1:])
    # printed to 4 decimals: measured on real and imaginary parts separately
    compare_spectrum(res, "parts", ref + (3e-5 + 3e-5j), ref, tolerance=5e-5, source="s",
                     parts=True)
    assert res.comparisons[-1].ok and np.isclose(res.comparisons[-1].workbench, 3e-5)


def test_compare_rows_records_each_row_with_its_source():
    res = Result("t", "t")
    rows = compare_rows(res, [("a", 1.0, 1.0 + 1e-10, 1e-9),
                              ("b", 2.0, 2.5, 0.1, "own source")], source="default")
    assert [(c.quantity, c.source, c.ok) for c in rows] == [("a", "default", True),
                                                            ("b", "own source", False)]
    rel = compare_rows(res, [("c", 100.0, 101.0, 0.02)], source="s", relative=True)
    assert rel[0].ok and np.isclose(rel[0].deviation, 0.01)
    with pytest.raises(ParameterError, match="source"):
        compare_rows(res, [("d", 0.0, 0.0, 1.0)])
    with pytest.raises(ParameterError, match="row"):
        compare_rows(res, [("e", 0.0, 0.0)], source="s")
    assert len(res.comparisons) == 3


def test_counts_and_stability_of_a_saddle():
    es = eigenstructure(np.diag([1.0, -2.0]))
    res = Result("t", "t")
    compare_stability(res, "saddle", es, Stability.SADDLE, 1, source="diag(1, -2)")
    compare_counts(res, "saddle", {"stable modes": (1, es.n_stable)}, source="diag(1, -2)")
    assert [c.ok for c in res.comparisons] == [True, True, True]
    compare_stability(res, "wrong", es, Stability.STABLE_NODE, 0, source="s")
    assert [c.ok for c in res.comparisons[3:]] == [False, False]


def test_decay_rate_finds_the_slowest_exponent():
    t = np.linspace(0.0, 40.0, 801)
    z = 0.5 * np.exp(-0.7 * t) + 1e-3 * np.exp(-3.0 * t)  # the slow mode dominates late
    assert abs(decay_rate(t, z) + 0.7) < 1e-6
    assert np.isnan(decay_rate(t[:3], z[:3]))  # too few samples in the band


def test_sign_pattern_counts_each_class():
    ev = np.array([0.0, 1e-14, -1.0, -2.0, 3.0, -0.5 + 1j, -0.5 - 1j, 0.2 + 2j])
    sp = sign_pattern(ev, 1e-10)
    assert sp == {"zero": 2, "negative_real": 2, "positive_real": 1, "left_half_plane": 4,
                  "right_half_plane": 2}


def test_result_figure_keeps_caption_and_figures_mapping():
    res = Result("t", "t")
    fig = line_figure([Panel("a", {"x": ([0, 1], [1, 2])}),
                       Panel("b", {"y": ([0, 1], [1, 1e-3]), "z": ([0, 1], [2, 1])},
                             yscale="log")])
    res.figure("lines", fig, caption="Two panels.")
    assert res.figures["lines"] is fig and res.as_dict()["captions"] == {"lines": "Two panels."}
    assert len([a for a in fig.axes if a.get_visible()]) == 2
    many = line_figure([Panel("c", {"k": ([0, 1, 2], np.ones((3, 4))), "l": ([0, 2], [1, 2])})])
    ax = many.axes[0]
    assert len(ax.lines) == 5 and len({ln.get_color() for ln in ax.lines[:4]}) == 1
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["k", "l"]
    with pytest.raises(ParameterError, match="caption"):
        res.figure("bad", fig, caption="  ")
    # one legend under the panels: every label once, in first-seen order, none in a panel
    below = line_figure([Panel("a", {"k": ([0, 1], [1, 2]), "l": ([0, 1], [2, 1])}),
                         Panel("b", {"l": ([0, 1], [1, 1]), "m": ([0, 1], [0, 1])})],
                        legend="below")
    assert all(a.get_legend() is None for a in below.axes)
    assert [t.get_text() for t in below.legends[0].get_texts()] == ["k", "l", "m"]
    with pytest.raises(ParameterError, match="legend must be 'panels' or 'below'; got 'top'"):
        line_figure([Panel("a", {"k": ([0, 1], [1, 2])})], legend="top")
    spec = spectrum_figure({"hanging": ([1j, -1j], [1j, -1j]), "alone": ([-1.0], None)})
    assert len(spec.axes) == 2  # two panels on one row of at most three
    assert np.allclose(spec.axes[0].lines[2].get_ydata(), [1.0, -1.0])  # Im of computed
    assert len(spec.axes[1].lines) == 3  # no reference ring drawn


# ----------------------------------------------------------------------------------------
# cases and isolated runs (the extremes study's machinery)


def _child_facts(x):
    import os

    return os.getpid(), os.environ.get("OPENBLAS_NUM_THREADS"), 2 * x


def _child_raises():
    raise ParameterError("refused in the child")


def _child_dies():
    import os

    os._exit(3)


def test_run_isolated_runs_in_a_fresh_single_threaded_process():
    import os

    from workbench.study import run_isolated

    pid, threads, doubled = run_isolated(_child_facts, 21)
    assert pid != os.getpid() and threads == "1" and doubled == 42
    with pytest.raises(ParameterError, match="refused in the child"):
        run_isolated(_child_raises)
    from workbench.core.errors import SolverError

    with pytest.raises(SolverError, match="exit code 3"):
        run_isolated(_child_dies)


def test_cases_count_outcomes_over_groups():
    from workbench.study import CLEAR, CORRECT, DEFECT, Cases, Check

    cases = Cases()
    cases.run("a", "ok", lambda: Check("did", 0.5, "m", 1.0))
    cases.run("a", "above", lambda: Check("did", 2.0, "m", 1.0))
    cases.run("b", "clear", lambda: (_ for _ in ()).throw(ParameterError("no")))
    assert cases.outcomes() == {CORRECT: 1, DEFECT: 1, CLEAR: 1}
    assert [r["case"] for r in cases.groups["a"]] == ["ok", "above"]


# ----------------------------------------------------------------------------------------
# measures on the sphere


def _great_circle(normal, n=50):
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    a = np.cross(normal, [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(normal, a)
    s = np.linspace(0.0, 2.0, n)
    return np.outer(np.cos(s), a) + np.outer(np.sin(s), b), np.cross(a, b)


def test_great_circle_and_circle_defects_vanish_on_exact_curves():
    from workbench.study import circle_defect, great_circle_defect

    q, normal = _great_circle([0.3, -0.2, 0.9])
    w = 2.0 * np.tile(normal, (len(q), 1))  # rotation about the circle's normal
    dist, sin = great_circle_defect(q, w)
    assert dist < 1e-14 and sin < 1e-14
    tilted = q + 0.01 * normal * np.sin(np.linspace(0, 6, len(q)))[:, None]
    assert great_circle_defect(tilted, w)[0] > 1e-3
    phi = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    ring = np.c_[0.6 * np.cos(phi), 0.6 * np.sin(phi), np.full(40, -0.8)]  # about e3
    d, tilt = circle_defect(ring)
    assert d < 1e-14 and tilt < 1e-14
    assert circle_defect(ring @ so3(0.2).T)[1] > 0.1


def so3(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def test_cover_counts_of_meridians_sweeping_a_cap():
    from workbench.study import angle_travelled, cover_counts

    # meridians from the south pole up to polar angle theta_max, around the whole circle:
    # every point of the cap is covered once, points beyond it not at all
    theta = np.linspace(0.0, 2.0, 60)
    phi = np.linspace(0.0, 2 * np.pi, 48, endpoint=False)
    Q = np.stack([np.sin(theta)[:, None] * np.cos(phi), np.sin(theta)[:, None] * np.sin(phi),
                  -np.cos(theta)[:, None] * np.ones_like(phi)], axis=-1)
    def point(th, ph):  # off the grid lines: strictly inside a cell
        return [np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)]

    pts = np.array([point(1.01, 0.07), point(0.33, 3.0), point(2.5, 0.07), point(3.1, 1.0)])
    assert cover_counts(Q, pts).tolist() == [1, 1, 0, 0]
    # the same sweep twice (two turns of meridians): covered twice
    assert cover_counts(np.concatenate([Q, Q], axis=1), pts).tolist() == [2, 2, 0, 0]
    travelled = angle_travelled(Q)
    assert travelled.shape == (60, 48)
    np.testing.assert_allclose(travelled[-1], 2.0, rtol=1e-12)


def test_so3_measures_axis_shares_body_axis_angle_and_cover():
    from scipy.spatial.transform import Rotation

    from workbench.study import axis_shares, body_axis_angle, rotation_cover_fraction

    R_e = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    turns = np.array([R_e @ Rotation.from_rotvec([0.0, 0.0, a]).as_matrix()
                      for a in (0.1, 1.0, 3.0)])  # about body axis 3 of R_e
    np.testing.assert_allclose(axis_shares(turns, R_e), [[0, 0, 1]] * 3, atol=1e-14)
    mixed = R_e @ Rotation.from_rotvec([0.3, 0.4, 0.0]).as_matrix()
    np.testing.assert_allclose(axis_shares(mixed[None], R_e), [[0.36, 0.64, 0.0]], atol=1e-12)
    tilt = np.array([R_e @ Rotation.from_rotvec([np.radians(30.0), 0, 0]).as_matrix()])
    np.testing.assert_allclose(body_axis_angle(tilt, R_e, 2), [30.0], atol=1e-12)
    np.testing.assert_allclose(body_axis_angle(tilt, R_e, 0), [0.0], atol=1e-12)
    test = Rotation.random(200, random_state=3).as_matrix()
    assert rotation_cover_fraction(test, test, 1e-6) == 1.0  # each is its own neighbour
    near = np.array([R_e])
    far = np.array([R_e @ Rotation.from_rotvec([0, 0, 1.0]).as_matrix()])
    assert rotation_cover_fraction(near, far, 0.9) == 0.0  # 1 rad apart
    assert rotation_cover_fraction(near, far, 1.1) == 1.0
    # both signs of the quaternion: the rotation by 2 pi - 0.05 is 0.05 away
    wrap = np.array([R_e @ Rotation.from_rotvec([0, 0, 2 * np.pi - 0.05]).as_matrix()])
    assert rotation_cover_fraction(near, wrap, 0.1) == 1.0



def test_compare_lyapunov_on_a_damped_oscillator():
    import casadi as ca

    from models.spherical import spherical_pendulum
    from workbench.control import Lyapunov
    from workbench.simulation import simulate
    from workbench.study import compare_lyapunov

    # the hanging spherical pendulum damped by u = -c omega: V = energy decreases
    model = spherical_pendulum(m=1.0, l=1.0, g=9.81)
    x = ca.SX.sym("x", 6)
    k = ca.Function("damping", [x, ca.SX.sym("p", model.n_params)], [-0.5 * x[3:]])
    V = Lyapunov(model, lambda ctx: 0.5 * ca.dot(ctx["q"][3:], ctx["q"][3:])
                 + 9.81 * (1 - ctx["q"][2]), name="energy")
    q0 = np.array([np.sin(0.5), 0.0, np.cos(0.5), 0.0, 0.3, 0.0])
    tr = simulate(model, model.state(q=q0), np.linspace(0, 5, 101), controller=k,
                  rtol=1e-10, atol=1e-10)
    res = Result("t", "t")
    mono = compare_lyapunov(res, V, tr, k, name="V (energy)", along="the run",
                            source="damping")
    assert [c.quantity for c in res.comparisons] == [
        "max relative rise of V (energy) along the run",
        "max V-dot (energy) along the run, from the graph"]
    assert all(c.ok for c in res.comparisons) and mono.relative_increase <= 1e-8


def _child_has_module(name):
    import sys

    return name in sys.modules


def test_run_isolated_forks_when_not_fresh():
    import os
    import sys
    import types

    from workbench.study import run_isolated

    pid, _, doubled = run_isolated(_child_facts, 4, fresh=False)
    assert pid != os.getpid() and doubled == 8
    # a module that exists only in this process: a forked child has it, a spawned one not
    sys.modules["_workbench_test_marker"] = types.ModuleType("_workbench_test_marker")
    try:
        assert run_isolated(_child_has_module, "_workbench_test_marker", fresh=False)
        assert not run_isolated(_child_has_module, "_workbench_test_marker")
    finally:
        del sys.modules["_workbench_test_marker"]
    wanted = r"fresh must be True \(spawn\) or False \(fork\); got 'no'"
    with pytest.raises(ParameterError, match=wanted):
        run_isolated(_child_facts, 1, fresh="no")


def _child_adds_memory(mb):
    import mmap

    from workbench.study import peak_memory_mb, reset_peak_memory

    start = reset_peak_memory()
    # a fresh anonymous mapping, every page written: new resident pages. (An allocator's
    # block may instead reuse heap pages the forked child shares with its parent, whose
    # copy on write leaves the resident size unchanged: the test failed once so.)
    n = int(mb * 2**20)
    block = mmap.mmap(-1, n)
    for i in range(0, n, mmap.PAGESIZE):  # one byte a page: no 64 MB buffer to copy from
        block[i] = 1
    return start, peak_memory_mb(), float(block[n - 1])


def test_peak_memory_after_a_reset_counts_what_the_work_adds():
    from workbench.study import run_isolated

    start, peak, _ = run_isolated(_child_adds_memory, 64, fresh=False)
    assert 60 < peak - start < 120  # the 64 MB block, and little else
