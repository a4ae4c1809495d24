"""The spherical pendulum on S^2 with a control moment, paper 002 Section II.

A point mass ``m`` on a massless link of length ``l`` about a fixed frictionless pivot;
``q`` in S^2 is the link direction (``e3`` points down, along gravity), ``omega`` its
angular velocity with ``q . omega = 0`` and ``q-dot = omega x q``; ``u`` is a control
moment at the pivot::

    omega-dot = (g / l) q x e3 + (I - q q^T) u / (m l^2)

The paper writes ``u / (m l^2)``; a moment along the link turns a point mass on a
massless link not at all, so the model keeps only the part of ``u`` normal to ``q``.
The two agree for every moment normal to the link (the paper's PD controllers produce
only such moments), and with the projection TS^2 is invariant for every input.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench.core import Context, Model, Parameter, positive
from workbench.core.manifolds import TS2, ProductManifold

__all__ = ["spherical_pendulum", "E3"]

E3 = np.array([0.0, 0.0, 1.0])


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

    def field(ctx: Context) -> ca.SX:
        x = ctx["q"]
        q, w = x[0:3], x[3:6]
        m_, l_, g_ = ctx["m"], ctx["l"], ctx["g"]
        u_normal = ctx.u - ca.dot(q, ctx.u) * q
        wdot = (g_ / l_) * ca.cross(q, ca.DM(E3)) + u_normal / (m_ * l_**2)
        return ca.vertcat(ca.cross(w, q), wdot)

    def energy(ctx: Context) -> ca.SX:
        x = ctx["q"]
        m_, l_, g_ = ctx["m"], ctx["l"], ctx["g"]
        return 0.5 * m_ * l_**2 * ca.dot(x[3:6], x[3:6]) - m_ * g_ * l_ * x[2]

    return Model(
        name="spherical_pendulum",
        manifold=ProductManifold([("q", TS2())]),
        n_inputs=3,
        parameters=(
            Parameter("m", (), "point mass [kg]", positive),
            Parameter("l", (), "link length [m]", positive),
            Parameter("g", (), "gravitational acceleration [m/s^2]", positive),
        ),
        values={"m": m, "l": l, "g": g},
        vector_field=field,
        invariants={"energy": energy},
        description="spherical pendulum on TS^2 with a control moment (paper 002, Section II)",
        equations=(
            r"\dot q = \omega\times q,\; \dot\omega = \tfrac{g}{l} q\times e_3 + "
            r"\tfrac{1}{ml^2}(I - qq^T)u \quad \text{(paper 002, Sec. II)}",
        ),
        input_description="control moment at the pivot u [N m]",
    )
