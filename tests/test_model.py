"""Model: parameter validation, lazy building with a build log, shared graphs, AD."""

from __future__ import annotations

import json

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from workbench.core._model import Evaluator, Model, Parameter, Symbolic
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import ProductManifold, Rn

BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": [0.0, 0.0, 0.3]}


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"J": np.array([[1, 0.5, 0], [0, 1, 0], [0, 0, 1.0]])},
         "symmetric positive definite.*non-symmetric"),
        ({"J": np.diag([3.0, 2.0, -1.0])}, r"symmetric positive definite; got eigenvalues \[-1\."),
        ({"J": [1.0, 2.0, 3.0]}, "3x3 matrix; got a 3-vector"),
        ({"rho": [0.0, 0.3]}, r"'rho'.*shape \(3,\); got shape \(2,\)"),
        ({"m": -1.0}, "'m'.*must be positive; got -1"),
        ({"g": 0.0}, "'g'.*must be positive"),
        ({"rho": [np.nan, 0, 0]}, "must be finite"),
    ],
)
def test_bad_parameters_are_named(kwargs, pattern):
    with pytest.raises(ParameterError, match=pattern):
        p3.full(**{**BODY, **kwargs})


def test_unknown_parameter_and_function_names():
    model = p3.full(**BODY)
    with pytest.raises(ParameterError, match="unknown parameter.*'mass'"):
        model.with_parameters(mass=2.0)
    with pytest.raises(ModelError, match="no function 'g'"):
        model.function("g")
    with pytest.raises(ModelError, match="u must have 3 entries"):
        model.rhs(model.state(R=np.eye(3), omega=np.zeros(3)), u=[1.0])


def test_nothing_is_built_until_asked_and_builds_are_logged_once():
    model = p3.full(**BODY)
    assert len(model.build_log) == 0
    model.function("f")
    model.function("f")
    assert model.build_log.names() == ["pendulum3d_full.f"]
    rec = model.build_log.records[0]
    assert rec.n_nodes == model.function("f").n_nodes()  # the log describes the cached graph
    model.function("energy")
    assert model.build_log.names() == ["pendulum3d_full.f", "pendulum3d_full.energy"]


def test_with_parameters_shares_graphs_and_changes_values():
    a = p3.full(**BODY)
    a.function("f")
    b = a.with_parameters(m=2.0)
    assert b.function("f") is a.function("f") and len(b.build_log) == 1
    x = a.state(R=np.eye(3), omega=[0.1, 0.2, 0.3])
    # gravity moment doubles with m at a tilted attitude
    R = p3.so3_exp([0.4, 0.0, 0.0])
    x = a.state(R=R, omega=np.zeros(3))
    assert_close(b.rhs(x)[9:], 2 * a.rhs(x)[9:], atol=1e-14, what="moment scales with m")
    assert a.values["m"] == 1.0


def test_frozen_function_agrees_and_is_smaller(rng):
    model = p3.full(**BODY)
    f, ff = model.function("f"), model.function("f", frozen=True)
    assert ff.n_in() == 2 and ff.n_nodes() < f.n_nodes()
    for _ in range(5):
        x = model.manifold.random_point(rng)
        u = rng.standard_normal(3)
        assert_close(np.asarray(ff(x, u)).ravel(), np.asarray(f(x, u, model.p)).ravel(),
                     atol=1e-14, what="frozen == parametric")


def test_jacobian_from_graph_matches_finite_differences(rng):
    model = p3.full(**{**BODY, "J": np.array([[0.3, 0.02, 0.01], [0.02, 0.2, 0.0],
                                              [0.01, 0.0, 0.25]])})
    fx = model.function("f_x")
    x = model.manifold.random_point(rng)
    u = rng.standard_normal(3)
    J = np.asarray(fx(x, u, model.p))
    h = 1e-6
    fd = np.column_stack([(model.rhs(x + h * e, u) - model.rhs(x - h * e, u)) / (2 * h)
                          for e in np.eye(12)])
    assert_close(J, fd, atol=1e-8, what="f_x vs central differences")


def test_evaluator_matches_plain_call(rng):
    model = p3.full(**BODY)
    ev = Evaluator(model.function("f"))
    for _ in range(3):
        x, u = model.manifold.random_point(rng), rng.standard_normal(3)
        assert_close(ev(x, u, model.p), model.rhs(x, u), atol=0, what="buffer evaluation")


# ----------------------------------------------------------------------------------------
# moved from test_review_engine.py


def _decay(symbolic):
    return Model(name="decay", manifold=ProductManifold([("x", Rn(2))]), n_inputs=0,
                 parameters=[Parameter("a", (), "rate [1/s]")], values={"a": 2.0},
                 vector_field=lambda ctx: -ctx["a"] * ctx["x"], symbolic=symbolic)


@pytest.mark.parametrize(("given", "member", "cls", "kind"), [
    (Symbolic.SX, Symbolic.SX, ca.SX, "SXFunction"), ("SX", Symbolic.SX, ca.SX, "SXFunction"),
    (Symbolic.MX, Symbolic.MX, ca.MX, "MXFunction"), ("MX", Symbolic.MX, ca.MX, "MXFunction"),
])
def test_model_symbolic_is_a_str_enum(given, member, cls, kind):
    model = _decay(given)
    assert model.symbolic is member and model.symbolic == member.value and model.sym is cls
    f = model.function("f")
    assert f.is_a(kind) and model.function("f", frozen=True).is_a(kind)
    assert_close(model.rhs([1.0, -3.0]), [-2.0, 6.0], atol=0, what="f = -a x")
    record = model.build_log.as_list()[0]
    assert json.loads(json.dumps(record))["symbolic"] == member.value
    assert f"{model.symbolic}" == member.value


def test_model_refuses_an_unknown_symbol_class():
    with pytest.raises(ModelError, match=r"symbolic must be one of \['SX', 'MX'\]; got 'QX'"):
        _decay("QX")


def test_model_spd_solves_is_a_declared_bool():
    assert _decay("SX").spd_solves is False  # nothing declared: solves replay as QR
    with pytest.raises(ModelError, match=r"spd_solves must be a bool; got 'yes'"):
        Model(name="decay", manifold=ProductManifold([("x", Rn(2))]), n_inputs=0,
              parameters=[Parameter("a", (), "rate [1/s]")], values={"a": 2.0},
              vector_field=lambda ctx: -ctx["a"] * ctx["x"], spd_solves="yes")
