"""IPOPT on the design NLP: the solver and its options (:func:`_ipopt_solver`,
:func:`_ipopt_options`, :data:`MU_MAX`, :data:`WARM_IPOPT`), how a build evaluated its
functions, what a run returns (:class:`Solve`, :class:`Multipliers`, :data:`IPOPT_STATUS`,
:func:`iteration_history`) and the signal handling around a run (:func:`signals_kept`)."""
from __future__ import annotations

import contextlib
import signal
import threading
from contextvars import ContextVar
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..designs import Design
from . import compiled
from ..interrupts import STOPPING
from ..library_files import ipopt_options
from ..problem import Options
from .stall import STALL_STATUS, StallRule, stall_watch, watched

#: The largest barrier parameter IPOPT's adaptive μ may choose, in the NLP's scaled units (mm,
#: mm², the objective at :data:`cadcam.solve.objective.OBJECTIVE_SCALE`). IPOPT's own cap is a
#: thousand times the start's average complementarity: from a circular start, whose slacks in
#: mm² are large, it chose a μ orders of magnitude above the objective's scale on the first
#: iteration, the iterates left every row's neighbourhood, and Ludovico2021's pendulum ended
#: at max_iterations on most grids between 21 and 51 angles (``make convergence`` measures
#: it). A cap of 1 does as well there, but leads Endo2010's inverted pendulum to a worse
#: optimum next to a fold of its departure.
MU_MAX = 10.0
#: IPOPT options of a solve that starts from an optimum and its multipliers: the solve that
#: imposes the deferred rows (from the optimum without them) and a warm re-solve after a small
#: edit (from the last answer, :class:`Multipliers`). Such a start is already near the central
#: path's end, so it starts from a small barrier parameter and without pushing the point off
#: its active bounds. From IPOPT's default μ = 0.1 the imposing restart lost the optimum's
#: active set and ended at max_iterations on Endo2010's weak-spring pendulum and its ``low``
#: variant; warm, both converge.
WARM_IPOPT = {"ipopt.warm_start_init_point": "yes", "ipopt.mu_init": 1e-6,
              "ipopt.warm_start_bound_push": 1e-9, "ipopt.warm_start_mult_bound_push": 1e-9}
#: IPOPT options of MUMPS, the linear solver, in a warm re-solve after a small edit
#: (:data:`RESOLVE_IPOPT`): the approximate minimum degree ordering and no scaling of the KKT
#: matrix, which for these small matrices cost more than they save. Measured warm after 1 % edits
#: of the design page's templates (1-DOF wire cam, Ludovico2021's pendulum, the roller
#: follower): the same iterations and objective (to IPOPT's tolerance), and the linear algebra
#: in half the time (Ludovico2021's pendulum: 65 against 145 ms of CPU per solve).
RESOLVE_LINEAR = {"ipopt.mumps_pivot_order": 0, "ipopt.mumps_scaling": 0, "ipopt.mumps_permuting_scaling": 0}
#: IPOPT options of a warm re-solve from the last answer, its point and its multipliers
#: (:class:`Multipliers`): :data:`WARM_IPOPT` with :data:`RESOLVE_LINEAR`.
RESOLVE_IPOPT = {**WARM_IPOPT, **RESOLVE_LINEAR}
#: How far IPOPT pushes a design session's warm start (the last answer's own NLP point) off its
#: bounds, and its slacks off theirs, and the multipliers of the bounds away from zero (each
#: ``warm_start_*_push`` and ``*_frac``), in the NLP's scaled units. IPOPT's default slack push
#: opens every active inequality of the answer by 1e-3, so that a re-solve after a small step
#: starts far from feasible; a push much smaller still (1e-8) or larger (1e-6) costs some steps
#: many more iterations (``benchmarks/bench_speed.py`` measures the warm solves).
SESSION_PUSH = 1e-7
#: IPOPT options of a design session's warm re-solves (:class:`cadcam.Session`, the design page's
#: path): :data:`RESOLVE_IPOPT`, pushed :data:`SESSION_PUSH`. Sweeps and catalogue searches keep
#: :data:`RESOLVE_IPOPT`.
SESSION_IPOPT = {**RESOLVE_IPOPT, **{f"ipopt.warm_start_{name}": SESSION_PUSH for name in (
    "bound_push", "bound_frac", "mult_bound_push", "slack_bound_push", "slack_bound_frac")}}
#: IPOPT options of a catalogue search's solve that imposes the deferred rows
#: (:data:`IMPOSE_OPTIONS`): :data:`WARM_IPOPT` with :data:`RESOLVE_LINEAR`, because that
#: solve's KKT matrix, of twice the first solve's rows, costs the most per iteration and the
#: warm re-solves' linear algebra is cheaper on it, to the same verdicts (``bench_springs.py``).
SEARCH_IMPOSE_IPOPT = {**WARM_IPOPT, **RESOLVE_LINEAR}
#: The options of the solve imposing the deferred rows in the running context
#: (:meth:`cadcam.solve.transcription.Transcription.solve`): :data:`WARM_IPOPT`, or
#: :data:`SEARCH_IMPOSE_IPOPT` within a catalogue search's design
#: (:func:`cadcam.sweep.springs.design_part`).
IMPOSE_OPTIONS: ContextVar[dict] = ContextVar("impose_options", default=WARM_IPOPT)
#: The largest barrier parameter of a provisional re-solve (:data:`MOVING_IPOPT`), in the NLP's
#: scaled units: IPOPT's adaptive μ raises it from a warm start, and the iterates wander off the
#: last answer before they return to the optimum beside it; capped, a small slider step ends in
#: fewer iterations at the same optimum (``bench_page.py``). A monotone μ this small is not
#: used: it stops at a complementarity too loose for the optimum's objective.
MOVING_MU_MAX = 1e-8
#: IPOPT options of a provisional re-solve while a slider moves (:class:`cadcam.Session`'s
#: ``recheck=False``): :data:`SESSION_IPOPT`, the barrier capped at :data:`MOVING_MU_MAX`; its
#: tolerance is the problem's, loosened (:func:`moving_options`).
MOVING_IPOPT = {**SESSION_IPOPT, "ipopt.mu_max": MOVING_MU_MAX}
#: How much looser than the problem's own IPOPT tolerance (``solver.tol``) a provisional
#: re-solve stops. What the page draws of a provisional design is that design evaluated on the
#: design grid, whatever its optimality; a solve to the full tolerance spends its last
#: iteration or two on digits the curves do not show. The design made when the slider is let
#: go, warm from this one, is solved to the full tolerance and re-checked.
MOVING_TOL_FACTOR = 100.0


def moving_options(tol: float) -> dict:
    """The IPOPT options of a provisional re-solve of a problem whose IPOPT tolerance is ``tol``:
    :data:`MOVING_IPOPT`, stopping at :data:`MOVING_TOL_FACTOR` times ``tol``."""
    return {**MOVING_IPOPT, "ipopt.tol": MOVING_TOL_FACTOR * tol}


#: The options of a warm re-solve from an answer and its multipliers in the running context
#: (:meth:`cadcam.solve.transcription.Transcription.solve`): :data:`RESOLVE_IPOPT`, or
#: :data:`SESSION_IPOPT` within a design session's design (:func:`moving_options` within its
#: provisional one).
RESOLVE_OPTIONS: ContextVar[dict] = ContextVar("resolve_options", default=RESOLVE_IPOPT)


IPOPT_STATUS = {
    "Solve_Succeeded": "converged", "Solved_To_Acceptable_Level": "acceptable",
    "Infeasible_Problem_Detected": "infeasible", "Maximum_Iterations_Exceeded": "max_iterations",
    "Restoration_Failed": "restoration_failed", "Maximum_CpuTime_Exceeded": "max_time",
    "Maximum_WallTime_Exceeded": "max_time",
    "Diverging_Iterates": "diverging", "Search_Direction_Becomes_Too_Small": "stalled",
    "Error_In_Step_Computation": "step_failed", "Invalid_Number_Detected": "invalid_number",
    "User_Requested_Stop": STALL_STATUS,
}


@dataclass(frozen=True)
class Multipliers:
    """IPOPT's multipliers at an answer, which warm-start a solve of the same structure from
    it (:meth:`cadcam.solve.transcription.Transcription.solve`).

    Attributes
    ----------
    lam_x : numpy.ndarray
        Of the variables' bounds.
    lam_g : numpy.ndarray
        Of the rows the answer was solved with: the NLP's, then (``whole``) its deferred rows.
    whole : bool
        Whether the answer's solve imposed the deferred rows
        (:attr:`cadcam.solve.transcription.Transcription.whole_nlp`).
    x : numpy.ndarray, optional
        The answer's NLP point, the primal half of the warm start: its departure unknowns,
        lifted values and epigraph variables as IPOPT left them, with which the multipliers
        agree (None: the start is made afresh from the design,
        :meth:`cadcam.solve.transcription.Transcription.start_point`).
    """

    lam_x: np.ndarray
    lam_g: np.ndarray
    whole: bool
    x: np.ndarray | None = None


@dataclass
class Solve:
    """One IPOPT run: the design found and what the solver said."""

    design: Design
    status: str             # "converged" or one word for the failure
    return_status: str      # IPOPT's own words
    iterations: int
    solve_time_s: float
    objective: float        # Eq. 46/47 value in SI units, with the band term of any band_weight
    z: list[np.ndarray]     # NLP's departure unknowns per mechanism (unknowns × n)
    start: int = 0
    trials: list[dict] = field(default_factory=list)
    #: IPOPT's iterates: ``iteration``, ``objective`` (the scaled NLP objective), ``inf_pr``,
    #: ``inf_du``, ``mu``, ``d_norm`` and ``alpha_pr`` per iteration (empty lists without an NLP)
    history: dict = field(default_factory=lambda: iteration_history({}))
    #: What CasADi warned during the run (a NaN in an evaluation at a trial point, …), kept
    #: rather than printed: ``{"message", "count"}`` per distinct message
    #: (:func:`cadcam.solve.messages.kept_warnings`)
    warnings: list[dict] = field(default_factory=list)
    #: IPOPT's multipliers at the answer (None without an NLP), for a warm start from it
    multipliers: Multipliers | None = None
    #: Per mechanism, the parameters the NLP placed (its spring end within the spec's
    #: region, :meth:`cadcam.mechanisms.base.Mechanism.placement_region`) by name [SI]
    placements: list[dict] = field(default_factory=list)
    #: The solver options the NLP was solved with where raised above the problem's own (the
    #: convexity and limit margins of :func:`cadcam.optimize._margin_refined`; empty: the
    #: problem's), for a warm start from it
    margins: dict = field(default_factory=dict)


def _ipopt_solver(nlp: dict, opt: Options, split=None, extra: dict | None = None,
                  key: str | None = None, stall: StallRule | None = None) -> tuple[ca.Function, str]:
    """IPOPT on ``nlp``, its functions evaluated as ``opt.functions`` says (with the ``extra``
    CasADi options), and how they were; its runs stopped by the stall rule ``stall``, if given
    (:mod:`.stall`). ``split()``, if given, is the NLP written as compiled
    functions are generated from (:meth:`Transcription._split_graph`), built only to compile
    them (else ``nlp``); their library is named by ``nlp``'s graph (its key ``key``, if the caller
    has it). ``auto`` loads the library the cache holds, else expands ``nlp`` while the library
    compiles in the background where it can
    (:func:`cadcam.solve.compiled.compile_in_background`); ``compiled`` expands it where the
    cache may not be used (:func:`cadcam.solve.compiled.library`)."""
    watching, watch = stall_watch(stall, nlp)
    ipopt = _ipopt_options(opt, {**(extra or {}), **watching})
    used = opt.functions
    if used == "compiled":
        lib, compiled_now = compiled.library(nlp, split)
        if lib is not None:
            return (watched(ca.nlpsol("cadcam", "ipopt", str(lib), ipopt), watch),
                    COMPILED_NOW if compiled_now else COMPILED_CACHED)
        used = "expanded"  # the cache may not be used: compiled.library said why
    elif used == "auto":
        key = key or compiled.key_of(nlp)
        lib = compiled.cached_library(key)
        if lib is not None:
            return watched(ca.nlpsol("cadcam", "ipopt", str(lib), ipopt), watch), COMPILED_CACHED
        used = EXPANDED_COMPILING if compiled.compile_in_background(nlp, split, key) else "expanded"
    return watched(ca.nlpsol("cadcam", "ipopt", nlp, {**ipopt, "expand": used != "mapped"}), watch), used


def _ipopt_options(opt: Options, extra: dict | None = None) -> dict:
    """CasADi's ``nlpsol`` options of an IPOPT solve with ``opt``'s settings and ``extra``."""
    # show_eval_warnings: CasADi's warning of a NaN at a trial point (IPOPT's to handle: it
    # shortens the step) is kept in the result by Transcription.solve, not printed
    return ipopt_options({"show_eval_warnings": True, "ipopt.max_iter": opt.max_iter, "ipopt.tol": opt.tol,
                          "ipopt.mu_strategy": "adaptive", "ipopt.mu_max": MU_MAX,
                          **{f"ipopt.{k}": v for k, v in opt.ipopt}, **(extra or {})})


#: How a build's functions were evaluated (:attr:`cadcam.solve.transcription.Transcription.functions_used`),
#: beyond ``expanded`` and ``mapped``; ``auto`` (:data:`cadcam.problem.FUNCTIONS`) is one of
#: the last two or ``expanded``.
COMPILED_NOW = "compiled (now)"
COMPILED_CACHED = "compiled (from the cache)"
EXPANDED_COMPILING = "expanded (compiling in the background for the next build)"


@contextlib.contextmanager
def signals_kept():
    """Raise again, after the block, what a Python handler of a stopping signal
    (:data:`cadcam.interrupts.STOPPING`) raised inside it (Ctrl-C's KeyboardInterrupt;
    ``cadcam``'s SIGTERM and SIGHUP handler raises the same).

    While IPOPT iterates, CasADi runs Python's pending signal handlers; when one raises, CasADi
    stops IPOPT and returns status ``NonIpopt_Exception_Thrown`` without the exception, so an
    interrupted solve would carry on as a failed design (``cadcam design`` writing it and
    exiting 1, a serial sweep re-solving or recording the case and going on). Only the main
    thread receives signals; elsewhere the block runs as it is.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    raised: list[BaseException] = []

    def kept(handler):
        def run(signum, frame):
            try:
                handler(signum, frame)
            except BaseException as exc:
                raised.append(exc)
                raise
        return run

    installed = {}
    try:
        for s in STOPPING:
            handler = signal.getsignal(s)
            if callable(handler):
                installed[s] = handler  # recorded first: the finally restores it whenever a signal comes
                signal.signal(s, kept(handler))
        yield
    except BaseException as exc:
        if raised and exc is not raised[0]:  # the interrupt first, with what followed it
            raise raised[0] from exc
        raise
    finally:
        for s, handler in installed.items():
            signal.signal(s, handler)
    if raised:
        raise raised[0]


#: The per-iteration values :func:`iteration_history` keeps, by IPOPT's (CasADi's) name.
HISTORY_FIELDS = {"obj": "objective", "inf_pr": "inf_pr", "inf_du": "inf_du", "mu": "mu",
                  "d_norm": "d_norm", "alpha_pr": "alpha_pr"}


def iteration_history(stats: dict) -> dict:
    """IPOPT's iterates from CasADi's ``stats()["iterations"]`` as lists of floats (iteration 0
    is the start): the NLP objective, the primal and dual infeasibilities, the barrier
    parameter, the step's max-norm and the primal step size."""
    its = stats.get("iterations") or {}
    out = {"iteration": list(range(len(its.get("obj", []))))}
    out.update({name: [float(v) for v in its.get(key, [])] for key, name in HISTORY_FIELDS.items()})
    return out


def joined(histories: list[dict]) -> dict:
    """One :func:`iteration_history` of consecutive IPOPT runs, numbered on."""
    out = {key: sum((h[key] for h in histories), []) for key in histories[0]}
    out["iteration"] = list(range(len(out["iteration"])))
    return out
