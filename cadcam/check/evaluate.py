"""Evaluate a fixed design on any grid by an independent path (rootfinder and quadrature).

This is how every optimum is re-checked and how designs typed in from a paper are scored.
It shares the symbolic model with the NLP but not the NLP's solution: the tangency angles come
from a Newton rootfinder, the wrapped length from a Gauss–Legendre rule of high order, the wire
torque from the quadrature of Eq. 35 (seed 003) even under the exact friction model, and
convexity and ρ are sampled densely over the whole wrapped range and minimised.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.optimize import minimize_scalar

from ..physics.departure import TangencySolver, cam_function
from ..design import Design
from ..problem import Problem
from ..physics.profile import Basis, profile_function
from ..physics.quadrature import trapezoid_weights
from ..physics.springs import network_function
from ..mechanisms.wire_cam import port_function
from ..physics.wrap import length_function

#: Tolerances of the feasibility check: lengths [m], tangency residual [-, m], branch [-].
LENGTH_TOL = 1e-6
RESIDUAL_TOL = 1e-9
BRANCH_TOL = 1e-6
#: Gauss–Legendre order of the evaluation path (the NLP uses problem.options.quadrature_order).
EVAL_QUADRATURE_ORDER = 48


@lru_cache(maxsize=64)
def tangency_solver(basis: Basis) -> TangencySolver:
    """Cached :class:`TangencySolver` for a basis."""
    return TangencySolver(basis)


@dataclass
class CamSamples:
    """Per-angle quantities of one cam on its own grid (angles [rad], lengths [m])."""

    theta: np.ndarray
    alpha: np.ndarray
    gamma: np.ndarray
    alpha_ref: float
    gamma_ref: float
    residual: np.ndarray
    branch: np.ndarray
    d: np.ndarray          # (2, n) wire and platform displacements [m]
    arm: np.ndarray        # (2, n) wire and normal moment arms [m]
    qx: np.ndarray         # idler centre x [m]
    phi: np.ndarray        # dense profile angles over the wrapped range [rad]
    rho: np.ndarray        # ρ(phi) [m]
    convexity: np.ndarray  # Eq. 40 margin at phi [m²]
    convexity_min: float
    rho_lo: float
    rho_hi: float


@dataclass
class Evaluation:
    """A design evaluated on the tensor grid of all cams' angles.

    ``theta`` (m, N) are the grid points [rad], ``tau``/``tau_d`` (m, N) the cam and target
    torques [N·m], ``x`` (S, N) the spring extensions [m], ``dtau_dk`` (m, N, S) the rate
    sensitivities [m²]; ``metrics`` summarises them (see :func:`evaluate`).
    """

    problem: Problem
    design: Design
    grid: int
    cams: list[CamSamples]
    theta: np.ndarray
    tau: np.ndarray
    tau_d: np.ndarray
    x: np.ndarray
    dtau_dk: np.ndarray
    metrics: dict = field(default_factory=dict)

    @property
    def violations(self) -> list[str]:
        """Human-readable constraint violations beyond the check tolerances."""
        return self.metrics["violations"]


def _profile_extremes(basis: Basis, c: np.ndarray, phi_hi: float, n: int):
    """Dense samples of ρ and the convexity margin on [0, phi_hi], with refined minima."""
    prof = profile_function(basis)
    phi = np.linspace(0.0, phi_hi, n)
    rho, _, _, conv = (np.asarray(v).ravel() for v in prof.map(n)(phi, c))
    conv_min = _refine_min(prof, c, phi, conv, 3)
    rho_lo = _refine_min(prof, c, phi, rho, 0)
    rho_hi = -_refine_min(prof, c, phi, -rho, 0, sign=-1.0)
    return phi, rho, conv, conv_min, rho_lo, rho_hi


def _refine_min(prof, c, phi, values, out_index, sign=1.0):
    """Minimum of ``values`` (= sign·output ``out_index`` of ``prof``) refined between samples
    (NaN where the profile itself is not finite)."""
    if not np.all(np.isfinite(values)):
        return float("nan")
    k = int(np.argmin(values))
    lo, hi = phi[max(k - 1, 0)], phi[min(k + 1, phi.size - 1)]
    res = minimize_scalar(lambda p: sign * float(prof(p, c)[out_index]), bounds=(lo, hi),
                          method="bounded", options={"xatol": 1e-12})
    return float(min(values[k], res.fun))


def cam_samples(problem: Problem, design: Design, i: int, theta: np.ndarray,
                order: int = EVAL_QUADRATURE_ORDER, wire_arm: str = "quadrature",
                profile: bool = True, seed=None) -> CamSamples:
    """Solve the tangency with the rootfinder and evaluate cam ``i``'s port quantities
    (and, with ``profile``, scan ρ and the convexity margin over the wrapped range).

    ``seed`` = (θ, α, γ) samples, e.g. an NLP's solution, interpolated as Newton's start.
    """
    cam, basis, c = problem.cams[i], design.bases[i], np.asarray(design.coefficients[i])
    r, a0 = cam.idler_radius, cam.idler_offset
    th = np.concatenate([[0.0], theta])
    start = None if seed is None else (np.interp(th, seed[0], seed[1]), np.interp(th, seed[0], seed[2]))
    alpha, gamma, residual = tangency_solver(basis).solve(th, c, r, a0, start)
    n = theta.size
    wrapped = length_function(basis, order).map(n)(alpha[0], alpha[1:], c)
    ports = port_function(basis, problem.friction_model, order, wire_arm).map(n)
    qx_ref = float(cam_function(basis)(0.0, alpha[0], gamma[0], c, r, a0)[2])
    d, arm, _, branch = (np.asarray(v) for v in ports(theta, alpha[1:], gamma[1:], gamma[0],
                                                       qx_ref, wrapped, c, r, a0, cam.mu))
    qx = np.asarray(cam_function(basis).map(n)(theta, alpha[1:], gamma[1:], c, r, a0)[2]).ravel()
    # the wrapped range; where the tangency failed (NaN), the whole design interval
    phi_hi = float(np.max(alpha)) if np.all(np.isfinite(alpha)) else basis.domain[1]
    phi, rho, conv, conv_min, rho_lo, rho_hi = (
        _profile_extremes(basis, c, phi_hi, max(20 * n, 2000)) if profile
        else (np.array([]), np.array([]), np.array([]), np.nan, np.nan, np.nan))
    return CamSamples(theta, alpha[1:], gamma[1:], float(alpha[0]), float(gamma[0]),
                      np.maximum(residual[1:], residual[0]), branch.ravel(), d, arm, qx,
                      phi, rho, conv, conv_min, rho_lo, rho_hi)


def evaluate(problem: Problem, design: Design, grid: int | None = None,
             order: int = EVAL_QUADRATURE_ORDER, wire_arm: str = "quadrature",
             profile: bool = True, seeds=None) -> Evaluation:
    """Evaluate ``design`` on a uniform grid of ``grid`` angles per cam (default: the problem's).

    Returns an :class:`Evaluation` whose ``metrics`` hold, in SI units: ``rmse`` and
    ``max_abs_error`` [N·m] per cam over the grid points; ``extension_min``/``extension_max``
    [m] per spring; ``convexity_min`` [m²], ``rho_min``/``rho_max`` [m] per cam over the whole
    wrapped range [0, max α]; ``tangency_residual_max``; ``sensitivity_integral``
    ∫|∂τ_i/∂k_j| [m²·rad^m] per cam and spring (trapezoidal); ``objective`` (Eq. 46/47);
    ``margins`` (positive = satisfied) and ``violations``. ``profile = False`` skips the
    scan of the profile (its metrics are then NaN), for callers that need only the grid;
    ``seeds`` (per cam, see :func:`cam_samples`) start the rootfinder from known angles.
    """
    n = grid or problem.options.grid
    m, S = len(problem.cams), len(problem.springs)
    cams = [cam_samples(problem, design, i, problem.cams[i].grid(n), order, wire_arm, profile,
                        None if seeds is None else seeds[i]) for i in range(m)]
    idx = np.indices((n,) * m).reshape(m, -1)
    N = idx.shape[1]
    theta = np.vstack([cams[i].theta[idx[i]] for i in range(m)])
    D = np.vstack([cams[i].d[:, idx[i]] for i in range(m)])
    A = np.vstack([cams[i].arm[:, idx[i]] for i in range(m)])
    k = np.array([s.rate for s in problem.springs])
    net = network_function(list(problem.springs), m).map(N)
    x, tau, jac = (np.asarray(v) for v in net(D, A, k, design.preextension))
    dtau_dk = jac.reshape(m, N, S)
    tau_d = np.vstack([np.asarray(problem.cams[i].target.function(m, i).map(N)(theta)).ravel()
                       for i in range(m)])
    weights = np.prod([trapezoid_weights(cams[i].theta)[idx[i]] for i in range(m)], axis=0)
    ev = Evaluation(problem, design, n, cams, theta, tau, tau_d, x, dtau_dk)
    ev.metrics = _metrics(ev, weights)
    return ev


def rate_deviation(problem: Problem, design: Design, factor: float, springs=None,
                   grid: int | None = None) -> np.ndarray:
    """RMSE per cam [N·m] between the torques of ``design`` with nominal spring rates and with
    the rates of ``springs`` (default all, as seed 003's Table 5) multiplied by ``factor``.

    τ is linear in the rates, so with every rate scaled this is |factor − 1| × the RMS torque
    for any design; one spring at a time is what measures robustness.
    """
    nominal = evaluate(problem, design, grid=grid, profile=False)
    changed = evaluate(problem.with_spring_rates(factor, springs), design, grid=grid, profile=False)
    return np.sqrt(np.mean((changed.tau - nominal.tau) ** 2, axis=1))


def _metrics(ev: Evaluation, weights: np.ndarray) -> dict:
    p = ev.problem
    err = ev.tau - ev.tau_d
    sens = np.einsum("inj,n->ij", np.abs(ev.dtau_dk), weights)
    objective = float(sum(c.tracking_weight * np.dot(err[i] ** 2, weights)
                          + np.dot(c.sensitivity_weights, sens[i]) for i, c in enumerate(p.cams)))
    travel = np.array([s.travel for s in p.springs])
    margins = {
        "travel": (travel - ev.x.max(axis=1)).tolist(),
        "extension_lower": ev.x.min(axis=1).tolist(),
        "convexity": [c.convexity_min for c in ev.cams],
        "rho_min": [c.rho_lo - pc.rho_min for c, pc in zip(ev.cams, p.cams)],
        "rho_max": [pc.rho_max - c.rho_hi for c, pc in zip(ev.cams, p.cams)],
        "tangency": [float(RESIDUAL_TOL - c.residual.max()) for c in ev.cams],
        "branch": [float(BRANCH_TOL - 1.0 - c.branch.max()) for c in ev.cams],
        "preextension": ev.design.preextension.tolist(),
    }
    tol = {"travel": LENGTH_TOL, "extension_lower": LENGTH_TOL, "convexity": 0.0,
           "rho_min": LENGTH_TOL, "rho_max": LENGTH_TOL, "tangency": 0.0, "branch": 0.0,
           "preextension": LENGTH_TOL}
    names = {"travel": "spring above its travel", "extension_lower": "spring in compression",
             "convexity": "profile not convex", "rho_min": "radius below rho_min",
             "rho_max": "radius above rho_max", "tangency": "tangency not solved",
             "branch": "wire on the wrong tangency branch",
             "preextension": "negative pre-extension"}
    violations = []
    for key, vals in margins.items():
        owner = p.springs if key in ("travel", "extension_lower", "preextension") else p.cams
        for item, v in zip(owner, vals):
            if not v >= -tol[key]:  # NaN (not computable) counts as violated
                violations.append(f"{names[key]}: {item.name} (margin {v:.3g})")
    return {
        "grid": ev.grid,
        "rmse": np.sqrt(np.mean(err**2, axis=1)).tolist(),
        "max_abs_error": np.abs(err).max(axis=1).tolist(),
        "extension_min": ev.x.min(axis=1).tolist(),
        "extension_max": ev.x.max(axis=1).tolist(),
        "convexity_min": margins["convexity"],
        "rho_min": [c.rho_lo for c in ev.cams],
        "rho_max": [c.rho_hi for c in ev.cams],
        "alpha_max": [float(c.alpha.max()) for c in ev.cams],
        "tangency_residual_max": float(max(c.residual.max() for c in ev.cams)),
        "sensitivity_integral": sens.tolist(),
        "objective": objective,
        "margins": margins,
        "violations": violations,
    }
