"""Design a cam system: solve the NLP (with optional multistarts) and re-check the optimum.

The NLP's answer is trusted only after :func:`cadcam.check.evaluate.evaluate` has re-evaluated it on
a grid ``recheck_factor`` times finer, by the rootfinder and independent quadrature, and found
every constraint satisfied (status ``success``); otherwise the status says what went wrong.
"""
from __future__ import annotations

import numpy as np

from .design import Design
from .check.evaluate import evaluate
from .problem import Problem
from .result import Result
from .nlp.transcription import Transcription


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


def start_samples(tr: Transcription, problem: Problem, design: Design) -> list:
    """Per-mechanism samples of ``design`` on ``tr``'s grid for
    :meth:`Transcription.initial_guess`: departure by the rootfinder, port quantities in closed
    form."""
    ev = evaluate(problem, design, grid=tr.n, order=tr.start_order(), wire_arm="closed-form",
                  profile=False)
    return ev.units


def solve(tr: Transcription, problem: Problem, start: Design):
    """One IPOPT run of ``tr`` from ``start``; see :meth:`Transcription.solve`."""
    return tr.solve(problem, start, start_samples(tr, problem, start))


def optimize(problem: Problem, transcription: Transcription | None = None,
             start: Design | None = None) -> Result:
    """Solve ``problem`` and re-check the optimum.

    Parameters
    ----------
    problem : Problem
    transcription : Transcription, optional
        A solver built for a problem of the same structure (reused across sweep cases).
    start : Design, optional
        First initial guess (default :func:`default_start`); ``problem.options.multistart``
        random starts follow, and the best converged one is kept.

    Returns
    -------
    Result
        ``status`` is ``success`` only for a converged optimum whose fine re-check passed.
    """
    tr = transcription or Transcription(problem)
    rng = np.random.default_rng(problem.options.seed)
    starts = [start or default_start(problem)]
    starts += [random_start(problem, rng) for _ in range(problem.options.multistart)]
    solves = []
    for k, s in enumerate(starts):
        sol = solve(tr, problem, s)
        sol.start = k
        solves.append(sol)
    converged = [s for s in solves if s.status == "converged"]
    best = min(converged or solves, key=lambda s: s.objective if np.isfinite(s.objective) else np.inf)
    best.trials = [{"start": s.start, "status": s.status, "objective": s.objective,
                    "iterations": s.iterations, "solve_time_s": s.solve_time_s} for s in solves]
    # the NLP's tangency angles start the independent rootfinder (the roots it converges to
    # are checked by their residuals either way)
    seeds = [(problem.joints[mech.joint].grid(problem.options.grid), best.z[u])
             for u, mech in enumerate(problem.mechanisms)]
    on_grid = evaluate(problem, best.design, seeds=seeds)
    fine = evaluate(problem, best.design, seeds=seeds,
                    grid=problem.options.recheck_factor * (problem.options.grid - 1) + 1)
    if best.status != "converged":
        status = best.status
        message = f"IPOPT stopped: {best.return_status}"
    elif fine.violations:
        status = "recheck_failed"
        message = "the optimum violates constraints on the fine re-check grid"
    else:
        status = "success"
        message = "converged; every constraint holds on the fine re-check grid"
    return Result(status=status, message=message, problem=problem, design=best.design,
                  evaluation=on_grid, recheck=fine, solve=best, build_time_s=tr.build_time_s)
