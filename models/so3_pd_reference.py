"""What paper 002 prints for geometric PD control on SO(3): independent references.

Section III-C and (17)-(19) print the closed-loop eigenvalues (four decimals) and
eigenvectors ``v = e_j + lambda e_{j+3}`` of the 3D pendulum with J = diag(3, 2, 1) under
the PD law with G = diag(0.9, 1, 1.1), k_R = k_Omega = 1, at the desired attitude (I, 0)
and at the three saddles (exp(pi e_i^), 0). The problems compare the graph's
linearisations with these tables; nothing here is derived from a model.
"""

from __future__ import annotations

import numpy as np

from workbench.linear import Stability

__all__ = ["PRINTED", "flip", "printed_stable_subspace"]


def flip(i: int) -> np.ndarray:
    """``exp(pi hat(e_i)) = 2 e_i e_i^T - I``, the rotation by pi about ``e_i``.

    Parameters
    ----------
    i : int
        The axis, 0, 1 or 2.

    Returns
    -------
    ndarray, shape=(3, 3)
    """
    e = np.eye(3)[i]
    return 2 * np.outer(e, e) - np.eye(3)


PRINTED: dict[str, tuple[np.ndarray, list[tuple[complex, int | None]], Stability, int, str]] = {
    "I": (np.eye(3),
          [(-0.1667 + 0.5676j, None), (-0.1667 - 0.5676j, None), (-0.25 + 0.6614j, None),
           (-0.25 - 0.6614j, None), (-0.5 + 0.8367j, None), (-0.5 - 0.8367j, None)],
          Stability.STABLE_FOCUS, 0, "Sec. III-C 1)"),
    "exp(pi e1^)": (flip(0), [(-0.7813, 1), (-0.5854, 2), (-1.0477, 3), (0.4480, 1),
                              (0.0854, 2), (0.0477, 3)], Stability.SADDLE, 3, "(17)"),
    "exp(pi e2^)": (flip(1), [(-0.3775, 1), (-1.0, 2), (-0.9472, 3), (-0.0528, 3),
                              (0.0442, 1), (0.5, 2)], Stability.SADDLE, 2, "(18)"),
    "exp(pi e3^)": (flip(2), [(-0.0613, 1), (-0.2721, 1), (-0.1382, 2), (-0.3618, 2),
                              (-1.5954, 3), (0.5954, 3)], Stability.SADDLE, 1,
                    "(19) with erratum v6"),
}
"""Per equilibrium: attitude, printed (eigenvalue, axis j of ``v = e_j + lambda e_{j+3}``)
(axis None: no eigenvector printed), classification, number of unstable modes, where it is
printed. (19) v6 uses the erratum (axis 3; the paper prints e2)."""


def printed_stable_subspace(lams: list[float], *, erratum: bool = True) -> np.ndarray:
    """Tangent of the printed E^s_loc(exp(pi e3^)) in (eta, delta Omega), shape (6, 5).

    ``eta = (a1 + a2, a3 + a4, a5)``, ``Omega = (l1 a1 + l2 a2, l3 a3 + l4 a4, +-l5 a5)``;
    the erratum is the sign ``+l5`` (the paper prints ``-l5``).

    Parameters
    ----------
    lams : list of float
        The five stable eigenvalues ``l1..l5`` at exp(pi e3^), in the printed order.
    erratum : bool
        Use the corrected sign.

    Returns
    -------
    ndarray, shape=(6, 5)
    """
    s5 = 1.0 if erratum else -1.0
    cols = []
    for i in range(5):
        a = np.zeros(5)
        a[i] = 1.0
        eta = [a[0] + a[1], a[2] + a[3], a[4]]
        om = [lams[0] * a[0] + lams[1] * a[1], lams[2] * a[2] + lams[3] * a[3],
              s5 * lams[4] * a[4]]
        cols.append(np.r_[eta, om])
    return np.column_stack(cols)
