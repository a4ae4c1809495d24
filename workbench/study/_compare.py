"""Shared comparisons of problems: spectra against printed values, counts, sign patterns.

A problem compares what the graph gives with what a paper prints (or a closed form). The
recurring pieces live here, once:

* :func:`match_spectrum` -- pairs each reference eigenvalue with one computed eigenvalue
  (an optimal assignment, so multisets with repeated values and conjugate pairs match
  one to one, whatever the order of either list);
* :func:`compare_spectrum` -- records that match as comparisons (one for the worst
  eigenvalue, or one per eigenvalue);
* :func:`compare_rows` -- a table of comparisons, one row each (quantity, reference,
  workbench, tolerance, and optionally the source);
* :func:`compare_counts` -- exact integer comparisons (dimensions, numbers of modes);
* :func:`compare_stability` -- the classification and the number of unstable modes of an
  :class:`~workbench.linear.Eigenstructure`;
* :func:`sign_pattern` -- how many eigenvalues are zero, real negative, real positive, in
  each open half plane;
* :func:`decay_rate` -- the exponential rate of a decaying signal, to set beside a
  spectral abscissa;
* :func:`compare_lyapunov` -- along a closed-loop run, that a Lyapunov function never
  rises and that its derivative from the graph is never positive.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from workbench.core.errors import ParameterError
from workbench.core.types import ArrayLike
from workbench.study._result import Comparison, Result

__all__ = [
    "SpectrumMatch",
    "compare_counts",
    "compare_lyapunov",
    "compare_rows",
    "compare_spectrum",
    "compare_stability",
    "decay_rate",
    "match_spectrum",
    "sign_pattern",
]


@dataclass(frozen=True)
class SpectrumMatch:
    """Reference eigenvalues paired one to one with computed ones.

    Attributes
    ----------
    reference : ndarray of complex, shape=(k,)
        The reference values, in their given order.
    computed : ndarray of complex, shape=(k,)
        The computed eigenvalue paired with each reference value.
    index : ndarray of int, shape=(k,)
        Where each paired value sits in the computed list.
    """

    reference: np.ndarray
    computed: np.ndarray
    index: np.ndarray

    @property
    def deviations(self) -> np.ndarray:
        """``|computed - reference|`` per pair, shape=(k,)."""
        return np.abs(self.computed - self.reference)

    @property
    def max_deviation(self) -> float:
        """The largest ``|computed - reference|`` (0 for an empty reference)."""
        return float(self.deviations.max(initial=0.0))

    @property
    def max_part_deviation(self) -> float:
        """The largest deviation of a real or an imaginary part (for printed digits)."""
        d = self.computed - self.reference
        return float(np.maximum(np.abs(d.real), np.abs(d.imag)).max(initial=0.0))


def match_spectrum(computed: ArrayLike, reference: ArrayLike) -> SpectrumMatch:
    """Pair every reference eigenvalue with a distinct computed eigenvalue.

    The pairing minimises the sum of distances ``|computed_j - reference_i|`` (an optimal
    assignment), so it neither depends on the order of either list nor lets two reference
    values take the same computed one; a repeated reference value takes as many computed
    values as it is repeated.

    Parameters
    ----------
    computed : array-like of complex, shape=(n,)
        The eigenvalues found.
    reference : array-like of complex, shape=(k,)
        The values to find among them, ``k <= n`` (the rest of ``computed`` is left
        unpaired, e.g. zeros that the reference does not list).

    Returns
    -------
    SpectrumMatch

    Raises
    ------
    ParameterError
        If there are more reference values than computed ones, or a value is not finite.
    """
    c = np.asarray(computed, dtype=complex).ravel()
    r = np.asarray(reference, dtype=complex).ravel()
    if r.size > c.size:
        raise ParameterError(f"reference has {r.size} eigenvalues, more than the {c.size} "
                             "computed; pass a reference of at most that many")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(r))):
        raise ParameterError("eigenvalues must be finite; got "
                             f"computed {c.tolist()}, reference {r.tolist()}")
    rows, cols = linear_sum_assignment(np.abs(r[:, None] - c[None, :]))
    index = np.empty(r.size, dtype=int)
    index[rows] = cols
    return SpectrumMatch(reference=r, computed=c[index], index=index)


def compare_spectrum(res: Result, label: str, computed: ArrayLike, reference: ArrayLike, *,
                     tolerance: float, source: str, each: bool = False,
                     parts: bool = False) -> SpectrumMatch:
    """Record how far the computed spectrum is from the reference (after matching).

    Parameters
    ----------
    res : Result
        Where the comparisons go.
    label : str
        What is compared (e.g. ``"hanging, full (6)"``).
    computed, reference : array-like of complex
        As in :func:`match_spectrum`.
    tolerance : float
        Largest accepted deviation.
    source : str
        Where the reference comes from.
    each : bool
        One comparison per reference eigenvalue instead of one for the worst.
    parts : bool
        Measure ``max(|d Re|, |d Im|)`` (values printed to a number of digits) instead of
        ``|d|``.

    Returns
    -------
    SpectrumMatch
    """
    m = match_spectrum(computed, reference)
    d = m.computed - m.reference
    dev = np.maximum(np.abs(d.real), np.abs(d.imag)) if parts else np.abs(d)
    what = "max(|d Re|, |d Im|)" if parts else "|lambda - reference|"
    if each:
        for i, (ref, di) in enumerate(zip(m.reference, dev)):
            res.compare(f"{label}: lambda_{i + 1} ({_short(ref)}), {what}", 0.0, float(di),
                        tolerance=tolerance, source=source)
    else:
        res.compare(f"{label}: max {what} over {m.reference.size} eigenvalues", 0.0,
                    float(dev.max(initial=0.0)), tolerance=tolerance, source=source)
    return m


def _short(z: complex) -> str:
    z = complex(z)
    if abs(z.imag) <= 1e-15 * max(1.0, abs(z)):
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{z.imag:+.6g}i"


def compare_rows(res: Result, rows: Iterable[Sequence[Any]], *, source: str | None = None,
                 relative: bool = False) -> list[Comparison]:
    """Record a table of comparisons, one per row.

    Parameters
    ----------
    res : Result
        Where the comparisons go.
    rows : iterable of tuple
        ``(quantity, reference, workbench, tolerance)`` or
        ``(quantity, reference, workbench, tolerance, source)``.
    source : str, optional
        The source of the rows that give none.
    relative : bool
        Whether deviations and tolerances are relative (for every row).

    Returns
    -------
    list of Comparison

    Raises
    ------
    ParameterError
        If a row has neither its own source nor a default, or has the wrong length.
    """
    out = []
    for row in rows:
        if len(row) not in (4, 5) or (len(row) == 4 and source is None):
            raise ParameterError("a comparison row is (quantity, reference, workbench, "
                                 f"tolerance[, source]) with a source somewhere; got {row!r}")
        quantity, reference, workbench, tolerance = row[:4]
        out.append(res.compare(quantity, reference, workbench, tolerance=tolerance,
                               source=row[4] if len(row) == 5 else source,
                               relative=relative))
    return out


def compare_counts(res: Result, label: str, checks: Mapping[str, tuple[int, int]], *,
                   source: str) -> list[Comparison]:
    """Record exact integer comparisons ``{what: (expected, got)}`` (tolerance 0).

    Parameters
    ----------
    res : Result
        Where the comparisons go.
    label : str
        Prefix of every quantity.
    checks : mapping of str to (int, int)
        What is counted, and the expected and the found count.
    source : str
        Where the expected counts come from.

    Returns
    -------
    list of Comparison
    """
    return [res.compare(f"{label}: {what}", int(want), int(got), tolerance=0, source=source)
            for what, (want, got) in checks.items()]


def compare_stability(res: Result, label: str, es: Any, kind: Any, n_unstable: int, *,
                      source: str) -> list[Comparison]:
    """Record the classification and the number of unstable modes of an eigenstructure.

    Parameters
    ----------
    res : Result
        Where the comparisons go.
    label : str
        Prefix of both quantities (the equilibrium).
    es : Eigenstructure
        From :func:`workbench.linear.eigenstructure`.
    kind : Stability
        The expected classification.
    n_unstable : int
        The expected number of unstable modes.
    source : str
        Where the expectation comes from.

    Returns
    -------
    list of Comparison
    """
    return compare_counts(res, label, {
        f"classification is {kind.value}": (1, int(es.stability is kind)),
        "unstable modes": (n_unstable, es.n_unstable)}, source=source)


def sign_pattern(eigenvalues: ArrayLike, tol: float) -> dict[str, int]:
    """Count eigenvalues by sign: zero, real negative/positive, open left/right half plane.

    Parameters
    ----------
    eigenvalues : array-like of complex
        The spectrum.
    tol : float
        Below this modulus (or real/imaginary part) a number counts as zero.

    Returns
    -------
    dict of str to int
        ``zero``, ``negative_real``, ``positive_real``, ``left_half_plane``,
        ``right_half_plane``.
    """
    ev = np.asarray(eigenvalues, dtype=complex).ravel()
    re, im = ev.real, ev.imag
    real = np.abs(im) <= tol
    return {
        "zero": int(np.sum(np.abs(ev) <= tol)),
        "negative_real": int(np.sum((re < -tol) & real)),
        "positive_real": int(np.sum((re > tol) & real)),
        "left_half_plane": int(np.sum(re < -tol)),
        "right_half_plane": int(np.sum(re > tol)),
    }


def decay_rate(t: ArrayLike, z: ArrayLike, lo: float = 1e-9, hi: float = 1e-2) -> float:
    """Least-squares slope of ``log z`` over the later half of the samples with lo < z < hi.

    The later half, so that the faster modes have died out and the slowest one dominates;
    the band keeps out the start (nonlinear) and the integration noise floor.

    Parameters
    ----------
    t : array-like, shape=(n,)
        Sample times.
    z : array-like, shape=(n,)
        A positive decaying signal (e.g. the norm of a chart error).
    lo, hi : float
        The band of values used.

    Returns
    -------
    float
        The rate (negative for decay); NaN if fewer than 5 samples qualify.
    """
    t, z = np.asarray(t, dtype=float), np.asarray(z, dtype=float)
    idx = np.flatnonzero((z > lo) & (z < hi))
    idx = idx[len(idx) // 2:]
    if idx.size < 5:
        return float("nan")
    return float(np.polyfit(t[idx], np.log(z[idx]), 1)[0])


def compare_lyapunov(res: Result, V: Any, trajectory: Any, controller: Any, *, name: str,
                     along: str, source: str, rise_tolerance: float = 1e-8,
                     derivative_tolerance: float = 1e-12) -> Any:
    """Record that a Lyapunov function decreases along a closed-loop run.

    Two comparisons: the largest relative rise of ``V`` between samples of the trajectory
    (against 0, to ``rise_tolerance``), and the largest ``V-dot`` at the samples, from the
    graph with the controller composed in (against 0, to ``derivative_tolerance``).

    Parameters
    ----------
    res : Result
        Where the comparisons go.
    V : Lyapunov
        From :mod:`workbench.control` (``monotonicity``, ``derivative_values``).
    trajectory : Trajectory
        The closed-loop run.
    controller : casadi.Function
        The feedback of the run.
    name : str
        How ``V`` is named (e.g. ``"V (25)"``).
    along : str
        What the run is (e.g. ``"Fig. 5"``).
    source : str
        Where the decrease is stated.
    rise_tolerance, derivative_tolerance : float
        The tolerances of the two comparisons.

    Returns
    -------
    Monotonicity
        ``V.monotonicity(trajectory)``.
    """
    mono = V.monotonicity(trajectory, tolerance=rise_tolerance)
    vdot = float(np.max(V.derivative_values(trajectory.x, controller)))
    res.compare(f"max relative rise of {name} along {along}", 0.0, mono.relative_increase,
                tolerance=rise_tolerance, source=source)
    symbol, _, tag = name.partition(" ")  # "V (25)" -> "V-dot (25)"
    res.compare(f"max {symbol}-dot{' ' + tag if tag else ''} along {along}, from the graph",
                0.0, max(0.0, vdot), tolerance=derivative_tolerance, source=source)
    return mono
