"""Eigenstructure: classification, invariant subspaces, tolerances, ambient directions."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from models.controllers import so3_pd
from workbench.core.errors import ModelError
from workbench.core.manifolds import so3_exp
from workbench.linear._eigen import Stability, Subspace, default_tol, eigenstructure
from workbench.linear._linearize import linearize


def _similar(rng, D):
    T = rng.standard_normal(D.shape) + 2 * np.eye(D.shape[0])
    return T @ D @ np.linalg.inv(T)


@pytest.mark.parametrize(
    ("blocks", "stability", "dims"),
    [
        ([-1.0, -2.0, -3.0], Stability.STABLE_NODE, (3, 0, 0)),
        ([[-1.0, 2.0], -3.0], Stability.STABLE_FOCUS, (3, 0, 0)),
        ([1.0, 2.0], Stability.UNSTABLE_NODE, (0, 2, 0)),
        ([[0.5, 1.0]], Stability.UNSTABLE_FOCUS, (0, 2, 0)),
        ([-1.0, 2.0, 3.0], Stability.SADDLE, (1, 2, 0)),
        ([[0.0, 1.0], [0.0, 3.0]], Stability.CENTRE, (0, 0, 4)),
        ([-1.0, 1.0, [0.0, 2.0], 0.0], Stability.NONHYPERBOLIC, (1, 1, 3)),
    ],
)
def test_classification(rng, blocks, stability, dims):
    # real blocks: a number; complex pair [a, b]: a +- i b
    mats = []
    for b in blocks:
        if isinstance(b, list):
            mats.append(np.array([[b[0], b[1]], [-b[1], b[0]]]))
        else:
            mats.append(np.array([[b]]))
    n = sum(m.shape[0] for m in mats)
    D = np.zeros((n, n))
    k = 0
    for m in mats:
        D[k:k + m.shape[0], k:k + m.shape[0]] = m
        k += m.shape[0]
    es = eigenstructure(_similar(rng, D))
    assert es.stability is stability
    assert es.dims == dims
    assert es.residual < 1e-10


def test_invariant_subspaces_are_invariant_and_orthonormal(rng):
    A = _similar(rng, np.diag([-3.0, -1.0, 0.0, 2.0, 5.0]))
    es = eigenstructure(A)
    for which, ev in ((Subspace.STABLE, [-3, -1]), (Subspace.UNSTABLE, [2, 5]),
                      (Subspace.CENTRE, [0])):
        V = es.subspace(which)
        assert_close(V.T @ V, np.eye(V.shape[1]), atol=1e-12, what="orthonormal")
        # A V = V S: the restriction has exactly this part of the spectrum
        S = V.T @ A @ V
        assert_close(A @ V, V @ S, atol=1e-10, what=f"{which.value} invariant")
        assert_close(np.sort(np.linalg.eigvals(S).real), ev, atol=1e-10, what="spectrum")


def test_jordan_block_zero_counts_as_centre_with_the_default_tolerance(rng):
    J = np.array([[0.0, 1.0], [0.0, 0.0]])
    A = np.zeros((4, 4))
    A[:2, :2] = J
    A[2:, 2:] = [[-1.0, 0.0], [0.0, -2.0]]
    As = _similar(rng, A)
    es = eigenstructure(As)
    assert es.dims == (2, 0, 2)
    assert es.stability is Stability.NONHYPERBOLIC
    assert es.eigenvector_condition > 1e6  # the defective pair is flagged
    assert es.tol == default_tol(As)  # the tolerance used is reported
    # the computed zero pair spreads far beyond rounding (O(sqrt(eps))), which is why the
    # default tolerance is 1e-7 |A| and not a multiple of eps
    spread = np.max(np.abs(np.sort(np.abs(es.eigenvalues))[:2]))
    assert 1e-14 < spread < es.tol


def test_3d_pendulum_spectra_and_ambient_directions():
    body = {"J": np.diag([3.0, 2.0, 1.0]), "rho": [0.0, 0.0, 0.4], "m": 2.0, "g": 9.81}
    model = p3.full(**body)
    hang = eigenstructure(linearize(model, model.state(R=np.eye(3), omega=np.zeros(3))))
    assert hang.stability is Stability.CENTRE and hang.dims == (0, 0, 6)
    inv_x = model.state(R=so3_exp([np.pi, 0, 0]), omega=np.zeros(3))
    inv = eigenstructure(linearize(model, inv_x))
    assert inv.dims == (2, 2, 2)  # paper 000 after (3.28)
    assert "2 stable, 2 unstable, 2 centre" in inv.describe()
    # ambient directions are tangent to TSO(3) at the equilibrium
    lin = linearize(model, inv_x)
    for which in Subspace:
        W = inv.ambient(which)
        assert W.shape[0] == 12
        for col in W.T:
            assert model.manifold.factor("R").is_tangent(inv_x[:9], col[:9], tol=1e-12)
    with pytest.raises(ModelError, match="tangent basis"):
        eigenstructure(lin.A).ambient(Subspace.STABLE)


def test_so3_pd_classification_of_paper_002():
    model = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.1, -0.2, 0.3])
    k = so3_pd(model, np.eye(3), k_R=1.0, k_Omega=1.0, G=[0.9, 1.0, 1.1])
    results = []
    for R in (np.eye(3), so3_exp([np.pi, 0, 0]), so3_exp([0, np.pi, 0]),
              so3_exp([0, 0, np.pi])):
        es = eigenstructure(linearize(model, model.state(R=R, omega=np.zeros(3)),
                                      controller=k))
        results.append((es.stability, es.n_unstable))
    assert results == [(Stability.STABLE_FOCUS, 0), (Stability.SADDLE, 3),
                       (Stability.SADDLE, 2), (Stability.SADDLE, 1)]


def test_bad_input():
    with pytest.raises(ModelError, match="square"):
        eigenstructure(np.zeros((2, 3)))
    with pytest.raises(ModelError, match="tol must be a positive"):
        eigenstructure(np.eye(2), tol=-1.0)
    with pytest.raises(ModelError, match="basis must have 2 columns"):
        eigenstructure(np.eye(2), basis=np.eye(3))
