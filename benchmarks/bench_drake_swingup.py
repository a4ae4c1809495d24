"""Drake's swing-up, posed identically in Drake and in the workbench: CPU medians and ratios.

The problem (issue 17): a spherical pendulum on a cart, tip mass 0.1 kg on a massless
link of 0.1 m, cart 0.5 kg moving in the horizontal plane under a horizontal force
``u`` in R^2, g = 9.81. 41 knots with equal intervals, cost ``integral u'u dt`` (the
trapezoid over the knots) ``+ T``, ``|u_i| <= 10 N``, ``T in [0.5, 3] s``; from hanging at
rest with the cart at the origin to upright at rest, with the cart back at the origin
(``origin``) or anywhere (``free``). Initial guess: ``u = 0`` and the straight swing
(the state interpolated linearly in Drake's coordinates, a great circle in ours) over
``T = 1.5 s``.

Drake's side (when ``pydrake`` is installed; ``pip install
'geometric-pendulum-workbench[peers]'``): a MultibodyPlant (two prismatic joints for the
cart, a UniversalJoint for the pendulum: two angles, Drake has no S^2), transcribed by
``pydrake.planning.DirectCollocation`` (Hermite-Simpson, first-order-hold controls,
trapezoidal running cost) and solved by Drake's ``IpoptSolver`` with its default options
(a limited-memory Hessian: Drake does not give Ipopt second derivatives). The iteration
count is read from Ipopt's output file. CPU seconds are ``time.process_time`` around
``Solve`` (building the program excluded).

The workbench's side: the same NLP (Hermite-Simpson, first-order hold, trapezoid, 40
intervals) on the model in ambient coordinates, exact Hessian, automatic gauge of the
rotation about the vertical (see ``problems/swingup_drake_reference.py``); CPU seconds are
those of Ipopt's solve (building excluded, reported once).

Both sides run interleaved (drake, workbench, drake, ...) and the medians of the CPU
times are compared. Without Drake, the figures recorded in issue 17 are printed, labelled
as recorded. This script installs nothing.

Usage: python benchmarks/bench_drake_swingup.py [--quick] [--repeat K]
"""

from __future__ import annotations

import os
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import table  # noqa: E402

RECORDED = {
    "origin": {"cpu_seconds": 7.2, "iterations": 121, "cost": 5.2289},
    "free": {"cpu_seconds": 7.67, "iterations": None, "cost": None},
}
"""Drake 1.51 IPOPT on this machine class, as recorded in issue 17 (not measured here)."""

KNOTS = 41
U_MAX = 10.0
T_RANGE = (0.5, 3.0)
T_GUESS = 1.5
L, M_TIP, M_CART, G = 0.1, 0.1, 0.5, 9.81
TARGET_RATIO = 10.0


def drake_available() -> bool:
    """Whether pydrake imports."""
    try:
        import pydrake.planning  # noqa: F401
    except ImportError:
        return False
    return True


# Drake ---------------------------------------------------------------------------------


def drake_plant():
    """The cart-pendulum as a MultibodyPlant: prismatic x, prismatic y, universal joint."""
    from pydrake.math import RigidTransform
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import (
        PrismaticJoint,
        SpatialInertia,
        UnitInertia,
        UniversalJoint,
        WeldJoint,
    )

    plant = MultibodyPlant(0.0)

    def point_mass(mass):
        return SpatialInertia(mass, np.zeros(3), UnitInertia(0.0, 0.0, 0.0))

    carriage = plant.AddRigidBody("carriage", point_mass(0.0))
    cart = plant.AddRigidBody("cart", point_mass(M_CART))
    link = plant.AddRigidBody("link", point_mass(0.0))
    bob = plant.AddRigidBody("bob", point_mass(M_TIP))
    jx = plant.AddJoint(PrismaticJoint("x", plant.world_frame(), carriage.body_frame(),
                                       [1.0, 0.0, 0.0]))
    jy = plant.AddJoint(PrismaticJoint("y", carriage.body_frame(), cart.body_frame(),
                                       [0.0, 1.0, 0.0]))
    plant.AddJoint(UniversalJoint("swing", cart.body_frame(), link.body_frame()))
    plant.AddJoint(WeldJoint("rod", link.body_frame(), bob.body_frame(),
                             RigidTransform([0.0, 0.0, -L])))
    plant.AddJointActuator("fx", jx)
    plant.AddJointActuator("fy", jy)
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -G])
    plant.Finalize()
    return plant


def drake_program(plant, *, cart_free: bool):
    """Drake's DirectCollocation of the swing-up (state: x, y, angles, their rates)."""
    from pydrake.planning import DirectCollocation
    from pydrake.trajectories import PiecewisePolynomial

    n = KNOTS - 1
    dc = DirectCollocation(plant, plant.CreateDefaultContext(), KNOTS, T_RANGE[0] / n,
                           T_RANGE[1] / n, plant.get_actuation_input_port().get_index())
    dc.AddEqualTimeIntervalsConstraints()
    dc.AddDurationBounds(*T_RANGE)
    u = dc.input()
    for i in range(2):
        dc.AddConstraintToAllKnotPoints(u[i] <= U_MAX)
        dc.AddConstraintToAllKnotPoints(u[i] >= -U_MAX)
    x0 = np.zeros(8)
    xf = np.array([0.0, 0.0, np.pi, 0.0, 0.0, 0.0, 0.0, 0.0])  # upright: pi about x
    prog = dc.prog()
    prog.AddBoundingBoxConstraint(x0, x0, dc.initial_state())
    k = 2 if cart_free else 0
    prog.AddBoundingBoxConstraint(xf[k:], xf[k:], dc.final_state()[k:])
    dc.AddRunningCost(u.dot(u))
    dc.AddFinalCost(dc.time())
    dc.SetInitialTrajectory(
        PiecewisePolynomial.FirstOrderHold([0.0, T_GUESS], np.zeros((2, 2))),
        PiecewisePolynomial.FirstOrderHold([0.0, T_GUESS], np.column_stack([x0, xf])))
    return dc


def drake_solve(plant, *, cart_free: bool) -> dict:
    """Build Drake's program, solve it with Drake's IpoptSolver; CPU and wall seconds."""
    from pydrake.solvers import IpoptSolver, SolverOptions

    dc = drake_program(plant, cart_free=cart_free)
    options = SolverOptions()
    fd, log = tempfile.mkstemp(suffix=".ipopt.txt")
    os.close(fd)
    options.SetOption(IpoptSolver.id(), "output_file", log)
    options.SetOption(IpoptSolver.id(), "file_print_level", 3)
    solver = IpoptSolver()
    c0, t0 = time.process_time(), time.perf_counter()
    result = solver.Solve(dc.prog(), None, options)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    text = Path(log).read_text()
    os.unlink(log)
    found = re.search(r"Number of Iterations\.+:\s*(\d+)", text)
    exit_line = re.search(r"EXIT: (.*)", text)
    return {"side": "drake", "cpu": cpu, "wall": wall,
            "iterations": int(found.group(1)) if found else -1,
            "cost": float(result.get_optimal_cost()), "ok": bool(result.is_success()),
            "status": exit_line.group(1).strip() if exit_line else "unknown"}


# workbench -----------------------------------------------------------------------------


def workbench_problem(*, cart_free: bool):
    """The same problem on the workbench: (OCP, transcription, guess, solve options)."""
    from problems import swingup_drake_reference as ref

    return ref.problem(cart_free=cart_free), ref.METHOD, ref.drake_guess, ref.SOLVE_OPTIONS


def workbench_solve(setup) -> dict:
    """One solve of the workbench's problem from Drake's guess (transcription built once)."""
    from workbench.control.ocp import solve

    ocp, method, guess, options = setup
    s = solve(ocp, method, guess=guess(ocp), raise_on_failure=False, **options)
    return {"side": "workbench", "cpu": s.cost["solve_cpu_seconds"],
            "wall": s.cost["solve_seconds"], "iterations": s.cost["iterations"],
            "cost": s.objective, "ok": s.status.ok, "status": s.ipopt_status,
            "build": s.cost["first_build_seconds"], "gauge": s.gauge}


def _median(rows, key):
    return statistics.median(r[key] for r in rows)


def main() -> None:
    quick = "--quick" in sys.argv
    repeat = 1 if quick else 3
    if "--repeat" in sys.argv:
        repeat = int(sys.argv[sys.argv.index("--repeat") + 1])
    have_drake = drake_available()
    plant = drake_plant() if have_drake else None
    rows = []
    for case in ("origin", "free"):
        free = case == "free"
        try:
            setup = workbench_problem(cart_free=free)
        except ImportError as exc:  # the workbench's side lands with its problem module
            print(f"workbench side unavailable ({exc}); Drake only")
            if have_drake:
                print(drake_solve(plant, cart_free=free))
            continue
        drake_runs, ours = [], []
        for _ in range(repeat):  # interleaved: drake, workbench, drake, workbench, ...
            if have_drake:
                drake_runs.append(drake_solve(plant, cart_free=free))
            ours.append(workbench_solve(setup))
        if have_drake:
            d = {"cpu": _median(drake_runs, "cpu"), "wall": _median(drake_runs, "wall"),
                 **{k: drake_runs[-1][k] for k in ("iterations", "cost", "status")},
                 "source": "measured"}
        else:
            d = dict(RECORDED[case], status="n/a", wall=float("nan"),
                     source="RECORDED (issue 17)")
            d["cpu"] = d.pop("cpu_seconds")
        w_cpu = _median(ours, "cpu")
        ratio = d["cpu"] / w_cpu
        rows.append({
            "case": f"cart {case}",
            "drake": d["source"],
            "drake cpu s": f"{d['cpu']:.3f}", "drake wall s": f"{d['wall']:.3f}",
            "drake it": d["iterations"], "drake cost": d["cost"] if d["cost"] is None
            else f"{d['cost']:.6f}", "drake status": d["status"],
            "ours cpu s": f"{w_cpu:.3f}", "ours wall s": f"{_median(ours, 'wall'):.3f}",
            "ours it": ours[-1]["iterations"], "ours cost": f"{ours[-1]['cost']:.6f}",
            "ours status": ours[-1]["status"], "ours build s": f"{ours[-1]['build']:.2f}",
            "ratio (cpu)": f"{ratio:.1f}",
            "target": f"{'met' if ratio >= TARGET_RATIO else 'MISSED'} (>= {TARGET_RATIO:g}x)",
        })
        if case == "origin":
            rows[-1]["target"] += (" cost ok" if ours[-1]["cost"] <= RECORDED["origin"]["cost"]
                                   else " COST ABOVE 5.2289")
    if not have_drake:
        print("drake not installed: Drake's figures below are the ones RECORDED in issue 17, "
              "not measured in this run (pip install 'geometric-pendulum-workbench[peers]')")
    cols = ["case", "drake", "drake cpu s", "drake wall s", "drake it", "drake cost",
            "drake status", "ours cpu s", "ours wall s", "ours it", "ours cost", "ours status",
            "ours build s", "ratio (cpu)", "target"]
    print(table(rows, cols))
    print(f"(CPU-time medians of {repeat} interleaved runs; building excluded on both sides; "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; gauge: "
          f"{ours[-1]['gauge']})")


if __name__ == "__main__":
    main()
