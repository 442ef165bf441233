"""A first-order predictor of a warm re-solve: where the last answer moves when the problem's
numbers change a little (a slider's step), from the parametric sensitivity of that answer.

At the last answer x with multipliers λ, solved for the parameters and bounds of the last
problem, the new problem's KKT conditions are linearized on the answer's active set (its
equality rows, the inequality rows and bounds whose multiplier is a share
:data:`ACTIVE_SHARE` of the largest, the fixed variables held): one solve with the KKT matrix
at x (the Lagrangian's Hessian and the constraint Jacobian, evaluated at the new parameters)
gives the step of x and of the active multipliers, the residual of the new problem's
conditions at x being first order in the change of its numbers; a row the step breaks joins
the active set, one whose multiplier changes side leaves it, and the step is made again
(:data:`ACTIVE_SET_PASSES`). IPOPT then starts there instead of at x (:data:`PREDICTED_IPOPT`):
the same optimum, in fewer iterations. The predictor changes only where IPOPT starts;
where the KKT matrix is singular, the start is the last answer itself, and where IPOPT does
not converge from the predicted start within :data:`PREDICTED_IPOPT`'s iterations, it starts
again from the last answer (or goes on, :data:`NEARLY_CONVERGED`).
"""
from __future__ import annotations

import warnings
from contextvars import ContextVar

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from .ipopt import Multipliers

if TYPE_CHECKING:
    import scipy.sparse as sp

#: Whether the warm re-solves in the running context start from the predicted point
#: (:func:`predicted`) rather than the last answer: a design session's provisional designs
#: while a slider moves (:meth:`cadcam.Session.design` with ``recheck=False``).
PREDICT: ContextVar[bool] = ContextVar("predict", default=False)
#: An inequality row or variable bound is taken as active where its multiplier is at least
#: this share of the largest multiplier of the inequality rows and bounds (1). The answers of
#: an interior-point solve hold multipliers of the size μ/gap on the rows beside the active
#: ones, orders of magnitude below the binding ones; held active, they over-determine the
#: linearization, whose step then breaks the rows that do bind. Rows bound more weakly than
#: this share are left to the passes (:data:`ACTIVE_SET_PASSES`); a larger share lets go of
#: rows that do bind, weakly (``benchmarks/bench_design.py`` measures the steps).
ACTIVE_SHARE = 1e-3
#: Passes of the active set: after each step, the row its linearization breaks most joins the
#: active set and every row whose multiplier changed side leaves it, and the step is made
#: again (a row about to bind, the anchored pulleys' next peak of the torque error). Few
#: passes: each adds one row, and a long chain of them follows a linearization far from where
#: it holds.
ACTIVE_SET_PASSES = 3
#: How far beyond its bound a linearized inactive row may go before it joins the active set, in
#: the NLP's scaled units (IPOPT's own constraint tolerance is 1e-8 of these).
BOUND_TOL = 1e-8
#: IPOPT's options of a solve from the predicted start, beside the running context's: at most
#: this many iterations, after which the solve starts again from the last answer itself (or goes
#: on, :data:`NEARLY_CONVERGED`); and the barrier parameter held at IPOPT's least (its
#: ``mu_min``), where the last answer's solve ended: the predicted start is that answer moved,
#: so it starts at the end of the central path. A linearization on a wrong active set (a row
#: about to bind) can lead IPOPT a long way round, where from a good one it takes a few. A
#: barrier held higher than where the last solve ended stops at a looser complementarity (a
#: higher objective) or wanders; an adaptive one climbs back up the central path first.
PREDICTED_IPOPT = {"ipopt.max_iter": 12, "ipopt.mu_strategy": "monotone", "ipopt.mu_init": 1e-11}
#: The largest primal and dual infeasibility (IPOPT's ``inf_pr`` and ``inf_du``, in the NLP's
#: scaled units) at which a solve from the predicted start cut short by :data:`PREDICTED_IPOPT`
#: goes on from where it stopped rather than again from the last answer: near its end, going
#: on costs an iteration or two, starting again a whole warm solve.
NEARLY_CONVERGED = 1e-4
#: SuperLU's column ordering of the KKT matrix: the minimum degree ordering of its symmetric
#: pattern (a KKT matrix is symmetric), which fills it in less than SciPy's default (COLAMD).
ORDERING = "MMD_AT_PLUS_A"
#: The sparsities whose indices are kept (:func:`_indices`): a Jacobian's and a Hessian's for
#: each structure a design session keeps (:data:`cadcam.solve.builds.KEPT_BUILDS` of them).
KEPT_INDICES = 16
#: The derivatives of the NLP the predictor evaluates, by CasADi's name of IPOPT's function.
FUNCTIONS = ("nlp_grad_f", "nlp_jac_g", "nlp_hess_l")
#: The kept indices of sparsities, by their hash (:func:`_indices`).
_INDICES: dict = {}


def predicted(solver: ca.Function, warm: Multipliers, pv: np.ndarray, bounds, variable_bounds) -> Multipliers:
    """The predicted warm start of the NLP ``solver`` solves (an IPOPT ``nlpsol``, whose
    derivatives are evaluated) for the parameters ``pv`` and the bounds ``bounds`` (of its rows,
    lower and upper) and ``variable_bounds``, from the last answer ``warm`` (its point and
    multipliers, of this NLP's rows): the point and multipliers of one step on the linearized
    KKT conditions (the module's docstring); ``warm`` itself where that step is not finite."""
    x, lam_g, lam_x = (np.asarray(v, dtype=float) for v in (warm.x, warm.lam_g, warm.lam_x))
    (lbg, ubg), (lbx, ubx) = bounds, variable_bounds
    grad_f, jac_g, hess = (solver.get_function(name) for name in FUNCTIONS)
    g, jac = jac_g(x, pv)
    g, jac = np.asarray(g).ravel(), _triplets(jac)
    upper = _triplets(hess(x, pv, 1.0, lam_g))  # the Hessian's upper triangle
    # ∇f + Jᵀλ_g + λ_x: the Lagrangian's gradient, zero at the last answer for its own numbers
    residual_x = np.asarray(grad_f(x, pv)[1]).ravel() + np.bincount(
        jac[1], jac[2] * lam_g[jac[0]], x.size) + lam_x
    rows, moved = _active(lam_g, lam_x, lbg == ubg, lbx < ubx)
    # each active row's bound: the upper where its multiplier pushes it up, else the lower
    bound = np.where(lam_g > 0, ubg, lbg)
    step = None
    for _ in range(ACTIVE_SET_PASSES):
        tried = _step(upper, jac, rows, moved, residual_x, g - bound, x.size)
        if tried is None:  # singular: the last pass's step, if any
            break
        step = dx, dlam = tried
        lam = lam_g + dlam
        g_lin = g + np.bincount(jac[0], jac[2] * dx[jac[1]], g.size)
        below, above = ~rows & (g_lin < lbg - BOUND_TOL), ~rows & (g_lin > ubg + BOUND_TOL)
        released = rows & _turned(lam, bound, lbg, ubg)
        if not (below.any() or above.any() or released.any()):
            break
        # the most broken row joins the active set, every row whose multiplier turned leaves it
        worst = int(np.argmax(np.where(below, lbg - g_lin, 0) + np.where(above, g_lin - ubg, 0)))
        rows = rows & ~released
        if below[worst] or above[worst]:
            rows[worst], bound[worst] = True, lbg[worst] if below[worst] else ubg[worst]
        if rows.sum() > moved.size:  # more rows than the step can meet: singular
            break
    if step is None:
        return warm
    dx, dlam = step
    lam = lam_g + dlam
    # an inequality's multiplier stays on the side of its bound (zero where it turned)
    lam[_turned(lam, bound, lbg, ubg)] = 0.0
    return Multipliers(lam_x, lam, warm.whole, np.clip(x + dx, lbx, ubx))


def _turned(lam: np.ndarray, bound: np.ndarray, lbg: np.ndarray, ubg: np.ndarray) -> np.ndarray:
    """The inequality rows (``lbg`` < ``ubg``) whose multiplier ``lam`` has turned to the other
    side of the bound ``bound`` each is held at: pulling a row at its upper bound down, or one
    at its lower bound up."""
    return (lbg < ubg) & (lam * np.where(bound == ubg, 1, -1) < 0)


def _step(upper: tuple, jac: tuple, rows: np.ndarray, moved: np.ndarray, residual_x: np.ndarray,
          residual_g: np.ndarray, n: int):
    """The step (of the ``n`` variables, and of the multipliers of every row) that zeroes the
    linearized Lagrangian's gradient ``residual_x`` and the linearized active ``rows``'
    distances to their bounds ``residual_g``, moving the ``moved`` variables alone; None where
    the KKT matrix is singular."""
    import scipy.sparse.linalg as spl  # here: every design imports this module, few predict

    kkt = _kkt(upper, jac, rows, moved, n)
    with warnings.catch_warnings():  # singular: a step not finite, or SuperLU refuses
        warnings.simplefilter("ignore", spl.MatrixRankWarning)
        try:
            solution = spl.spsolve(kkt, -np.r_[residual_x[moved], residual_g[rows]], permc_spec=ORDERING)
        except RuntimeError:
            return None
    if not np.all(np.isfinite(solution)):
        return None
    dx, dlam = np.zeros(n), np.zeros(rows.size)
    dx[moved] = solution[:moved.size]
    dlam[rows] = solution[moved.size:]
    return dx, dlam


def _active(lam_g: np.ndarray, lam_x: np.ndarray, equal: np.ndarray, free: np.ndarray):
    """The rows of the active set (a mask: the equality rows, ``equal``, and the inequality rows
    whose multiplier is :data:`ACTIVE_SHARE` of the largest) and the variables the step moves
    (their indices: the ``free`` ones whose bound is not active so)."""
    largest = max(np.abs(lam_g[~equal]).max(initial=0.0), np.abs(lam_x).max(initial=0.0))
    if largest == 0:
        return equal, np.flatnonzero(free)
    rows = equal | (np.abs(lam_g) >= ACTIVE_SHARE * largest)
    return rows, np.flatnonzero(free & (np.abs(lam_x) < ACTIVE_SHARE * largest))


def _kkt(upper: tuple, jac: tuple, rows: np.ndarray, moved: np.ndarray, n: int) -> sp.csc_matrix:
    """The KKT matrix [[H, Aᵀ], [A, 0]] of the ``moved`` variables (of ``n``) and the active
    ``rows`` (a mask), H from the triplets of the Hessian's ``upper`` triangle and A from the Jacobian's
    ``jac``, assembled from their triplets at once (SciPy's block assembly took milliseconds)."""
    import scipy.sparse as sp

    x_at = np.full(n, -1)
    x_at[moved] = np.arange(moved.size)
    g_at = np.full(rows.size, -1)
    g_at[rows] = moved.size + np.arange(int(rows.sum()))
    hr, hc, hv = upper
    hr, hc = x_at[hr], x_at[hc]
    keep = (hr >= 0) & (hc >= 0)
    off = keep & (hr != hc)  # the lower triangle mirrors the upper's off-diagonal entries
    jr, jc, jv = jac
    jr, jc = g_at[jr], x_at[jc]
    both = (jr >= 0) & (jc >= 0)
    i = np.r_[hr[keep], hc[off], jr[both], jc[both]]
    j = np.r_[hc[keep], hr[off], jc[both], jr[both]]
    size = moved.size + int(rows.sum())
    return sp.csc_matrix((np.r_[hv[keep], hv[off], jv[both], jv[both]], (i, j)), shape=(size, size))


def _triplets(dm: ca.DM) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A CasADi sparse matrix's rows, columns and values of its structural nonzeros."""
    return (*_indices(dm.sparsity()), np.asarray(dm.nonzeros()))


def _indices(sparsity: ca.Sparsity) -> tuple[np.ndarray, np.ndarray]:
    """The rows and columns of ``sparsity``'s nonzeros, made once per sparsity (the same at
    every step: as lists from CasADi, a millisecond a step)."""
    kept = _INDICES.get(sparsity.hash())
    if kept is None or not kept[0].is_equal(sparsity):
        rows, cols = sparsity.get_triplet()
        kept = _INDICES[sparsity.hash()] = sparsity, np.asarray(rows, dtype=int), np.asarray(cols, dtype=int)
        while len(_INDICES) > KEPT_INDICES:
            del _INDICES[next(iter(_INDICES))]
    return kept[1], kept[2]


def nearly_converged(stats: dict) -> bool:
    """Whether the IPOPT run of ``stats`` (CasADi's ``stats()``) ended with its primal and dual
    infeasibility within :data:`NEARLY_CONVERGED`."""
    its = stats.get("iterations") or {}
    return all(its.get(key) and its[key][-1] <= NEARLY_CONVERGED for key in ("inf_pr", "inf_du"))
