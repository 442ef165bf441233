"""Ludovico2021's convex QCQP for the moment arm of an anchored-spring pulley (Sec. III).

The moment arm is a polynomial in the joint angle itself, r_m = Hβ with H = [1 θ θ² … θ^m]
(Eq. 7), fitted to the target through the spring force of the *target's* energy, v (Eq. 8):

    min_β ‖diag(v) Hβ − τ‖²                                            (Eq. 10)
    s.t.  ε ≤ Hβ ≤ L − ε                                               (Eq. 11–12)
          (H_i β)² + (H_d,i β)² ≤ L²,  i = 1 … n                        (Eq. 15, 17)
          (H_dd + H/4) β ≥ ε                                           (Eq. 35)

Eq. 17 is printed with L on the right; Eq. 15, which it discretises, has L². The strict
inequalities of the paper are closed with a margin ε. The constraints are the paper's convex
subsets of feasibility: |φ′| < 1 for the curvature (Eq. 13–15) and r″ + r/4 > 0 against
non-regular points (Eq. 31–33). Both are symmetric in the sign of r′, so they hold whichever
way the pulley winds.

Reading of Eq. 8 and of the direction. The grid is θ_j = θ_i + j(θ_f − θ_i)/(n − 1),
j = 0 … n − 1 (both ends included), while dα = (θ_f − θ_i)/n exactly as printed, and
v_j = √(2k Σ_{α=0}^{j} τ(θ_α) dα + k²u0²) includes the current point (a rectangle sum). The
sum starts where the spring is at u0: from θ_i upwards when θ0 = θ_i, and from θ_f downwards,
v_j = √(2k Σ_{α=j}^{n−1} τ(θ_α) dα + k²u0²), when θ0 = θ_f.

cvxpy is optional (``pip install 'cadcam[convex]'``) and imported only when a problem is solved.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial


@dataclass(frozen=True)
class QCQPResult:
    """Solution of Ludovico2021's QCQP (Eq. 36) on its grid.

    Attributes
    ----------
    theta : ndarray
        The grid θ_j [rad].
    beta : ndarray
        Coefficients β_0 … β_m of r_m = Σ β_j θ^j [m/rad^j], increasing powers.
    r_m, dr_m, d2r_m : ndarray
        Hβ [m], H_d β [m/rad] and H_dd β [m/rad²] on the grid (Eq. 7, 16, 34).
    v : ndarray
        The paper's spring force of the target (Eq. 8) [N].
    error_paper : ndarray
        diag(v)Hβ − τ [N·m], the residual of Eq. 9 the paper minimises and plots.
    torque : ndarray
        The torque magnitude k u r_m [N·m] a spring really gives with this moment arm, its
        extension u = u0 + |∫_{θ0}^{θ} r_m dα| integrated exactly (du/dθ = ±r_m).
    status : str
        cvxpy's status (``"optimal"`` on success).
    solver : str
        The solver cvxpy used.
    solve_time : float
        Wall time of ``Problem.solve`` [s].
    """

    theta: np.ndarray
    beta: np.ndarray
    r_m: np.ndarray
    dr_m: np.ndarray
    d2r_m: np.ndarray
    v: np.ndarray
    error_paper: np.ndarray
    torque: np.ndarray
    status: str
    solver: str
    solve_time: float


def design_matrices(theta: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """H, H_d and H_dd of the monomials θ^j, j = 0 … order (Ludovico2021 Eq. 7, 16, 34)."""
    j = np.arange(order + 1)
    power = theta[:, None] ** j  # Ludovico2021 Eq. 7
    first = j * theta[:, None] ** np.maximum(j - 1, 0) * (j >= 1)  # Ludovico2021 Eq. 16
    second = j * (j - 1) * theta[:, None] ** np.maximum(j - 2, 0) * (j >= 2)  # Ludovico2021 Eq. 34
    return power, first, second


def _check_inputs(theta_i, theta_f, theta0, k, u0, L, order, n, eps) -> None:
    """ValueError naming the first argument of :func:`solve_qcqp` out of its range."""
    if not theta_f > theta_i:
        raise ValueError(f"need theta_i < theta_f, got {theta_i} and {theta_f}")
    if not np.isclose(theta0, theta_i, rtol=0, atol=1e-12) and not np.isclose(
            theta0, theta_f, rtol=0, atol=1e-12):
        raise ValueError(f"theta0 must be theta_i or theta_f, got {theta0}")
    if not (k > 0 and u0 > 0 and L > 0):
        raise ValueError(f"k, u0 and L must be positive, got {k}, {u0} and {L}")
    if order < 2 or n < order + 1:
        raise ValueError(f"need order >= 2 and n > order, got order {order} and n {n}")
    if not 0 <= eps < L / 2:
        raise ValueError(f"eps must be in [0, L/2), got {eps}")


def _spring_force_term(tau, theta: np.ndarray, theta0: float, k: float, u0: float):
    """The target τ_p on the grid [N·m] and v = k·u(θ) [N], the spring force the energy
    balance gives (Ludovico2021 Eq. 8: ½k(u² − u0²) = ∫τ dθ, by the paper's rectangle rule)."""
    target = np.broadcast_to(np.asarray(tau(theta), dtype=float), theta.shape)
    if np.any(target < 0):
        raise ValueError("tau must be >= 0 on the grid: a pulley gives a torque magnitude")
    d_alpha = (theta[-1] - theta[0]) / theta.size  # as printed under Eq. 7
    from_start = np.isclose(theta0, theta[0], rtol=0, atol=1e-12)
    work = np.cumsum(target) if from_start else np.cumsum(target[::-1])[::-1]
    v = np.sqrt(2 * k * work * d_alpha + k**2 * u0**2)  # Ludovico2021 Eq. 8
    return target, v


def _qcqp(cp, beta, matrices, v, target, L: float, eps: float):
    """Ludovico2021's QCQP (Eq. 36) in ``beta``: the least-squares torque error with the arm's
    bounds, its curve inside the circle of radius L and the pulley's convexity."""
    H, Hd, Hdd = matrices
    arm, slope = H @ beta, Hd @ beta
    return cp.Problem(
        cp.Minimize(cp.sum_squares(cp.multiply(v, arm) - target)),  # Ludovico2021 Eq. 10
        [arm >= eps, arm <= L - eps,  # Ludovico2021 Eq. 11–12
         cp.norm(cp.vstack([arm, slope]), 2, axis=0) <= L,  # Ludovico2021 Eq. 17 (RHS L², Eq. 15)
         (Hdd + H / 4) @ beta >= eps])  # Ludovico2021 Eq. 35


def solve_qcqp(tau, theta_i: float, theta_f: float, theta0: float, k: float, u0: float,
               L: float, order: int = 5, n: int = 250, eps: float = 1e-6,
               solver: str | None = None) -> QCQPResult:
    """Solve Ludovico2021's convex QCQP (Eq. 36) for one pulley.

    Parameters
    ----------
    tau : callable
        Torque magnitude τ_p(θ) ≥ 0 [N·m] this pulley must give, vectorised.
    theta_i, theta_f : float
        Range of motion [rad], θ_i < θ_f.
    theta0 : float
        θ_i or θ_f: where the spring has extension ``u0``; it extends away from there.
    k : float
        Spring rate [N/m].
    u0 : float
        Extension at θ0 [m].
    L : float
        Distance from the joint to the spring's insertion point [m].
    order : int
        Polynomial order m (the paper: 5).
    n : int
        Grid points (the paper: 250, dα = 8.378e-3 rad on [π/6, 5π/6]).
    eps : float
        Margin ε closing the strict inequalities, in m for Eq. 11–12 and m/rad² for Eq. 35.
    solver : str, optional
        A cvxpy solver name; cvxpy's choice by default.

    Returns
    -------
    QCQPResult

    Raises
    ------
    ValueError
        For bad input.
    ImportError
        If cvxpy is not installed.
    """
    _check_inputs(theta_i, theta_f, theta0, k, u0, L, order, n, eps)
    try:
        import cvxpy as cp
    except ImportError:
        raise ImportError("solve_qcqp needs cvxpy: pip install 'cadcam[convex]'") from None

    theta = np.linspace(theta_i, theta_f, n)
    target, v = _spring_force_term(tau, theta, theta0, k, u0)
    H, Hd, Hdd = design_matrices(theta, order)

    beta = cp.Variable(order + 1)
    problem = _qcqp(cp, beta, (H, Hd, Hdd), v, target, L, eps)
    start = time.perf_counter()
    problem.solve(solver=solver)
    elapsed = time.perf_counter() - start
    if beta.value is None:
        raise RuntimeError(f"the QCQP has no solution: cvxpy status {problem.status}")

    b = np.asarray(beta.value, dtype=float)
    r_m = H @ b
    antiderivative = Polynomial(b).integ()
    u = u0 + np.abs(antiderivative(theta) - antiderivative(theta0))  # du/dθ = ±r_m
    return QCQPResult(theta=theta, beta=b, r_m=r_m, dr_m=Hd @ b, d2r_m=Hdd @ b, v=v,
                      error_paper=v * r_m - target, torque=k * u * r_m, status=problem.status,
                      solver=problem.solver_stats.solver_name, solve_time=elapsed)
