"""The design NLP of Johnston2023 (Eq. 46, 47) for IPOPT, for any mechanisms, built once and
solved with parameters.

Transcription: a uniform grid of n angles per joint; every mechanism's departure unknowns z at
every grid angle of its joint and at its reference angle are NLP variables constrained by the
mechanism's residuals (simultaneous approach); wrapped lengths by Gauss–Legendre integrals
along each profile, lifted segment by segment; a high-degree profile's ρ, ρ′, ρ″ at its
convexity check points lifted too; trapezoidal integrals over the angle grid;
∂τ/∂k split into non-negative parts s⁺ − s⁻ whose sum is minimised (no ``abs`` in the NLP), and
so is each part of the tolerance band where a joint weighs it
(:func:`cadcam.solve.objective._band_rows`).

Everything that is a number of the problem rather than its structure — grid angles, spring
rates and preloads, the mechanisms' numbers (idler radius and offset, μ, …), weights, target
samples — is a CasADi parameter, and every limit (travels, ρ bounds, convexity margin, fixed
pre-extensions) a bound passed at solve time, so one built solver serves every case of a
parameter sweep.

Scaling: lengths in millimetres (coefficients, pre-extensions, closure and travel constraints),
convexity margins in mm², sensitivities in units of :data:`SENSITIVITY_SCALE`, the band's parts
in units of :data:`BAND_SCALE`, and the objective
divided by the tracking weight times ∫τ_d² and multiplied by :data:`OBJECTIVE_SCALE`.

:class:`Transcription` assembles the NLP from its parts and solves it; the parts have modules
of their own: the containers of its variables, parameters and rows (:mod:`.variables`), the
rows of the mechanisms and the spring network (:mod:`.rows`), the objective's terms
(:mod:`.objective`), and IPOPT with its options and what a run returns (:mod:`.ipopt`).
"""
from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

import casadi as ca
import numpy as np

from ..designs import Design
from . import compiled, robust
from .blocks import BAND_SCALE, LENGTH_SCALE
from .ipopt import (COMPILED_CACHED, COMPILED_NOW, EXPANDED_COMPILING, IMPOSE_OPTIONS, IPOPT_STATUS, RESOLVE_OPTIONS,
                    Multipliers, Solve, _ipopt_options, _ipopt_solver, iteration_history, joined, signals_kept)
from .memory import check_memory
from .messages import kept_warnings, printed_to_stderr
from .predictor import PREDICT, PREDICTED_IPOPT, nearly_converged, predicted
from .objective import (OBJECTIVE_SCALE, _band_rows, _output_law_terms, _sensitivity_rows,
                        _tracking_terms)
from .rows import _mechanism_rows, _spring_fit_rows, _spring_network_rows, _start_order, placement_scales
from .sharing import sharing_solver
from .stall import STALL_RULE, run_starts, stall_watch, watched
from .variables import _parameter_blocks, _Rows, _Vars
from ..physics.quadrature import trapezoid_weights, trapezoid_weights_sx
from ..physics.wrap import length_function
from ..problem import Problem
from ..errors import SpecError

#: How many times its rows' largest error at a start a minimax epigraph variable starts at
#: (:meth:`Transcription.epigraphs_met`), where :meth:`Transcription.initial_guess` leaves it at
#: zero: on it, the rows hold at once and their barrier terms are steep, so that IPOPT's first
#: steps throw the start away; just above it, a start can slide onto another branch of the
#: departures. A few times the error leaves the barrier room (``benchmarks/bench_speed.py``
#: measures the balancer's edits).
EPIGRAPH_START = 3.0
#: How far below its bound a deferred row may end, in its scaled units (mm, mm²), before the
#: solve is repeated with it imposed (IPOPT's own constraint tolerance is 1e-8 of these).
DEFERRED_TOL = 1e-6


class Transcription:
    """The NLP of a problem's structure, built once.

    Parameters
    ----------
    problem : Problem
        Supplies the structure (joints, mechanisms and their bases, springs and ports, torque
        model, grid size, quadrature order, convexity points, which sensitivity and band
        weights are non-zero).

    Attributes
    ----------
    nlp : dict
        The NLP as CasADi MX expressions (``x``, ``p``, ``f``, ``g``): mapped per-angle
        functions, so its size does not grow with the grid.
    solver : casadi.Function
        IPOPT on :attr:`nlp`, its functions evaluated as ``problem.options.functions`` says.
    build_time_s : float
        Wall time of building the symbolic NLP and the IPOPT solver (with ``compiled``
        functions: loading, or generating and compiling, their library) [s].
    functions_used : str
        How this build evaluates IPOPT's functions: ``expanded``, ``mapped`` or one of
        :data:`COMPILED_NOW`, :data:`COMPILED_CACHED`, :data:`EXPANDED_COMPILING`.
    stall : StallRule or None
        The stall rule in force when it was built (:data:`cadcam.solve.stall.STALL_RULE`),
        which stops its solvers' runs (None: none).
    """

    def __init__(self, problem: Problem):
        """Build the NLP of ``problem``'s structure, step by step, and its IPOPT solver.

        Raises :class:`~cadcam.solve.memory.MemoryBudgetError` (a SpecError) before the solver
        is built where its memory is estimated beyond the budget (:mod:`cadcam.solve.memory`)."""
        t0 = time.perf_counter()
        self._build_graph(problem)
        # refused before CasADi expands and differentiates the graph, where the memory goes
        check_memory(problem.options, self.nlp)
        self._split: Transcription | None = None  # the graph compiled functions come from
        # the library auto looks for, named once (serializing the graph takes a while)
        self._key = compiled.key_of(self.nlp) if problem.options.functions == "auto" else None
        # the stall rule in force now (builds.structure_key keeps builds under it apart) stops
        # the runs of every solver of this build, those built later too
        self.stall = STALL_RULE.get()
        self._build_solvers()
        self.build_time_s = time.perf_counter() - t0

    @classmethod
    def graph_of(cls, problem: Problem) -> "Transcription":
        """The NLP of ``problem``'s structure without its solvers: enough to compile its
        libraries (:meth:`compile_libraries`), which a build then loads."""
        tr = object.__new__(cls)
        tr._build_graph(problem)
        tr._split = None
        return tr

    def _build_solvers(self) -> None:
        """IPOPT on :attr:`nlp` (:attr:`solver`, :attr:`functions_used`); the solvers with the
        deferred rows and the warm one are built when first needed."""
        self.solver, self.functions_used = _ipopt_solver(self.nlp, self.problem.options, self._split_nlp,
                                                         key=self._key, stall=self.stall)
        self._imposing: dict = {}  # the solvers with the deferred rows, by their options
        self._warm: dict = {}  # the solvers warm from an answer and its multipliers, by their options

    def adopt_compiled(self) -> bool:
        """Solve through this structure's compiled library from now on where this build
        expanded its functions while the library compiled in the background
        (:data:`EXPANDED_COMPILING`) and the library is now in the cache: the solvers are built
        again from it, in milliseconds. Whether they were."""
        if self.functions_used != EXPANDED_COMPILING or compiled.cached_library(self._key) is None:
            return False
        self._build_solvers()
        return self.functions_used == COMPILED_CACHED

    def _build_graph(self, problem: Problem) -> None:
        """The NLP of ``problem``'s structure as MX expressions (:attr:`nlp`) and the functions
        of its parts, step by step."""
        self.problem = problem
        opt = problem.options
        m, S, n = len(problem.joints), len(problem.springs), opt.grid
        self.m, self.S, self.n = m, S, n
        self.N = n**m
        net = problem.network()
        self.pairs = [(i, j) for i, c in enumerate(problem.joints)
                      for j, w in enumerate(c.sensitivity_weights)
                      if w > 0 and i in net.joints_of(j)]  # others have ∂τ_i/∂k_j ≡ 0
        self.banded = [i for i, c in enumerate(problem.joints) if c.band_weight > 0]
        self.robust = robust.robust(problem)
        self.v, self.p = _Vars("w"), _parameter_blocks(problem)
        if self.robust:
            robust.parameter_blocks(self.p, problem)
        rows = _Rows(self.v)

        # -- per mechanism and per angle: O(n) --------------------------------------------------
        d, arm, outputs, poses = [[] for _ in range(m)], [[] for _ in range(m)], [], []
        for u, (mech, sl) in enumerate(zip(problem.mechanisms, problem.profile_slices())):
            du, au, output, pose = _mechanism_rows(rows, self.p, problem, u, sl.start)
            poses.append(pose)
            d[mech.joint] += [du[r, :].T for r in range(du.shape[0])]
            arm[mech.joint] += [au[r, :].T for r in range(au.shape[0])]
            if output is not None:
                outputs.append((u, mech.joint, output))
        w = [trapezoid_weights_sx(self.p[f"theta{i}"]).T for i in range(m)]
        x0 = LENGTH_SCALE * self.v.add("x0", S)

        # -- the spring network over the grid of all joints: still O(n) -------------------------
        e, terms = _spring_network_rows(rows, self.p, net, x0, d, arm)
        _spring_fit_rows(rows, problem, poses, x0, e)

        # -- the objective: tracking, rate sensitivity, tolerance band, output laws --------------
        span = [ca.sum1(wc) for wc in w]
        # the robust objective judges the builds, not the design: no tracking term of its own
        tracking = [] if self.robust else _tracking_terms(rows, self.p, problem, terms, e, w, span)
        sens, sensitivity = _sensitivity_rows(rows, self.p, net, self.pairs, x0, e, arm, w, span)
        changes = {}  # each joint's port changes per unit of each tolerance, made once for both
        self._band_splits, band, band_terms = _band_rows(rows, self.p, problem, self.banded, x0, e, d,
                                                         arm, poses, w, span, changes)
        # summed one term at a time, in this order: the graph, and so the compiled library's
        # cache key and IPOPT's iterates, depend on it
        objective = 0
        for term in tracking + sensitivity + band_terms:
            objective += term
        torque_objective = objective
        scaled = 0
        for term, weighted in _output_law_terms(rows, self.p, opt.objective == "minimax", outputs, w):
            objective += term
            scaled += weighted
        errors = ca.MX(0, 1)
        if self.robust:  # a share of the joints' scales: scaled as a minimax share is
            errors, builds = robust.robust_rows(rows, self.p, problem, changes, poses, x0, e, d, arm, terms)
            objective += robust.ROBUST_UNIT * builds
            scaled += OBJECTIVE_SCALE * robust.ROBUST_UNIT * builds

        x, P = self.v.vector(), self.p.vector()
        self.objective = ca.Function("objective", [x, P], [objective])
        self._lifted_fn = [(name, ca.Function(f"lift_{name}", [x, P], [expr]))
                           for name, expr in rows.lifted]
        self._sensitivity_fn = ca.Function("sensitivity", [x, P], [ca.vertcat(*sens, ca.MX(0, 1))])
        self._band_fn = ca.Function("band", [x, P], [ca.vertcat(*band, ca.MX(0, 1))])
        self._robust_fn = ca.Function("robust", [x, P], [errors])
        #: the block names of the minimax epigraph variables (:meth:`epigraphs_met`)
        self.epigraph_names = [name for name, _ in rows.epigraphs]
        self._epigraph_fn = ca.Function("epigraphs", [x, P], [ca.vertcat(*(e for _, e in rows.epigraphs),
                                                                       ca.MX(0, 1))])
        self._bounds, self._deferred_bounds = rows.bounds, rows.deferred_bounds
        self._deferred = ca.Function("deferred", [x, P], [ca.vertcat(*rows.deferred_g, ca.MX(0, 1))])
        self.nlp = {"x": x, "p": P, "f": torque_objective * self.p["obj_scale"] + scaled,
                    "g": ca.vertcat(*rows.g)}

    def _split_graph(self) -> "Transcription":
        """The same NLP with each mapped function's outputs called apart
        (:func:`cadcam.solve.rows._apart`): the graph compiled functions are generated from,
        with exact sparsity; built on first use (only to compile a library: one in the cache is
        named by :attr:`nlp`'s graph)."""
        if self._split is None:
            self._split = Transcription.graph_of(self.problem.with_options(functions="mapped"))
        return self._split

    def _split_nlp(self) -> dict:
        """:attr:`nlp` as :meth:`_split_graph` writes it."""
        return self._split_graph().nlp

    def _whole_split_nlp(self) -> dict:
        """:attr:`whole_nlp` as :meth:`_split_graph` writes it."""
        return self._split_graph().whole_nlp

    @property
    def compiled_now(self) -> bool:
        """Whether this build compiled the NLP's library (False: found in the cache, or its
        functions not compiled)."""
        return self.functions_used == COMPILED_NOW

    # -- numbers of a case -------------------------------------------------------------------
    def parameters(self, problem: Problem) -> np.ndarray:
        """The parameter vector of ``problem`` (same structure as the one built).

        The target enters through its weighted marginals: r̃_i(a) = w_i(a) Σ W′ τ_d,i and
        M̃_ic(a, b) = w_i(a) w_c(b) Σ W″ τ_d,i, summed over the other joints' angles, and
        ∫τ_d,i² — all that :func:`cadcam.solve.objective._squared_error` needs.
        """
        p, m, n = self.p, self.m, self.n
        vec = np.zeros(p.size)
        grids = [c.grid(n) for c in problem.joints]
        ws = [trapezoid_weights(g) for g in grids]
        mesh = np.meshgrid(*grids, indexing="ij")
        theta = np.vstack([t.ravel() for t in mesh])
        energy, minimax_scale, own = 0.0, 0.0, []
        for i, c in enumerate(problem.joints):
            td = np.asarray(c.target.function(m, i).map(self.N)(theta)).reshape((n,) * m)
            if problem.options.objective in ("minimax", "robust"):
                minimax_scale += c.tracking_weight * self._own_target(vec, i, c, td)
                own.append(self.p.part(vec, f"td{i}"))
            weighted = td
            for ax in range(m):
                weighted = weighted * np.expand_dims(ws[ax], [a for a in range(m) if a != ax])
            td2 = float(np.sum(weighted * td))
            energy += c.tracking_weight * td2
            p.put(vec, f"theta{i}", grids[i])
            p.put(vec, f"weights{i}", c.tracking_weight)
            p.put(vec, f"wsens{i}", c.sensitivity_weights)
            p.put(vec, f"rt{i}", weighted.sum(axis=tuple(a for a in range(m) if a != i)))
            p.put(vec, f"td2{i}", td2)
            for cc in range(m):
                if cc != i:
                    marg = weighted.sum(axis=tuple(a for a in range(m) if a not in (i, cc)))
                    if i > cc:
                        marg = marg.T  # rows: joint i's angles, columns: joint cc's
                    p.put(vec, f"Mt{i}_{cc}", marg.ravel(order="F"))
        for u, mech in enumerate(problem.mechanisms):
            p.put(vec, f"q{u}", mech.parameter_values())
            if mech.output_target is not None:
                xd = np.asarray(mech.output_target.function(1, 0).map(n)(grids[mech.joint])).ravel()
                p.put(vec, f"xd{u}", xd)
                spread = (xd - xd.mean()) / LENGTH_SCALE  # mm
                size = (np.sqrt(np.mean(spread**2)) if problem.options.objective == "minimax"
                        else float(np.dot(ws[mech.joint], spread**2)))
                p.put(vec, f"xs{u}", OBJECTIVE_SCALE / size if size > 0 else OBJECTIVE_SCALE)
        for pk in range(len(problem.profiles)):
            if f"rc{pk}" in p.blocks:
                p.put(vec, f"rc{pk}", problem.curvature_limit(pk) * (1 + problem.options.limit_margin))
        p.put(vec, "k", problem.spring_parameters().rate)
        p.put(vec, "F0", problem.spring_parameters().preload)
        if self.banded or self.robust:
            self._band_parameters(vec, problem)
        if self.robust:
            robust.put_parameters(self.p, vec, problem, own)
        scale = minimax_scale if problem.options.objective == "minimax" else energy
        p.put(vec, "obj_scale", OBJECTIVE_SCALE / scale if scale > 0 else 1.0)
        return vec

    def _band_parameters(self, vec, problem: Problem) -> None:
        """Put the band's weights and steps into ``vec``: each tolerance of
        :attr:`cadcam.problem.Problem.tolerance` as the step of the NLP's numbers it allows."""
        p, tol = self.p, problem.tolerance
        for i in self.banded:
            p.put(vec, f"wband{i}", problem.joints[i].band_weight)
        k = problem.spring_parameters().rate
        p.put(vec, "dk", tol["rate"] * k)
        # a preload's and a spring end's error both move the force by a constant
        p.put(vec, "dF", tol["preload"] * np.abs(problem.spring_parameters().preload) + tol["placement"] * k)
        for u, mech in enumerate(problem.mechanisms):
            p.put(vec, f"dq{u}", mech.placement_steps(LENGTH_SCALE))
        p.put(vec, "tol", [tol["placement"] / LENGTH_SCALE, tol["profile"] / LENGTH_SCALE])

    def band_half_width(self, w, pv) -> dict[int, np.ndarray]:
        """Per joint that weighs its band, the band's first-order half-width [N·m] at its grid
        angles that the NLP point ``w`` holds (the other joints' angles averaged where a
        spring joins it to them), with parameters ``pv``: Σ |each part|
        (:func:`cadcam.solve.objective._band_rows`)."""
        values = np.abs(np.asarray(self._band_fn(w, pv)).reshape(-1, self.n)) * BAND_SCALE
        out = {i: np.zeros(self.n) for i in self.banded}
        for (i, _, _), v in zip(self._band_splits, values):
            out[i] += v
        return out

    def _own_target(self, vec, i: int, joint, td: np.ndarray) -> float:
        """Put joint i's target samples ``td`` (the tensor grid) on its own angles into ``vec``
        for the minimax rows; SpecError if it depends on the other joints' angles. Returns its
        RMS [N·m], the minimax objective's scale."""
        own = np.moveaxis(td, i, 0).reshape(self.n, -1)
        if np.ptp(own, axis=1).max() > 1e-9 * (1 + np.abs(td).max()):
            raise SpecError(f"solver.objective = '{self.problem.options.objective}' needs each target to depend on its own "
                            f"joint's angle only; {joint.name!r}'s depends on the others: "
                            f"use 'least_squares'")
        self.p.put(vec, f"td{i}", own[:, 0])
        return float(np.sqrt(np.mean(td**2)))

    def bounds(self, problem: Problem, deferred: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the constraint rows (``deferred``: of the deferred rows)
        for ``problem``'s limits."""
        blocks = self._deferred_bounds if deferred else self._bounds
        if not blocks:
            return np.zeros(0), np.zeros(0)
        lo, hi = zip(*[np.broadcast_arrays(*(np.broadcast_to(b, (size,)) for b in fn(problem)))
                       for size, fn in blocks])
        return np.concatenate(lo), np.concatenate(hi)

    def variable_bounds(self, problem: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the NLP variables: the mechanisms' bounds on their unknowns, x₀ ≥ 0
        (Johnston2023 Eq. 46) or fixed where a spring gives its pre-extension, s± ≥ 0."""
        v = self.v
        lbx, ubx = np.full(v.size, -np.inf), np.full(v.size, np.inf)
        fixed = np.array([np.nan if s.preextension is None else s.preextension / LENGTH_SCALE
                          for s in problem.springs])
        for u, mech in enumerate(problem.mechanisms):  # the mechanisms' bounds on unknowns
            for r, (lo, hi) in enumerate(mech.unknown_bounds):
                v.put(lbx, f"z{u}_{mech.unknowns[r]}", lo)
                v.put(ubx, f"z{u}_{mech.unknowns[r]}", hi)
                a = v.blocks[f"ref{u}"][0] + r
                lbx[a], ubx[a] = lo, hi
        for u, mech in enumerate(problem.mechanisms):  # a mount placed within its region
            if mech.placement_region():
                lo, hi = np.array(list(mech.placement_region().values())).T / placement_scales(mech)
                v.put(lbx, f"mount{u}", lo)
                v.put(ubx, f"mount{u}", hi)
        v.put(lbx, "x0", np.where(np.isnan(fixed), 0.0, fixed))
        v.put(ubx, "x0", np.where(np.isnan(fixed), np.inf, fixed))
        for i, j in self.pairs:
            v.put(lbx, f"sp{i}_{j}", 0)
            v.put(lbx, f"sn{i}_{j}", 0)
        for _, pos, neg in self._band_splits:
            v.put(lbx, pos, 0)
            v.put(lbx, neg, 0)
        if self.robust:
            robust.variable_bounds(v, problem, lbx, ubx)
        return lbx, ubx

    def start_order(self) -> int:
        """Gauss–Legendre order the samples handed to :meth:`initial_guess` should use."""
        return _start_order(self.problem)

    def initial_guess(self, problem: Problem, design: Design, samples, pv=None) -> np.ndarray:
        """NLP start from a design and its per-mechanism ``samples`` on the design grid.

        ``samples`` holds, per mechanism, the departure unknowns ``z`` and ``z_ref``, the port
        displacements ``d`` and moment arms ``arm`` at the grid angles, as
        :func:`cadcam.verify.evaluate.mechanism_samples` computes them with the rootfinder
        (order :meth:`start_order`); the wrapped lengths follow from the angles, and every
        lifted variable, then s± (the split of the NLP's own x̄·a) and the band's splits, start
        on their definition
        (the start's moment arms are not used). ``pv`` is
        :meth:`parameters` of ``problem`` if the caller has it already.
        """
        v, n = self.v, self.n
        order = self.start_order()
        design = design.in_bases(pr.basis for pr in problem.profiles)  # a start made in other bases
        w0 = np.zeros(v.size)
        for u, (mech, sl) in enumerate(zip(problem.mechanisms, problem.profile_slices())):
            s = samples[u]
            for r, name in enumerate(mech.unknowns):
                v.put(w0, f"z{u}_{name}", s.z[r])
            v.put(w0, f"ref{u}", s.z_ref)
            for k in range(sl.start, sl.stop):
                v.put(w0, f"c{k}", design.coefficients[k] / LENGTH_SCALE)
                r = k - sl.start
                wrapped = length_function(design.bases[k], order).map(n)(
                    s.z_ref[r], s.z[r], design.coefficients[k])  # Johnston2023 Eq. 10
                v.put(w0, f"len{k}", np.asarray(wrapped).ravel() / LENGTH_SCALE)
        v.put(w0, "x0", design.preextension / LENGTH_SCALE)
        for u, mech in enumerate(problem.mechanisms):  # a placed mount starts where the spec puts it
            if mech.placement_region():
                values = dict(zip(mech.parameter_names, mech.parameter_values()))
                v.put(w0, f"mount{u}", [values[n] for n in mech.placement_region()] / placement_scales(mech))
        net = problem.network()
        d = _displacements(problem, samples)
        for j in range(self.S):
            joints = net.joints_of(j)
            if len(joints) > 1:
                shares = [net.term(j, c, d[c]) / LENGTH_SCALE for c in joints]
                v.put(w0, f"hi{j}", [s.max() for s in shares])
                v.put(w0, f"lo{j}", [s.min() for s in shares])
        pv = self.parameters(problem) if pv is None else pv
        for name, fn in self._lifted_fn:  # in creation order: later ones use earlier ones
            v.put(w0, name, np.asarray(fn(w0, pv)).ravel())
        sens = np.asarray(self._sensitivity_fn(w0, pv)).reshape(-1, self.n)
        for (i, j), s_ij in zip(self.pairs, sens):  # s± start on the split of x̄·a: feasible, tight
            v.put(w0, f"sp{i}_{j}", np.maximum(s_ij, 0))
            v.put(w0, f"sn{i}_{j}", np.maximum(-s_ij, 0))
        band = np.asarray(self._band_fn(w0, pv)).reshape(-1, self.n)
        for (_, pos, neg), part in zip(self._band_splits, band):  # so do the band's
            v.put(w0, pos, np.maximum(part, 0))
            v.put(w0, neg, np.maximum(-part, 0))
        if self.robust:
            robust.initial_guess(v, problem, w0, samples[len(problem.mechanisms):], self._robust_fn, pv, order)
        return w0

    def start_point(self, problem: Problem, design: Design, samples) -> tuple[np.ndarray, np.ndarray]:
        """The NLP's start from ``design`` (:meth:`initial_guess`) and the parameters it is
        solved with: :meth:`parameters` of ``problem`` and each high-degree profile's check
        range (:meth:`_with_check_ranges`) from the start's departures."""
        pv = self._with_check_ranges(problem, self.parameters(problem), lambda u, r: samples[u].z[r])
        return self.initial_guess(problem, design, samples, pv), pv

    def epigraphs_met(self, w: np.ndarray, pv: np.ndarray, above: float = EPIGRAPH_START) -> np.ndarray:
        """``w`` (an NLP vector, with the parameters ``pv``) with each minimax epigraph
        variable at ``above`` times the largest error its rows bound (:meth:`_Rows.epigraph`),
        where :meth:`initial_guess` leaves it at zero: a start inside the rows it can meet
        (:data:`EPIGRAPH_START`)."""
        w = np.array(w, dtype=float)
        for name, value in zip(self.epigraph_names, np.asarray(self._epigraph_fn(w, pv)).ravel()):
            self.v.put(w, name, [above * value])
        return w

    def warm_point(self, problem: Problem, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The NLP's start at an answer's own NLP point ``w`` (:attr:`Multipliers.x`, of a
        problem of this structure) and the parameters ``problem`` is solved with, each
        high-degree profile's check range from the departures ``w`` holds (as
        :meth:`start_point` takes them from a design's samples)."""
        w = np.asarray(w, dtype=float)
        return w, self._with_check_ranges(problem, self.parameters(problem),
                                          lambda u, r: self.v.part(w, f"z{u}_{problem.mechanisms[u].unknowns[r]}"))

    def _with_check_ranges(self, problem: Problem, pv: np.ndarray, departures) -> np.ndarray:
        """``pv`` with each high-degree profile's check range (``wc``,
        :func:`cadcam.solve.rows._fixed_check_angles`): up to the start's most-wound departure
        plus one grid step's wrap, so that the wrap may grow a step before the rows bind;
        ``departures(u, r)`` is mechanism ``u``'s unknown ``r`` at the grid angles."""
        for u, (mech, sl) in enumerate(zip(problem.mechanisms, problem.profile_slices())):
            for k in range(sl.start, sl.stop):
                if f"wc{k}" in self.p.blocks:
                    alpha = departures(u, k - sl.start)
                    end = float(mech.wrap_end(alpha[0], alpha[-1], ca.DM(mech.parameter_values())))
                    self.p.put(pv, f"wc{k}", end + abs(alpha[-1] - alpha[0]) / (self.n - 1))
        return pv

    def _breaks_deferred(self, problem: Problem, w, pv) -> bool:
        """Whether the NLP point ``w`` breaks a deferred row by more than DEFERRED_TOL. The
        deferred rows are left out of the first solve: a local optimum that meets them is one
        with them, and their barrier terms and their place in the KKT matrix would otherwise
        move IPOPT's path and its optimum where they never bind."""
        if not self._deferred_bounds:
            return False
        g = np.asarray(self._deferred(w, pv)).ravel()
        lo, hi = self.bounds(problem, deferred=True)
        return bool(np.any(g < lo - DEFERRED_TOL) or np.any(g > hi + DEFERRED_TOL))

    @property
    def whole_nlp(self) -> dict:
        """The NLP with its deferred rows after the others: the whole problem, which the export
        writes and the second solve of :meth:`solve` solves."""
        return {**self.nlp, "g": ca.vertcat(self.nlp["g"], self._deferred(self.nlp["x"], self.nlp["p"]))}

    def whole_bounds(self, problem: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the rows of :attr:`whole_nlp` for ``problem``'s limits."""
        (lo, hi), (dlo, dhi) = self.bounds(problem), self.bounds(problem, deferred=True)
        return np.r_[lo, dlo], np.r_[hi, dhi]

    def whole_library(self) -> tuple:
        """:func:`cadcam.solve.compiled.library` of :attr:`whole_nlp`, generated from the graph
        the solve imposing the deferred rows compiles it from (:meth:`_split_graph`): a library
        in the cache is named by the NLP's graph alone, so whoever compiles it first must
        generate it as every other does."""
        return compiled.library(self.whole_nlp, self._whole_split_nlp)

    def compile_libraries(self) -> tuple:
        """:func:`cadcam.solve.compiled.library` of :attr:`nlp` and of :attr:`whole_nlp`
        (:meth:`whole_library`), compiled at the same time: each library's longest file, its
        Hessian's, would otherwise leave the other cores idle while it compiles."""
        self._split_graph()  # built once here, not by both compiles at once
        with ThreadPoolExecutor(2) as pool:
            plain, whole = pool.submit(compiled.library, self.nlp, self._split_nlp), pool.submit(self.whole_library)
            return plain.result(), whole.result()

    def _imposing_solver(self) -> ca.Function:
        """IPOPT on :attr:`whole_nlp` started warm, with the options of the running context
        (:data:`cadcam.solve.ipopt.IMPOSE_OPTIONS`: :data:`WARM_IPOPT` but in a catalogue
        search), built on first use. Its derivatives are generated for the whole NLP, not summed
        from :attr:`solver`'s and the deferred rows' (:mod:`.sharing`): that sum differs by
        rounding, and IPOPT's path through these problems is sensitive enough to it to change
        the optimum reached."""
        options = IMPOSE_OPTIONS.get()
        key = tuple(sorted(options.items()))
        if key not in self._imposing:
            self._imposing[key], _ = _ipopt_solver(self.whole_nlp, self.problem.options,
                                                   self._whole_split_nlp, options, stall=self.stall)
        return self._imposing[key]

    def _warm_solver(self, extra: dict | None = None) -> ca.Function:
        """IPOPT on :attr:`nlp` re-solving warm from an answer, with the options of the running
        context (:data:`cadcam.solve.ipopt.RESOLVE_OPTIONS`) and ``extra``, built on first use:
        from the library :attr:`solver` loaded (in milliseconds), else from its derivatives."""
        options = {**RESOLVE_OPTIONS.get(), **(extra or {})}
        key = tuple(sorted(options.items()))
        if key not in self._warm:
            opt = self.problem.options
            if self.functions_used in (COMPILED_NOW, COMPILED_CACHED):
                self._warm[key], _ = _ipopt_solver(self.nlp, opt, self._split_nlp, options, key=self._key,
                                                   stall=self.stall)
            else:
                watching, watch = stall_watch(self.stall, self.nlp)
                self._warm[key] = watched(sharing_solver(self.solver, self.nlp,
                                                         _ipopt_options(opt, {**options, **watching}),
                                                         expand=opt.functions != "mapped"), watch)
        return self._warm[key]

    def design_of(self, w) -> Design:
        """The design held in an NLP vector."""
        profiles = self.problem.profiles
        return Design([pr.basis for pr in profiles],
                      [self.v.part(w, f"c{k}") * LENGTH_SCALE for k in range(len(profiles))],
                      self.v.part(w, "x0") * LENGTH_SCALE)

    def solve(self, problem: Problem, start: Design, samples, warm: Multipliers | None = None) -> Solve:
        """Run IPOPT from ``start`` (with its ``samples``, see :meth:`initial_guess`) with
        ``problem``'s numbers; with ``warm``, the multipliers of the answer ``start`` is (a
        neighbouring problem's), from them and the running context's options
        (:data:`cadcam.solve.ipopt.RESOLVE_OPTIONS`), and from that answer's
        own NLP point where ``warm`` holds it (``samples`` are then not used and may be
        None): with the deferred rows at once if that answer's solve imposed them."""
        t0 = time.perf_counter()
        lbg, ubg = self.bounds(problem)
        lbx, ubx = self.variable_bounds(problem)
        guess = None  # the predicted start (:mod:`.predictor`), tried first
        if warm is not None and warm.x is not None:
            w0, pv = self.warm_point(problem, warm.x)
            if PREDICT.get() and not warm.whole:
                guess = predicted(self.solver, warm, pv, (lbg, ubg), (lbx, ubx))
        else:
            w0, pv = self.start_point(problem, start, samples)
        runs = []

        def impose(x0, m: Multipliers):
            """The solve with the deferred rows, from ``x0`` and ``m`` (of every row)."""
            wlo, whi = self.whole_bounds(problem)
            solver = self._imposing_solver()
            run_starts(solver)
            sol = solver(x0=x0, lam_x0=m.lam_x, lam_g0=m.lam_g, p=pv, lbx=lbx, ubx=ubx, lbg=wlo, ubg=whi)
            runs.append(solver.stats())
            return sol

        with signals_kept(), kept_warnings() as warnings, printed_to_stderr():
            if warm is not None and warm.whole:  # the answer needed the deferred rows: so will this one
                sol = impose(w0, warm)
            else:
                sol, x0, m0 = None, w0, warm
                if guess is not None and guess is not warm:  # from the prediction, in few iterations or not at all
                    solver = self._warm_solver(PREDICTED_IPOPT)
                    run_starts(solver)
                    sol = solver(x0=guess.x, p=pv, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, lam_x0=guess.lam_x,
                                 lam_g0=guess.lam_g)
                    runs.append(solver.stats())
                    if nearly_converged(runs[-1]):  # cut short near its end: on from there
                        x0, m0 = sol["x"], Multipliers(sol["lam_x"], sol["lam_g"], False)
                if sol is None or not runs[-1].get("success", False):
                    solver = self.solver if m0 is None else self._warm_solver()
                    run_starts(solver)
                    sol = solver(x0=x0, p=pv, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg,
                                 **({} if m0 is None else {"lam_x0": m0.lam_x, "lam_g0": m0.lam_g}))
                    runs.append(solver.stats())
                if self._breaks_deferred(problem, sol["x"], pv):
                    lam_g0 = np.r_[np.asarray(sol["lam_g"]).ravel(), np.zeros(self._deferred.numel_out(0))]
                    sol = impose(sol["x"], Multipliers(sol["lam_x"], lam_g0, True))
        elapsed = time.perf_counter() - t0
        w, ret = np.asarray(sol["x"]).ravel(), runs[-1].get("return_status", "unknown")
        lam_g = np.asarray(sol["lam_g"]).ravel()
        histories = [iteration_history(stats) for stats in runs]
        return Solve(
            design=self.design_of(w), status=IPOPT_STATUS.get(ret, "solver_error"),
            return_status=ret, iterations=sum(int(stats.get("iter_count", -1)) for stats in runs),
            solve_time_s=elapsed, objective=float(self.objective(w, pv)),
            z=[np.vstack([self.v.part(w, f"z{u}_{name}") for name in mech.unknowns])
               for u, mech in enumerate(problem.mechanisms)],
            history=joined(histories), warnings=warnings,
            multipliers=Multipliers(np.asarray(sol["lam_x"]).ravel(), lam_g, lam_g.size > lbg.size, w),
            placements=self.placements_of(problem, w))

    def placements_of(self, problem: Problem, w) -> list[dict]:
        """Per mechanism, the parameters the NLP vector ``w`` places, by name [SI]."""
        return [dict(zip(mech.placement_region(), self.v.part(w, f"mount{u}") * placement_scales(mech)))
                if mech.placement_region() else {} for u, mech in enumerate(problem.mechanisms)]


def _displacements(problem: Problem, samples) -> list[list[np.ndarray]]:
    """Per joint, the port displacements ``d`` of its mechanisms' ports in global port order."""
    out = [[] for _ in problem.joints]
    for mech, s in zip(problem.mechanisms, samples):
        out[mech.joint] += list(s.d)
    return out
