"""Plain figures of problems: curves in panels, spectra in the complex plane.

* :class:`Panel` and :func:`line_figure` -- named curves per panel (time series,
  convergence histories), linear or logarithmic axes;
* :func:`spectrum_figure` -- computed eigenvalues beside reference values in the complex
  plane, one panel per equilibrium, each titled with its class
  (:func:`equilibrium_class`: how many unstable, stable and centre modes, and how many of
  the centre modes a symmetry explains);
* :func:`mode_counts` and :func:`equilibrium_class` -- the same counts in words, for
  tables;
* ``labels`` (both figures): words for the codes in legends and titles, e.g.
  ``{"q1": "tilt of link 1", "omega1": "rate of link 1"}`` (a problem's
  :attr:`~workbench.study.Result.labels`), shown as ``"tilt of link 1 (q1)"``.

Both make a new figure with the non-interactive Agg backend and return it; nothing is
shown or saved.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from workbench.core.errors import ParameterError
from workbench.core.types import ArrayLike
from workbench.simulation.accuracy._legend import legend_below

__all__ = ["Panel", "line_figure", "spectrum_figure", "mode_counts", "equilibrium_class",
           "labelled"]


def labelled(code: str, labels: Mapping[str, str] | None) -> str:
    """``"words (code)"`` when ``labels`` has words for ``code``, else ``code`` itself."""
    words = (labels or {}).get(code, "")
    return f"{words} ({code})" if words and code and words != code else (words or code)


def mode_counts(eigenvalues: ArrayLike, *, tol: float) -> dict[str, int]:
    """Numbers of unstable, stable and centre modes of a spectrum.

    Parameters
    ----------
    eigenvalues : array-like
        The eigenvalues (complex), each counted with its multiplicity.
    tol : float
        Real parts within ``tol`` of zero count as centre modes.

    Returns
    -------
    dict
        ``{"unstable": Re > tol, "stable": Re < -tol, "centre": |Re| <= tol}``.

    Raises
    ------
    ParameterError
        If ``tol`` is not a finite number >= 0 or an eigenvalue is not finite.
    """
    if not (isinstance(tol, (int, float)) and np.isfinite(tol) and tol >= 0):
        raise ParameterError(f"tol must be a finite number >= 0; got {tol!r}")
    ev = np.asarray(eigenvalues, dtype=complex).ravel()
    if not np.all(np.isfinite(ev)):
        raise ParameterError(f"eigenvalues must be finite; got {ev[~np.isfinite(ev)][:3]}")
    re = ev.real
    return {"unstable": int(np.sum(re > tol)), "stable": int(np.sum(re < -tol)),
            "centre": int(np.sum(np.abs(re) <= tol))}


def _symmetry_counts(symmetry: Any) -> dict[str, Any]:
    """``{words: count}`` from a mapping, or from verified symmetry directions."""
    if symmetry is None:
        return {}
    if isinstance(symmetry, Mapping):
        return dict(symmetry)
    if hasattr(symmetry, "orbit_rank") and hasattr(symmetry, "conserved_rank"):
        out = {}
        if symmetry.orbit_rank:
            out[f"orbits of {', '.join(symmetry.orbits)}"] = int(symmetry.orbit_rank)
        if symmetry.conserved_rank:
            out[f"conserved {', '.join(symmetry.conserved)}"] = int(symmetry.conserved_rank)
        return out
    raise ParameterError(f"symmetry must be a mapping of words to counts or the result of "
                         f"workbench.linear.symmetry_directions; got {type(symmetry).__name__}")


def equilibrium_class(eigenvalues: ArrayLike, *, tol: float,
                      symmetry: Mapping[str, int] | None = None) -> str:
    """An equilibrium's class in words: its unstable, stable and centre modes.

    Parameters
    ----------
    eigenvalues : array-like
        The linearisation's eigenvalues.
    tol : float
        Real parts within ``tol`` of zero count as centre modes.
    symmetry : mapping of str to int, or SymmetryDirections, optional
        Centre modes explained by a symmetry, by its name (e.g.
        ``{"rotation about e3": 2}``: the orbit of the symmetry through the equilibrium and
        its conserved momentum), checked against the number of centre modes; or the
        verified directions of :func:`workbench.linear.symmetry_directions` (its orbit
        directions and conserved momenta are counted).

    Returns
    -------
    str
        e.g. ``"2 unstable, 4 stable, 2 centre (2 from rotation about e3)"``, or
        ``"... 4 centre (2 from rotation about e3, 2 others)"``.

    Raises
    ------
    ParameterError
        If the symmetry explains more centre modes than there are, or a count is negative.
    """
    n = mode_counts(eigenvalues, tol=tol)
    text = f"{n['unstable']} unstable, {n['stable']} stable, {n['centre']} centre"
    sym = _symmetry_counts(symmetry)
    bad = {k: v for k, v in sym.items() if not isinstance(v, (int, np.integer)) or v < 0}
    if bad:
        raise ParameterError(f"symmetry: counts must be whole numbers >= 0; got {bad}")
    explained = sum(int(v) for v in sym.values())
    if explained > n["centre"]:
        raise ParameterError(f"symmetry: {explained} centre modes attributed to {sym}, but the "
                             f"spectrum has only {n['centre']} (|Re| <= {tol:g})")
    if explained:
        parts = [f"{v} from {k}" for k, v in sym.items() if v]
        rest = n["centre"] - explained
        text += " (" + ", ".join(parts) + (f", {rest} other{'s' if rest > 1 else ''}"
                                           if rest else "") + ")"
    return text


@dataclass
class Panel:
    """One axes of a :func:`line_figure`.

    Attributes
    ----------
    title : str
        The panel's title.
    curves : mapping of str to (array-like, array-like)
        ``label -> (x, y)``; ``y`` may have several columns (one line each, drawn in
        one colour under one legend entry; e.g. many trajectories of one kind).
    xlabel, ylabel : str
        Axis labels with units.
    yscale : str
        ``"linear"``, ``"log"`` (values at or below 0 are dropped from the view), or
        ``"symlog"``.
    xscale : str
        As ``yscale``.
    marker : str
        A matplotlib marker for every curve (``""``: lines only).
    linestyle : str
        A matplotlib line style for every curve (``""``: markers only).
    """

    title: str
    curves: Mapping[str, tuple[ArrayLike, ArrayLike]] = field(default_factory=dict)
    xlabel: str = ""
    ylabel: str = ""
    yscale: str = "linear"
    xscale: str = "linear"
    marker: str = ""
    linestyle: str = "-"


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _grid(n: int, ncols: int, size: tuple[float, float]) -> tuple[Any, list[Any]]:
    if n < 1:
        raise ParameterError("a figure needs at least one panel; got none")
    plt = _pyplot()
    cols = min(ncols, n)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(size[0] * cols, size[1] * rows),
                             squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.set_visible(False)
    return fig, flat[:n]


def line_figure(panels: Sequence[Panel], *, ncols: int = 2,
                size: tuple[float, float] = (4.6, 3.3),
                labels: Mapping[str, str] | None = None, legend: str = "panels") -> Any:
    """Curves in panels, laid out ``ncols`` to a row.

    Parameters
    ----------
    panels : sequence of Panel
        What each axes shows.
    ncols : int
        Panels per row.
    size : (float, float)
        Width and height of one panel in inches.
    labels : mapping of str to str, optional
        Words for curve labels and axis labels that are codes (``{"q1": "tilt of link
        1"}``): the legend shows ``"tilt of link 1 (q1)"``.
    legend : str
        ``"panels"``: a legend in each panel with more than one curve; ``"below"``: one
        legend for every label of every panel, in rows under the panels (for scattered
        points that leave a panel no free corner).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ParameterError
        If ``legend`` is neither.
    """
    if legend not in ("panels", "below"):
        raise ParameterError(f"legend must be 'panels' or 'below'; got {legend!r}")
    fig, axes = _grid(len(panels), ncols, size)
    for ax, p in zip(axes, panels):
        for label, (x, y) in p.curves.items():
            lines = ax.plot(np.asarray(x), np.asarray(y), marker=p.marker or None,
                            linestyle=p.linestyle or "none")
            for line in lines[1:]:  # columns of a 2D y: one colour, one legend entry
                line.set_color(lines[0].get_color())
            lines[0].set_label(labelled(label, labels))
        ax.set(title=p.title, xlabel=labelled(p.xlabel, labels),
               ylabel=labelled(p.ylabel, labels), xscale=p.xscale, yscale=p.yscale)
        ax.grid(True, alpha=0.3)
        if len(p.curves) > 1 and legend == "panels":
            ax.legend(fontsize=8)
    if legend == "below":
        legend_below(fig, axes, fontsize=8, max_columns=4)
        return fig
    fig.set_layout_engine("tight")  # laid out when drawn, once, at its final size
    return fig


def spectrum_figure(spectra: Mapping[str, tuple[ArrayLike, ArrayLike | None]], *,
                    ncols: int = 3, reference_label: str = "paper",
                    size: tuple[float, float] = (3.4, 3.2), tol: float | None = None,
                    symmetry: Mapping[str, Mapping[str, int]] | None = None,
                    labels: Mapping[str, str] | None = None) -> Any:
    """Computed eigenvalues (dots) beside reference values (rings) in the complex plane.

    Parameters
    ----------
    spectra : mapping of str to (array-like, array-like or None)
        ``title -> (computed, reference)``, one panel each; ``reference`` may be None.
    ncols : int
        Panels per row.
    reference_label : str
        The legend's name of the reference values.
    size : (float, float)
        Width and height of one panel in inches.
    tol : float, optional
        When given, each panel's title gets a second line with the class of its computed
        spectrum (:func:`equilibrium_class`; real parts within ``tol`` of zero are centre
        modes).
    symmetry : mapping of str to mapping, optional
        Per panel title, the centre modes a symmetry explains (see
        :func:`equilibrium_class`); needs ``tol``.
    labels : mapping of str to str, optional
        Words for panel titles that are codes (``{"L1": "hanging, spinning"}``).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ParameterError
        If ``symmetry`` names a panel that is not in ``spectra``, or is given without
        ``tol``.
    """
    symmetry = dict(symmetry or {})
    if symmetry and tol is None:
        raise ParameterError("symmetry: the centre modes a symmetry explains need tol (the "
                             "real part below which a mode is a centre mode); got tol=None")
    stray = sorted(set(symmetry) - set(spectra))
    if stray:
        raise ParameterError(f"symmetry: {stray} are not panels of this figure (panels: "
                             f"{list(spectra)})")
    fig, axes = _grid(len(spectra), ncols, size)
    for ax, (title, (computed, reference)) in zip(axes, spectra.items()):
        c = np.asarray(computed, dtype=complex).ravel()
        ax.axvline(0.0, color="0.6", lw=0.8)
        ax.axhline(0.0, color="0.85", lw=0.6)
        ax.plot(c.real, c.imag, "o", ms=4, label="workbench")
        if reference is not None:
            r = np.asarray(reference, dtype=complex).ravel()
            ax.plot(r.real, r.imag, "o", ms=10, mfc="none", mec="C3", label=reference_label)
        head = labelled(title, labels)
        if tol is not None:  # wrapped to the panel's width (about 9 characters an inch)
            head += "\n" + textwrap.fill(equilibrium_class(c, tol=tol,
                                                           symmetry=symmetry.get(title)),
                                          width=max(20, int(9 * size[0])))
        ax.set(title=head, xlabel="Re lambda", ylabel="Im lambda")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8, loc="best")
    fig.set_layout_engine("tight")  # laid out when drawn, once, at its final size
    return fig
