"""Design a cam system: solve the NLP (with optional multistarts) and re-check the optimum.

The NLP's answer is trusted only after :func:`cadcam.verify.evaluate.evaluate` has re-evaluated it on
a grid ``recheck_factor`` times finer, by the rootfinder and independent quadrature, and found
every constraint satisfied (status ``success``); otherwise the status says what went wrong.
"""
from __future__ import annotations

import time
from dataclasses import replace

import casadi as ca
import numpy as np

from .designs import Design
from .mechanisms.anchored_pulley.model import AnchoredPulley
from .mechanisms.differential_pulley.model import DifferentialPulley
from .mechanisms.differential_pulley.fedorov_envelope import cable_length, differential_envelopes, fit_pulley
from .mechanisms.anchored_pulley.kim_deshpande import closed_form, fit_profile
from .verify.evaluate import evaluate, start_samples
from .problem import Problem
from .result import Result
from .solve.transcription import Solve, Transcription


def default_start(problem: Problem) -> Design:
    """Circular profiles of each mechanism's start radius
    (:meth:`cadcam.mechanisms.base.Mechanism.start_radius`) and pre-extensions at 10 % of travel
    (or the spring's fixed pre-extension)."""
    bases, coefs = [], []
    for mech in problem.mechanisms:
        for prof in mech.profiles:
            m = np.zeros(prof.basis.size)
            m[0] = mech.start_radius(prof)
            bases.append(prof.basis)
            coefs.append(prof.basis.from_monomial(m))
    return Design(bases, coefs, _preextensions(problem, lambda s: 0.1 * s.travel))


def closed_form_start(problem: Problem, shares=None, samples: int = 400) -> Design:
    """A start from Kim & Deshpande's closed form (Ludovico2021 Sec. II): each anchored-spring
    pulley shaped for its share of its joint's torque, fitted in its basis; other profiles
    start as in :func:`default_start`.

    Parameters
    ----------
    problem : Problem
        Every anchored pulley needs a spring of its own on its ``cable`` port; its fixed
        pre-extension (else 10 % of travel) is the extension u₀ at its reference angle.
    shares : dict, optional
        Mechanism index → callable θ [rad] → that pulley's torque ∂V_u/∂θ [N·m] (cadcam's
        sign); by default a pulley alone on its joint takes the joint's whole target (a target
        of that joint's angle only).
    samples : int
        Joint angles at which the closed form is evaluated and fitted.

    Returns
    -------
    Design
        The fitted profiles; where the closed form is infeasible (a cusp, a non-regular point)
        the fit is only a start, which the NLP then corrects.
    """
    start = default_start(problem)
    coefs = list(start.coefficients)
    slices = problem.profile_slices()
    for u, mech in enumerate(problem.mechanisms):
        if not isinstance(mech, AnchoredPulley):
            continue
        joint = problem.joints[mech.joint]
        share = (shares or {}).get(u)
        if share is None:
            if sum(m.joint == mech.joint for m in problem.mechanisms) > 1:
                raise ValueError(f"mechanism {mech.name!r} shares its joint: give its torque share")
            share = _own_target(problem, mech.joint)
        own = [s for s in problem.springs if [(p.mechanism, p.name) for p in s.ports] == [(u, "cable")]]
        if len(own) != 1:
            raise ValueError(f"mechanism {mech.name!r} needs one spring of its own on its cable port")
        spring = own[0]
        u0 = spring.preextension if spring.preextension is not None else 0.1 * spring.travel
        ell, chi0, sigma = mech.parameter_values()[:3]
        theta = np.linspace(*joint.theta_range, samples)
        form = closed_form(lambda th, f=share: sigma * f(th), theta, mech.reference_angle,
                           spring.rate, u0, ell, spring.preload, chi0)
        k = slices[u].start
        coefs[k] = fit_profile(problem.profiles[k].basis, *_uniform_polar(form.envelope, samples))
    return Design(start.bases, coefs, start.preextension)


def differential_start(problem: Problem, design: Design, samples: int = 2001):
    """Fedorov's envelope pulleys (Fedorov2018 Sec. 2.2) as the start of every differential pair
    without a ``cable_length``: shaped for its output law (or, without one, circles at its
    start distance), transferring cable at its rolling radius
    (:meth:`~cadcam.mechanisms.differential_pulley.model.DifferentialPulley.start_radius`).

    Returns the problem with those pairs' anchor angles and cable lengths set from the start
    (the NLP then keeps the cable length) and ``design`` with their profiles replaced.
    """
    mechanisms, coefs = list(problem.mechanisms), list(design.coefficients)
    for u, (mech, sl) in enumerate(zip(problem.mechanisms, problem.profile_slices())):
        if not isinstance(mech, DifferentialPulley) or mech.cable_length > 0:
            continue
        theta = np.linspace(*problem.joints[mech.joint].theta_range, samples)
        x, dx = _law(mech, theta)
        mech, envs = differential_envelopes(mech, theta, x, dx, mech.start_radius(mech.profiles[0]))
        fitted = [fit_pulley(p.basis, env) for p, env in zip(mech.profiles, envs)]
        k = int(np.argmin(np.abs(theta - mech.reference_angle)))
        length = cable_length(mech, fitted, theta[k], x[k], [env.phi_polar[k] for env in envs])
        mechanisms[u] = replace(mech, cable_length=length)
        coefs[sl] = fitted
    return (replace(problem, mechanisms=tuple(mechanisms)),
            Design(design.bases, coefs, design.preextension))


def _law(mech: DifferentialPulley, theta: np.ndarray):
    """x(θ) [m] and dx/dθ [m/rad] of a pair's output law (constant without one)."""
    if mech.output_target is None:
        return np.full_like(theta, mech.slider_start()), np.zeros_like(theta)
    t = ca.SX.sym("theta")
    x = mech.output_target.expression([t], 0)
    f = ca.Function("law", [t], [x, ca.jacobian(x, t)]).map(theta.size)
    return tuple(np.asarray(v).ravel() for v in f(theta))


def _own_target(problem: Problem, i: int):
    """Joint ``i``'s target as a vectorised callable of its own angle [rad] (the others at 0:
    for targets that depend on their own joint's angle only)."""
    f = problem.joints[i].target.function(len(problem.joints), i)

    def target(theta):
        theta = np.asarray(theta, dtype=float)
        angles = np.zeros((len(problem.joints), theta.size))
        angles[i] = theta.ravel()
        return np.asarray(f.map(theta.size)(angles)).reshape(theta.shape)
    return target


def _uniform_polar(env, samples: int):
    """The envelope's polar samples (φ, ρ) resampled uniformly in φ (the departure point can
    sweep fast where the moment arm changes fast), continued linearly down to the anchor
    φ = 0 (a convex continuation: ρ″ = 0)."""
    order = np.argsort(env.phi_polar)
    phi, rho = env.phi_polar[order], env.rho[order]
    lo = max(phi[0], 0.0)
    grid = np.linspace(lo, phi[-1], samples)
    values = np.interp(grid, phi, rho)
    slope = (values[1] - values[0]) / (grid[1] - grid[0])
    head = np.linspace(0.0, lo, max(int(samples * lo / (phi[-1] - lo + 1e-12)), 2), endpoint=False)
    return np.concatenate([head, grid]), np.concatenate([values[0] + slope * (head - lo), values])


def _preextensions(problem: Problem, free) -> np.ndarray:
    """Each spring's fixed pre-extension, or ``free(spring)`` where it is a design variable."""
    return np.array([free(s) if s.preextension is None else s.preextension for s in problem.springs])


def random_start(problem: Problem, rng: np.random.Generator) -> Design:
    """A random convex start: ρ = ρ₀ + sφ with ρ₀ ∈ [ρ_min, 3ρ_min], s ∈ [0, ρ₀/2] per rad,
    pre-extensions uniform in [0, 0.9 travel]."""
    bases, coefs = [], []
    for prof in problem.profiles:
        hi = min(3 * prof.rho_min, prof.rho_max)
        rho0 = rng.uniform(prof.rho_min, 0.5 * (prof.rho_min + hi))
        m = np.zeros(prof.basis.size)
        m[0] = rho0
        if prof.basis.order >= 1:
            m[1] = rng.uniform(0, 0.5 * rho0)
        bases.append(prof.basis)
        coefs.append(prof.basis.from_monomial(m))
    return Design(bases, coefs, _preextensions(problem, lambda s: rng.uniform(0, 0.9 * s.travel)))


def solve(tr: Transcription, problem: Problem, start: Design):
    """One IPOPT run of ``tr`` from ``start``; see :meth:`Transcription.solve`."""
    return tr.solve(problem, start, start_samples(problem, start, tr.n, tr.start_order()))


#: The statuses :func:`verdict` gives a design whose solve converged.
VERDICTS = ("success", "not_finite", "recheck_failed", "target_missed")


def verdict(problem: Problem, solve: Solve, fine, what: str) -> tuple[str, str]:
    """Status and message of a design from its solve and its fine re-check ``fine``.

    ``success`` only if the solve converged, every number of the re-check is finite, no
    constraint is violated and every joint's ``acceptance`` limits hold; else the first that
    fails: the solver's status, ``not_finite``, ``recheck_failed`` or ``target_missed``.
    """
    m = fine.metrics
    if solve.status != "converged":
        return solve.status, f"IPOPT stopped: {solve.return_status}"
    numbers = [m[k] for k in ("rmse", "max_abs_error", "extension_min", "extension_max", "rho_min",
                              "rho_max", "curvature_radius_min", "alpha_max")]
    numbers += [v for v in m["output_max_abs_error"] if v is not None]
    if not np.all(np.isfinite(np.concatenate([np.ravel(v) for v in numbers] + [[m["objective"]]]))):
        return "not_finite", "the re-check has NaN or infinite values: the design cannot be trusted"
    if fine.violations:
        return "recheck_failed", f"{what}, but it violates constraints on the fine re-check grid"
    missed = [f"{joint.name!r}: {key.replace('_', ' ')} {m[key][i]:.4g} N·m > {limit:.4g}"
              for i, joint in enumerate(problem.joints) for key, limit in joint.acceptance
              if not m[key][i] <= limit]
    if missed:
        return "target_missed", f"{what}, but the target is missed on the fine re-check: {'; '.join(missed)}"
    return "success", f"{what}; every constraint holds on the fine re-check grid"


def _trial(s: Solve) -> dict:
    """One start's line in ``result.json``'s ``solver.trials``."""
    return {"start": s.start, "status": s.status, "objective": s.objective, "iterations": s.iterations,
            "solve_time_s": s.solve_time_s}


def _recheck(problem: Problem, design: Design, seeds=None):
    """The fine re-check of ``design`` (:func:`cadcam.verify.evaluate.evaluate` on the problem's
    ``recheck_grid``) and its wall time [s]."""
    t0 = time.perf_counter()
    fine = evaluate(problem, design, seeds=seeds, grid=problem.options.recheck_grid)
    return fine, time.perf_counter() - t0


def _synthesis_result(problem: Problem, design: Design, seconds: float) -> Result:
    """The start design re-checked as the answer (``method = "envelope"``): its evaluation on
    the design grid and on the fine grid, and a :class:`Solve` of zero iterations whose
    objective is the largest output error on the design grid [m]."""
    on_grid = evaluate(problem, design)
    fine, recheck_s = _recheck(problem, design)
    errors = [e for e in on_grid.metrics["output_max_abs_error"] if e is not None]
    solve = Solve(design=design, status="converged", return_status="Fedorov2018 envelope synthesis (no NLP)",
                  iterations=0, solve_time_s=seconds, objective=max(errors),
                  z=[u.z for u in on_grid.units])
    solve.trials = [_trial(solve)]
    status, message = verdict(problem, solve, fine, "envelope design")
    return Result(status=status, message=message, problem=problem, design=design,
                  evaluation=on_grid, recheck=fine, solve=solve, build_time_s=0.0, recheck_time_s=recheck_s)


def optimize(problem: Problem, transcription: Transcription | None = None,
             start: Design | None = None) -> Result:
    """Solve ``problem`` and re-check the optimum.

    Parameters
    ----------
    problem : Problem
    transcription : Transcription, optional
        A solver built for a problem of the same structure (reused across sweep cases).
    start : Design, optional
        First initial guess (default :func:`default_start`, with Fedorov's envelope pulleys for
        differential pairs: :func:`differential_start`, which also sets their cable lengths);
        ``problem.options.multistart`` random starts follow, and the best converged one is
        kept.

    Returns
    -------
    Result
        ``status`` is ``success`` only for a converged optimum whose fine re-check passed.
        With ``problem.options.method == "envelope"`` the start design is the answer: no NLP
        is built, and ``success`` means that it passed the fine re-check.
    """
    t0 = time.perf_counter()
    if start is None:
        problem, start = differential_start(problem, default_start(problem))
    if problem.options.method == "envelope":
        return _synthesis_result(problem, start, time.perf_counter() - t0)
    tr = transcription or Transcription(problem)
    rng = np.random.default_rng(problem.options.seed)
    starts = [start]
    starts += [random_start(problem, rng) for _ in range(problem.options.multistart)]
    solves = []
    for k, s in enumerate(starts):
        sol = solve(tr, problem, s)
        sol.start = k
        solves.append(sol)
    converged = [s for s in solves if s.status == "converged"]
    best = min(converged or solves, key=lambda s: s.objective if np.isfinite(s.objective) else np.inf)
    best.trials = [_trial(s) for s in solves]
    # the NLP's tangency angles start the independent rootfinder (the roots it converges to
    # are checked by their residuals either way)
    seeds = [(problem.joints[mech.joint].grid(problem.options.grid), best.z[u])
             for u, mech in enumerate(problem.mechanisms)]
    on_grid = evaluate(problem, best.design, seeds=seeds)
    fine, recheck_s = _recheck(problem, best.design, seeds)
    status, message = verdict(problem, best, fine, "converged")
    return Result(status=status, message=message, problem=problem, design=best.design,
                  evaluation=on_grid, recheck=fine, solve=best, build_time_s=tr.build_time_s,
                  recheck_time_s=recheck_s)
