"""Classification of a stiff spectrum: a saddle beside a very fast oscillation.

A cart on a spring of stiffness ``k`` carries a pendulum linearised at its unstable
equilibrium. In the coordinates ``(x, th, v, w)`` (unit masses, ``l = 1``)

    A = [[0, 0, 1, 0], [0, 0, 0, 1], [-k, g, 0, 0], [-k, 2g, 0, 0]]

whose characteristic polynomial ``s^4 + (k - 2g) s^2 - k g`` gives ``s^2 = (2g - k +-
sqrt((k - 2g)^2 + 4kg)) / 2``: one real pair ``+-a``, ``a^2 = 2kg / (k - 2g + sqrt(..))``
(``a -> sqrt(g)`` as ``k`` grows), and one
imaginary pair. ``|A|_2`` grows like ``k``, the eigenvalues like ``sqrt(k)``: a tolerance
taken from ``|A|_2`` called the saddle's ``+-3.1`` a centre from ``k = 1e8``. The default
tolerance is taken from the balanced matrix, which is the scale of the computed
eigenvalues' errors.
"""

from __future__ import annotations

import numpy as np
import pytest

from workbench.linear import Stability, default_tol, eigenstructure

G = 9.81


def _stiff(k: float) -> np.ndarray:
    return np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0],
                     [-k, G, 0.0, 0.0], [-k, 2 * G, 0.0, 0.0]])


@pytest.mark.parametrize("k", [1e2, 1e6, 1e8, 1e10, 1e12, 1e14])
def test_a_saddle_beside_a_stiff_spring_is_not_a_centre(k):
    A = _stiff(k)
    es = eigenstructure(A)
    disc = np.sqrt((k - 2 * G) ** 2 + 4 * k * G)
    a = np.sqrt(2 * k * G / (k - 2 * G + disc))  # the real pair, without cancellation
    assert es.stability is Stability.NONHYPERBOLIC
    assert (es.stable_basis.shape[1], es.unstable_basis.shape[1],
            es.centre_basis.shape[1]) == (1, 1, 2)
    assert es.tol < 0.5 * a  # the tolerance stays below the saddle's rate
    real = es.eigenvalues[np.abs(es.eigenvalues.imag) == 0].real
    assert np.allclose(np.sort(real), [-a, a], rtol=1e-6)
    for basis in (es.stable_basis, es.unstable_basis, es.centre_basis):
        # orthonormal, and invariant to backward-stable rounding, eps |A|_2
        assert np.allclose(basis.T @ basis, np.eye(basis.shape[1]), atol=1e-12)
        image = A @ basis
        rest = image - basis @ (basis.T @ image)
        assert np.linalg.norm(rest) <= 16 * np.finfo(float).eps * np.linalg.norm(A, 2)
    assert es.tol == default_tol(A)


def test_the_balanced_tolerance_is_the_plain_one_for_a_balanced_matrix():
    rng = np.random.default_rng(3)
    Q, _ = np.linalg.qr(rng.standard_normal((6, 6)))
    A = Q @ np.diag([-2.0, -1.0, 0.5, 1.0, 3.0, 4.0]) @ Q.T  # symmetric: balancing is a no-op
    assert default_tol(A) == pytest.approx(1e-7 * np.linalg.norm(A, 2), rel=1e-12)


def test_time_scales_further_apart_than_the_tolerance_are_said_not_hidden():
    """A slow saddle (rate 1e-3) beside a fast one (1e5): within the default tolerance."""
    A = np.zeros((4, 4))
    A[0, 1], A[1, 0], A[2, 3], A[3, 2] = 1.0, 1e10, 1.0, 1e-6  # +-1e5 and +-1e-3 exactly
    with pytest.warns(UserWarning, match="resolved beyond rounding"):
        es = eigenstructure(A)
    assert es.dims == (1, 1, 2)  # the tolerance's classification, as documented
    assert np.allclose(np.sort(es.resolved_in_tol.real), [-1e-3, 1e-3], rtol=1e-9)
    assert eigenstructure(A, tol=1e-6).dims == (2, 2, 0)  # the advice classifies them


def test_a_jordan_block_and_a_centre_are_not_flagged(recwarn):
    jordan = eigenstructure(np.array([[0.0, 1.0], [0.0, 0.0]]))
    centre = eigenstructure(np.array([[0.0, 1.0], [-4.0, 0.0]]))
    assert jordan.dims == (0, 0, 2) and centre.dims == (0, 0, 2)
    assert jordan.resolved_in_tol.size == 0 and centre.resolved_in_tol.size == 0
    assert not [w for w in recwarn if "resolved beyond rounding" in str(w.message)]
