"""cadcam as a library: design, evaluate and check a problem given as a spec file, spec data (a
dict) or a :class:`~cadcam.problem.Problem`, with the command line's options as keyword
arguments.

Examples
--------
>>> import cadcam
>>> result = cadcam.design("models/johnston2023_1dof.toml", grid=24)  # doctest: +SKIP
>>> result.success, result.nit, result.fun                            # doctest: +SKIP
>>> figures = result.plot()                                           # doctest: +SKIP
>>> result.save("out/demo")                                           # doctest: +SKIP
"""
from __future__ import annotations

from typing import Any

import copy
import json
import os
import time
from collections import OrderedDict
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from .verify import derivatives
from .verify.evaluate import FULL_SCAN, MOVING_SCAN, SCAN, Evaluation, start_samples
from .verify.evaluate import evaluate as evaluate_design
from .verify.model import solved_poses, torque_function, torque_jacobian_function
from .verify.reachable import unreachable
from .designs import Design, DesignError
from .files import InputFileError, read_input, short_repr
from .solve import compiled
from .solve.builds import KEPT_BUILDS, built_for, structure_key
from .solve.ipopt import RESOLVE_OPTIONS, SESSION_IPOPT, Multipliers, moving_options
from .solve.predictor import PREDICT
from .solve.transcription import Transcription
from .optimize import completed, optimize, start_design, start_result, warm_optimize
from .problem import SOLVER, Options, Problem, evaluation_size_error, size_error
from .result import Result
from .spec import SpecError, parse_spec, read_spec_data, with_overrides
from .sweep.runner import flat_table, read_rows
from .sweep.study import StudyError

#: The ``[solver]`` keys that may be given as keyword arguments.
SOLVER_KEYS = tuple(f.name for f in fields(Options) if f.name != "ipopt")


def load_problem(spec, *, variant: str | None = None, overrides=None, torque_model: str | None = None,
                 ipopt: dict | None = None, **solver) -> Problem:
    """The problem of ``spec`` with overrides and options applied, checked like a spec file.

    Parameters
    ----------
    spec : str, Path, dict or Problem
        A spec file (TOML) or a cadcam ``result.json``, spec data as a dict (the TOML's
        tables), or a Problem.
    variant : str, optional
        Apply the spec's ``[variants.NAME]`` overrides.
    overrides : dict or list of (key, value), optional
        Dotted-key overrides, as ``--set`` (``{"springs.1.rate": 1200.0}``).
    torque_model : str, optional
        ``energy``, ``force`` or ``force-as-printed``.
    ipopt : dict, optional
        IPOPT options (``{"mu_strategy": "monotone"}``), merged into ``[solver.ipopt]``.
    **solver
        ``[solver]`` keys (:data:`SOLVER_KEYS`: ``grid``, ``multistart``, ``max_iter``, …).

    Raises
    ------
    SpecError
        One line naming the key and the expected form, as for a spec file.
    """
    unknown = sorted(set(solver) - set(SOLVER_KEYS))
    if unknown:
        raise SpecError(f"unknown option {unknown[0]!r}; the [solver] keys are {', '.join(SOLVER_KEYS)}")
    pairs = _override_pairs(overrides)
    if ipopt is not None and not (isinstance(ipopt, dict) and all(isinstance(k, str) for k in ipopt)):
        raise SpecError(f"ipopt = {short_repr(ipopt)}: expected a dict of IPOPT option names to values")
    solver = {k: v.item() if isinstance(v, np.generic) else v for k, v in solver.items()}  # numpy scalars
    if isinstance(spec, Problem):
        if variant is not None:
            raise SpecError("variant: a Problem has no variants; give the spec file instead")
        if not (pairs or torque_model or ipopt or solver):
            return spec
        data, origin, base = spec.to_dict(), f"<problem {spec.name}>", Path(".")
        with_overrides(data, origin, None, pairs)
    elif isinstance(spec, dict):
        data, origin, base = with_overrides(copy.deepcopy(spec), "<spec>", variant, pairs), "<spec>", Path(".")
    elif isinstance(spec, (str, os.PathLike)):
        path = Path(spec)
        data, origin, base = read_spec_data(path, variant, pairs), str(path), path.parent
    else:
        raise SpecError(f"spec: expected a file name, a dict or a Problem, not {type(spec).__name__}")
    if solver or ipopt:
        table = data.setdefault("solver", {})
        if not isinstance(table, dict):
            raise SpecError(f"{origin}: solver: expected a table")
        table.update(solver)
        if ipopt:
            table["ipopt"] = {**table.get("ipopt", {}), **ipopt}
    if torque_model is not None:
        data.pop("friction_model", None)
        data["torque_model"] = torque_model
    problem = parse_spec(data, origin, base)
    too_big = size_error(problem.options, len(problem.joints))
    if too_big:
        raise SpecError(f"{origin}: solver.{too_big[0]}: {too_big[1]}")
    return problem


def _override_pairs(overrides) -> list:
    """``overrides`` (a dict, or (key, value) pairs) as a list of pairs with dotted string keys;
    SpecError for anything else."""
    if overrides is None:
        return []
    pairs = list(overrides.items()) if isinstance(overrides, dict) else overrides
    if not (isinstance(pairs, (list, tuple)) and all(
            isinstance(p, (list, tuple)) and len(p) == 2 and isinstance(p[0], str) for p in pairs)):
        raise SpecError(f"overrides = {short_repr(overrides)}: expected a dict or a list of (key, value) pairs "
                        "with dotted string keys such as 'springs.1.rate'")
    return list(pairs)


def load_design(design, problem: Problem) -> Design:
    """A :class:`Design` for ``problem`` from a Design, a design or result dict, or a JSON file."""
    if isinstance(design, Design):
        return design
    origin = "<design>"
    if isinstance(design, (str, os.PathLike)):
        origin = str(design)
        try:
            design = json.loads(read_input(design))
        except InputFileError as exc:
            raise DesignError(f"{origin}: the design: {exc}") from None
        except (ValueError, RecursionError):
            raise DesignError(f"{origin}: not valid JSON (or nested too deeply)") from None
    return Design.from_dict(design, problem, origin)


def design(spec, *, start=None, **options) -> Result:
    """Design the profiles of ``spec`` and re-check them, as ``cadcam design`` does.

    Parameters
    ----------
    spec : str, Path, dict or Problem
        See :func:`load_problem`.
    start : Design, dict or path, optional
        The first start (default: cadcam's start for the mechanisms).
    **options
        :func:`load_problem`'s keywords (``variant``, ``overrides``, ``torque_model``,
        ``ipopt``, ``grid``, ``multistart``, …).

    Returns
    -------
    Result
        ``success`` only for a converged optimum that passed the fine re-check; ``plot()``,
        ``save(directory)``, ``to_dict()``.
    """
    problem = load_problem(spec, **options)
    refuse_unreachable(problem)
    return optimize(problem, start=None if start is None else load_design(start, problem))


def compile_ahead(spec, *, variant: str | None = None) -> int | None:
    """Compile now, into the cache of compiled libraries (:mod:`cadcam.solve.compiled`), what
    the first design of ``spec`` on the default path (``solver.functions = "auto"``) would
    compile in the background while it solves with expanded functions, so that it loads them
    instead: ``spec`` is designed once with compiled functions, which compiles every library
    its design loads (the NLP's, the NLP's with the outline rows where the design imposes them)
    that the cache does not hold. Returns how many libraries were compiled, or None where a
    design of ``spec`` loads none (its functions expanded or mapped, a method of its own
    designs it, or no C compiler)."""
    problem = load_problem(spec, variant=variant)
    if problem.options.method != "nlp" or problem.options.functions != "auto" or not compiled.available():
        return None
    before = set(compiled.cached_libraries())
    optimize(problem.with_options(functions="compiled"))
    return len(set(compiled.cached_libraries()) - before)


def refuse_unreachable(problem: Problem) -> None:
    """Raise :class:`SpecError`, before any solve, if a joint's target cannot be met within its
    acceptance limits by any design (:func:`cadcam.verify.reachable.unreachable`: the springs'
    energy budget, the sign of their pull)."""
    message = unreachable(problem)
    if message is not None:
        raise SpecError(f"{problem.name}: {message}")


class Session:
    """Design again and again after small edits, as a design page does: each problem
    structure's NLP is built once and kept (:func:`cadcam.solve.builds.built_for`), and each
    design starts warm from the last successful answer of the same structure and its IPOPT
    multipliers, falling back on the default start when that fails or does worse
    (:func:`cadcam.optimize.warm_optimize`).

    Where the default start completes the problem's numbers (a differential pair's cable length
    from Fedorov's envelope of its output law), the last answer starts the next design only if
    the numbers completed are the same (an edit of a limit or a spring's travel, not of the law
    or of a quantity it shares with the target or the springs): an answer made for
    another cable length is a poor start, and the new envelope a close one. After such an
    edit a provisional design (while a slider moves) is that start judged on the design grid,
    without the NLP, and a full one the NLP solved from it (:func:`_from_completing_start`);
    a first design whose NLP fails from such a start is solved from it again
    (:func:`_again_from_start`).

    >>> session = cadcam.Session()
    >>> first = session.design("models/johnston2023_1dof.toml")
    >>> again = session.design("models/johnston2023_1dof.toml", overrides={"springs.1.rate": 1010.0})
    """

    def __init__(self):
        self._last: OrderedDict[str, Result] = OrderedDict()  # as many as builds are kept

    def design(self, spec, *, recheck: bool = True, **options) -> Result:
        """:func:`design` of ``spec`` (``options`` as for :func:`load_problem`), through the
        NLP kept for its structure and from the last answer of that structure; its
        ``build_time_s`` is what this design built (0 through an NLP kept). With ``recheck``
        False, no fine re-check and no refusal of a target out of reach
        (:func:`refuse_unreachable`, milliseconds to tens of them): a provisional design judged
        on the design grid (:func:`cadcam.optimize.optimize`), as while a slider moves, re-solved
        warm with a low cap on IPOPT's barrier and a looser tolerance
        (:func:`cadcam.solve.ipopt.moving_options`: fewer iterations from the last answer),
        from where the last answer moves to
        (:mod:`cadcam.solve.predictor`), its profiles scanned coarser
        (:data:`cadcam.verify.evaluate.MOVING_SCAN`); designed again with it, the same edits
        start from that answer and need few iterations."""
        problem = load_problem(spec, **options)
        if recheck:
            refuse_unreachable(problem)
        if problem.options.method != "nlp":
            return optimize(problem, recheck=recheck)
        # a warm start at the last answer: pushed little off it; provisional, its barrier capped
        # and its tolerance loosened
        token = RESOLVE_OPTIONS.set(SESSION_IPOPT if recheck else moving_options(problem.options.tol))
        predicting = PREDICT.set(not recheck)  # provisional: from where the last answer moves to
        scan = SCAN.set(FULL_SCAN if recheck else MOVING_SCAN)  # and its profiles scanned coarser
        try:
            return self._designed(problem, recheck)
        finally:
            SCAN.reset(scan)
            PREDICT.reset(predicting)
            RESOLVE_OPTIONS.reset(token)

    def _designed(self, problem: Problem, recheck: bool) -> Result:
        """:meth:`design` of ``problem``, whose method is the NLP."""
        completed, start = default = start_design(problem)
        transcription, built = built_for(completed)
        key = structure_key(completed)
        last = self._last.get(key)
        if last is not None and completed is not problem and \
                completed.to_dict()["mechanisms"] != last.problem.to_dict()["mechanisms"]:
            # the default start completed other numbers than the last answer's
            result = _from_completing_start(completed, start, transcription, last, recheck)
        elif last is None:
            result = optimize(completed, transcription=transcription, start=start, recheck=recheck)
            if not result.success and recheck and completed is not problem and transcription.epigraph_names:
                result = _again_from_start(completed, start, transcription, result)
        else:
            result = warm_optimize(problem, transcription, last.design, last.evaluation.metrics.objective,
                                   "the last design", last.solve.multipliers if last.solve else None, default,
                                   recheck=recheck)
        if not built:  # the NLP kept from an earlier design: this design built none of it
            result.build_time_s -= transcription.build_time_s
        if result.success and result.solve is not None and result.solve.multipliers is not None:  # an NLP's answer
            self._last[key] = result
            self._last.move_to_end(key)
            while len(self._last) > KEPT_BUILDS:
                self._last.popitem(last=False)
        return result


def _from_completing_start(problem: Problem, start: Design, transcription: Transcription, last: Result,
                           recheck: bool) -> Result:
    """A session's design of ``problem`` after an edit that its default start ``start``
    completed other numbers for than the last answer ``last`` of its structure had (a
    differential pair's cable length, from Fedorov's envelope of the edited law): an answer
    made for another cable length is a poor start, the new envelope a close one.

    Provisional (not ``recheck``: while a slider moves), the start itself judged on the
    design grid (:func:`cadcam.optimize.start_result`), in a fraction of the NLP's time.
    Otherwise the NLP from the start, its minimax epigraphs above the start's errors
    (:meth:`Transcription.epigraphs_met`), with ``last``'s multipliers (a neighbouring
    problem's duals, of the rows it was solved with: with the deferred rows at once where it
    needed them): from the start as a first design starts it, its epigraph at zero and its
    deferred rows after, an edit of Fedorov2018's balancer's law ran to IPOPT's iteration
    limit. Where that NLP fails,
    the start judged as the answer, the NLP's end in its message."""
    t0 = time.perf_counter()
    if not recheck:
        moving = start_result(problem, start, time.perf_counter() - t0, recheck=False)
        # counted as an NLP's result counts its build: the session deducts a build it kept
        moving.build_time_s = transcription.build_time_s
        return moving
    result = _from_start_above(problem, start, transcription, last.solve.multipliers if last.solve else None)
    how = ("the default start, its epigraphs above its errors, and the last design's multipliers: that design "
           "was made for other numbers")
    if result.success:
        result.message += f" (from {how})"
        return result
    fallback = start_result(problem, start, time.perf_counter() - t0)
    fallback.build_time_s = result.build_time_s  # the NLP tried was built as the result's
    fallback.message += f" (the NLP from {how}, ended {result.status}: {result.message})"
    return fallback if fallback.success else result


def _again_from_start(problem: Problem, start: Design, transcription: Transcription, failed: Result) -> Result:
    """A session's first design of ``problem``, whose NLP from the default start ``start``
    (which completed its numbers) ended ``failed``, solved again from that start with its
    minimax epigraphs above the start's errors and every row at once
    (:func:`_from_start_above`): on Fedorov2018's balancer with a heavier pendulum the first
    can end at the iteration limit where the second converges (and the page's edits then start
    from its answer). The better of the two (the first unless the second succeeds), its
    message saying what was tried."""
    again = _from_start_above(problem, start, transcription, None)
    if not again.success:
        failed.message += f" (solved again from the default start, its epigraphs above its errors: {again.status})"
        return failed
    if again.solve is not None and failed.solve is not None:  # result.json lists both runs
        again.solve.trials = failed.solve.trials + again.solve.trials
    again.message += (f" (from the default start again, its epigraphs above its errors and every row at once: "
                      f"from it as a first design starts, the NLP ended {failed.status})")
    return again


def _from_start_above(problem: Problem, start: Design, tr: Transcription, duals: Multipliers | None) -> Result:
    """:func:`cadcam.optimize.optimize` of ``problem`` (full, re-checked) from its default
    start ``start`` through ``tr``, the start's minimax epigraphs above its errors
    (:meth:`Transcription.epigraphs_met`), from the multipliers ``duals`` of a neighbouring
    problem's answer (with the deferred rows at once where it needed them), or with none
    (None), every row at once."""
    w0, pv = tr.start_point(problem, start, start_samples(problem, start, tr.n, tr.start_order()))
    if duals is None:
        rows, whole = tr.whole_bounds(problem)[0].size, tr.bounds(problem)[0].size
        duals = Multipliers(np.zeros(w0.size), np.zeros(rows), rows > whole)
    warm = Multipliers(duals.lam_x, duals.lam_g, duals.whole, tr.epigraphs_met(w0, pv))
    return optimize(problem, transcription=tr, start=start, warm=warm)


def evaluate(spec, design, *, grid: int | None = None, profile: bool = True, **options) -> Evaluation:
    """Metrics of ``design`` (a Design, dict or JSON file) for ``spec`` on a ``grid``-angle
    grid per joint (default the spec's), as ``cadcam evaluate`` (``profile=False`` skips the
    dense profile scan); ``options`` as for :func:`load_problem`, the problem completed as a
    design run completes it (:func:`cadcam.optimize.completed`). A ``grid`` beyond
    :func:`cadcam.problem.evaluation_size_error`'s caps raises :class:`SpecError`."""
    problem = completed(load_problem(spec, **options))
    grid_ok = SOLVER["grid"].ok
    if grid is not None and grid_ok is not None and not grid_ok(grid):
        raise SpecError(f"grid = {short_repr(grid)}: expected {SOLVER['grid'].form}")
    too_big = None if grid is None else evaluation_size_error(grid, len(problem.joints))
    if too_big:
        raise SpecError(f"grid: {too_big}")
    return evaluate_design(problem, load_design(design, problem), grid=grid, profile=profile)


@dataclass
class DerivativeCheck:
    """Automatic derivatives of a problem against finite differences.

    Attributes
    ----------
    rows : list of cadcam.verify.derivatives.Partial
        One per (function output, input), the worst over the points checked.
    tol : float
        Largest relative error accepted.
    notes : list of str
        What was checked where, and what was not (and why).
    """

    rows: list
    tol: float
    notes: list

    @property
    def passed(self) -> bool:
        return all(r.passed(self.tol) for r in self.rows)

    def __repr__(self) -> str:
        verdict = "every block agrees" if self.passed else "some blocks do NOT agree"
        return "\n".join([derivatives.table(self.rows, self.tol), *self.notes,
                          f"{verdict} within a relative error of {self.tol:g}"])

    def to_dict(self) -> dict:
        return {"tol": self.tol, "passed": self.passed, "notes": self.notes,
                "rows": [{"of": r.of, "wrt": r.wrt, "shape": list(r.shape), "norm": r.norm,
                          "abs_error": r.abs_error, "rel_error": r.rel_error,
                          "passed": r.passed(self.tol)} for r in self.rows]}


#: Typical size of each torque-model input (the floor of the difference step): angles [rad],
#: profile coefficients [m], rates [N/m], pre-extensions [m], preloads [N].
INPUT_SCALE = {"theta": 1.0, "c": 1e-2, "k": 1e3, "x0": 1e-2, "F0": 1.0}


def check_derivatives(spec, design=None, *, points: int = 3, tol: float = 1e-6, nlp: bool = True,
                      seed: int = 0, **options) -> DerivativeCheck:
    """The torque model's and the NLP's automatic derivatives against central differences.

    The torque model (:func:`cadcam.verify.model.torque_function`, the rootfinder form whose
    derivatives come from the implicit function theorem): ∂τ and ∂x with respect to the joint
    angles, the profile coefficients, the spring rates and the pre-extensions, at ``points``
    random poses in the joints' ranges. The NLP (the functions IPOPT calls): the objective's
    gradient, the constraint Jacobian and the Lagrangian's Hessian (random multipliers) at
    the NLP vector of ``design``. Each table row is the worst of its block over the points.

    Parameters
    ----------
    spec : str, Path, dict or Problem
    design : Design, dict or path, optional
        Where to check (default: cadcam's start design for the problem).
    points : int
        Poses of the torque model (1 … 20).
    tol : float
        Largest relative error accepted (Frobenius norms of the block).
    nlp : bool
        Also check the NLP (builds it).
    seed : int
        Seed of the poses, the multipliers and the columns sampled in large blocks.
    """
    if not (isinstance(points, int) and not isinstance(points, bool) and 1 <= points <= 20):
        raise SpecError(f"points = {short_repr(points)}: give 1 … 20 poses")
    if not (isinstance(tol, (int, float)) and not isinstance(tol, bool) and 0 < tol < 1):
        raise SpecError(f"tol = {short_repr(tol)}: give a relative error between 0 and 1")
    problem = load_problem(spec, **options)
    if design is None:
        problem, start = start_design(problem)
    else:
        problem = completed(problem)
        start = load_design(design, problem)
    rng = np.random.default_rng(seed)
    rows, notes = [], []
    if problem.springs:
        rows += _torque_model_partials(problem, start, points, rng)
        notes.append(f"torque model (rootfinder tangency, CasADi's derivatives) and the exported Jacobian "
                     f"(Newton tangency, implicit function theorem by hand): {points} random poses in the "
                     "joints' ranges")
    else:
        notes.append("torque model: not checked (the problem has no springs, so no torque)")
    if nlp and problem.options.method == "nlp":
        rows += _nlp_partials(problem, start, rng)
        notes.append("NLP: at the start design's NLP vector (the functions IPOPT calls)")
    elif nlp:
        notes.append(f"NLP: not checked (solver.method = {problem.options.method!r} builds no NLP)")
    return DerivativeCheck(derivatives.worst(rows), tol, notes)


def _torque_model_partials(problem: Problem, start: Design, points: int, rng: np.random.Generator) -> list:
    """∂τ and ∂x of the torque model (rootfinder tangency, CasADi's derivatives) and of the
    exported Jacobian (Newton tangency, implicit function theorem by hand) against central
    differences, at ``points`` random poses in the joints' ranges, each model started from the
    design's solved poses."""
    poses = solved_poses(problem, start)
    model = torque_function(problem, start.bases, poses=poses)
    springs = problem.spring_parameters()
    point: dict[str, Any] = {"c": np.concatenate(start.coefficients), "x0": start.preextension,
                             "k": springs.rate, "F0": springs.preload}
    lo = np.array([j.theta_range[0] for j in problem.joints])
    hi = np.array([j.theta_range[1] for j in problem.joints])
    newton = torque_function(problem, start.bases, tangency="newton", poses=poses)
    exported = torque_jacobian_function(problem, start.bases, poses=poses)
    rows = []
    for _ in range(points):
        point["theta"] = lo + (hi - lo) * rng.uniform(0.05, 0.95, lo.size)
        rows += derivatives.function_partials(model, point, ["tau", "x"], ["theta", "c", "k", "x0"],
                                              INPUT_SCALE, "torque model")
        rows += _exported_jacobian_partials(newton, exported(**point), point)
    return rows


def _exported_jacobian_partials(newton, jac, point: dict) -> list:
    """The exported Jacobian's blocks ``jac`` at ``point`` against central differences of the
    torque model with Newton tangency, ``newton``."""
    rows = []
    for wrt in ("theta", "c", "k", "x0"):
        for of in ("tau", "x"):
            def value(v, of=of, wrt=wrt):
                return np.asarray(newton(**{**point, wrt: v})[of]).ravel()
            rows.append(derivatives.compare(value, point[wrt], np.asarray(jac[f"d{of}_d{wrt}"]),
                                            f"exported Jacobian: {of}", wrt, INPUT_SCALE[wrt]))
    return rows


def _nlp_partials(problem: Problem, start: Design, rng: np.random.Generator) -> list:
    """The gradient, the constraint Jacobian and the Lagrangian Hessian IPOPT is given, against
    central differences of the objective, the constraints and the gradient of the Lagrangian."""
    tr = Transcription(problem)
    solver = tr.solver
    w, pv = tr.start_point(problem, start, start_samples(problem, start, tr.n, tr.start_order()))
    f, g = solver.get_function("nlp_f"), solver.get_function("nlp_g")
    grad, jac = solver.get_function("nlp_grad_f"), solver.get_function("nlp_jac_g")
    lam = rng.standard_normal(g.size1_out(0))
    upper = np.asarray(solver.get_function("nlp_hess_l")(w, pv, 1.0, lam).full())
    hess = upper + np.triu(upper, 1).T

    def lagrangian_gradient(x):
        return (np.asarray(grad(x, pv)[1]).ravel()
                + np.asarray(jac(x, pv)[1].T @ lam).ravel())

    return [derivatives.compare(lambda x: float(f(x, pv)), w, np.asarray(grad(w, pv)[1]).reshape(1, -1),
                                "NLP: objective", "x", rng=rng),
            derivatives.compare(lambda x: np.asarray(g(x, pv)).ravel(), w,
                                np.asarray(jac(w, pv)[1].full()), "NLP: constraints", "x", rng=rng),
            derivatives.compare(lagrangian_gradient, w, hess, "NLP: Lagrangian gradient (Hessian)", "x", rng=rng)]


def read_study(path):
    """A study database (``cadcam sweep``) as a pandas DataFrame: one row per case with its
    parameters, status and metrics (the columns of ``cadcam sweep-export``).
    :class:`StudyError` for a path that is not a study database."""
    import pandas as pd

    if not isinstance(path, (str, os.PathLike)):
        raise StudyError(f"path = {short_repr(path)}: expected the file name of a study database")
    table = flat_table(*read_rows(path))
    header = dict.fromkeys(k for row in table for k in row)  # every column, in first-seen order
    return pd.DataFrame({name: [row.get(name) for row in table] for name in header})
