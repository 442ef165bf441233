"""Evaluate a fixed design on any grid by an independent path (rootfinder and quadrature).

This is how every optimum is re-checked and how designs typed in from a paper are scored.
It shares the symbolic model with the NLP but not the NLP's solution: the departure unknowns
come from a Newton rootfinder, the wrapped lengths from a Gauss–Legendre rule of high order
(and, under Johnston2023's force models, the wire torque from the quadrature of its Eq. 35),
and convexity and ρ are sampled densely over each profile's wrapped range and minimised.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from ..designs import Design
from ..mechanisms.base import (departure_solver, margin_function, port_function, split_coefficients,
                               wound_lengths)
from ..physics.profile import Basis, profile_function
from ..physics.quadrature import trapezoid_weights
from ..physics.wrap import length_function
from ..problem import Problem

#: Tolerances of the feasibility check: lengths [m], departure residual [-, m], branch [-].
LENGTH_TOL = 1e-6
RESIDUAL_TOL = 1e-9
BRANCH_TOL = 1e-6
#: Gauss–Legendre order of the evaluation path (the NLP uses problem.options.quadrature_order).
EVAL_QUADRATURE_ORDER = 48


@dataclass
class UnitSamples:
    """Per-angle quantities of one mechanism on its joint's grid (angles [rad], lengths [m]).

    ``z`` (unknowns × n) are the departure unknowns, ``z_ref`` those at the reference pose,
    ``d`` and ``arm`` (ports × n) the port displacements [m] and moment arms [m] of the
    problem's torque model, ``margins`` (the mechanism's margin_names × n) its per-pose limits
    [m], ≥ 0 when met.
    """

    theta: np.ndarray
    z: np.ndarray
    z_ref: np.ndarray
    residual: np.ndarray
    branch: np.ndarray
    d: np.ndarray
    arm: np.ndarray
    margins: np.ndarray


@dataclass
class ProfileSamples:
    """One profile: its departure angle α on the joint's grid and a dense scan of ρ and the
    convexity margin over its wrapped range [0, max α] (angles [rad], lengths [m])."""

    theta: np.ndarray
    alpha: np.ndarray
    alpha_ref: float
    phi: np.ndarray
    rho: np.ndarray
    convexity: np.ndarray  # Johnston2023 Eq. 40 margin at phi [m²]
    convexity_min: float
    rho_lo: float
    rho_hi: float
    curvature_radius_min: float  # smallest radius of curvature over the scan [m]


@dataclass
class Evaluation:
    """A design evaluated on the tensor grid of all joints' angles.

    ``theta`` (m, N) are the grid points [rad], ``tau``/``tau_d`` (m, N) the joint and target
    torques [N·m], ``x`` (S, N) the spring extensions [m], ``dtau_dk`` (m, N, S) the rate
    sensitivities [m²]; ``units`` and ``profiles`` hold the per-mechanism and per-profile
    samples; ``metrics`` summarises them (see :func:`evaluate`).
    """

    problem: Problem
    design: Design
    grid: int
    units: list[UnitSamples]
    profiles: list[ProfileSamples]
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

    @property
    def energy(self) -> np.ndarray:
        """Spring energy V = Σ ½k x² + F0 x [J] at every grid point (N,)."""
        return sum(s.energy(self.x[j]) for j, s in enumerate(self.problem.springs))


def _profile_extremes(basis: Basis, c: np.ndarray, phi_hi: float, n: int):
    """Dense samples of ρ and the convexity margin on [0, phi_hi], with refined minima."""
    prof = profile_function(basis)
    phi = np.linspace(0.0, phi_hi, n)
    rho, drho, _, conv = (np.asarray(v).ravel() for v in prof.map(n)(phi, c))
    conv_min = _refine_min(prof, c, phi, conv, 3)
    rho_lo = _refine_min(prof, c, phi, rho, 0)
    rho_hi = -_refine_min(prof, c, phi, -rho, 0, sign=-1.0)
    with np.errstate(divide="ignore", invalid="ignore"):  # 0 where not convex
        curvature = np.where(conv > 0, (rho**2 + drho**2) ** 1.5 / conv, 0.0)
    return phi, rho, conv, conv_min, rho_lo, rho_hi, float(np.min(curvature))


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


def mechanism_samples(problem: Problem, design: Design, u: int, theta: np.ndarray,
                      order: int = EVAL_QUADRATURE_ORDER, wire_arm: str = "quadrature",
                      profile: bool = True, seed=None) -> tuple[UnitSamples, list[ProfileSamples]]:
    """Solve mechanism ``u``'s departure with the rootfinder at ``theta`` and evaluate its port
    quantities (and, with ``profile``, scan ρ and the convexity margin of its profiles).

    ``seed`` = (θ, z) samples (z: unknowns × n), e.g. an NLP's solution, interpolated as
    Newton's start.
    """
    mech = problem.mechanisms[u]
    sl = problem.profile_slices()[u]
    bases = tuple(design.bases[sl])
    structure = (type(mech), bases)
    c = np.concatenate([np.asarray(v, dtype=float) for v in design.coefficients[sl]])
    q = np.asarray(mech.parameter_values(), dtype=float)
    th = np.concatenate([[mech.reference_angle], theta])
    start = None if seed is None else np.vstack([np.interp(th, seed[0], row) for row in seed[1]])
    z, residual = departure_solver(structure).solve(th, c, q, start)
    n = theta.size
    pieces = split_coefficients(bases, c)
    wrapped = [np.asarray(length_function(b, order).map(n)(z[k, 0], z[k, 1:], ck)).ravel()
               for k, (b, ck) in enumerate(zip(bases, pieces))]
    wound = np.asarray(wound_lengths(bases, z[:, 0], c)).ravel()[:, None] + np.vstack(wrapped)
    ports = port_function(structure, problem.torque_model, order, wire_arm).map(n)
    d, arm, _, branch = (np.asarray(v) for v in ports(theta, z[:, 1:], z[:, 0], np.vstack(wrapped),
                                                      wound, c, q))
    margins = np.asarray(margin_function(structure).map(n)(theta, z[:, 1:], c, q, arm))
    unit = UnitSamples(theta, z[:, 1:], z[:, 0], np.maximum(residual[1:], residual[0]),
                       branch.ravel(), d.reshape(-1, n), arm.reshape(-1, n),
                       margins.reshape(-1, n))
    profiles = []
    for k, (b, ck) in enumerate(zip(bases, pieces)):
        # the wrapped range; where the departure failed (NaN), the whole design interval
        phi_hi = float(np.max(z[k])) if np.all(np.isfinite(z[k])) else b.domain[1]
        scan = (_profile_extremes(b, ck, phi_hi, max(20 * n, 2000)) if profile
                else (np.array([]), np.array([]), np.array([]), np.nan, np.nan, np.nan, np.nan))
        profiles.append(ProfileSamples(theta, z[k, 1:], float(z[k, 0]), *scan))
    return unit, profiles


def start_samples(problem: Problem, design: Design, grid: int, order: int) -> list:
    """Per-mechanism samples of ``design`` on a ``grid``-angle grid with quadrature ``order``, for
    :meth:`cadcam.nlp.transcription.Transcription.initial_guess`: departure by the rootfinder,
    port quantities in closed form."""
    return evaluate(problem, design, grid=grid, order=order, wire_arm="closed-form", profile=False).units


def evaluate(problem: Problem, design: Design, grid: int | None = None,
             order: int = EVAL_QUADRATURE_ORDER, wire_arm: str = "quadrature",
             profile: bool = True, seeds=None) -> Evaluation:
    """Evaluate ``design`` on a uniform grid of ``grid`` angles per joint (default: the
    problem's), under the problem's torque model.

    Returns an :class:`Evaluation` whose ``metrics`` hold, in SI units: ``rmse`` and
    ``max_abs_error`` [N·m] per joint over the grid points; ``output_rmse`` and
    ``output_max_abs_error`` [m] per mechanism with an output law (None for the others); ``extension_min``/``extension_max``
    [m] per spring; ``convexity_min`` [m²], ``rho_min``/``rho_max`` [m], ``alpha_max`` [rad]
    per profile over its wrapped range [0, max α]; ``tangency_residual_max``;
    ``sensitivity_integral`` ∫|∂τ_i/∂k_j| [m²·rad^m] per joint and spring (trapezoidal);
    ``objective`` (Johnston2023 Eq. 46/47); ``margins`` (positive = satisfied) and
    ``violations``. ``profile = False`` skips the profile scans (their metrics are then NaN);
    ``seeds`` (per mechanism, see :func:`mechanism_samples`) start the rootfinder from known
    unknowns.
    """
    n = grid or problem.options.grid
    m, S = len(problem.joints), len(problem.springs)
    units, profiles = [], []
    for u, mech in enumerate(problem.mechanisms):
        unit, profs = mechanism_samples(problem, design, u, problem.joints[mech.joint].grid(n),
                                        order, wire_arm, profile, None if seeds is None else seeds[u])
        units.append(unit)
        profiles += profs
    grids = [j.grid(n) for j in problem.joints]
    idx = np.indices((n,) * m).reshape(m, -1)
    N = idx.shape[1]
    theta = np.vstack([grids[i][idx[i]] for i in range(m)])
    rows = [(u, k) for u, mech in enumerate(problem.mechanisms) for k in range(len(mech.ports))]
    D = np.vstack([units[u].d[k, idx[problem.mechanisms[u].joint]] for u, k in rows])
    A = np.vstack([units[u].arm[k, idx[problem.mechanisms[u].joint]] for u, k in rows])
    k = np.array([s.rate for s in problem.springs])
    F0 = np.array([s.preload for s in problem.springs])
    net = problem.network().function().map(N)
    x, tau, jac = (np.asarray(v) for v in net(D, A, k, design.preextension, F0))
    dtau_dk = jac.reshape(m, N, S)
    tau_d = np.vstack([np.asarray(problem.joints[i].target.function(m, i).map(N)(theta)).ravel()
                       for i in range(m)])
    weights = np.prod([trapezoid_weights(grids[i])[idx[i]] for i in range(m)], axis=0)
    ev = Evaluation(problem, design, n, units, profiles, theta, tau, tau_d, x, dtau_dk)
    ev.metrics = _metrics(ev, weights)
    return ev


def rate_deviation(problem: Problem, design: Design, factor: float, springs=None,
                   grid: int | None = None) -> np.ndarray:
    """RMSE per joint [N·m] between the torques of ``design`` with nominal spring rates and with
    the rates of ``springs`` (default all, as Johnston2023's Table 5) multiplied by ``factor``.

    τ is linear in the rates, so with every rate scaled this is |factor − 1| × the RMS torque
    for any design; one spring at a time is what measures robustness.
    """
    nominal = evaluate(problem, design, grid=grid, profile=False)
    changed = evaluate(problem.with_spring_rates(factor, springs), design, grid=grid, profile=False)
    return np.sqrt(np.mean((changed.tau - nominal.tau) ** 2, axis=1))


def _relative(errors, sizes) -> list:
    """errors / sizes per joint (the RMSE against the target's RMS), None where the target is
    zero everywhere."""
    return [float(e / s) if s > 0 else None for e, s in zip(errors, sizes)]


def output_law(mech, theta: np.ndarray) -> np.ndarray:
    """The mechanism's output target x_d [m] at the joint angles ``theta`` [rad]."""
    return np.asarray(mech.output_target.function(1, 0).map(theta.size)(theta)).ravel()


def output_error(mech, unit: UnitSamples):
    """x − x_d [m] of a mechanism's output over its samples, or None without an output law."""
    if mech.output_target is None:
        return None
    return unit.z[mech.unknowns.index(mech.output)] - output_law(mech, unit.theta)


#: The names of an evaluation's metrics (the keys of :attr:`Evaluation.metrics`), which a
#: study may ``record``.
METRIC_NAMES = ("grid", "output_rmse", "output_max_abs_error", "rmse", "relative_rmse", "max_abs_error",
                "extension_min", "extension_max", "convexity_min", "rho_min", "rho_max",
                "curvature_radius_min", "alpha_max", "tangency_residual_max", "sensitivity_integral",
                "objective", "margins", "violations")


def _metrics(ev: Evaluation, weights: np.ndarray) -> dict:
    p = ev.problem
    err = ev.tau - ev.tau_d
    sens = np.einsum("inj,n->ij", np.abs(ev.dtau_dk), weights)
    objective = float(sum(c.tracking_weight * np.dot(err[i] ** 2, weights)
                          + np.dot(c.sensitivity_weights, sens[i]) for i, c in enumerate(p.joints)))
    travel = np.array([s.travel for s in p.springs])
    margins = {
        "travel": (travel - ev.x.max(axis=1)).tolist(),
        "extension_lower": ev.x.min(axis=1).tolist(),
        "convexity": [c.convexity_min for c in ev.profiles],
        "rho_min": [c.rho_lo - pc.rho_min for c, pc in zip(ev.profiles, p.profiles)],
        "rho_max": [pc.rho_max - c.rho_hi for c, pc in zip(ev.profiles, p.profiles)],
        "tangency": [float(RESIDUAL_TOL - u.residual.max()) for u in ev.units],
        "branch": [float(BRANCH_TOL - u.branch.max()) for u in ev.units],
        "preextension": ev.design.preextension.tolist(),
        "curvature_radius": [c.curvature_radius_min - pc.min_curvature_radius
                             for c, pc in zip(ev.profiles, p.profiles)],
        "mechanism": [{name: float(row.min()) for name, row in zip(mech.margin_names, u.margins)}
                      for mech, u in zip(p.mechanisms, ev.units)],
    }
    tol = {"travel": LENGTH_TOL, "extension_lower": LENGTH_TOL, "convexity": 0.0,
           "rho_min": LENGTH_TOL, "rho_max": LENGTH_TOL, "tangency": 0.0, "branch": 0.0,
           "preextension": LENGTH_TOL, "curvature_radius": LENGTH_TOL}
    names = {"travel": "spring above its travel", "extension_lower": "spring in compression",
             "convexity": "profile not convex", "rho_min": "radius below rho_min",
             "rho_max": "radius above rho_max", "tangency": "departure not solved",
             "branch": "cable on the wrong departure branch",
             "preextension": "negative pre-extension",
             "curvature_radius": "radius of curvature below its minimum"}
    violations = []
    for mech, own in zip(p.mechanisms, margins["mechanism"]):
        violations += [f"{name.replace('_', ' ')} below its limit: {mech.name} (margin {v:.3g})"
                       for name, v in own.items() if not v >= -LENGTH_TOL]
    for key, vals in margins.items():
        if key == "mechanism":
            continue
        owner = (p.springs if key in ("travel", "extension_lower", "preextension")
                 else p.mechanisms if key in ("tangency", "branch") else p.profiles)
        for item, v in zip(owner, vals):
            if not v >= -tol[key]:  # NaN (not computable) counts as violated
                violations.append(f"{names[key]}: {item.name} (margin {v:.3g})")
    out_err = [output_error(mech, u) for mech, u in zip(p.mechanisms, ev.units)]
    return {
        "grid": ev.grid,
        "output_rmse": [None if e is None else float(np.sqrt(np.mean(e**2))) for e in out_err],
        "output_max_abs_error": [None if e is None else float(np.abs(e).max()) for e in out_err],
        "rmse": np.sqrt(np.mean(err**2, axis=1)).tolist(),
        "relative_rmse": _relative(np.sqrt(np.mean(err**2, axis=1)), np.sqrt(np.mean(ev.tau_d**2, axis=1))),
        "max_abs_error": np.abs(err).max(axis=1).tolist(),
        "extension_min": ev.x.min(axis=1).tolist(),
        "extension_max": ev.x.max(axis=1).tolist(),
        "convexity_min": margins["convexity"],
        "rho_min": [c.rho_lo for c in ev.profiles],
        "rho_max": [c.rho_hi for c in ev.profiles],
        "curvature_radius_min": [c.curvature_radius_min for c in ev.profiles],
        "alpha_max": [float(c.alpha.max()) for c in ev.profiles],
        "tangency_residual_max": float(max(u.residual.max() for u in ev.units)),
        "sensitivity_integral": sens.tolist(),
        "objective": objective,
        "margins": margins,
        "violations": violations,
    }
