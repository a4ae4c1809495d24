"""The chain on a cart derived by workbench.mechanics vs today's hand-written model (issue 15).

For n = 5, 10, 20, 50, 100 links, each measurement in its own subprocess (a cold process:
build costs and peak RSS are not shared), variants interleaved and repeated (medians):

* ``derived``: ``models.chain_cart.chain_cart`` (the Lagrangian through workbench.mechanics);
* ``printed``: ``models.paper_forms.chain_cart_printed`` (paper 003 (12) typed in, an MX
  graph differentiated entry by entry) -- skipped above n = 50 (26 s and 2 GB at n = 50);
* peers when installed (optional, never dependencies): sympy.physics.mechanics (Kane's method
  in angles, its own table at n = 1, 2, 3, ``--sympy-ns``) and Pinocchio (``pin``: numeric
  ABA derivatives; each link a universal joint carrying a point mass, ``2 n + 2`` degrees
  of freedom as the derived model, see :func:`_pin_chain` for why not spherical joints).
  Pinocchio's field is checked against the derived model's at seeded states, once per
  ``n`` in its own process (``pin vs derived``: the largest deviation of the field relative
  to its largest entry, with Pinocchio's ABA and with its CRBA mass matrix solved densely,
  then of the spectra at the hanging equilibrium; in brackets ABA's residual in
  ``M ddq + nle = tau``, see :func:`child_pin_check`).

Columns: CPU seconds to build the model and ``f``, to build ``f_x``, to linearise at the
hanging equilibrium the first time (``build+lin`` is the sum: the figure of the targets),
then the median CPU time of a linearisation of the built model, of one ``f`` evaluation,
and the peak RSS of the process. For the derived model the linearisation is timed
interleaved with the old path (AD of the ``f`` graph, which calls the accelerations'
supplied Jacobian once per batch of 64 directions, then dense products): both medians, the
median ratio and the load average are printed. Targets: n = 50 build + linearise < 2 s
CPU and < 400 MB; n = 100 < 10 s; a built model linearises at an equilibrium in < 50 ms at n = 50.

Usage: ``python benchmarks/bench_mechanics.py [--quick] [--ns 5 10 20 50 100] [--repeat 3]
[--sympy-ns 1 2 3]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import table  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
PRINTED_MAX_N = 50
SYMPY_NS = (1, 2, 3)
"""Chain sizes for sympy.physics.mechanics (its linearisation takes minutes beyond n = 3)."""


def _cpu() -> float:
    return time.process_time()


def _median_cpu(fn, repeat: int = 7) -> float:
    samples = []
    for _ in range(repeat):
        t0 = _cpu()
        fn()
        samples.append(_cpu() - t0)
    return statistics.median(samples)


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _hanging(model, n: int) -> np.ndarray:
    parts = {"x": np.zeros(2), "v": np.zeros(2)}
    parts.update({f"link{i + 1}": np.r_[0.0, 0.0, 1.0, 0.0, 0.0, 0.0] for i in range(n)})
    return model.manifold.join(parts)


def _old_linearize(model):
    """The previous path, for the ratio: AD of the ``f`` graph (the supplied Jacobian called
    once per batch of 64 directions), a dense pseudo-inverse and products, the SVD norm."""
    import casadi as ca

    f = model.function("f")
    x, u, p = (ca.MX.sym(k, f.size1_in(i)) for i, k in enumerate("xup"))
    xdot = f(x, u, p)
    jac = ca.Function("old_jacobians", [x, u, p],
                      [xdot, ca.jacobian(xdot, x), ca.jacobian(xdot, u)])

    def lin(xe: np.ndarray) -> tuple:
        N = model.manifold.tangent_basis(xe)
        f0, Jx, Ju = (np.asarray(v) for v in jac(xe, np.zeros(model.n_inputs), model.p))
        np.linalg.norm(Jx, 2)
        L = np.linalg.pinv(N)
        return L @ Jx @ N, L @ Ju

    return lin


def _interleaved(new, old, repeat: int = 15) -> tuple[float, float, float]:
    """CPU medians of ``new()`` and ``old()`` called alternately, and the median ratio."""
    a, b = [], []
    for _ in range(repeat):
        for fn, out in ((new, a), (old, b)):
            t0 = _cpu()
            fn()
            out.append(_cpu() - t0)
    return (statistics.median(a), statistics.median(b),
            statistics.median([y / x for x, y in zip(a, b)]))


def child_casadi(variant: str, n: int) -> dict:
    """Build, Jacobian, linearisation and evaluation of one chain model (in this process)."""
    from workbench import linearize

    if variant == "derived":
        from models.chain_cart import chain_cart

        def make(n: int, **kw):
            return chain_cart(n, max_links=n, **kw)
    else:
        from models.paper_forms import chain_cart_printed as make
    rss0 = _rss_mb()
    t0 = _cpu()
    model = make(n, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    f = model.function("f")
    t1 = _cpu()
    model.function("f_x")
    t2 = _cpu()
    xe = _hanging(model, n)
    linearize(model, xe)
    t3 = _cpu()
    out = {}
    if variant == "derived":
        old = _old_linearize(model)
        lin = linearize(model, xe)
        A_old, _ = old(xe)
        out["lin_dev"] = float(np.max(np.abs(lin.A - A_old)) / np.max(np.abs(A_old)))
        again, out["lin_old"], out["lin_ratio"] = _interleaved(lambda: linearize(model, xe),
                                                               lambda: old(xe))
    else:
        again = _median_cpu(lambda: linearize(model, xe))
    x = model.manifold.random_point(np.random.default_rng(0))
    u, p = np.zeros(2), model.p
    ev = _median_cpu(lambda: [f(x, u, p) for _ in range(20)]) / 20
    return {"build": t1 - t0, "jac": t2 - t1, "lin": t3 - t2, "total": t3 - t0,
            "lin_again": again, "eval": ev, "rss": _rss_mb(), "rss_import": rss0, **out}


def child_sympy(n: int) -> dict:
    """Kane's equations of the chain on a cart in angles, linearised at the hanging state."""
    import sympy as sp
    from sympy.physics import mechanics as me

    t0 = _cpu()
    N = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(N, 0)
    x, y = me.dynamicsymbols("x y")
    ang = me.dynamicsymbols(f"a1:{n + 1}") + me.dynamicsymbols(f"b1:{n + 1}")
    qs = [x, y, *ang]
    us = me.dynamicsymbols(f"u1:{len(qs) + 1}")
    g, m0 = sp.symbols("g m0")
    ms, ls = sp.symbols(f"m1:{n + 1}"), sp.symbols(f"l1:{n + 1}")
    F = me.dynamicsymbols("F1 F2")
    P = origin.locatenew("P0", x * N.x + y * N.y)
    P.set_vel(N, P.pos_from(origin).dt(N))
    bodies, loads = [me.Particle("cart", P, m0)], [(P, F[0] * N.x + F[1] * N.y)]
    for i in range(n):
        A = N.orientnew(f"A{i}", "Body", [ang[i], ang[n + i], 0], "XYZ")
        Q = P.locatenew(f"P{i + 1}", ls[i] * A.z)  # A.z = N.z (down) at zero angles
        Q.set_vel(N, Q.pos_from(origin).dt(N))
        bodies.append(me.Particle(f"bob{i}", Q, ms[i]))
        loads.append((Q, ms[i] * g * N.z))
        P = Q
    kane = me.KanesMethod(N, q_ind=qs, u_ind=us,
                          kd_eqs=[qd.diff() - u for qd, u in zip(qs, us)])
    kane.kanes_equations(bodies, loads)
    t1 = _cpu()
    op = {s: 0 for s in qs + us}
    op.update({s.diff(): 0 for s in us})
    lin = kane.to_linearizer()
    A, B = lin.linearize(op_point=op, A_and_B=True)
    vals = {g: 9.81, m0: 0.5, **{s: 0.1 for s in ms}, **{s: 0.1 for s in ls}}
    np.array(A.subs(vals).evalf(), dtype=float)
    t2 = _cpu()
    return {"build": t1 - t0, "lin": t2 - t1, "total": t2 - t0, "rss": _rss_mb()}


def _pin_chain(n: int):
    """Pinocchio's chain on a cart: PX, PY, then a universal joint and a point mass per link.

    Why not spherical joints: a point mass has no rotational inertia, so the spin of a
    spherical joint about its own link moves no mass. The joint-space inertia is then
    singular (one zero eigenvalue per link at the hanging state, where every link's spin
    axis is the chain's axis; at least the last link's spin anywhere), and ABA, which
    divides by each joint's articulated inertia ``S^T I^A S``, returns NaN. Pinocchio's
    examples give each bob a sphere's inertia (``Inertia.FromSphere``) on revolute joints;
    here a universal joint (two revolutes, about ``e1`` then the turned ``e2``) carries the
    point mass exactly: the link's configuration is a point of S^2 in two angles, as the
    derived model's TS^2 factor, so both solve the same mechanics (``2 n + 2`` degrees of
    freedom; the spherical version had ``3 n + 2``, its spins being mass-less) and agree
    to rounding. The angles are singular where a link's second angle is ``+-pi/2`` (the
    benchmark's states stay within 0.8 rad). Pinocchio's ``z`` is the workbench's ``e3``
    (down, along gravity), so the two share one frame.
    """
    import pinocchio as pin

    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, 9.81])  # along +z = e3: down
    jx = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
    jy = model.addJoint(jx, pin.JointModelPY(), pin.SE3.Identity(), "y")
    model.appendBodyToJoint(jy, pin.Inertia(0.5, np.zeros(3), np.zeros((3, 3))),
                            pin.SE3.Identity())
    parent, offset, bobs = jy, np.zeros(3), []
    link = np.array([0.0, 0.0, 0.1])  # hanging along e3 at zero angles
    for i in range(n):
        j = model.addJoint(parent, pin.JointModelUniversal(np.array([1.0, 0.0, 0.0]),
                                                           np.array([0.0, 1.0, 0.0])),
                           pin.SE3(np.eye(3), offset), f"link{i + 1}")
        model.appendBodyToJoint(j, pin.Inertia(0.1, link, np.zeros((3, 3))),
                                pin.SE3.Identity())
        bobs.append(model.addFrame(pin.Frame(f"bob{i + 1}", j, pin.SE3(np.eye(3), link),
                                             pin.FrameType.OP_FRAME)))
        parent, offset = j, link
    return model, bobs


def child_pin(n: int) -> dict:
    """Pinocchio: chain on a cart (PX, PY, n universal joints), numeric ABA derivatives."""
    import pinocchio as pin

    t0 = _cpu()
    model, _ = _pin_chain(n)
    data = model.createData()
    t1 = _cpu()
    q, v, tau = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv)

    def linearise():
        pin.computeABADerivatives(model, data, q, v, tau)
        nv = model.nv
        A = np.zeros((2 * nv, 2 * nv))
        A[:nv, nv:] = np.eye(nv)
        A[nv:, :nv], A[nv:, nv:] = data.ddq_dq, data.ddq_dv
        return A, data.Minv

    A, _ = linearise()
    t2 = _cpu()
    if not np.all(np.isfinite(A)):
        raise FloatingPointError("Pinocchio's ABA derivatives are not finite at hanging")
    again = _median_cpu(linearise)
    aba = _median_cpu(lambda: pin.computeABADerivatives(model, data, q, v, tau))
    return {"build": t1 - t0, "lin": t2 - t1, "total": t2 - t0, "lin_again": again,
            "aba": aba, "rss": _rss_mb()}


def _pin_as_field(pin, pm, pd, bobs, q, v, ddq, n: int) -> tuple[dict, dict]:
    """The derived model's state and expected field from Pinocchio's ``(q, v, ddq)``."""
    pin.forwardKinematics(pm, pd, q, v, ddq)
    pin.updateFramePlacements(pm, pd)
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    pts = [np.r_[q[:2], 0.0]] + [pd.oMf[f].translation.copy() for f in bobs]
    vel = [np.r_[v[:2], 0.0]] + [pin.getFrameVelocity(pm, pd, f, world).linear for f in bobs]
    acc = [np.r_[ddq[:2], 0.0]] + [pin.getFrameClassicalAcceleration(pm, pd, f, world).linear
                                   for f in bobs]
    state, field = {"x": q[:2], "v": v[:2]}, {"x": v[:2], "v": ddq[:2]}
    for i in range(n):
        qi, qd, qdd = ((z[i + 1] - z[i]) / 0.1 for z in (pts, vel, acc))
        w = np.cross(qi, qd)  # q-dot = w x q with w normal to q
        state[f"link{i + 1}"] = np.r_[qi, w]
        field[f"link{i + 1}"] = np.r_[np.cross(w, qi), np.cross(qi, qdd)]
    return state, field


def child_pin_check(n: int, states: int = 3) -> dict:
    """Pinocchio's dynamics against the derived model's field at the same seeded states.

    At each state (angles uniform in +-0.8 rad, rates and the cart force normal) the
    Pinocchio bobs' positions, velocities and classical accelerations give the derived
    model's state (``q_i = (p_i - p_(i-1)) / l``, ``omega_i = q_i x q_i-dot``) and its
    expected field (``omega_i-dot = q_i x q_i-ddot``). Returned: the largest deviation of
    the derived field relative to its largest entry, with Pinocchio's accelerations from
    ABA (``aba_dev``) and from a dense solve with its CRBA mass matrix and
    ``nonLinearEffects`` (``crba_dev``), ABA's own residual in that equation relative to
    ``|nonLinearEffects|`` (``aba_residual``: ABA is the less accurate of the two when the
    mass matrix is ill-conditioned, about 1e9 at n = 100), and the relative gap of the two
    spectra at the hanging equilibrium (Pinocchio's ABA derivatives against ``linearize``).
    """
    import pinocchio as pin

    from models.chain_cart import chain_cart
    from workbench import linearize

    pm, bobs = _pin_chain(n)
    pd = pm.createData()
    wm = chain_cart(n, max_links=n, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    rng = np.random.default_rng(n)
    out = {"aba_dev": 0.0, "crba_dev": 0.0, "aba_residual": 0.0}
    for _ in range(states):
        q = np.r_[rng.normal(0.0, 0.3, 2), rng.uniform(-0.8, 0.8, pm.nq - 2)]
        v, u = rng.normal(0.0, 1.0, pm.nv), rng.normal(0.0, 1.0, 2)
        tau = np.r_[u, np.zeros(pm.nv - 2)]
        M = np.triu(pin.crba(pm, pd, q))
        M = M + np.triu(M, 1).T
        nle = pin.nonLinearEffects(pm, pd, q, v).copy()
        solutions = {"aba_dev": pin.aba(pm, pd, q, v, tau).copy(),
                     "crba_dev": np.linalg.solve(M, tau - nle)}
        res = M @ solutions["aba_dev"] + nle - tau
        out["aba_residual"] = max(out["aba_residual"],
                                  float(np.max(np.abs(res)) / np.max(np.abs(nle))))
        for key, ddq in solutions.items():
            state, field = _pin_as_field(pin, pm, pd, bobs, q, v, ddq, n)
            f, ref = wm.rhs(wm.manifold.join(state), u), wm.manifold.join(field)
            out[key] = max(out[key], float(np.max(np.abs(f - ref)) / np.max(np.abs(ref))))
    pin.computeABADerivatives(pm, pd, pin.neutral(pm), np.zeros(pm.nv), np.zeros(pm.nv))
    nv = pm.nv
    A = np.block([[np.zeros((nv, nv)), np.eye(nv)], [pd.ddq_dq, pd.ddq_dv]])
    lin = linearize(wm, _hanging(wm, n))
    lam_p, lam_w = (np.sort(np.abs(np.linalg.eigvals(X).imag)) for X in (A, lin.A))
    out["spectrum_dev"] = float(np.max(np.abs(lam_p - lam_w)) / np.max(lam_w))
    return out


def run_child(variant: str, n: int, timeout: float) -> dict | None:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    cmd = [sys.executable, str(Path(__file__)), "--child", variant, str(n)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT,
                             env=env)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:.0f} s"}
    if out.returncode != 0:
        lines = (out.stderr or out.stdout).strip().splitlines()
        return {"error": lines[-1] if lines else f"exit {out.returncode}"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def _available(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


def _med(runs: list[dict], key: str) -> float:
    vals = [r[key] for r in runs if r and "error" not in r and key in r]
    return statistics.median(vals) if vals else float("nan")


def _fmt(v: float, scale: float = 1.0, digits: int = 3) -> str:
    return "-" if v != v else f"{v * scale:.{digits}g}"


def _sympy_table(ns: list[int]) -> None:
    """Kane's method in sympy (angles) against the derived model, one cold run each."""
    rows = []
    for n in ns:
        d, k = run_child("derived", n, 600.0), run_child("sympy", n, 900.0)
        ok = "error" not in k
        rows.append({"n": n, "derived build+lin [s]": _fmt(d.get("total", float("nan"))),
                     "sympy derive [s]": _fmt(k["build"]) if ok else k["error"],
                     "sympy linearise [s]": _fmt(k["lin"]) if ok else "-",
                     "ratio sympy/derived": _fmt(k["total"] / d["total"]) if ok else "-"})
        print(table(rows[-1:], list(rows[-1])), flush=True)
    print("sympy.physics.mechanics, chain on a cart in angles (Kane, linearize at rest):")
    print(table(rows, list(rows[0])))
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ns", type=int, nargs="+", default=[5, 10, 20, 50, 100])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="n = 5, 10, 20; one repeat")
    ap.add_argument("--sympy-ns", type=int, nargs="*", default=list(SYMPY_NS))
    ap.add_argument("--child", nargs=2, metavar=("VARIANT", "N"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        variant, n = args.child[0], int(args.child[1])
        fn = {"sympy": child_sympy, "pin": child_pin, "pin_check": child_pin_check}.get(variant)
        print(json.dumps(fn(n) if fn else child_casadi(variant, n)))
        return
    ns, repeat = ([5, 10, 20], 1) if args.quick else (args.ns, args.repeat)
    print(f"load average at start: {os.getloadavg()}  (2 shared cores; CPU times, medians of "
          f"{repeat} cold processes, variants interleaved)")
    peers = [p for p, mod in (("sympy", "sympy.physics.mechanics"), ("pin", "pinocchio"))
             if _available(mod)]
    for p, mod in (("sympy", "sympy.physics.mechanics"), ("pin", "pinocchio")):
        if p not in peers:
            print(f"{mod}: not installed (optional peer)")
    if "sympy" in peers and args.sympy_ns:
        _sympy_table(args.sympy_ns)
    rows, lin_runs = [], {}
    for n in ns:
        variants = ["derived"] + (["printed"] if n <= PRINTED_MAX_N else [])
        variants += [p for p in peers if p != "sympy"]
        runs: dict[str, list] = {v: [] for v in variants}
        for _ in range(repeat):
            for v in variants:
                runs[v].append(run_child(v, n, timeout=600.0))
        check = run_child("pin_check", n, timeout=600.0) if "pin" in peers else None
        if check is not None:
            runs["pin_check"] = [check]
        d, h = runs["derived"], runs.get("printed", [])
        lin_runs[n] = [r for r in d if r and "error" not in r]
        errors = {v: r["error"] for v, rs in runs.items() for r in rs if r and "error" in r}
        rows.append({
            "n": n,
            "derived build+lin [s]": _fmt(_med(d, "total")),
            "printed build+lin [s]": _fmt(_med(h, "total")) if h else "skipped",
            "ratio printed/derived": _fmt(_med(h, "total") / _med(d, "total")) if h else "-",
            "derived build/jac/lin [s]": "/".join(_fmt(_med(d, k), digits=2)
                                                 for k in ("build", "jac", "lin")),
            "derived RSS [MB]": _fmt(_med(d, "rss"), digits=4),
            "printed RSS [MB]": _fmt(_med(h, "rss"), digits=4) if h else "-",
            "lin at eq. derived/printed [ms]": f"{_fmt(_med(d, 'lin_again'), 1e3)}/"
                                               f"{_fmt(_med(h, 'lin_again'), 1e3)}",
            "lin at eq. old path [ms] (old/new)": f"{_fmt(_med(d, 'lin_old'), 1e3)} "
                                                  f"({_fmt(_med(d, 'lin_ratio'))})",
            "f eval derived/printed [us]": f"{_fmt(_med(d, 'eval'), 1e6)}/"
                                           f"{_fmt(_med(h, 'eval'), 1e6)}",
            "pin build/lin/ABA [ms]": "/".join(_fmt(_med(runs.get("pin", []), k), 1e3)
                                               for k in ("build", "lin_again", "aba")),
            "pin vs derived: ABA/CRBA/spectrum (ABA resid.)": "/".join(
                _fmt(_med(runs.get("pin_check", []), k), digits=2)
                for k in ("aba_dev", "crba_dev", "spectrum_dev"))
            + f" ({_fmt(_med(runs.get('pin_check', []), 'aba_residual'), digits=2)})",
        })
        for v, e in errors.items():
            print(f"n = {n}, {v}: {e}")
        print(table(rows[-1:], list(rows[-1])), flush=True)
    print()
    print(table(rows, list(rows[0])))
    by_n = {r["n"]: r for r in rows}
    if 50 in by_n:
        r = by_n[50]
        print(f"target n = 50 build + linearise < 2 s CPU: {r['derived build+lin [s]']} s "
              f"(printed {r['printed build+lin [s]']} s, ratio {r['ratio printed/derived']}); "
              f"peak RSS < 400 MB: {r['derived RSS [MB]']} MB (printed {r['printed RSS [MB]']})"
              f"; linearise a built model < 50 ms: {r['lin at eq. derived/printed [ms]']} ms")
    for n in ns:
        d = lin_runs.get(n, [])
        if d:
            print(f"n = {n}: linearise a built model at the hanging equilibrium: median "
                  f"{_fmt(_med(d, 'lin_again'), 1e3)} ms CPU (target < 50 ms at n = 50); the "
                  f"old path (AD of the f graph, dense pinv, SVD norm) "
                  f"{_fmt(_med(d, 'lin_old'), 1e3)} ms interleaved in the same processes, "
                  f"ratio old/new {_fmt(_med(d, 'lin_ratio'))}; max |A - A_old| / max |A_old| "
                  f"= {_fmt(max(r['lin_dev'] for r in d), digits=2)}; load average "
                  f"{os.getloadavg()}")
    if 100 in by_n:
        print(f"target n = 100 < 10 s CPU: {by_n[100]['derived build+lin [s]']} s")
    print(f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
