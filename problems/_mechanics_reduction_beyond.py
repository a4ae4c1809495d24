"""The checks of the problem mechanics_reduction, section "beyond the papers".

The systems the workbench added (models/furuta.py, pendulum3d_cart.py,
quadrotor_slung_load.py, double_pendulum3d.py) reduced by ``workbench.mechanics.reduce``;
their relative equilibria found as equilibria of the reduced models from structured starts
and checked in the full model (:func:`steady_motion`) and against closed forms (each
function's docstring derives its own).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import sympy as sp
from matplotlib.figure import Figure
from scipy import optimize

from models.double_pendulum3d import double_pendulum3d
from models.furuta import furuta as furuta_model
from models.pendulum3d_cart import pendulum3d_cart
from models.quadrotor_slung_load import hover_input, quadrotor_slung_load
from workbench import mechanics
from workbench.core.errors import ModelError
from workbench.core.manifolds import SO3
from workbench.equilibria import enumerate_equilibria, find_equilibrium

__all__ = ["Row", "steady_motion", "amended_gradient", "furuta", "cart", "quadrotor",
           "double_pendulum", "beyond_the_papers", "figure", "planar_amended_potential", "rx",
           "FURUTA_ALPHA", "CART_MU", "DOUBLE_MU"]

E3 = np.array([0.0, 0.0, 1.0])

@dataclass
class Row:
    """One comparison of the section "beyond the papers" (see :func:`beyond_the_papers`)."""

    quantity: str
    reference: float
    value: float
    tolerance: float
    source: str


def _generator(red: mechanics.Reduction) -> ca.Function:
    """``x -> d/dtheta (g_theta x)`` at ``theta = 0``: the symmetry's generator on states."""
    x, th = ca.SX.sym("x", red.full.manifold.ambient_dim), ca.SX.sym("theta")
    return ca.Function("generator", [x], [ca.substitute(ca.jacobian(red.act(x, th), th),
                                                        th, 0.0)])


def steady_motion(red: mechanics.Reduction, r: np.ndarray, u: np.ndarray | None = None,
                  ) -> dict[str, float]:
    """How far the full motion over a reduced equilibrium ``r`` is from a steady one.

    ``x`` is the full state over ``r`` (Routh: at the reduced model's momentum value);
    its group velocity is ``xi = J(x) / I(x)`` (``I`` the locked inertia). A relative
    equilibrium moves along the group only: ``f(x, u) = xi (d/dtheta) g_theta x``.

    Returns
    -------
    dict
        ``residual`` (``max|f - xi g'(x)| / max|xi g'(x)|``), ``momentum`` (the full
        state's ``J``), ``xi`` and the full state ``x``.
    """
    x = red.full_state(r)
    uu = np.zeros(red.full.n_inputs) if u is None else np.asarray(u, dtype=float)
    p = red.full.p
    xi = red.momentum_of(x) / float(red.locked_inertia_full(x, p))
    motion = xi * np.asarray(_generator(red)(x), dtype=float).ravel()
    f = np.asarray(red.full.function("f")(x, uu, p), dtype=float).ravel()
    return {"residual": float(np.max(np.abs(f - motion)) / np.max(np.abs(motion))),
            "momentum": red.momentum_of(x), "xi": xi, "x": x}


FURUTA_ALPHA = 0.9
"""The pendulum's steady angle [rad] from the downward vertical at which the Furuta
pendulum's momentum value is set (closed form below)."""


def furuta() -> tuple[list[Row], dict]:
    """The Furuta pendulum reduced by the shift of its arm angle, unforced.

    Closed form, by hand from the Lagrangian of models/furuta.py: with ``l = Lp / 2`` and
    ``Jp = mp Lp^2 / 12`` the link's Lagrange equation at ``alpha-dot = 0``, ``theta-ddot
    = 0`` (equivalently ``d V_mu / d alpha = 0`` for the amended potential ``V_mu = -mp g l
    cos(alpha) + mu^2 / (2 I(alpha))``; cf. the pendulum equation of Cazzolato and Prime
    (2011) with their ``J2-hat = mp l^2 + Jp``) says that a uniform thin link of length
    ``Lp`` and mass ``mp`` on an arm turning at ``Omega`` stands at ``alpha`` with

        sin(alpha) (mp g Lp / 2 - Omega^2 (mp Lp^2 / 3) cos(alpha)) = 0,

    so besides ``alpha = 0, pi``: ``cos(alpha) = 3 g / (2 Omega^2 Lp) = g / (Omega^2
    r_eff)``, ``r_eff = 2 Lp / 3`` (the arm length drops out), at the momentum ``mu =
    I(alpha) Omega``, ``I(alpha) = mr Lr^2 / 3 + mp Lr^2 + (mp Lp^2 / 3) sin^2(alpha)``.
    """
    full = furuta_model()
    refusal = ""
    try:
        mechanics.reduce(full, "angular_momentum_theta", momentum=0.0)
    except ModelError as e:
        refusal = str(e)
    v = {k: float(val) for k, val in full.values.items()}
    a = FURUTA_ALPHA
    omega = np.sqrt(3.0 * v["g"] / (2.0 * v["Lp"] * np.cos(a)))
    inertia = v["mr"] * v["Lr"] ** 2 / 3 + v["mp"] * v["Lr"] ** 2 + v["mp"] * v["Lp"] ** 2 / 3 \
        * np.sin(a) ** 2
    mu = inertia * omega
    red = mechanics.reduce(full, "angular_momentum_theta", momentum=mu,
                           breaking_inputs="hold_zero")
    starts = [red.model.state(alpha=t, alpha_dot=[0.0])
              for t in np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False)]
    found = enumerate_equilibria(red.model, starts)
    angles = [float(np.arctan2(e.x[1], e.x[0])) for e in found.equilibria]
    expect = np.array([0.0, a, -a, np.pi])
    dev = max(float(np.min(np.abs(np.angle(np.exp(1j * (expect - t)))))) for t in angles)
    steady = [steady_motion(red, e.x) for e in found.equilibria]
    tilted = [s for s, t in zip(steady, angles) if 0.1 < abs(t) < 3.0]
    src = "closed form cos(alpha) = 3 g / (2 Omega^2 Lp) (module docstring)"
    rows = [
        Row("Furuta: the motor is refused by name (1 = 'u[0]' and 'motor torque' in the "
            "message)", 1.0, float("u[0]" in refusal and "motor torque" in refusal), 0.0,
            "reduce(..., breaking_inputs='refuse')"),
        Row("Furuta (motor held at zero): Routh equilibria from 8 angles at rest", 4.0,
            float(len(found.equilibria)), 0.0, "alpha = 0, pi, +-alpha* (closed form)"),
        Row("Furuta: max |alpha - alpha*| over the Routh equilibria [rad]", 0.0, dev, 1e-12,
            src),
        Row("Furuta: max |Omega - Omega*| / Omega* at the tilted ones", 0.0,
            max(abs(s["xi"] - omega) / omega for s in tilted), 1e-12, src),
    ]
    grads = [amended_gradient(red, e.x) for e in found.equilibria]
    # the branch: the Routh equilibria over momentum values across the pitchfork at mu_c
    i0 = v["mr"] * v["Lr"] ** 2 / 3 + v["mp"] * v["Lr"] ** 2
    mu_c = i0 * np.sqrt(3.0 * v["g"] / (2.0 * v["Lp"]))
    branch, miscount, cone = [], 0, 0.0
    for mu_k in mu_c * np.linspace(0.6, 3.1, 11):  # 1.1 mu_c the closest
        red_k = mechanics.reduce(full, "angular_momentum_theta", momentum=float(mu_k),
                                 breaking_inputs="hold_zero")
        eqs = enumerate_equilibria(red_k.model, starts).equilibria
        miscount += len(eqs) != (4 if mu_k > mu_c else 2)
        for e in eqs:
            t, xi = float(np.arctan2(e.x[1], e.x[0])), steady_motion(red_k, e.x)["xi"]
            branch.append((float(mu_k), xi, t))
            if 0.0 < abs(t) < np.pi / 2:
                cone = max(cone, abs(np.cos(t) * xi**2 * 2.0 * v["Lp"] / (3.0 * v["g"]) - 1))
    rows += [
        Row("Furuta: momentum values (of 11, 0.6 to 3.1 mu_c) with a wrong number of Routh "
            "equilibria (2 below mu_c, 4 above)", 0.0, float(miscount), 0.0,
            "pitchfork at mu_c = I(0) sqrt(3 g / (2 Lp)) (closed form)"),
        Row("Furuta: max |cos(alpha) Omega^2 2 Lp / (3 g) - 1| along the branch", 0.0, cone,
            1e-12, src)]
    return rows + _steady_rows("Furuta", steady, mu, grads), {
        "mu": mu, "Omega": omega, "alpha": angles, "refusal": refusal, "mu_c": mu_c,
        "branch": branch, "Lp": v["Lp"], "g": v["g"], "held_inputs": list(red.held_inputs),
        "model": red.model}


def figure(values: dict) -> Figure:
    """The Furuta pendulum's relative equilibria: Routh equilibria against the closed form."""
    fur = values["furuta"]
    lp, g = fur["Lp"], fur["g"]
    fig = Figure(figsize=(4.2, 3.0))
    ax = fig.subplots()
    b = np.asarray(fur["branch"])
    ax.plot(b[:, 1], np.degrees(b[:, 2]), "o", ms=4, mfc="none", label="Routh equilibria")
    om = np.sqrt(3 * g / (2 * lp)) * np.linspace(1.0, b[:, 1].max() / np.sqrt(
        3 * g / (2 * lp)), 200)
    alpha = np.arccos(np.minimum(3 * g / (2 * om**2 * lp), 1.0))
    for sign in (1, -1):
        ax.plot(om, sign * np.degrees(alpha), "k-", lw=0.8,
                label="cos(alpha) = 3 g / (2 Omega^2 Lp)" if sign > 0 else None)
    ax.set(xlabel="arm rate Omega = mu / I(alpha) [rad/s]", ylabel="alpha [deg]",
           ylim=(-100.0, 250.0))
    ax.legend(fontsize=7, loc="upper center")
    fig.set_layout_engine("tight")
    return fig


def amended_gradient(red: mechanics.Reduction, r: np.ndarray) -> float:
    """``max |N^T grad V_mu|`` at a Routh state (``N`` a basis of its tangent space)."""
    m = red.model
    grad = red.amended_potential.factory("grad", ["x", "p"], ["grad:V_mu:x"])
    g = np.asarray(grad(r, m.p), dtype=float).ravel()
    return float(np.max(np.abs(np.asarray(m.manifold.tangent_basis(r)).T @ g)))


def _steady_rows(name: str, steady: list[dict], mu: float,
                 gradients: list[float] | None = None) -> list[Row]:
    extra = [] if gradients is None else [
        Row(f"{name}: max |grad V_mu| (tangent) at the Routh equilibria", 0.0,
            max(gradients), 1e-10, "critical points of the amended potential V + mu^2/(2 I)")]
    return extra + [
        Row(f"{name}: max |f(x) - xi g'(x)| / |xi g'(x)| over the lifted equilibria", 0.0,
            max(s["residual"] for s in steady), 1e-10,
            "the full model's field at the reconstructed state (a steady motion)"),
        Row(f"{name}: max |J(x) - mu| / |mu| over the lifted equilibria", 0.0,
            max(abs(s["momentum"] - mu) for s in steady) / abs(mu), 1e-12,
            "the full model's momentum"),
    ]


def rx(angle: float) -> np.ndarray:
    """The rotation by ``angle`` about e1."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


CART_MU = 0.7
"""The cart's momentum value [kg m/s] of the Routh models of the 3D pendulum on a cart."""


def cart() -> tuple[list[Row], dict]:
    """The 3D pendulum on a cart reduced by each translation of the cart, unforced.

    Closed form: the locked inertia of a translation is the total mass ``M + m``, so the
    amended potential is ``V + mu^2 / (2 (M + m))``: its critical points are those of
    ``V`` (the body's centre of mass straight below or above the pivot, ``R^T e3``
    parallel to ``rho``) and the relative equilibria are these equilibria carried at the
    uniform velocity ``mu / (M + m)``.
    """
    full = pendulum3d_cart()
    v = {k: np.asarray(val, dtype=float) for k, val in full.values.items()}
    total = float(v["M"] + v["m"])
    rho = v["rho"] / np.linalg.norm(v["rho"])
    rows: list[Row] = []
    out: dict = {}
    for sym in ("p_x", "p_y"):
        red = mechanics.reduce(full, sym, momentum=CART_MU, breaking_inputs="hold_zero")
        m = red.model
        starts = [m.state(x=[0.0], v=[0.0], R=rx(a), Omega=[0.0, 0.0, 0.0])
                  for a in (0.0, 0.6, np.pi - 0.6, np.pi)]
        found = enumerate_equilibria(m, starts)
        steady = [steady_motion(red, e.x) for e in found.equilibria]
        vmu = red.amended_potential
        pot = red.potential_full
        gammas = [SO3.matrix(e.parts["R"]).T @ E3 for e in found.equilibria]
        rows += [
            Row(f"cart, {sym}: Routh equilibria from 4 tilts at rest (hanging, inverted)",
                2.0, float(len(found.equilibria)), 0.0, "critical points of V (docstring)"),
            Row(f"cart, {sym}: max |R^T e3 x rho| / |rho| at them", 0.0,
                max(float(np.linalg.norm(np.cross(g, rho))) for g in gammas), 1e-12,
                "the centre of mass below or above the pivot"),
            Row(f"cart, {sym}: max |xi - mu / (M + m)| / |xi|", 0.0,
                max(abs(s["xi"] - CART_MU / total) for s in steady) / (CART_MU / total),
                1e-12, "uniform motion at the total momentum (closed form)"),
            Row(f"cart, {sym}: max |V_mu - V - mu^2 / (2 (M + m))| [J]", 0.0,
                max(abs(float(vmu(e.x, m.p)) - float(pot(s["x"], full.p))
                        - CART_MU**2 / (2 * total)) for e, s in zip(found.equilibria, steady)),
                1e-12, "the amended potential of a translation (closed form)"),
            *_steady_rows(f"cart, {sym}", steady, CART_MU)]
        out[sym] = {"held_inputs": list(red.held_inputs), "velocity": CART_MU / total,
                    "equilibria": len(found.equilibria), "model": m}
    return rows, out


def _tilted(angle: float) -> np.ndarray:
    """``e3`` turned by ``angle`` about e1."""
    return rx(angle) @ E3


def quadrotor(rng: np.random.Generator, n_states: int) -> tuple[list[Row], dict]:
    """The quadrotor with a slung load reduced by its translations and its yaw.

    The thrust ``-f R e3`` is the same wherever the quadrotor is and however it is turned
    about the vertical (an equivariant input: Lagrange-Poincare keeps it), but it changes
    the horizontal momentum whenever the quadrotor is tilted, and the body moment changes
    the angular momentum about the vertical: the Routh models hold them at zero. With the
    thrust held at zero nothing holds the system up and the Routh model has no equilibrium:
    its centre of mass falls at ``g`` (closed form, a row). The relative equilibria of the
    flying system are the equilibria of the Lagrange-Poincare models at the hover input
    ``f = (mQ + mL) g``: level (``R^T e3 = e3``), the load hanging (``q = e3``), the
    quadrotor moving at a constant horizontal velocity (translation); or (yaw) the level
    quadrotor spinning at ``Omega`` about the vertical through the centre of mass while the
    load swings out on the opposite side, the cable at ``beta`` from the vertical with

        cos(beta) = (mQ + mL) g / (mQ L Omega^2),   mQ a = mL b

    (``a``, ``b`` the distances of quadrotor and load from the axis; from the load's
    ``T q = mL (g e3 + Omega^2 b n)``, the quadrotor's ``mQ Omega^2 a = T |q_h|`` and
    ``a + b = L sin(beta)``; hanging on the axis below ``Omega^2 = (mQ + mL) g / (mQ L)``).
    """
    full = quadrotor_slung_load()
    v = {k: np.asarray(val, dtype=float) for k, val in full.values.items()}
    mq, ml, L, g = (float(v[k]) for k in ("mQ", "mL", "L", "g"))
    hover = hover_input(full)
    ro = mechanics.reduce(full, "p_x", momentum=0.4, breaking_inputs="hold_zero")
    fall = 0.0
    for _ in range(n_states):
        r = ro.model.manifold.random_point(rng)
        d = ro.model.rhs(r, rng.standard_normal(ro.model.n_inputs))
        q, w = r[-6:-3], r[-3:]
        qd, wd = d[-6:-3], d[-3:]
        qdd = np.cross(wd, q) + np.cross(w, qd)  # q-dot = w x q
        acc = (mq * d[2:4] + ml * (d[2:4] + L * qdd[1:])) / (mq + ml)  # (y, z) components
        fall = max(fall, float(np.max(np.abs(acc - np.array([0.0, g])))) / g)
    rows = [Row("quadrotor, p_x: Routh inputs held at zero (the thrust: 1)", 1.0,
                float(ro.held_inputs == (0,)), 0.0, "the thrust tilts with R"),
            Row("quadrotor, p_x Routh (thrust held at zero): max |a_com - g e3| / g (free "
                "fall: no relative equilibrium)", 0.0, fall, 1e-12,
                "closed form: gravity the only external force")]
    out: dict = {"held_inputs": list(ro.held_inputs)}
    starts = {"p_x": {"xQ": [0.3, -0.2], "vQ": [1.5, 0.2, -0.1], "R": rx(0.2),
                      "Omega": [0.1, -0.2, 0.3], "q": np.r_[_tilted(0.3), 0.2, 0.0, 0.0]},
              "L_z": {"xQ_rel": [0.0, -0.15, -0.5], "vQ_rel": [0.0, 0.0, 0.0],
                      "Gamma": _tilted(0.1), "Omega": [0.0, 0.0, 5.0],
                      "q_rel": np.r_[_tilted(-1.0), 0.0, 0.0, 0.0]}}
    for sym, start in starts.items():
        lp = mechanics.reduce(full, sym, kind="lagrange_poincare")
        eq = find_equilibrium(lp.model, lp.model.state(**start), u=hover)
        s = steady_motion(lp, eq.x, hover)
        x = s["x"]
        xq, vq, R, om, q = x[0:3], x[3:6], SO3.matrix(x[6:15]), x[15:18], x[18:21]
        level = max(float(np.linalg.norm(R.T @ E3 - E3)), float(np.max(np.abs(om[:2]))))
        if sym == "p_x":
            xi_ref, what = vq[0], "xi = the horizontal velocity v_x"
            shape = max(level, float(np.linalg.norm(q - E3)), float(np.max(np.abs(vq[1:]))),
                        abs(om[2]))
            closed = ("distance from level hover, load hanging, v = (v_x, 0, 0)", shape)
        else:  # the load swings out opposite the quadrotor, the centre of mass on the axis
            xi_ref, what = om[2], "xi = the yaw rate Omega_3"
            com = mq * xq[:2] + ml * (xq[:2] + L * q[:2])
            cone = abs(q[2] - (mq + ml) * g / (mq * L * xi_ref**2))
            closed = ("max(|cos(beta) - (mQ + mL) g / (mQ L Omega^2)|, |R^T e3 - e3|, "
                      "|m x_com,h| / (mL L |q_h|))",
                      max(cone, level, float(np.linalg.norm(com)) / (ml * L *
                                                                     np.linalg.norm(q[:2]))))
        rows += [
            Row(f"quadrotor, {sym} (Lagrange-Poincare at hover thrust): |xi - xi*| / |xi|",
                0.0, abs(s["xi"] - xi_ref) / abs(xi_ref), 1e-12, what),
            Row(f"quadrotor, {sym}: {closed[0]}", 0.0, closed[1], 1e-10,
                "closed form (docstring)"),
            Row(f"quadrotor, {sym}: |f(x, u_hover) - xi g'(x)| / |xi g'(x)|", 0.0,
                s["residual"], 1e-10, "the full model at the reconstructed state")]
        out[sym] = {"xi": s["xi"], "iterations": eq.iterations, "rank": eq.rank,
                    "model": lp.model}
    return rows, out


DOUBLE_MU = 0.8
"""The double 3D pendulum's angular momentum about the vertical [kg m^2/s]."""


def planar_amended_potential(values: dict, mu: float) -> tuple:
    """The amended potential ``V_mu(phi1, phi2)`` of the pair turned about e1, by hand (sympy).

    Body ``i`` at ``R_i = Rx(phi_i)``: ``Gamma_i = R_i^T e3 = (0, sin phi_i, cos phi_i)``;
    the locked inertia about the vertical through the pivot is ``Gamma1.J1 Gamma1 +
    Gamma2.J2 Gamma2 + m2 (|p_h|^2 + 2 p_h.c_h)`` (parallel axes: ``p = R1 d1`` the joint,
    ``c = R2 rho2``, ``_h`` the horizontal parts) and ``V = -g (m1 e3.R1 rho1 + m2 e3.(p +
    c))``. Returns ``(gradient, Hessian, I)`` as numeric functions of ``(phi1, phi2)``.
    """
    p1, p2 = sp.symbols("phi1 phi2", real=True)

    def rx(a: sp.Symbol) -> sp.Matrix:
        return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])

    v = {k: sp.Matrix(np.atleast_1d(np.asarray(val, dtype=float))) for k, val in
         values.items()}
    e3 = sp.Matrix([0, 0, 1])
    R1, R2 = rx(p1), rx(p2)
    g1, g2 = R1.T * e3, R2.T * e3
    p, c = R1 * v["d1"], R2 * v["rho2"]
    m1, m2, g = (v[k][0] for k in ("m1", "m2", "g"))
    inertia = ((g1.T * v["J1"] * g1)[0] + (g2.T * v["J2"] * g2)[0]
               + m2 * (p[0] ** 2 + p[1] ** 2 + 2 * (p[0] * c[0] + p[1] * c[1])))
    pot = -g * (m1 * (e3.T * R1 * v["rho1"])[0] + m2 * (e3.T * (p + c))[0])
    vmu = pot + mu**2 / (2 * inertia)
    grad = [sp.diff(vmu, s) for s in (p1, p2)]
    hess = [[sp.diff(d, s) for s in (p1, p2)] for d in grad]
    return (sp.lambdify([p1, p2], grad), sp.lambdify([p1, p2], hess),
            sp.lambdify([p1, p2], inertia))


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * np.asarray(a, dtype=float)))


def _canonical(phi: np.ndarray) -> np.ndarray:
    """``(phi1, phi2)`` wrapped, with the mirror ``phi -> -phi`` (yaw by pi) identified."""
    phi = _wrap(phi)
    k = int(np.argmax(np.abs(np.sin(phi)) > 1e-9)) if np.any(np.abs(np.sin(phi)) > 1e-9) \
        else 0
    return _wrap(-phi) if np.sin(phi[k]) < 0 else phi


def _distinct(points: list[np.ndarray], tol: float = 1e-7) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for x in points:
        if all(np.max(np.abs(_wrap(x - y))) > tol for y in out):
            out.append(x)
    return out


def double_pendulum(n_grid: int) -> tuple[list[Row], dict]:
    """The double 3D pendulum reduced by yaw of the pair, at the momentum DOUBLE_MU.

    Quotient coordinates: the first body's reduced attitude ``Gamma1 = R1^T e3`` (with
    ``w``, ``Gamma1-dot = w x Gamma1``) and the relative attitude ``Q = R1^T R2`` (with
    ``Omega2 - Q^T Omega1``). Structured starts: the sign patterns of gravity (each body
    hanging or inverted) with each body tilted by 0 or +-0.5 rad about e1 (36 starts,
    ``Gamma1 = (0, sin phi1, cos phi1)``, ``Q = Rx(phi2 - phi1)``); the tilt about a
    principal axis keeps Newton's iterates in that plane. The equilibria found are compared
    with the critical points of the hand-written amended potential of the pair tilted in
    that plane (:func:`planar_amended_potential`), found by scipy from an ``n_grid`` x ``n_grid``
    grid of the torus, both up to the mirror ``phi -> -phi`` (a yaw by pi).
    """
    full = double_pendulum3d()
    red = mechanics.reduce(full, "L_z", momentum=DOUBLE_MU)
    grad, hess, inertia = planar_amended_potential(full.values, DOUBLE_MU)
    tilts = [(s1 + t1, s2 + t2) for s1 in (0.0, np.pi) for s2 in (0.0, np.pi)
             for t1 in (0.0, 0.5, -0.5) for t2 in (0.0, 0.5, -0.5)]
    starts = [red.model.state(Gamma=np.r_[rx(a).T @ E3, 0.0, 0.0, 0.0],
                              R2_rel=rx(b - a), Omega2_rel=[0.0, 0.0, 0.0]) for a, b in tilts]
    found = enumerate_equilibria(red.model, starts)
    planar = dev_xi = 0.0
    angles, steady = [], []
    for e in found.equilibria:
        g1, Q = e.parts["Gamma"][:3], SO3.matrix(e.parts["R2_rel"])
        phi = np.array([np.arctan2(g1[1], g1[2]), 0.0])
        phi[1] = phi[0] + np.arctan2(Q[2, 1], Q[1, 1])
        planar = max(planar, abs(g1[0]), float(np.max(np.abs(Q - rx(phi[1] - phi[0])))))
        s = steady_motion(red, e.x)
        dev_xi = max(dev_xi, abs(s["xi"] * inertia(*phi) / DOUBLE_MU - 1.0))
        angles.append(_canonical(phi))
        steady.append(s)
    routh = _distinct(angles)
    grid = np.linspace(-np.pi, np.pi, n_grid, endpoint=False)
    hand = []
    for a in grid:
        for b in grid:
            sol = optimize.root(lambda y: grad(*y), [a, b], jac=lambda y: hess(*y), tol=1e-15)
            if sol.success and np.max(np.abs(grad(*sol.x))) <= 1e-11:
                hand.append(_canonical(sol.x))
    hand = _distinct(hand)
    match = max((min(float(np.max(np.abs(_wrap(x - y)))) for y in hand) for x in routh),
                default=np.inf)
    src = "the amended potential of the tilted pair, by hand (sympy, scipy root)"
    rows = [Row("double pendulum: critical points of V_mu(phi1, phi2) by hand (up to the "
                "mirror)", float(len(hand)), float(len(routh)), 0.0,
                f"{src}; Routh equilibria from 36 structured starts"),
            Row("double pendulum: max out-of-plane part of Gamma1, R1^T R2", 0.0, planar,
                1e-12, "the tilt about e1 (principal axes)"),
            Row("double pendulum: max |phi - phi*| [rad] over the Routh equilibria", 0.0,
                match, 1e-10, src),
            Row("double pendulum: max |xi I(phi) / mu - 1|", 0.0, dev_xi, 1e-12,
                "locked inertia by parallel axes (closed form)"),
            *_steady_rows("double pendulum", steady, DOUBLE_MU,
                          [amended_gradient(red, e.x) for e in found.equilibria])]
    return rows, {"angles": [a.tolist() for a in routh], "hand": [a.tolist() for a in hand],
                  "model": red.model, "xi": [s["xi"] for s in steady],
                  "equilibria": len(found.equilibria)}


def _split_models(v: object, models: list) -> object:
    """``v`` without its ``model`` entries (collected into ``models``), numbers as floats."""
    if isinstance(v, dict):
        if "model" in v:
            models.append(v["model"])
        return {k: _split_models(x, models) for k, x in v.items() if k != "model"}
    if isinstance(v, (list, tuple)):
        return [_split_models(x, models) for x in v]
    return float(v) if isinstance(v, (float, np.floating)) else v


def beyond_the_papers(rng: np.random.Generator, quick: bool) -> tuple[list[Row], dict, list]:
    """The rows of the section "beyond the papers", the values to record, the models used.

    Parameters
    ----------
    rng : numpy.random.Generator
        Seeded; draws the random states of the quadrotor's free-fall check.
    quick : bool
        5 random states there instead of 20 (the rest is the same: it is fast).

    Returns
    -------
    tuple
        ``(rows, values, models)``.
    """
    rows: list[Row] = []
    values: dict = {}
    models: list = []
    for name, run in (("furuta", furuta), ("pendulum3d_cart", cart),
                      ("quadrotor_slung_load", lambda: quadrotor(rng, 5 if quick else 20)),
                      ("double_pendulum3d", lambda: double_pendulum(16))):
        r, v = run()
        rows += r
        values[name] = _split_models(v, models)
    return rows, values, models
