"""The spherical pendulum on S^2 with a control moment, paper 002 Section II.

A point mass ``m`` on a massless link of length ``l`` about a fixed frictionless pivot;
``q`` in S^2 is the link direction (``e3`` points down, along gravity), ``omega`` its
angular velocity with ``q . omega = 0`` and ``q-dot = omega x q``; ``u`` is a control
moment at the pivot::

    omega-dot = (g / l) q x e3 + (I - q q^T) u / (m l^2)

The paper writes ``u / (m l^2)``; a moment along the link turns a point mass on a
massless link not at all, so the model keeps only the part of ``u`` normal to ``q``.
The model is defined by its Lagrangian (a point mass at ``l q`` under gravity, a moment at
the pivot) and :mod:`workbench.mechanics` derives the equation above; the printed form is
kept as an independent check in :func:`models.paper_forms.spherical_pendulum_printed`.
The two agree for every moment normal to the link (the paper's PD controllers produce
only such moments), and with the projection TS^2 is invariant for every input.
"""

from __future__ import annotations

import numpy as np

from workbench import mechanics
from workbench.core import Model, positive, validate

__all__ = ["spherical_pendulum", "E3"]

E3 = np.array([0.0, 0.0, 1.0])


_SCALAR = validate.parameter(validate.array, shape=())
"""The builder refuses complex, bool, str, None and NaN before any conversion."""


@validate.arguments(m=_SCALAR, l=_SCALAR, g=_SCALAR)
def spherical_pendulum(*, m: float = 1.0, l: float = 1.0, g: float = 9.81) -> Model:  # noqa: E741
    """Build the spherical pendulum of paper 002, Section II.

    Parameters
    ----------
    m : float
        Point mass [kg], positive.
    l : float
        Link length [m], positive.
    g : float
        Gravitational acceleration [m/s^2], positive.

    Returns
    -------
    Model
        One TS2 factor ``q`` storing ``(q, omega)``; input ``u`` (moment, R^3); invariant
        ``energy = m l^2 |omega|^2 / 2 - m g l e3 . q`` (conserved when ``u = 0``).
    """
    s = mechanics.System("spherical_pendulum")
    link = s.s2("q")
    mm = s.parameter("m", m, "point mass [kg]", check=positive)
    ll = s.parameter("l", l, "link length [m]", check=positive)
    gg = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    s.point_mass(mm, ll * link.q, name="bob")
    s.gravity(gg, direction=E3)
    s.moment(link, s.input(3, "control moment at the pivot u [N m]"))
    return s.model(
        description="spherical pendulum on TS^2 with a control moment (paper 002, Section II; "
        "derived from its Lagrangian by workbench.mechanics)",
        equations=(
            r"L = \tfrac12 m l^2\|\omega\|^2 + m g l\, e_3\cdot q,\quad"
            r" (I - qq^T)\tfrac{d}{dt}\tfrac{\partial L}{\partial\omega} = q\times"
            r"\tfrac{\partial L}{\partial q} + (I - qq^T)u",
            r"\dot q = \omega\times q,\; \dot\omega = \tfrac{g}{l} q\times e_3 + "
            r"\tfrac{1}{ml^2}(I - qq^T)u \quad \text{(paper 002, Sec. II)}",
        ),
        input_description="control moment at the pivot u [N m]",
    )
