"""Design a cam system: solve the NLP (with optional multistarts) and re-check the optimum.

The NLP's answer is trusted only after :func:`cadcam.verify.evaluate.evaluate` has re-evaluated it on
a grid ``recheck_factor`` times finer, by the rootfinder and independent quadrature, and found
every constraint satisfied (status ``success``); otherwise the status says what went wrong.
"""
from __future__ import annotations

import time
from contextvars import ContextVar
from dataclasses import replace

import numpy as np

from .designs import Design, DesignError, default_start, preextensions
from .errors import SpecError
from .mechanisms.base import design_methods, kinds_in
from .verify.evaluate import LIMIT_TOL, MARGINS, evaluate, poses_of, start_samples
from .verify.remedy import SHAPE_MARGINS, next_step
from .problem import ACCEPTANCE, SOLVER, Problem, cap
from .result import Result
from .solve.builds import built_for
from .solve.memory import MemoryBudgetError
from .solve.messages import count, merged
from .solve.ipopt import Multipliers, Solve, joined
from .solve.stall import STALL_STATUS
from .solve.transcription import Transcription


def start_design(problem: Problem) -> tuple[Problem, Design]:
    """The default start design: :func:`default_start`'s circles, then each mechanism kind's
    own start (:meth:`~cadcam.mechanisms.base.Mechanism.prepare_start`: a synthesis the
    mechanism knows, which may also complete its numbers). Returns the problem
    those starts complete and the design."""
    design = default_start(problem)
    for kind in kinds_in(problem.mechanisms):
        problem, design = kind.prepare_start(problem, design)
    return problem, design


def completed(problem: Problem) -> Problem:
    """``problem`` with the numbers its default start completes (:func:`start_design`: a
    differential pair's cable length and anchor angles from Fedorov's envelope, where the spec
    leaves them to it): the problem a design made from the same spec was solved for, against
    which that design is evaluated (with a cable length of zero there is no pose at all)."""
    return start_design(problem)[0]


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
    return Design(bases, coefs, preextensions(problem, lambda s: rng.uniform(0, 0.9 * s.travel)))


def solve(tr: Transcription, problem: Problem, start: Design, warm: Multipliers | None = None) -> Solve:
    """One IPOPT run of ``tr`` from ``start`` (and the multipliers ``warm``); see
    :meth:`Transcription.solve`.

    Where a joint weighs its tolerance band and no multipliers are given, the run starts from
    the optimum without the band, solved first from ``start`` (its iterations and time counted
    in): the band's splits of parts that are zero at a start (every placement part of a circle)
    are pushed up by IPOPT's early barrier with nothing to hold them, and from the mechanisms'
    circular starts that sent Endo2010's ordinary pendulum to the iteration limit at every
    weight tried, and the 1-DOF wire cam to a wider band than without the weight; from the
    optimum without the band, both converged. The robust objective starts likewise from the
    least-squares optimum (:mod:`cadcam.solve.robust`): its builds' errors are a few per cent of
    that design's, which it refines.
    """
    first = None
    if (tr.banded or tr.robust) and warm is None:
        plain = problem.with_weights(band=0.0)
        if tr.robust:
            plain = plain.with_options(objective="least_squares")
        first = solve(built_for(plain)[0], plain, start)
        if first.status == "converged":
            start = first.design
    # a warm start at the answer's own NLP point needs no samples of its design
    samples = None if warm is not None and warm.x is not None else start_samples(problem, start, tr.n,
                                                                                 tr.start_order())
    run = tr.solve(problem, start, samples, warm)
    if first is None:
        return run
    return replace(run, iterations=first.iterations + run.iterations,
                   solve_time_s=first.solve_time_s + run.solve_time_s, history=joined([first.history, run.history]))


#: The end of a provisional design's message (:func:`optimize` without its fine re-check).
PROVISIONAL = "provisional: not yet re-checked on the fine grid"
#: The end of the message of a design whose solve did not converge and that was not re-checked
#: (:data:`RECHECK_UNCONVERGED`).
UNCHECKED = "not re-checked on the fine grid: its solve did not converge"
#: Whether a design whose solve did not converge is re-checked on the fine grid all the same
#: (:func:`_judged`): its status is its solver's either way (:func:`verdict`), and the re-check
#: only adds the fine grid's numbers to its result. A catalogue search, which reports such a
#: spring undecided from its status alone, sets it False (:func:`cadcam.sweep.springs.search_solves`):
#: a re-check that cannot change a verdict is time the search's other springs wait for.
RECHECK_UNCONVERGED: ContextVar[bool] = ContextVar("recheck_unconverged", default=True)
#: Whether a design's evaluation on the design grid scans its profiles (their ρ and convexity
#: margin between the grid's angles, :func:`cadcam.verify.evaluate.evaluate`'s ``profile``)
#: where its fine re-check is made, which scans them itself and judges the design
#: (:func:`_checked`). A catalogue search, which reads the design grid's rmse alone, sets it False
#: (:func:`cadcam.sweep.springs.search_solves`): the scan is most of that evaluation's time;
#: its result's design-grid profile metrics are then NaN.
SCAN_DESIGN_GRID: ContextVar[bool] = ContextVar("scan_design_grid", default=True)
#: The statuses :func:`verdict` gives a design whose solve converged.
VERDICTS = ("success", "not_finite", "recheck_failed", "target_missed")


def verdict(problem: Problem, solve: Solve, fine, what: str, grid: str = "fine re-check") -> tuple[str, str]:
    """Status and message of a design from its solve and its fine re-check ``fine`` (or, for a
    provisional verdict, from the evaluation on the ``grid`` named: ``design``).

    ``success`` only if the solve converged, every number of the re-check is finite, no
    constraint is violated and every joint meets its acceptance limits (:attr:`Joint.limits`:
    the spec's, and by default an RMSE of at most 5 % of the target's RMS, or of its torque
    floor where the target's RMS is below that, :data:`cadcam.problem.TORQUE_FLOOR`); else the first that
    fails: the solver's status, ``not_finite``, ``recheck_failed`` or ``target_missed``.
    """
    m = fine.metrics
    if solve.status == "acceptable":
        return solve.status, (f"IPOPT stopped at its acceptable level ({solve.return_status}), not at its "
                              "tolerance: the design is not an optimum; tighten or drop the acceptable_* options")
    if solve.status == STALL_STATUS:
        return solve.status, (f"IPOPT stopped by the stall rule in force: its primal infeasibility still "
                              f"{solve.history['inf_pr'][-1]:.3g}; neither an optimum nor proof of none")
    if solve.status != "converged":
        return solve.status, f"IPOPT stopped: {solve.return_status}"
    numbers = [m.rmse, m.max_abs_error, m.extension_min, m.extension_max, m.rho_min, m.rho_max,
               m.curvature_radius_min, m.alpha_max]
    numbers += [v for v in m.output_max_abs_error if v is not None]
    if not np.all(np.isfinite(np.concatenate([np.ravel(v) for v in numbers] + [[m.objective]]))):
        return "not_finite", "the re-check has NaN or infinite values: the design cannot be trusted"
    if fine.violations:
        return "recheck_failed", f"{what}, but it violates constraints on the {grid} grid"
    missed = [text for i, joint in enumerate(problem.joints) for key, limit in joint.limits.items()
              if (text := _missed(problem, i, key, m, limit)) is not None]
    if missed:
        return "target_missed", f"{what}, but the target is missed on the {grid} grid: {'; '.join(missed)}"
    return "success", f"{what}; every constraint holds and the target is met on the {grid} grid"


def _missed(problem: Problem, i: int, key: str, m, limit: float) -> str | None:
    """Joint ``i``'s acceptance limit ``key`` = ``limit`` missed by the re-check's metrics
    ``m``, in words with the key that sets it; None where it is met. ``relative_rmse`` is
    judged against the joint's torque floor where its target's RMS is below it
    (:meth:`~cadcam.problem.Problem.floor_acceptance`: a zero target has no relative RMSE)."""
    joint, a, value = problem.joints[i], ACCEPTANCE[key], m[key][i]
    if key == "relative_rmse" and (floor := problem.floor_acceptance(i, limit, m.rmse[i], value)) is not None:
        if m.rmse[i] <= floor[0]:
            return None
        shown = f"RMSE = {1e3 * m.rmse[i]:.4g} N·mm, above its limit {1e3 * floor[0]:.4g} N·mm, {floor[1]}"
        return f"{joint.name!r}: {shown} ([joints.acceptance] {key})"
    if value is None or value <= limit:
        return None
    shown = (f"{100 * value:.3g} %, above its limit {100 * limit:.3g} %" if a.unit == "ratio"
             else f"{value:.4g} {a.unit}, above its limit {limit:.4g} {a.unit}")
    return f"{joint.name!r}: {a.label} = {shown} ([joints.acceptance] {key})"


def _trial(s: Solve) -> dict:
    """One start's line in ``result.json``'s ``solver.trials``."""
    return {"start": s.start, "status": s.status, "objective": s.objective, "iterations": s.iterations,
            "solve_time_s": s.solve_time_s, "warnings": count(s.warnings)}


def _recheck(problem: Problem, design: Design, seeds=None):
    """The fine re-check of ``design`` (:func:`cadcam.verify.evaluate.evaluate` on the problem's
    ``recheck_grid``) and its wall time [s]."""
    t0 = time.perf_counter()
    fine = evaluate(problem, design, seeds=seeds, grid=problem.options.recheck_grid)
    return fine, time.perf_counter() - t0


def _judged(problem: Problem, solved: Solve, on_grid, what: str, recheck: bool, seeds=None):
    """The fine re-check of ``solved``'s design (evaluated on the design grid as ``on_grid``),
    its wall time [s] and the status and message judged on it (:func:`verdict`); without
    ``recheck``, ``on_grid`` judged instead, in 0 s, and the message ends by saying that the
    design is provisional (:data:`PROVISIONAL`); likewise, where ``solved`` did not converge and
    :data:`RECHECK_UNCONVERGED` is False, its message ending with :data:`UNCHECKED`."""
    if not recheck:
        status, message = verdict(problem, solved, on_grid, what, "design")
        return on_grid, 0.0, status, f"{message} ({PROVISIONAL})"
    if solved.status != "converged" and not RECHECK_UNCONVERGED.get():
        status, message = verdict(problem, solved, on_grid, what, "design")
        return on_grid, 0.0, status, f"{message} ({UNCHECKED})"
    fine, recheck_s = _recheck(problem, solved.design, seeds)
    return fine, recheck_s, *verdict(problem, solved, fine, what)


def _synthesis_result(problem: Problem, design: Design, seconds: float, recheck: bool = True,
                      made: tuple[str, str] | None = None) -> Result:
    """The start design re-checked as the answer (a mechanism's own design method,
    :class:`~cadcam.mechanisms.base.DesignMethod`, or ``made``: what made it in the solver's
    words and in the message's): its evaluation on
    the design grid and on the fine grid, and a :class:`Solve` of zero iterations whose
    objective is the largest output error on the design grid [m], or where no mechanism has
    an output law, the largest torque error there [N·m]. Without ``recheck``, provisional
    (:func:`_judged`)."""
    on_grid = evaluate(problem, design)
    errors = [e for e in on_grid.metrics.output_max_abs_error if e is not None] or on_grid.metrics.max_abs_error
    if made is None:
        method = design_methods()[problem.options.method]
        made = (method.title, f"{method.name} design")
    solve = Solve(design=design, status="converged", return_status=made[0],
                  iterations=0, solve_time_s=seconds, objective=max(errors),
                  z=[u.z for u in on_grid.units])
    solve.trials = [_trial(solve)]
    fine, recheck_s, status, message = _judged(problem, solve, on_grid, made[1], recheck)
    result = Result(status=status, message=message, problem=problem,
                    design=replace(design, poses=poses_of(problem, on_grid.units)),
                    evaluation=on_grid, recheck=fine, solve=solve, build_time_s=0.0, recheck_time_s=recheck_s,
                    provisional=not recheck)
    return _with_next_step(result, fine)


def start_result(problem: Problem, design: Design, seconds: float, recheck: bool = True) -> Result:
    """The default start ``design`` of ``problem`` (:func:`start_design`: the mechanisms' own
    synthesis, Fedorov's envelope for a differential pair) judged as the answer, as a design
    method's is (:func:`_synthesis_result`), made in ``seconds``; no NLP solved."""
    return _synthesis_result(problem, design, seconds, recheck,
                             ("the default start (the mechanisms' own synthesis, no NLP)", "the default start"))


def optimize(problem: Problem, transcription: Transcription | None = None,
             start: Design | None = None, warm: Multipliers | None = None, refine: str = "points",
             margins: dict | None = None, recheck: bool = True) -> Result:
    """Solve ``problem`` and re-check the optimum.

    Parameters
    ----------
    problem : Problem
    transcription : Transcription, optional
        A solver built for a problem of the same structure (reused across sweep cases).
    start : Design, optional
        First initial guess (default :func:`start_design`, which may also complete the
        problem's mechanisms);
        ``problem.options.multistart`` random starts follow, and the converged one of the
        lowest objective is kept, or, where it fails its re-check, the next that passes.
    warm : Multipliers, optional
        The multipliers of the answer ``start`` is, to solve from it warm (the first start).
    refine : str
        How an optimum that broke only its profile's shape between the NLP's check points is
        solved again: one of :data:`REFINEMENTS`.
    margins : dict, optional
        Options of :data:`MARGIN_KEYS` to solve the NLP with, raised above ``problem``'s (the
        margins the answer ``start`` needed, :func:`_margin_refined`); every answer is
        re-checked and judged against ``problem`` itself.
    recheck : bool
        False: no fine re-check (a design shown while a slider moves, re-checked once it
        stops): the result is judged on the design grid alone, its ``recheck`` is its
        evaluation there, ``provisional`` is True and its message says so; an optimum that
        breaks its shape there is not solved again.

    Returns
    -------
    Result
        ``status`` is ``success`` only for a converged optimum whose fine re-check passed.
        With a mechanism's own ``problem.options.method`` (not ``"nlp"``) the start design is
        the answer: no NLP is built, and ``success`` means that it passed the fine re-check.

    Raises
    ------
    SpecError, DesignError
        ``problem`` not a Problem, ``start`` neither None nor a Design (one line).
    """
    _refuse_other_types(problem, start)
    t0 = time.perf_counter()
    if start is None:
        problem, start = start_design(problem)
    if problem.options.method != "nlp":
        return _synthesis_result(problem, start, time.perf_counter() - t0, recheck)
    tr = transcription or Transcription(problem)
    rng = np.random.default_rng(problem.options.seed)
    starts = [start]
    starts += [random_start(problem, rng) for _ in range(problem.options.multistart)]
    solved = problem.with_options(**margins) if margins else problem
    solves = []
    for k, s in enumerate(starts):
        sol = solve(tr, solved, s, warm if k == 0 else None)
        sol.start, sol.margins = k, dict(margins or {})
        solves.append(sol)
    converged = [s for s in solves if s.status == "converged"]
    ranked = sorted(converged or solves, key=lambda s: s.objective if np.isfinite(s.objective) else np.inf)
    trials, warnings = [_trial(s) for s in solves], merged([s.warnings for s in solves])
    for candidate in ranked:  # each keeps the run's trials and warnings, every start's
        candidate.trials, candidate.warnings = trials, warnings
    best = _verified(problem, tr, ranked[0], refine, recheck)
    if best.status == "success" or not converged:
        return best
    for other in ranked[1:]:
        result = _verified(problem, tr, other, refine, recheck)
        if result.status == "success":
            result.message += (f" (from start {other.start}: the lowest objective, start "
                               f"{best.solve.start}'s, ended {best.status})")
            return result
    return best


def _refuse_other_types(problem, start) -> None:
    """:func:`optimize`'s refusal of a ``problem`` or ``start`` of another type, in one line."""
    if not isinstance(problem, Problem):
        raise SpecError(f"problem: expected a Problem (cadcam.load_problem makes one from a spec), not "
                        f"{type(problem).__name__}")
    if start is not None and not isinstance(start, Design):
        raise DesignError(f"start: expected a Design (cadcam.load_design makes one from a dict or a design "
                          f"file) or None, not {type(start).__name__}")


def _verified(problem: Problem, tr: Transcription, solved: Solve, refine: str = "points",
              recheck: bool = True) -> Result:
    """:func:`_checked` of ``solved``, solved again as ``refine`` says (:data:`REFINEMENTS`)
    where its profile broke its shape between the check points; where it still fails its
    re-check, its message ends with the next step (:func:`_with_next_step`). Without
    ``recheck``, :func:`_checked`'s provisional result alone."""
    result = _checked(problem, tr, solved, recheck)
    if result.status != "recheck_failed" or not recheck:
        return result
    last = result  # the re-check the next step is read from: the last one made
    if _broken_between_checks(result.recheck):
        result, last = REFINEMENTS[refine](result, tr)
    return _with_next_step(result, last.recheck, last.problem.options.convexity_points)


def _with_next_step(result: Result, fine, tried: int = 0) -> Result:
    """``result``, where it failed its re-check, with what to change and by how much
    (:func:`cadcam.verify.remedy.next_step` of the re-check ``fine``, after solves given
    ``tried`` check points) ending its message."""
    step = next_step(fine, tried) if result.status == "recheck_failed" else None
    if step is not None:
        result.message += f"; next: {step}"
    return result


def _checked(problem: Problem, tr: Transcription, best: Solve, recheck: bool = True) -> Result:
    """The result of the solve ``best`` of ``tr``: evaluated on the design grid, re-checked on
    the fine one and judged (:func:`verdict`); without ``recheck``, judged on the design grid
    and provisional (:data:`PROVISIONAL` ends its message)."""
    # a mount the NLP placed is where the part is re-checked, drawn and written for
    problem = problem.placed(best.placements)
    # the NLP's tangency angles start the independent rootfinder (the roots it converges to
    # are checked by their residuals either way)
    seeds = [(problem.joints[mech.joint].grid(problem.options.grid), best.z[u])
             for u, mech in enumerate(problem.mechanisms)]
    on_grid = evaluate(problem, best.design, seeds=seeds, profile=not recheck or SCAN_DESIGN_GRID.get())
    fine, recheck_s, status, message = _judged(problem, best, on_grid, "converged", recheck, seeds)
    if best.margins:
        message += f" (solved with {_margin_words(best.margins)})"
    # the result's design keeps the poses it was checked at: re-evaluated from result.json, it
    # starts the rootfinder there and finds the same roots
    return Result(status=status, message=message, problem=problem,
                  design=replace(best.design, poses=poses_of(problem, on_grid.units)),
                  evaluation=on_grid, recheck=fine, solve=best, build_time_s=tr.build_time_s,
                  recheck_time_s=recheck_s, functions=tr.functions_used, provisional=not recheck)


#: How many times the check points a design that broke only its shape between them is
#: solved again with (from its own optimum).
CHECK_REFINEMENT = 4


def _broken_between_checks(fine) -> bool:
    """Whether the fine re-check ``fine`` found only shape margins (:data:`SHAPE_MARGINS`)
    broken: what more check points can mend."""
    margins = fine.metrics.margins
    broken = {key for key, (_, tol, _) in MARGINS.items() if not all(v >= -tol for v in margins[key])}
    own = any(not m[lim.name] >= -LIMIT_TOL[lim.unit]
              for mech, m in zip(fine.problem.mechanisms, margins["mechanism"]) for lim in mech.limits)
    return bool(broken) and broken <= set(SHAPE_MARGINS) and not own


def _refined(result: Result, tr: Transcription) -> tuple[Result, Result]:
    """``result``, whose profile broke its shape between the NLP's check points, solved again
    from its own optimum with :data:`CHECK_REFINEMENT` times the points (within their cap); the
    new result where it passes, else ``result`` with a note of the attempt; and the last
    result made (the new one wherever it was solved)."""
    problem = result.problem
    points = min(CHECK_REFINEMENT * problem.options.convexity_points, cap("convexity_points"))
    if points <= problem.options.convexity_points:
        return result, result
    finer = replace(problem, options=replace(problem.options, convexity_points=points))
    try:
        finer_tr = Transcription(finer)
    except MemoryBudgetError:  # the design stands as it was re-checked
        result.message += f" (not solved again with {points} convexity check points: beyond the memory budget)"
        return result, result
    again = solve(finer_tr, finer, result.design)
    # its multipliers are of the finer NLP's rows: no warm start of the spec's own NLP
    again.multipliers = None
    again.start = result.solve.start
    again.trials = result.solve.trials + [_trial(again)]
    again.warnings = merged([result.solve.warnings, again.warnings])
    refined = _checked(finer, finer_tr, again)
    refined.build_time_s += tr.build_time_s
    before = (f"the design with {problem.options.convexity_points} convexity check points broke its shape "
              f"between them; solved again from it with {points}")
    if refined.status == "success":
        refined.message += f" ({before})"
        return refined, refined
    result.message += f" ({before}: {refined.status})"
    return result, refined


#: The solver options :func:`_margin_refined` raises: the reserves the NLP keeps from a shape's
#: limits at its check points.
MARGIN_KEYS = ("convexity_epsilon", "limit_margin")
#: How many times :func:`_margin_refined` raises the margins, each time from the last answer.
MARGIN_ATTEMPTS = 3
#: Each attempt of :func:`_margin_refined` raises a broken margin's reserve in the NLP by this
#: many times the depth the re-check found it broken by.
MARGIN_STEP = 2.0


def _raised_margins(problem: Problem, solved: Problem, fine) -> Problem | None:
    """``solved`` (``problem`` with its margins as its last answer was solved with) with the
    reserves of the shape margins the fine re-check ``fine`` found broken raised by
    :data:`MARGIN_STEP` times their depth: ``convexity_epsilon`` for a convexity margin, the
    ``limit_margin`` for a radius (ρ bounds and radius of curvature; it also keeps the springs'
    travel further inside). None where nothing is broken or the limit margin would reach its cap."""
    margins, eps, limit = fine.metrics.margins, solved.options.convexity_epsilon, solved.options.limit_margin
    for k, prof in enumerate(problem.profiles):
        depths = {"convexity": -margins["convexity"][k] / prof.rho_min**2,
                  "rho_min": -margins["rho_min"][k] / prof.rho_min,
                  "rho_max": -margins["rho_max"][k] / prof.rho_max,
                  "curvature_radius": (-margins["curvature_radius"][k] / prof.min_curvature_radius
                                       if prof.min_curvature_radius > 0 else 0.0)}
        if depths["convexity"] > 0:
            eps = max(eps, solved.options.convexity_epsilon + MARGIN_STEP * depths["convexity"])
        radius = max(depths["rho_min"], depths["rho_max"], depths["curvature_radius"])
        if radius > 0:
            limit = max(limit, solved.options.limit_margin + MARGIN_STEP * radius)
    unchanged = (eps, limit) == (solved.options.convexity_epsilon, solved.options.limit_margin)
    if unchanged or not limit < SOLVER["limit_margin"].high:
        return None
    return solved.with_options(convexity_epsilon=eps, limit_margin=limit)


def _margin_refined(result: Result, tr: Transcription) -> tuple[Result, Result]:
    """``result``, whose profile broke its shape between the NLP's check points, solved again
    in the same build, warm from its own optimum, with the broken margins' reserves raised
    (:func:`_raised_margins`), up to :data:`MARGIN_ATTEMPTS` times: the answer re-checked
    against ``result``'s own problem where it passes, else ``result`` with a note of the
    attempts; and the last of those re-checked (as :func:`_refined`). A fraction of a second where :func:`_refined` builds a larger NLP and solves it
    cold (on the tutorial's catalogue springs: 3–25 s, and for half of them to the iteration
    limit)."""
    problem, last = result.problem, result
    solved = problem.with_options(**result.solve.margins)
    for _ in range(MARGIN_ATTEMPTS):
        raised = _raised_margins(problem, solved, last.recheck)
        if raised is None:
            break
        solved = raised
        again = solve(tr, solved, last.design, last.solve.multipliers)
        again.start, again.margins = result.solve.start, {k: getattr(solved.options, k) for k in MARGIN_KEYS}
        again.trials = last.solve.trials + [_trial(again)]
        again.warnings = merged([last.solve.warnings, again.warnings])
        last = _checked(problem, tr, again)
        if last.status == "success" or not (last.status == "recheck_failed" and _broken_between_checks(last.recheck)):
            break
    before = (f"the design with {problem.options.convexity_points} convexity check points broke its shape "
              "between them; solved again from it with its margins raised")
    if last is not result and last.status == "success":
        last.message += f" ({before})"
        return last, last
    result.message += f" ({before}: {last.status})" if last is not result else \
        " (its shape margins could not be raised further to mend it)"
    return result, last


def _margin_words(margins: dict) -> str:
    """Raised margins (:data:`MARGIN_KEYS`) in words."""
    return (f"the convexity margin ε = {margins['convexity_epsilon']:.3g} ρ_min² and the limit margin "
            f"{margins['limit_margin']:.3g}")


#: The ways :func:`optimize` solves again an optimum that broke only its profile's shape
#: between the NLP's check points (``refine``): ``points``, with :data:`CHECK_REFINEMENT` times
#: the check points (:func:`_refined`, ``cadcam design``'s); ``margin``, with the broken
#: margins' reserves raised in the same NLP (:func:`_margin_refined`, a catalogue search's).
REFINEMENTS = {"points": _refined, "margin": _margin_refined}


#: A warm-started design whose objective is worse than its start's by more than this fraction
#: is solved again from the default start, and the better of the two kept: a warm start can
#: lead IPOPT into a worse basin (measured on the 1-DOF bench sweep: up to +79 %).
WARM_GUARD = 0.10


def warm_optimize(problem: Problem, transcription: Transcription, start: Design | None,
                  start_objective: float | None, start_name: str, warm: Multipliers | None = None,
                  default: tuple[Problem, Design] | None = None, refine: str = "points",
                  margins: dict | None = None, retry: bool = True, recheck: bool = True) -> Result:
    """:func:`optimize` from ``start``, the design of a neighbouring problem named
    ``start_name`` whose objective was ``start_objective`` (a sweep's nearest case, a design
    session's last answer), with that answer's multipliers ``warm`` if given; and again from
    the default start when the warm start fails (unless not ``retry``) or ends worse than that
    objective by more than :data:`WARM_GUARD`; the better is kept and its message says which
    start it came from. Without ``start``, :func:`optimize`.

    The problem solved, warm or cold, is the one the default start completes
    (:func:`start_design`: a differential pair's cable length from the envelope of this
    problem's output law), so that a warm design answers the problem a cold one would;
    ``default`` is what :func:`start_design` gives for ``problem``, if the caller has it;
    ``refine`` and ``recheck`` as :func:`optimize`'s; ``margins`` those ``start`` was solved
    with, for the warm solve alone (:func:`optimize`).
    """
    problem, cold_start = default or start_design(problem)
    if start is None:
        return optimize(problem, transcription=transcription, start=cold_start, refine=refine, recheck=recheck)
    result = optimize(problem, transcription=transcription, start=start, warm=warm, refine=refine,
                      margins=margins, recheck=recheck)
    if not result.success and not retry:
        result.message += f" (warm start from {start_name}; not tried again from the default start)"
    elif not result.success:  # a warm start that did not help: start afresh
        result = optimize(problem, transcription=transcription, start=cold_start, refine=refine, recheck=recheck)
        result.message += " (from the default start, after a failed warm start)"
    elif start_objective is not None and \
            result.evaluation.metrics.objective > (1 + WARM_GUARD) * start_objective:
        # a worse basin? compare
        cold = optimize(problem, transcription=transcription, start=cold_start, refine=refine, recheck=recheck)
        warm_objective = result.evaluation.metrics.objective
        if cold.success and cold.evaluation.metrics.objective < warm_objective:
            result = cold
            result.message += (f" (from the default start: the warm start from {start_name} "
                               f"reached a worse objective, {warm_objective:.6g})")
        else:
            result.message += f" (warm start from {start_name} kept: the default start did no better)"
    else:
        result.message += f" (warm start from {start_name})"
    return result
