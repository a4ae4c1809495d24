"""Drake's side of the swing-up comparison (optional peer: ``pip install '...[peers]'``).

Drake has no S^2: the pendulum is a UniversalJoint (two angles) on a cart moved by two
prismatic joints, in a MultibodyPlant (z up). ``pydrake.planning.DirectCollocation``
transcribes it (Hermite-Simpson, first-order-hold controls, trapezoidal running cost) and
Drake's ``IpoptSolver`` solves it with its default options (a limited-memory Hessian:
Drake gives Ipopt no second derivatives). The iteration count is read from Ipopt's output
file; CPU seconds are ``time.process_time`` around ``Solve``. :func:`to_workbench` maps
Drake's knots to the workbench's state (e3 down: the frame rotated by pi about x).
Shared by ``problems/swingup_drake_reference.py`` and
``benchmarks/bench_drake_swingup.py``; nothing here installs anything.
"""

from __future__ import annotations

import os
import re
import tempfile
import time
from pathlib import Path

import numpy as np

RECORDED = {
    "origin": {"cpu_seconds": 11.1, "iterations": 108, "cost": 5.228900},
    "free": {"cpu_seconds": 14.6, "iterations": 127, "cost": 5.178014},
}
"""Drake 1.51.1's IpoptSolver on :func:`drake_program`, measured on this machine class (2
shared cores, load ~4, 2026-11-27); quoted, labelled as recorded, where Drake is not run."""

KNOTS = 41
U_MAX = 10.0
T_RANGE = (0.5, 3.0)
T_GUESS = 1.5
L, M_TIP, M_CART, G = 0.1, 0.1, 0.5, 9.81
FLIP = np.diag([1.0, -1.0, -1.0])
"""Drake's frame (z up) to the workbench's (e3 down): a rotation by pi about x."""


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
    """Drake's DirectCollocation of the swing-up, written as Drake's docs write one.

    ``DirectCollocation(plant, context, num_time_samples=41, ...)`` with equal time
    intervals and the duration bounds, bounding boxes on the inputs at every knot and on the
    boundary states, ``AddRunningCost(u . u)`` and ``AddFinalCost(T)``, and the straight
    swing over 1.5 s as the initial trajectory (state: x, y, the universal joint's angles,
    their rates).
    """
    from pydrake.planning import DirectCollocation
    from pydrake.trajectories import PiecewisePolynomial

    n = KNOTS - 1
    dc = DirectCollocation(plant, plant.CreateDefaultContext(), num_time_samples=KNOTS,
                           minimum_time_step=T_RANGE[0] / n, maximum_time_step=T_RANGE[1] / n,
                           input_port_index=plant.get_actuation_input_port().get_index())
    dc.AddEqualTimeIntervalsConstraints()
    dc.AddDurationBounds(*T_RANGE)
    prog = dc.prog()
    for k in range(KNOTS):
        prog.AddBoundingBoxConstraint(-U_MAX, U_MAX, dc.input(k))
    x0 = np.zeros(8)
    xf = np.array([0.0, 0.0, np.pi, 0.0, 0.0, 0.0, 0.0, 0.0])  # upright: pi about x
    prog.AddBoundingBoxConstraint(x0, x0, dc.initial_state())
    k = 2 if cart_free else 0
    prog.AddBoundingBoxConstraint(xf[k:], xf[k:], dc.final_state()[k:])
    u = dc.input()
    dc.AddRunningCost(u.dot(u))
    dc.AddFinalCost(dc.time())
    dc.SetInitialTrajectory(
        PiecewisePolynomial.FirstOrderHold([0.0, T_GUESS], np.zeros((2, 2))),
        PiecewisePolynomial.FirstOrderHold([0.0, T_GUESS], np.column_stack([x0, xf])))
    return dc


def drake_solve(plant, *, cart_free: bool, count_iterations: bool = True) -> dict:
    """Build Drake's program, solve it with Drake's IpoptSolver; CPU and wall seconds.

    With ``count_iterations`` the only options given are Ipopt's ``output_file`` and
    ``file_print_level`` 3, from which the iteration count is read (Drake's result does not
    report it); without, the solver runs with no options at all. The benchmark times both:
    the log costs nothing measurable.
    """
    from pydrake.solvers import IpoptSolver, SolverOptions

    dc = drake_program(plant, cart_free=cart_free)
    options, log = SolverOptions(), None
    if count_iterations:
        fd, log = tempfile.mkstemp(suffix=".ipopt.txt")
        os.close(fd)
        options.SetOption(IpoptSolver.id(), "output_file", log)
        options.SetOption(IpoptSolver.id(), "file_print_level", 3)
    solver = IpoptSolver()
    c0, t0 = time.process_time(), time.perf_counter()
    result = solver.Solve(dc.prog(), None, options)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    iterations, status = -1, str(result.get_solution_result())
    if log is not None:
        text = Path(log).read_text()
        os.unlink(log)
        found = re.search(r"Number of Iterations\.+:\s*(\d+)", text)
        exit_line = re.search(r"EXIT: (.*)", text)
        iterations = int(found.group(1)) if found else -1
        status = exit_line.group(1).strip() if exit_line else status
    return {"side": "drake", "cpu": cpu, "wall": wall, "iterations": iterations,
            "cost": float(result.get_optimal_cost()), "ok": bool(result.is_success()),
            "status": status,
            "t": dc.GetSampleTimes(result), "x": dc.GetStateSamples(result).T,
            "u": dc.GetInputSamples(result).T}


def to_workbench(t: np.ndarray, X: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, ...]:
    """Drake's knots (x, y, angles, rates) as workbench states (x, v, q, omega), inputs."""
    out = []
    for row in X:
        th, dth = row[2:4], row[6:8]
        q, J = _direction(th), np.zeros((3, 2))
        for j in range(2):  # dq/dtheta_j by central differences (exact to ~1e-10)
            e = np.eye(2)[j] * 1e-6
            J[:, j] = (_direction(th + e) - _direction(th - e)) / 2e-6
        qdot = J @ dth
        out.append(np.r_[row[0], -row[1], row[4], -row[5], q, np.cross(q, qdot)])
    return t, np.array(out), U * np.array([1.0, -1.0])


def _direction(th: np.ndarray) -> np.ndarray:
    """Unit vector cart -> bob in the workbench frame for Drake's universal-joint angles."""
    c1, s1, c2, s2 = np.cos(th[0]), np.sin(th[0]), np.cos(th[1]), np.sin(th[1])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, c1, -s1], [0.0, s1, c1]])
    Ry = np.array([[c2, 0.0, s2], [0.0, 1.0, 0.0], [-s2, 0.0, c2]])
    return FLIP @ Rx @ Ry @ np.array([0.0, 0.0, -1.0])
