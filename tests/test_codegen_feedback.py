"""One-call C export of a feedback designed in a session (workbench.codegen.export_feedback)."""

from __future__ import annotations

import re

import casadi as ca
import numpy as np
import pytest

from models.chain_cart import chain_cart, link_state
from workbench import ModelError, ParameterError, codegen, linearize, lqr


@pytest.fixture(scope="module")
def cart_lqr():
    cart = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    x_up = cart.state(x=[0, 0], v=[0, 0], link1=link_state([0.0, 0.0, -1.0]))
    k = lqr(linearize(cart, x_up), Q=np.eye(8), R=np.eye(2)).feedback(name="cart_lqr")
    return cart, x_up, k


def test_exported_lqr_law_agrees_with_casadi(cart_lqr, tmp_path):
    cart, x_up, k = cart_lqr
    out = codegen.export_feedback(cart, k, tmp_path / "c", name="cart_lqr",
                                  title="LQR of the cart pendulum */ #define X", example_state=x_up)
    assert {p.name for p in out.files} == {"cart_lqr.c", "cart_lqr.h", "main.c", "bench.c",
                                          "Makefile", ".workbench-export.json"}
    states = out.controller.sample_states(300, seed=3)
    assert np.allclose(states[0], x_up)  # the example state is among the test states
    gap = codegen.agreement(out.controller, out.compiled, states, binding=codegen.Binding.FROZEN)
    assert gap.max() < 1e-13
    header = (tmp_path / "c" / "cart_lqr.h").read_text()
    # the comment did not end early: the title's "*/" is broken (comment_text), so the
    # injected "#define X" stays inside the comment and no code outside comments has it
    code = re.sub(r"/\*.*?\*/", "", header, flags=re.S)
    assert "#define X" not in code and "*/ #define X" not in header
    assert "link1" in header and "cart position" not in header  # entries from the factors


def test_bad_feedbacks_are_refused_with_the_argument_named(cart_lqr, tmp_path):
    cart, x_up, k = cart_lqr
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", cart.n_params)
    wrong = ca.Function("wrong", [x, p], [x[0:2]])
    with pytest.raises(ModelError, match="function must map x"):
        codegen.feedback_controller(cart, wrong, name="w", title="t", example_state=x_up)
    with pytest.raises(ParameterError, match="name"):
        codegen.feedback_controller(cart, k, name="not an identifier", title="t",
                                    example_state=x_up)
    with pytest.raises(ParameterError, match="title"):
        codegen.feedback_controller(cart, k, name="ok", title="two\nlines", example_state=x_up)
    with pytest.raises(ModelError, match="casadi.Function"):
        codegen.feedback_controller(cart, lambda x, p: x, name="ok", title="t",
                                    example_state=x_up)


@pytest.mark.parametrize("name", ["int", "main", "bench", "sqrt", "_x", "a__b", "x" * 65])
def test_export_names_that_collide_in_c_are_refused(cart_lqr, tmp_path, name):
    """They failed inside casadi or as gcc errors; the message now names the argument."""
    from workbench.core.errors import ModelError

    cart, x_up, k = cart_lqr
    with pytest.raises(ModelError, match="C prefix of the export"):
        codegen.export_feedback(cart, k, tmp_path / "c", name=name, title="LQR",
                                example_state=x_up)
    assert not (tmp_path / "c").exists()
