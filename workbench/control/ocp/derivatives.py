r"""Ipopt's derivatives of a transcribed OCP, built interval by interval.

A transcription's constraints and cost are a sum over intervals: interval ``k`` reads a few
decision variables ``z_k = w[idx_k]`` (its nodes, collocation points, controls and the
horizon ``T``) and contributes its constraints ``c_k(z_k, p)`` (defects, continuity) and its
running cost ``l_k(z_k, p)``; a few more constraints (path, terminal, phase condition) and
the terminal cost read single nodes. Differentiating the whole flat scalar graph at once,
as ``casadi.nlpsol`` does by default, colours the NLP's Jacobian and Hessian and pushes every
colour through every interval: on Drake's swing-up (41 knots, 893 variables) that took
7-10 s per NLP and a 3.3-5 million node Hessian graph (measured, ``benchmarks/bench_ocp.py``).

Here the derivatives of *one* interval are generated once, symbolically and exactly,

    J_k = dc/dz (z_k, p),      H_k = d^2/dz^2 [sigma l + lambda_k' c](z_k, p),

mapped over the ``N`` intervals (``casadi.Function.map``) and scattered into the NLP's sparse
Jacobian and upper-triangular Hessian by a constant sparse matrix (entries shared by two
intervals, such as ``T`` or a node, are summed). The remaining constraints and the terminal
cost are small and keep casadi's own derivatives. The result is the same exact Jacobian and
Hessian (tests compare them entry by entry with casadi's), built in a fraction of the time.
The NLP's own cost and constraints are an MX graph of ``N`` calls of the SX interval (the
transcription maps it), so nothing is inlined ``N`` times either. On Drake's problem
(HS, N = 40, ambient) the whole build, Ipopt instance included, went from 6.9 s to 0.16 s
CPU, at the same iterations and cost; each Ipopt iteration costs about 10% more (the MX
graph's call overhead), measured in ``benchmarks/bench_ocp_build.py``.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
import scipy.sparse as sps

__all__ = ["IntervalLayout", "structured_derivatives"]


class IntervalLayout:
    """Where each interval's arguments live in the decision vector.

    Parameters
    ----------
    F : casadi.Function
        The interval, an SX function ``(*args, h, p) -> (defects, x_end, cost)``; ``args``
        are those of :class:`~workbench.control.ocp.transcription.Transcription`'s interval
        (without ``h`` and ``p``).
    blocks : list of list of (int, int)
        For each interval, the ``(offset, length)`` in ``w`` of each of ``args``, in order.
    next_node : list of (int, int)
        For each interval, the ``(offset, length)`` of the next node ``X_(k+1)`` (the
        continuity constraint is ``X_(k+1) - x_end``).
    i_T : int
        Index of the horizon ``T`` in ``w`` (``h = T / N``).

    Attributes
    ----------
    idx : ndarray, shape=(N, nz)
        Interval ``k``'s variables ``z_k = w[idx[k]]``: its arguments, then ``X_(k+1)``
        unless it is one of them, then ``T``.
    next_pos : int or None
        Which argument is ``X_(k+1)`` (the block with its offset and length; an empty block
        at the same offset is not it), or None when it follows the arguments.
    """

    def __init__(self, F: ca.Function, blocks: list[list[tuple[int, int]]],
                 next_node: list[tuple[int, int]], i_T: int) -> None:
        self.F, self.N, self.i_T = F, len(blocks), i_T
        self.blocks, self.next_node = blocks, next_node
        # X_(k+1) is an argument when a block has its offset *and* length. Matching the
        # offset alone is wrong: an empty block (no inputs, no collocation variables) starts
        # where the next block does, often at X_(k+1), and X_(k+1) would then be dropped.
        positions = {self._next_position(blocks[k], next_node[k]) for k in range(self.N)}
        if len(positions) != 1:
            raise AssertionError(f"the next node is an argument of some intervals only "
                                 f"(positions {sorted(positions, key=str)})")
        self.next_pos = positions.pop()
        idx = []
        for k in range(self.N):
            cols = [np.arange(o, o + n) for o, n in blocks[k]]
            if self.next_pos is None:
                o, n = next_node[k]
                cols.append(np.arange(o, o + n))
            cols.append(np.array([i_T]))
            idx.append(np.concatenate(cols).astype(int))
        self.idx = np.array(idx)  # N x nz
        self.nz = self.idx.shape[1]

    @staticmethod
    def _next_position(blocks: list[tuple[int, int]], next_node: tuple[int, int]
                       ) -> int | None:
        """Index of the argument that is the next node, or None when it is not one."""
        o, n = next_node
        if n == 0:
            raise AssertionError("the next node has no entries")
        return next((i for i, (b, m) in enumerate(blocks) if (b, m) == (o, n)), None)

    def local_functions(self, n_params: int) -> tuple[ca.Function, ca.Function, int]:
        """``(z, p) -> nz(J_k)`` and ``(z, p, sigma, lam) -> nz(H_k)`` with their triplets."""
        F = self.F
        z, p = ca.SX.sym("z", self.nz), ca.SX.sym("p", n_params)
        args, o = [], 0
        for (_, n), i in zip(self.blocks[0], range(len(self.blocks[0]))):
            args.append(ca.reshape(z[o: o + n], F.size1_in(i), F.size2_in(i)))
            o += n
        nx = self.next_node[0][1]
        if self.next_pos is None:  # X_(k+1) follows the arguments
            x_next = z[o: o + nx]
        else:  # X_(k+1) is one of the arguments
            start = sum(n for _, n in self.blocks[0][:self.next_pos])
            x_next = z[start: start + nx]
        h = z[self.nz - 1] / self.N
        defects, x_end, cost = F(*args, h, p)
        c = ca.vertcat(defects, x_next - x_end)
        lam, sigma = ca.SX.sym("lam", c.numel()), ca.SX.sym("sigma")
        J = ca.jacobian(c, z)
        H = ca.hessian(sigma * cost + ca.dot(lam, c), z)[0]
        self.J_sparsity, self.H_sparsity = J.sparsity(), H.sparsity()
        fJ = ca.Function("interval_jac", [z, p], [J.nz[:]])
        fH = ca.Function("interval_hess", [z, p, sigma, lam], [H.nz[:]])
        return fJ, fH, int(c.numel())


def _scatter(rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int]
             ) -> tuple[ca.Sparsity, sps.csc_matrix]:
    """Sparsity of the entries ``(rows, cols)`` and the matrix summing values into it."""
    key = cols.astype(np.int64) * shape[0] + rows  # column-major order, as casadi
    uniq, inverse = np.unique(key, return_inverse=True)
    r, c = (uniq % shape[0]).astype(int), (uniq // shape[0]).astype(int)
    sp = ca.Sparsity.triplet(shape[0], shape[1], r.tolist(), c.tolist())
    M = sps.csc_matrix((np.ones(len(key)), (inverse, np.arange(len(key)))),
                       shape=(len(uniq), len(key)))
    return sp, M


def _dm(M: sps.spmatrix) -> ca.DM:
    """A scipy sparse matrix as a casadi DM, through its compressed columns.

    ``casadi.DM(scipy_matrix)`` converts entry by entry: 0.89 s for the 480k entries of
    the double cart's N = 160 scatter, against 0.16 s from the CSC arrays.
    """
    M = sps.csc_matrix(M, copy=True)  # sum_duplicates works in place
    M.sum_duplicates()  # casadi wants each column's rows sorted and unique
    sp = ca.Sparsity(M.shape[0], M.shape[1], M.indptr.tolist(), M.indices.tolist())
    return ca.DM(sp, M.data)


def structured_derivatives(layout: IntervalLayout, nlp: dict[str, Any], n_block: int,
                           g_rest: Any, f_rest: Any, n_params: int) -> dict[str, ca.Function]:
    """``jac_g`` and ``hess_lag`` options of ``casadi.nlpsol`` for a transcribed OCP.

    Parameters
    ----------
    layout : IntervalLayout
        The intervals and where their arguments live.
    nlp : dict
        The NLP (``x``, ``p``, ``f``, ``g``, SX or MX); its first ``n_block`` constraints
        are the intervals' ``c_k`` stacked interval by interval, the rest (``g_rest``)
        depend on single nodes.
    n_block : int
        Number of interval constraints.
    g_rest : casadi.SX or casadi.MX
        The constraints after the first ``n_block``, as an expression of ``nlp["x"]`` and
        ``nlp["p"]``.
    f_rest : casadi.SX or casadi.MX
        The part of the cost that is not a sum of the intervals' running costs.
    n_params : int
        Number of model parameters (the first entries of ``nlp["p"]``).

    Returns
    -------
    dict
        ``{"jac_g": Function(x, p) -> (g, jac_g_x), "hess_lag": Function(x, p, lam_f,
        lam_g) -> triu_hess_gamma_x_x}``, exact, with casadi's signatures.
    """
    w, P, G = nlp["x"], nlp["p"], nlp["g"]
    nw, ng, N = int(w.numel()), int(G.numel()), layout.N
    fJ, fH, nrow = layout.local_functions(n_params)
    if nrow * N != n_block:
        raise AssertionError(f"interval rows {nrow} x {N} != {n_block} block constraints")
    idx = layout.idx
    # Jacobian of the interval constraints: row k * nrow + r, column idx[k, c]
    jr, jc = layout.J_sparsity.get_triplet()
    jr, jc = np.asarray(jr), np.asarray(jc)
    rows = (np.arange(N)[:, None] * nrow + jr[None, :]).ravel()
    cols = idx[:, jc].ravel()
    spJ, MJ = _scatter(rows, cols, (n_block, nw))
    # Hessian: entries (idx[k, r], idx[k, c]) in the upper triangle of w's order, summed
    hr, hc = layout.H_sparsity.get_triplet()
    hr, hc = np.asarray(hr), np.asarray(hc)
    gr, gc = idx[:, hr], idx[:, hc]
    keep = gr <= gc  # the symmetric local Hessian has both (r, c) and (c, r)
    sel = np.flatnonzero(keep.ravel())
    spH, MH = _scatter(gr.ravel()[sel], gc.ravel()[sel], (nw, nw))
    MH = _dm(MH @ sps.csc_matrix(
        (np.ones(len(sel)), (np.arange(len(sel)), sel)), shape=(len(sel), keep.size)))
    MJ = _dm(MJ)

    xs, ps = ca.MX.sym("x", nw), ca.MX.sym("p", P.numel())
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng)
    p_model = ps[0:n_params]
    Z = ca.reshape(xs[idx.ravel().tolist()], layout.nz, N)
    Lam = ca.reshape(lam_g[0:n_block], nrow, N)
    g_fun = ca.Function("nlp_g", [w, P], [G])
    Jnz = fJ.map(N, "serial")(Z, p_model)
    J_block = ca.MX(spJ, ca.mtimes(MJ, ca.vec(Jnz)))
    Hnz = fH.map(N, "serial")(Z, p_model, lam_f, Lam)
    H = ca.MX(spH, ca.mtimes(MH, ca.vec(Hnz)))
    G_rest = g_rest
    if ng > n_block:
        jr_fun = ca.Function("rest_jac", [w, P], [ca.jacobian(G_rest, w)], {"cse": True})
        J = ca.vertcat(J_block, jr_fun(xs, ps))
    else:
        J = J_block
    sym = ca.MX if isinstance(w, ca.MX) else ca.SX
    sig, lr = sym.sym("sigma"), sym.sym("lam", ng - n_block)
    H_rest = ca.triu(ca.hessian(sig * f_rest + ca.dot(lr, G_rest), w)[0])
    if H_rest.nnz():
        hr_fun = ca.Function("rest_hess", [w, P, sig, lr], [H_rest], {"cse": True})
        H = H + hr_fun(xs, ps, lam_f, lam_g[n_block:])
    jac_g = ca.Function("nlp_jac_g", [xs, ps], [g_fun(xs, ps), J],
                        ["x", "p"], ["g", "jac_g_x"])
    hess_lag = ca.Function("nlp_hess_l", [xs, ps, lam_f, lam_g], [ca.triu(H)],
                           ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
    return {"jac_g": jac_g, "hess_lag": hess_lag}
