"""The system builder: declare a mechanical system, get an ordinary Model.

Declare factors, parameters, inputs, bodies, energies and loads; :meth:`System.model`
returns a :class:`workbench.Model` whose equations of motion are derived by AD.

Example: a planar cart (R^2) carrying a spherical pendulum (S^2)::

    s = System("cart_pendulum")
    cart = s.rn("x", 2, velocity="v")
    link = s.s2("link")
    M, m, l, g = (s.parameter(k, v) for k, v in [("M", 0.5), ("m", 0.1), ("l", 0.3),
                                                   ("g", 9.81)])
    pivot = ca.vertcat(cart.x, 0)
    s.point_mass(M, pivot, name="cart")
    s.point_mass(m, pivot + l * link.q, name="bob")
    s.gravity(g)                       # along +e3: e3 points down
    s.force(cart, s.input(2, "horizontal force on the cart [N]"))
    model = s.model()
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics import _forces as F
from workbench.mechanics._bodies import PointMass, RigidBody
from workbench.mechanics._checks import (
    as_expr,
    as_number_array,
    check_inertia_value,
    check_origin_inertia,
    named_check,
    one_line,
    parameter_value,
)
from workbench.mechanics._checks import identifier as _name
from workbench.mechanics._engine import (
    MAX_DIM,
    ModelError,
    Parameter,
    ParameterError,
    finite,
)
from workbench.mechanics._factors import Factor, RnFactor, S1Factor, S2Factor, SO3Factor
from workbench.mechanics._model import build_model
from workbench.mechanics._momenta import Momenta
from workbench.mechanics._symbols import CONFIG, INPUT, PARAMETER, VELOCITY, SymbolTable
from workbench.mechanics._symmetry import configuration_action

__all__ = ["System", "E3"]

E3 = np.array([0.0, 0.0, 1.0])
"""The vertical, pointing *down* along gravity (the workbench's convention)."""

_Check = Callable[[np.ndarray], "str | None"]


def _velocity_name(name: Any, velocity: Any, suffix: str) -> str:
    """The storage name of a factor's velocity: ``velocity``, checked, or ``name + suffix``."""
    if velocity is None:
        return f"{_name(name, 'factor name')}{suffix}"
    return _name(velocity, f"velocity (the storage name of factor {name!r}'s velocity)")


class System(Momenta):
    """A mechanical system on a product of R^k, S^1, S^2 and SO(3), built declaratively.

    Parameters
    ----------
    name : str
        The model's name.

    Notes
    -----
    Symbols handed out (factors' configurations and velocities, parameters, inputs) are
    casadi ``SX``; write positions, attitudes, energies and loads as expressions of them.
    """

    def __init__(self, name: str) -> None:
        self.name = _name(name, "name")
        self.symbols = SymbolTable()
        self.factors: list[Factor] = []
        self._storage: set[str] = set()
        self.parameters: list[Parameter] = []
        self.values: dict[str, np.ndarray] = {}
        self._p: list[ca.SX] = []
        self._u: list[ca.SX] = []
        self._u_desc: list[str] = []
        self.kinetic_terms: list[ca.SX] = []
        self.potential_terms: list[ca.SX] = []
        self.dissipation_terms: list[ca.SX] = []
        self.bodies: list[PointMass | RigidBody] = []
        self.loads: list[F.Load] = []
        self.momenta: dict[str, dict[int, ca.SX]] = {}
        self._gravity: list[tuple[ca.SX, ca.SX]] = []

    # factors ------------------------------------------------------------------------------
    def _claim(self, *names: str) -> None:
        if len(set(names)) != len(names):
            raise ModelError(f"a factor's position and velocity need different names; got "
                             f"{list(names)}")
        for n in names:
            _name(n, "factor name")
            if n in self._storage:
                raise ModelError(f"factor name {n!r} is already used in system {self.name!r}")
            if any(b.name == n for b in self.bodies):
                raise ModelError(f"factor name {n!r} is already the name of a body in system "
                                 f"{self.name!r}; factors and bodies share one namespace (a "
                                 "load such as moment(name, ...) must resolve one of them)")
        self._storage.update(names)

    def rn(self, name: str, k: int, *, velocity: str | None = None) -> RnFactor:
        """Add an R^k factor: position ``x`` and velocity ``v``, ``x-dot = v``.

        Parameters
        ----------
        name : str
            Storage name of the position.
        k : int
            Dimension, >= 1.
        velocity : str, optional
            Storage name of the velocity (default ``name + "_dot"``).

        Returns
        -------
        RnFactor
            With symbols ``.x`` and ``.v``, shape=(k, 1).
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= MAX_DIM:
            raise ModelError(f"k (dimension of R^k factor {name!r}) must be an integer in "
                             f"[1, {MAX_DIM}]; got {k!r}")
        vname = _velocity_name(name, velocity, "_dot")
        self._claim(name, vname)
        f = RnFactor(name, self.symbols.new(f"{name}#c", int(k), CONFIG, name),
                     self.symbols.new(f"{name}#v", int(k), VELOCITY, vname), vname)
        self.factors.append(f)
        return f

    def s1(self, name: str, *, velocity: str | None = None) -> S1Factor:
        """Add an S^1 factor, an angle: ``p = (cos theta, sin theta)`` and its rate.

        No angle is stored (no wrapping, no singular coordinate): write positions with
        ``.cos``, ``.sin`` (or ``.p``), energies with ``.rate``. ``model.state(name=0.3)``
        takes the angle in radians, or ``(cos, sin)``.

        Parameters
        ----------
        name : str
            Storage name of the unit vector ``p`` (an S1 factor, 2 numbers).
        velocity : str, optional
            Storage name of the rate theta-dot (an Rn(1) factor; default ``name + "_dot"``).

        Returns
        -------
        S1Factor
            With symbols ``.p``, ``.perp`` (2x1), ``.cos``, ``.sin``, ``.rate`` (1x1) and
            ``.p_dot = rate * perp``; ``p-dot = theta-dot (-sin theta, cos theta)``.
        """
        vname = _velocity_name(name, velocity, "_dot")
        self._claim(name, vname)
        f = S1Factor(name, self.symbols.new(f"{name}#p", 2, CONFIG, name),
                     self.symbols.new(f"{name}#v", 1, VELOCITY, vname), vname)
        self.factors.append(f)
        return f

    def s2(self, name: str) -> S2Factor:
        """Add an S^2 factor: direction ``q`` and angular velocity ``omega`` (one TS2 factor).

        Parameters
        ----------
        name : str
            Storage name of the TS2 factor ``(q, omega)``.

        Returns
        -------
        S2Factor
            With symbols ``.q`` and ``.omega``, shape=(3, 1).
        """
        self._claim(name)
        f = S2Factor(name, self.symbols.new(f"{name}#q", 3, CONFIG, name),
                     self.symbols.new(f"{name}#w", 3, VELOCITY, f"omega of {name}"))
        self.factors.append(f)
        return f

    def so3(self, name: str, *, velocity: str | None = None) -> SO3Factor:
        """Add an SO(3) factor: attitude ``R`` and body angular velocity ``Omega``.

        Parameters
        ----------
        name : str
            Storage name of the rotation (9 numbers, column by column).
        velocity : str, optional
            Storage name of the body angular velocity (default ``name + "_omega"``).

        Returns
        -------
        SO3Factor
            With symbols ``.R`` (3x3) and ``.Omega`` (3x1), ``R-dot = R hat(Omega)``.
        """
        vname = _velocity_name(name, velocity, "_omega")
        self._claim(name, vname)
        f = SO3Factor(name, self.symbols.new(f"{name}#R", 9, CONFIG, name),
                      self.symbols.new(f"{name}#W", 3, VELOCITY, vname), vname)
        self.factors.append(f)
        return f

    def _factor_or_none(self, ref: Any) -> Factor | None:
        return next((f for f in self.factors if f is ref or f.name == ref), None)

    def factor(self, ref: Factor | str) -> Factor:
        """A factor of this system by object or name; ModelError for unknown ones."""
        for f in self.factors:
            if f is ref or f.name == ref:
                return f
        known = [f.name for f in self.factors]
        raise ModelError(f"unknown factor {getattr(ref, 'name', ref)!r} of system "
                         f"{self.name!r}; known: {known}")

    # parameters and inputs ---------------------------------------------------------------
    def parameter(self, name: str, value: Any, description: str = "", *,
                  check: _Check | None = finite, shape: tuple[int, ...] | None = None) -> ca.SX:
        """Declare a parameter; its symbol is an input of every function of the model.

        Parameters
        ----------
        name : str
            Identifier.
        value : float or array-like, shape=() or (n,) or (r, c)
            Its value (validated now: real, finite, and by ``check``).
        description : str
            What it is, with its unit.
        check : callable, optional
            ``check(value) -> message or None`` (e.g. ``workbench.core.positive``,
            :func:`workbench.mechanics.inertia`). A check that raises, or returns anything
            but a str or None, is reported as a ParameterError naming this parameter (here
            and in every ``Model.with_parameters``).
        shape : tuple of int, optional
            The shape ``value`` must have (default: whatever it has).

        Returns
        -------
        casadi.SX
            Shape ``(1, 1)``, ``(n, 1)`` or ``(r, c)``.
        """
        _name(name, "parameter name")
        if name in self.values:
            raise ModelError(f"parameter {name!r} is declared twice in system {self.name!r}")
        arr = parameter_value(name, value, description, check=check, shape=shape)
        par = Parameter(name, tuple(arr.shape), description or name, named_check(name, check))
        self.values[name] = par.validate(arr)
        self.parameters.append(par)
        flat = self.symbols.new(f"{name}#p", par.size, PARAMETER, name)
        self._p.append(flat)
        if arr.ndim == 2:
            return ca.reshape(flat, arr.shape[1], arr.shape[0]).T  # row-major storage
        return flat

    def inertia(self, name: str, value: Any, description: str = "") -> ca.SX:
        """Declare a 3x3 inertia parameter checked for SPD and the triangle inequality."""
        from workbench.mechanics._checks import inertia

        check_inertia_value(value, f"parameter {name!r}")
        return self.parameter(name, value, description or f"inertia {name} [kg m^2]",
                              check=inertia)

    def input(self, n: int, description: str = "") -> ca.SX:
        """Declare ``n`` more inputs (appended to ``u``, in call order); their symbols.

        Parameters
        ----------
        n : int
            How many, in ``[1, MAX_DIM]``.
        description : str
            What they are, with units: one line of text (it goes into the model's
            ``input_description``, reports and exported headers).

        Returns
        -------
        casadi.SX, shape=(n, 1)
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_DIM:
            raise ModelError(f"n (number of inputs) must be an integer in [1, {MAX_DIM}]; got "
                             f"{n!r}")
        one_line(description, "description (of the inputs)")
        k = sum(s.shape[0] for s in self._u)
        sym = self.symbols.new(f"u#{k}", int(n), INPUT, description or f"u[{k}:{k + n}]")
        self._u.append(sym)
        if description:
            self._u_desc.append(description)
        return sym

    # energies ------------------------------------------------------------------------------
    def _scalar(self, value: Any, what: str, allowed: tuple[str, ...], hint: str = "") -> ca.SX:
        expr = as_expr(value, what, (1, 1))
        self.symbols.require(expr, what, allowed, hint)
        return expr

    def kinetic(self, T: Any) -> None:
        """Add a kinetic energy written directly, ``T(configuration, velocities)``."""
        self.kinetic_terms.append(self._scalar(T, "kinetic energy T", (CONFIG, VELOCITY,
                                                                        PARAMETER)))

    def potential(self, V: Any) -> None:
        """Add a potential energy ``V(configuration)``."""
        self.potential_terms.append(self._scalar(V, "potential energy V", (CONFIG, PARAMETER),
                                                 "a potential depends on the configuration"))

    def dissipation(self, D: Any) -> None:
        """Add a Rayleigh dissipation function ``D(configuration, velocities) >= 0``.

        The generalised force is ``-dD/dnu``; for ``D`` quadratic in the velocities the
        dissipated power is ``2 D``.
        """
        self.dissipation_terms.append(self._scalar(D, "dissipation D", (CONFIG, VELOCITY,
                                                                         PARAMETER)))

    def _mass(self, mass: Any, what: str) -> ca.SX:
        if not isinstance(mass, (ca.SX, ca.MX)):
            m = as_number_array(mass, what)
            if m.shape != () or m <= 0:
                raise ParameterError(f"{what} must be a positive scalar; got {mass!r}")
        return self._scalar(mass, what, (PARAMETER,))

    def _position(self, p: Any, what: str) -> ca.SX:
        expr = as_expr(p, what)
        if expr.shape[1] != 1 or not 1 <= expr.shape[0] <= 3:
            raise ModelError(f"{what} must be a column of 1 to 3 coordinates; got shape "
                             f"{expr.shape}")
        self.symbols.require(expr, what, (CONFIG, PARAMETER),
                             "positions are functions of the configuration only")
        return expr

    def _body_name(self, name: str | None, kind: str) -> str:
        name = name if name is not None else f"{kind}{len(self.bodies) + 1}"
        _name(name, "body name")
        if any(b.name == name for b in self.bodies):
            raise ModelError(f"body name {name!r} is already used in system {self.name!r}")
        if name in self._storage:
            raise ModelError(f"body name {name!r} is already the name of a factor (or its "
                             f"velocity) in system {self.name!r}; factors and bodies share one "
                             "namespace (a load such as moment(name, ...) must resolve one of "
                             "them): give the body another name")
        return name

    def point_mass(self, mass: Any, position: Any, *, name: str | None = None) -> PointMass:
        """Add a point mass ``mass`` at ``position(configuration)`` (world frame)."""
        body = PointMass(self._body_name(name, "point"), self._mass(mass, "mass"),
                         self._position(position, "position"))
        self.bodies.append(body)
        return body

    def rigid_body(self, mass: Any, inertia: Any, attitude: SO3Factor | Any, *,
                   origin: Any = (0.0, 0.0, 0.0), com: Any = (0.0, 0.0, 0.0),
                   inertia_about: str = "com", name: str | None = None) -> RigidBody:
        """Add a rigid body.

        Parameters
        ----------
        mass : float or casadi.SX
            Mass (an expression of parameters).
        inertia : array-like or casadi.SX, shape=(3, 3)
            Inertia in the body frame, about the centre of mass (``inertia_about="com"``)
            or about ``origin`` (``"origin"``; parallel-axis theorem applied). About the
            origin, the inertia about the centre of mass it implies,
            ``J_com = J_O - m (|c|^2 I - c c^T)``, is checked too (symmetric positive
            semi-definite, triangle inequality): here when all three are numbers; at build
            (and ``with_parameters``) when they are parameters and ``J_com`` enters the
            kinetic energy, i.e. unless the body is on a fixed pivot of an SO(3) factor
            (its energy is then written about the pivot with ``J_O`` alone, and models such
            as the papers' 3D pendulum take ``J_O``, ``m``, ``c`` as independent).
        attitude : SO3Factor or casadi.SX, shape=(3, 3)
            Rotation body -> world: a factor, or an expression of the configuration.
        origin : array-like or casadi.SX, shape=(3,)
            World position of the body's reference point (a pivot), default 0.
        com : array-like or casadi.SX, shape=(3,)
            Centre of mass relative to ``origin``, body frame, default 0.
        inertia_about : {"com", "origin"}
            Where ``inertia`` is taken.
        name : str, optional
            The body's name.

        Returns
        -------
        RigidBody
        """
        if inertia_about not in ("com", "origin"):
            raise ModelError(f"inertia_about must be 'com' or 'origin'; got {inertia_about!r}")
        body_name = self._body_name(name, "body")
        m = self._mass(mass, "mass")
        if not isinstance(inertia, (ca.SX, ca.MX)):
            check_inertia_value(inertia, "inertia")
        J = as_expr(inertia, "inertia", (3, 3))
        self.symbols.require(J, "inertia", (PARAMETER,))
        factor = attitude if isinstance(attitude, SO3Factor) else None
        if factor is not None:
            self.factor(factor)
        R = factor.R if factor is not None else as_expr(attitude, "attitude", (3, 3))
        self.symbols.require(R, "attitude", (CONFIG, PARAMETER),
                             "an attitude is a function of the configuration only")
        p0 = as_expr(origin, "origin", (3, 1))
        self.symbols.require(p0, "origin", (CONFIG, PARAMETER),
                             "positions are functions of the configuration only")
        rho = as_expr(com, "com", (3, 1))
        self.symbols.require(rho, "com", (PARAMETER,))
        J_O = J if inertia_about == "origin" else None
        if inertia_about == "origin":
            if J.is_constant() and m.is_constant() and rho.is_constant():
                msg = check_origin_inertia(np.asarray(ca.DM(J)), float(ca.DM(m)),
                                           np.asarray(ca.DM(rho)).ravel())
                if msg:
                    raise ParameterError(f"rigid body {body_name!r}: inertia (about the "
                                         f"origin): {msg}")
            J = J - m * (ca.dot(rho, rho) * ca.SX.eye(3) - rho @ rho.T)
        body = RigidBody(body_name, m, J, R, factor, p0, rho, J_O)
        self.bodies.append(body)
        return body

    def gravity(self, g: Any, direction: Any = E3) -> None:
        """Uniform gravity ``g`` along ``direction`` on every body (declared before or after).

        Declared once per system (a second call is refused rather than adding a second
        field).

        Parameters
        ----------
        g : float or casadi.SX
            Gravitational acceleration [m/s^2].
        direction : array-like or casadi.SX of parameters, shape=(d,)
            Unit vector along which gravity pulls (default ``e3``: e3 points down); its
            length must match the bodies' positions. An expression of parameters is checked
            for unit length with the parameter values when the model is built (and by
            ``Model.with_parameters``).
        """
        if self._gravity:
            raise ModelError(f"gravity is declared once per system; system {self.name!r} has "
                             "it already (a second call would add a second field; write other "
                             "uniform fields with potential())")
        gg = self._scalar(g, "g", (PARAMETER,))
        if not isinstance(direction, (ca.SX, ca.MX)):
            d = as_number_array(direction, "direction").ravel()
            if d.size not in (1, 2, 3) or abs(np.linalg.norm(d) - 1) > 1e-12:
                raise ParameterError(f"direction must be a unit vector of 1 to 3 entries; got "
                                     f"{direction!r}")
        dexpr = as_expr(direction, "direction")
        if dexpr.shape[1] != 1 or dexpr.shape[0] not in (1, 2, 3):
            raise ModelError(f"direction must be a vector of 1 to 3 entries; got shape "
                             f"{dexpr.shape}")
        # an expression of parameters: its length is checked with the values, at build
        self.symbols.require(dexpr, "direction", (PARAMETER,))
        self._gravity.append((gg, dexpr))

    # loads ---------------------------------------------------------------------------------
    def _load_value(self, value: Any, what: str, n: int) -> ca.SX:
        expr = as_expr(value, what, (n, 1))
        self.symbols.kinds(expr, what)
        return expr

    def force(self, factor: RnFactor | str, value: Any) -> None:
        """A generalised force on the coordinates of an R^k factor (virtual work F . dx)."""
        f = self.factor(factor)
        if not isinstance(f, RnFactor):
            raise ModelError(f"force(...) acts on R^k factors; {f.name!r} is {f.kind} (use "
                             "moment(...) or force_at(...))")
        self.loads.append(F.coordinate_force(f"force on {f.name}", f.x,
                                             self._load_value(value, "force", f.dim)))

    def force_at(self, point: Any, value: Any, *, body: RigidBody | str | None = None) -> None:
        """A force applied at ``point(configuration)``: world frame, or body frame of ``body``.

        Parameters
        ----------
        point : casadi.SX, shape=(d, 1)
            Where it acts (world position, an expression of the configuration).
        value : casadi.SX or array-like, shape=(d,)
            The force (may depend on state, velocities, inputs, parameters).
        body : RigidBody or str, optional
            When given, ``value`` is in this body's frame.
        """
        p = self._position(point, "point")
        R = None
        if body is not None:
            R = self._rigid(body).attitude
            if p.shape[0] != 3:
                raise ModelError(f"force_at with body= needs a 3-vector point (the body frame "
                                 f"is 3-D); got a point of {p.shape[0]} entries")
        self.loads.append(F.force_at("force", p, self._load_value(value, "force", p.shape[0]),
                                     R))

    def _rigid(self, ref: RigidBody | str) -> RigidBody:
        for b in self.bodies:
            if isinstance(b, RigidBody) and (b is ref or b.name == ref):
                return b
        known = [b.name for b in self.bodies if isinstance(b, RigidBody)]
        raise ModelError(f"unknown rigid body {getattr(ref, 'name', ref)!r}; known: {known}")

    def moment(self, target: RigidBody | SO3Factor | S2Factor | S1Factor | str,
               value: Any) -> None:
        """A moment: body frame on a rigid body or SO(3) factor, world frame on an S^2 factor.

        On an S^2 factor (a link about its pivot) only the part normal to ``q`` acts. On an
        S^1 factor (a revolute joint) ``value`` is a scalar torque about the joint, its
        virtual work ``value * delta theta`` (a motor at the joint). A name resolves to one
        thing: factors and bodies share one namespace (a body cannot take a factor's name,
        nor a factor a body's).
        """
        f = self._factor_or_none(target)
        if isinstance(f, S1Factor):
            self.loads.append(F.angle_torque(f"torque on {f.name}", f.p,
                                             self._load_value(value, "moment", 1)))
            return
        M = self._load_value(value, "moment", 3)
        if isinstance(target, RigidBody) or (isinstance(target, str) and any(
                b.name == target for b in self.bodies)):
            self.loads.append(F.body_moment("moment", self._rigid(target).attitude, M))
            return
        f = self.factor(target)
        if isinstance(f, SO3Factor):
            self.loads.append(F.body_moment(f"moment on {f.name}", f.R, M))
        elif isinstance(f, S2Factor):
            self.loads.append(F.sphere_moment(f"moment on {f.name}", f.q, M))
        else:
            raise ModelError(f"moment(...) acts on S^2 or SO(3) factors, S^1 angles (a torque) "
                             f"or rigid bodies; {f.name!r} is {f.kind} (use force(...))")

    # the model -----------------------------------------------------------------------------
    def model(self, name: str | None = None, *, symbolic: str = "auto",
              linear_solver: str = "lapacklu", check: bool = True, description: str = "",
              equations: Sequence[str] = (), input_description: str = "") -> Any:
        """The :class:`workbench.Model` of this system (equations derived by AD).

        Parameters
        ----------
        name : str, optional
            Model name (default the system's).
        symbolic : {"auto", "SX", "MX"}
            Graph class: SX solves symbolically (compact for a few velocities), MX with a
            numeric linear solve and an implicit-function Jacobian; "auto" takes SX up to
            9 velocity coordinates.
        linear_solver : str
            casadi linsol plugin of the MX solve (``"lapacklu"``, ``"ldl"``, ``"qr"``...).
        check : bool
            Check at a seeded random state that the kinetic energy is positive definite on
            the tangent velocities and that every declared momentum is conserved.
        description, equations, input_description
            As in :class:`workbench.Model` (generated when empty).

        Returns
        -------
        workbench.Model
            With ``model.symmetry_actions``: for each momentum, a casadi.Function
            ``(x, p) -> delta x``, the infinitesimal action of its symmetry on the
            configuration (velocities zero: exact at states at rest), used by
            :func:`workbench.linear.symmetry_directions`.
        """
        if name is not None:
            _name(name, "model name")
        if not isinstance(check, bool):
            raise ModelError(f"check must be True or False; got {check!r}")
        model = build_model(self, name or self.name, symbolic=symbolic,
                            linear_solver=linear_solver, check=check, description=description,
                            equations=equations, input_description=input_description)
        model.symmetry_actions = {k: configuration_action(model.mechanics, k, g)
                                  for k, g in self.momenta.items()}
        return model

    # pieces for the model builder -------------------------------------------------------------
    def stacked_parameters(self) -> ca.SX:
        """All parameter symbols in storage order."""
        return ca.vertcat(*self._p) if self._p else ca.SX(0, 1)

    def stacked_inputs(self) -> ca.SX:
        """All input symbols in declaration order."""
        return ca.vertcat(*self._u) if self._u else ca.SX(0, 1)

    def input_descriptions(self) -> list[str]:
        """The descriptions given to :meth:`input`."""
        return list(self._u_desc)

    def total_potential(self) -> ca.SX:
        """Declared potentials plus gravity on every body."""
        V = ca.SX(0)
        for term in self.potential_terms:
            V = V + term
        for g, d in self._gravity:
            for b in self.bodies:
                if b.com.shape[0] != d.shape[0]:
                    raise ModelError(
                        f"gravity direction has {d.shape[0]} entries but body {b.name!r} is at "
                        f"a position of {b.com.shape[0]}; give positions and direction alike")
            V = V + F.gravity_potential(self.bodies, g, d)
        return V
