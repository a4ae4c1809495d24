"""Words for codes and classes of equilibria (study figures), and progress inside a problem.

The mode counts are checked on closed forms: the planar pendulum linearised upright
(eigenvalues +-sqrt(g/l): one unstable, one stable mode) and hanging (+-i sqrt(g/l): two
centre modes), and a cyclic coordinate (a double zero eigenvalue of [[0, 1], [0, 0]], the
symmetry's orbit and its conserved momentum).
"""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

from workbench.app.report import Format, build_report
from workbench.app.report import cache as report_cache
from workbench.app.report.progress import Progress
from workbench.core.errors import ParameterError
from workbench.linear import SymmetryDirections
from workbench.study import Panel, Result, line_figure, spectrum_figure
from workbench.study._figures import equilibrium_class, labelled, mode_counts
from workbench.study._result import PROGRESS_ENV, progress

G, L = 9.81, 0.5


def pendulum(upright: bool) -> np.ndarray:
    """Linearised planar pendulum (theta, theta_dot) about upright or hanging."""
    s = 1.0 if upright else -1.0
    return np.linalg.eigvals(np.array([[0.0, 1.0], [s * G / L, 0.0]]))


def with_cyclic(a_eigs: np.ndarray) -> np.ndarray:
    """Append the spectrum of a cyclic coordinate: [[0, 1], [0, 0]] (double zero)."""
    return np.concatenate([a_eigs, np.linalg.eigvals(np.array([[0.0, 1.0], [0.0, 0.0]]))])


def test_mode_counts_of_the_pendulum_closed_forms():
    assert mode_counts(pendulum(True), tol=1e-9) == {"unstable": 1, "stable": 1, "centre": 0}
    assert mode_counts(pendulum(False), tol=1e-9) == {"unstable": 0, "stable": 0, "centre": 2}
    up = pendulum(True)
    assert np.allclose(sorted(up.real), [-np.sqrt(G / L), np.sqrt(G / L)])
    with pytest.raises(ParameterError, match="tol"):
        mode_counts(up, tol=-1.0)
    with pytest.raises(ParameterError, match="finite"):
        mode_counts([np.nan], tol=1e-9)


def test_equilibrium_class_names_the_centre_modes_of_a_symmetry():
    ev = with_cyclic(pendulum(True))
    assert equilibrium_class(ev, tol=1e-9) == "1 unstable, 1 stable, 2 centre"
    assert (equilibrium_class(ev, tol=1e-9, symmetry={"rotation about e3": 2})
            == "1 unstable, 1 stable, 2 centre (2 from rotation about e3)")
    hanging = with_cyclic(pendulum(False))
    assert (equilibrium_class(hanging, tol=1e-9, symmetry={"rotation about e3": 2})
            == "0 unstable, 0 stable, 4 centre (2 from rotation about e3, 2 others)")
    with pytest.raises(ParameterError, match="only 2"):
        equilibrium_class(ev, tol=1e-9, symmetry={"rotation about e3": 3})
    # the verified directions of workbench.linear.symmetry_directions, counted as given:
    # the cyclic coordinate's orbit (right null vector) and its momentum (left null vector)
    sd = SymmetryDirections(n_zero=2, zero_tol=1e-9,
                            orbits={"yaw": np.array([0.0, 0.0, 1.0, 0.0])},
                            conserved={"J3": np.array([0.0, 0.0, 0.0, 1.0])})
    assert (equilibrium_class(ev, tol=1e-9, symmetry=sd)
            == "1 unstable, 1 stable, 2 centre (1 from orbits of yaw, 1 from conserved J3)")
    with pytest.raises(ParameterError, match="symmetry must be"):
        equilibrium_class(ev, tol=1e-9, symmetry=2)


def test_figures_say_what_codes_are_and_the_class_of_each_spectrum():
    t = np.linspace(0.0, 1.0, 5)
    fig = line_figure([Panel("tilt", {"q1": (t, t), "omega1": (t, 2 * t)}, xlabel="t [s]")],
                      labels={"q1": "tilt of link 1", "omega1": "rate of link 1"})
    legend = [x.get_text() for x in fig.axes[0].get_legend().get_texts()]
    assert legend == ["tilt of link 1 (q1)", "rate of link 1 (omega1)"]
    assert fig.axes[0].get_xlabel() == "t [s]"
    fig = spectrum_figure({"up": (with_cyclic(pendulum(True)), None),
                           "down": (pendulum(False), None)}, tol=1e-9,
                          symmetry={"up": {"rotation about e3": 2}},
                          labels={"up": "upright"})
    titles = [ax.get_title() for ax in fig.axes]
    # the class line is wrapped to the panel's width (3.4 in: 30 characters a line)
    assert [t.replace("\n", " ") for t in titles] == [
        "upright (up) 1 unstable, 1 stable, 2 centre (2 from rotation about e3)",
        "down 0 unstable, 0 stable, 2 centre"]
    assert all(t.startswith(("upright (up)\n", "down\n")) for t in titles)
    assert max(len(line) for t in titles for line in t.split("\n")[1:]) <= 30
    with pytest.raises(ParameterError, match="not panels"):
        spectrum_figure({"up": (pendulum(True), None)}, tol=1e-9,
                        symmetry={"upp": {"rotation": 1}})
    with pytest.raises(ParameterError, match="tol"):
        spectrum_figure({"up": (pendulum(True), None)}, symmetry={"up": {"rotation": 1}})
    assert labelled("x", None) == "x" and labelled("x", {"x": "cart position"}) == \
        "cart position (x)"


def test_result_labels():
    res = Result("p", "t")
    assert res.label(q1="tilt of link 1") == {"q1": "tilt of link 1"}
    assert res.as_dict()["labels"] == {"q1": "tilt of link 1"}
    with pytest.raises(ParameterError, match=r"\['w1'\]"):
        res.label(w1=" ")


def test_progress_writes_lines_only_inside_a_report(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv(PROGRESS_ENV, raising=False)
    progress("nothing to write to")  # outside a report: nothing happens
    path = tmp_path / "p.progress"
    monkeypatch.setenv(PROGRESS_ENV, str(path))
    progress("orbit", done=1, total=4)
    Result("p", "t").progress("orbit", done=2, total=4)
    lines = [json.loads(x) for x in path.read_text().splitlines()]
    assert [(x["message"], x["done"], x["total"]) for x in lines] == [
        ("orbit", 1.0, 4.0), ("orbit", 2.0, 4.0)]
    monkeypatch.setenv(PROGRESS_ENV, "-")  # workbench run: text on stderr
    progress("orbit", done=3, total=4)
    assert capsys.readouterr().err == "  progress: orbit (3/4)\n"
    for bad in ({"done": 1}, {"done": 5, "total": 4}, {"done": -1, "total": 4},
                {"done": "a", "total": 4}, {"done": 0, "total": 0}):
        with pytest.raises(ParameterError, match="progress"):
            progress("x", **bad)


def test_progress_estimates_the_time_left_from_the_fraction_done(monkeypatch):
    clock = [100.0]
    monkeypatch.setattr("workbench.app.report.progress.time.monotonic", lambda: clock[0])
    out = io.StringIO()
    show = Progress(1, stream=out, enabled=True, jobs=1)
    show.plan({"p": None})
    show.started("p")
    clock[0] = 110.0  # a quarter done after 10 s: 30 s left at the same pace
    show.step("p", {"message": "orbit", "done": 1, "total": 4})
    assert "p after 0:10: orbit (1/4), about 0:30 left in it" in out.getvalue()
    assert show.remaining() == pytest.approx(30.0)
    clock[0] = 112.0
    show.step("p", {"message": "orbit", "done": 2, "total": 4})  # within 5 s: not printed
    assert out.getvalue().count("after") == 1
    assert show.remaining() == pytest.approx(12.0)


PROBLEM = '''
import time
from workbench.study import Result
TITLE = "labelled and talkative"

def solve(*, quick=False):
    res = Result("talkative", TITLE, quick=quick)
    for i in range(3):
        res.progress("stage", done=i + 1, total=3)
        time.sleep(0.5)
    res.label(q1="tilt of link 1")
    res.values["q1"] = 0.25
    return res.finish()
'''


def test_report_shows_progress_inside_a_problem_and_its_symbols(tmp_path, monkeypatch):
    import importlib.util
    import types

    (tmp_path / "root" / "workbench").mkdir(parents=True)
    monkeypatch.setattr(report_cache, "ROOT", tmp_path / "root")
    path = tmp_path / "talkative.py"
    path.write_text(PROBLEM)
    spec = importlib.util.spec_from_file_location("labels_test_talkative", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    cat = types.ModuleType("catalogue")
    cat.names = lambda: ["talkative"]
    cat.load = lambda n: mod
    cat.title = lambda n: mod.TITLE
    err = io.StringIO()
    rep = build_report(["talkative"], quick=True, formats=[Format.HTML], out_dir=tmp_path / "o",
                       catalogue=cat, stream=err, cache_dir=None)
    assert rep.ok, rep.runs[0].error
    assert "talkative after" in err.getvalue() and ": stage (1/3)" in err.getvalue()
    html = (tmp_path / "o" / "report-quick.html").read_text()
    assert "tilt of link 1" in html


@pytest.mark.parametrize(("mathtext", "plain"), [
    (r"$\mathdefault{10^{-3}}$", "10\u207b\u00b3"),
    (r"$\mathdefault{10^{0}}$", "10\u2070"),
    (r"$\mathdefault{2\times10^{4}}$", "2\u00d710\u2074"),
    (r"$\mathdefault{-10^{12}}$", "\u221210\u00b9\u00b2"),
    (r"$\mathdefault{1}$", "1"),
    (r"$\mathdefault{-0.5}$", "\u22120.5"),
    # anything else stays as it was: never a wrong label
    (r"$\mathdefault{10^{-2.5}}$", r"$\mathdefault{10^{-2.5}}$"),
    (r"$\omega^2$", r"$\omega^2$"),
    ("", ""),
])
def test_plain_label_reads_like_the_mathtext_it_replaces(mathtext, plain):
    from workbench.app.report.figures import plain_label

    assert plain_label(mathtext) == plain
    assert "$" not in plain or plain == mathtext


def test_plain_log_labels_keep_every_tick_label_and_touch_only_log_axes():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from workbench.app.report.figures import plain_label, plain_log_labels

    fig, (a, b) = plt.subplots(1, 2)
    try:
        a.loglog([3e-4, 5e-2], [1e-12, 1e2])   # decades on y, a short span on x
        b.plot([0.0, 1.0], [0.0, 2.0])          # linear: left alone
        fig.canvas.draw()

        def labels() -> list[list[str]]:
            return [[t.get_text() for t in ax.get_ticklabels(minor=minor)]
                    for ax in (a.xaxis, a.yaxis, b.xaxis, b.yaxis) for minor in (False, True)]

        before = labels()
        linear = b.xaxis.get_major_formatter()
        assert plain_log_labels(fig) == 4  # major and minor of a's two axes
        assert plain_log_labels(fig) == 0  # already plain: not wrapped twice
        fig.canvas.draw()
        after = labels()
        assert b.xaxis.get_major_formatter() is linear
        assert after == [[plain_label(s) for s in row] for row in before]
        assert any("\u207b" in s for row in after for s in row)  # 10^-k written plainly
        assert not any("$" in s for row in after[:4] for s in row)
    finally:
        plt.close(fig)


def test_readable_lays_out_again_a_figure_that_was_laid_out_once_at_another_size():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from workbench.app.report.figures import PRINT_WIDTH, readable

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))  # as the work-precision diagram
    try:
        for ax in axes:
            ax.loglog([1e-4, 1e-2], [1e-12, 1e-1])
            ax.set_xlabel("wall time [s]")
            ax.set_ylabel("max |E - E0| / |E0|")
        fig.tight_layout()  # once, at 14 in: leaves a placeholder layout engine
        assert readable(fig)["width"] == PRINT_WIDTH
        fig.canvas.draw()
        box = fig.bbox
        for ax in axes:  # every axis label on the figure, none over another panel
            for label in (ax.xaxis.label, ax.yaxis.label):
                e = label.get_window_extent()
                assert box.x0 <= e.x0 and e.x1 <= box.x1 and box.y0 <= e.y0 and e.y1 <= box.y1
        for left, right in zip(axes[:-1], axes[1:]):
            assert (left.get_tightbbox().x1
                    <= right.yaxis.label.get_window_extent().x0 + 1.0)
    finally:
        plt.close(fig)
