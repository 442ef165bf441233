"""The design NLP of Johnston2023 (Eq. 46, 47) for IPOPT, for any mechanisms, built once and
solved with parameters.

Transcription: a uniform grid of n angles per joint; every mechanism's departure unknowns z at
every grid angle of its joint and at its reference angle are NLP variables constrained by the
mechanism's residuals (simultaneous approach); wrapped lengths by Gauss–Legendre integrals
along each profile, lifted segment by segment; a high-degree profile's ρ, ρ′, ρ″ at its
convexity check points lifted too; trapezoidal integrals over the angle grid;
∂τ/∂k split into non-negative parts s⁺ − s⁻ whose sum is minimised (no ``abs`` in the NLP), and
so is each part of the tolerance band where a joint weighs it (:func:`_band_rows`).

Everything that is a number of the problem rather than its structure — grid angles, spring
rates and preloads, the mechanisms' numbers (idler radius and offset, μ, …), weights, target
samples — is a CasADi parameter, and every limit (travels, ρ bounds, convexity margin, fixed
pre-extensions) a bound passed at solve time, so one built solver serves every case of a
parameter sweep.

Scaling: lengths in millimetres (coefficients, pre-extensions, closure and travel constraints),
convexity margins in mm², sensitivities in units of :data:`SENSITIVITY_SCALE`, the band's parts
in units of :data:`BAND_SCALE`, and the objective
divided by the tracking weight times ∫τ_d² and multiplied by :data:`OBJECTIVE_SCALE`.
"""
from __future__ import annotations

import contextlib
import signal
import threading
import time
from dataclasses import dataclass, field
from functools import lru_cache

import casadi as ca
import numpy as np

from ..designs import Design
from . import compiled
from .blocks import BAND_SCALE, FORCE_SCALE, LENGTH_SCALE, SENSITIVITY_SCALE, TORQUE_SCALE, block_name
from .messages import kept_warnings
from .sharing import sharing_solver
from ..mechanisms.base import (Mechanism, margin_function, port_change_function, port_function,
                               pose_change_function, pose_residual_function, split_coefficients,
                               wound_change_function, wound_lengths)
from ..physics.profile import convexity_margin, curvature, inside_tangent, profile_function, support_distance
from ..physics.quadrature import trapezoid_weights, trapezoid_weights_sx
from ..physics.springs import Network
from ..physics.wrap import length_change_function, length_function, segment_lengths
from ..problem import Options, Problem
from ..errors import SpecError

FRICTION_ORDER = 8   # the as-printed friction integral spans the whole wrap: 8× the points
#: Gauss–Legendre points of the segment from the reference pose to the grid's first angle, at
#: most: the rule grows with that segment's length in grid steps, which a narrow range far from
#: the reference pose would make unbounded (the re-check's own quadrature judges the accuracy).
FIRST_SEGMENT_MAX_ORDER = 256
#: A profile with more coefficients than this has its convexity, ρ-bound and curvature rows
#: written on lifted ρ, ρ′, ρ″ (:func:`_lifted_profile`), not as dense functions of its
#: coefficients, whose second derivatives grow as the square of their number: less build work
#: and memory at high degree. Lower degrees keep the rows they had: there lifting saves
#: little, and IPOPT's path on the lifted rows differs: on the shipped specs (order ≤ 15) it
#: took other iterates, one of them (ludovico2021_generic) to no optimum.
LIFTED_PROFILE_SIZE = 20
#: A profile with more coefficients than this is checked at fixed angles over a range set from
#: its start (:func:`_fixed_check_angles`), not at angles that scale with its unknown wrap.
#: From a start far from the optimum (a circle) that range restricts the design (the 1-DOF
#: cam's optimum is then worse); a high-degree profile, whose start is a synthesis of its shape
#: (Fedorov's envelope), gains robustness from it.
FIXED_RANGE_SIZE = 20
#: The objective is scaled so that a zero torque scores this much. The barrier terms of
#: IPOPT's ~10³ inequality rows must not swamp it: at a scale of 1, started from Johnston2023's
#: feasible Table 4 design (Eq. 47 value 6.01), IPOPT ends at 17.8; at 1000 it reaches 5.55
#: (and the 1-DOF and Sec. 10.4 problems converge in fewer iterations).
OBJECTIVE_SCALE = 1000.0
#: The largest barrier parameter IPOPT's adaptive μ may choose, in the NLP's scaled units (mm,
#: mm², the objective at :data:`OBJECTIVE_SCALE`). IPOPT's own cap is a thousand times the
#: start's average complementarity: from a circular start, whose slacks in mm² are large, it
#: chose a μ orders of magnitude above the objective's scale on the first iteration, the
#: iterates left every row's neighbourhood, and Ludovico2021's pendulum ended at
#: max_iterations on most grids between 21 and 51 angles (``make convergence`` measures it).
#: A cap of 1 does as well there, but leads Endo2010's inverted pendulum to a worse optimum next
#: to a fold of its departure.
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
#: How far below its bound a deferred row may end, in its scaled units (mm, mm²), before the
#: solve is repeated with it imposed (IPOPT's own constraint tolerance is 1e-8 of these).
DEFERRED_TOL = 1e-6

IPOPT_STATUS = {
    "Solve_Succeeded": "converged", "Solved_To_Acceptable_Level": "acceptable",
    "Infeasible_Problem_Detected": "infeasible", "Maximum_Iterations_Exceeded": "max_iterations",
    "Restoration_Failed": "restoration_failed", "Maximum_CpuTime_Exceeded": "max_time",
    "Maximum_WallTime_Exceeded": "max_time",
    "Diverging_Iterates": "diverging", "Search_Direction_Becomes_Too_Small": "stalled",
    "Error_In_Step_Computation": "step_failed", "Invalid_Number_Detected": "invalid_number",
}


@dataclass(frozen=True)
class Multipliers:
    """IPOPT's multipliers at an answer, which warm-start a solve of the same structure from
    it (:meth:`Transcription.solve`).

    Attributes
    ----------
    lam_x : numpy.ndarray
        Of the variables' bounds.
    lam_g : numpy.ndarray
        Of the rows the answer was solved with: the NLP's, then (``whole``) its deferred rows.
    whole : bool
        Whether the answer's solve imposed the deferred rows (:attr:`Transcription.whole_nlp`).
    """

    lam_x: np.ndarray
    lam_g: np.ndarray
    whole: bool


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


class _Vars:
    """Named blocks of symbols, stacked into one vector in the order they were added; each
    block is a family of :mod:`cadcam.solve.blocks` and an index (``families``)."""

    def __init__(self, kind: str):
        self.kind, self.blocks, self.families, self.syms, self.size = kind, {}, {}, {}, 0

    def add(self, family: str, n: int, *index):
        """A block of ``n`` symbols of ``family`` at ``index`` (named by :func:`block_name`)."""
        name = block_name(family, index)
        self.families[name] = (family, index)
        self.blocks[name] = (self.size, n)
        self.syms[name] = ca.MX.sym(f"{self.kind}_{name}", n)
        self.size += n
        return self.syms[name]

    def __getitem__(self, name):
        return self.syms[name]

    def vector(self):
        return ca.vertcat(*self.syms.values())

    def part(self, vec, name):
        a, n = self.blocks[name]
        return np.asarray(vec).ravel()[a:a + n]

    def put(self, vec, name, value):
        a, n = self.blocks[name]
        vec[a:a + n] = value


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
    """

    def __init__(self, problem: Problem):
        """Build the NLP of ``problem``'s structure, step by step, and its IPOPT solver."""
        t0 = time.perf_counter()
        self._build_graph(problem)
        self._split: Transcription | None = None  # the graph compiled functions come from
        # the library auto looks for, named once (serializing the graph takes a while)
        self._key = compiled.key_of(self.nlp) if problem.options.functions == "auto" else None
        self._build_solvers()
        self.build_time_s = time.perf_counter() - t0

    def _build_solvers(self) -> None:
        """IPOPT on :attr:`nlp` (:attr:`solver`, :attr:`functions_used`); the solvers with the
        deferred rows and the warm one are built when first needed."""
        self.solver, self.functions_used = _ipopt_solver(self.nlp, self.problem.options, self._split_nlp,
                                                         key=self._key)
        self._imposing = None  # the solver with the deferred rows
        self._warm = None  # the solver warm from an answer and its multipliers

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
        self.v, self.p = _Vars("w"), _parameter_blocks(problem)
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

        # -- the objective: tracking, rate sensitivity, tolerance band, output laws --------------
        span = [ca.sum1(wc) for wc in w]
        tracking = _tracking_terms(rows, self.p, problem, terms, e, w, span)
        sens, sensitivity = _sensitivity_rows(rows, self.p, net, self.pairs, x0, e, arm, w, span)
        self._band_splits, band, band_terms = _band_rows(rows, self.p, problem, self.banded, x0, e, d,
                                                         arm, poses, w, span)
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

        x, P = self.v.vector(), self.p.vector()
        self.objective = ca.Function("objective", [x, P], [objective])
        self._lifted_fn = [(name, ca.Function(f"lift_{name}", [x, P], [expr]))
                           for name, expr in rows.lifted]
        self._sensitivity_fn = ca.Function("sensitivity", [x, P], [ca.vertcat(*sens, ca.MX(0, 1))])
        self._band_fn = ca.Function("band", [x, P], [ca.vertcat(*band, ca.MX(0, 1))])
        self._bounds, self._deferred_bounds = rows.bounds, rows.deferred_bounds
        self._deferred = ca.Function("deferred", [x, P], [ca.vertcat(*rows.deferred_g, ca.MX(0, 1))])
        self.nlp = {"x": x, "p": P, "f": torque_objective * self.p["obj_scale"] + scaled,
                    "g": ca.vertcat(*rows.g)}

    def _split_graph(self) -> "Transcription":
        """The same NLP with each mapped function's outputs called apart (:func:`_apart`): the
        graph compiled functions are generated from, with exact sparsity; built on first use
        (only to compile a library: one in the cache is named by :attr:`nlp`'s graph)."""
        if self._split is None:
            self._split = object.__new__(Transcription)
            self._split._build_graph(self.problem.with_options(functions="mapped"))
        return self._split

    def _split_nlp(self) -> dict:
        """:attr:`nlp` as :meth:`_split_graph` writes it."""
        return self._split_graph().nlp

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
        ∫τ_d,i² — all that :func:`_squared_error` needs.
        """
        p, m, n = self.p, self.m, self.n
        vec = np.zeros(p.size)
        grids = [c.grid(n) for c in problem.joints]
        ws = [trapezoid_weights(g) for g in grids]
        mesh = np.meshgrid(*grids, indexing="ij")
        theta = np.vstack([t.ravel() for t in mesh])
        energy, minimax_scale = 0.0, 0.0
        for i, c in enumerate(problem.joints):
            td = np.asarray(c.target.function(m, i).map(self.N)(theta)).reshape((n,) * m)
            if problem.options.objective == "minimax":
                minimax_scale += c.tracking_weight * self._own_target(vec, i, c, td)
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
        for pk, prof in enumerate(problem.profiles):
            if f"rc{pk}" in p.blocks:
                p.put(vec, f"rc{pk}", prof.min_curvature_radius * (1 + problem.options.limit_margin))
        p.put(vec, "k", [s.rate for s in problem.springs])
        p.put(vec, "F0", [s.preload for s in problem.springs])
        if self.banded:
            self._band_parameters(vec, problem)
        scale = minimax_scale if problem.options.objective == "minimax" else energy
        p.put(vec, "obj_scale", OBJECTIVE_SCALE / scale if scale > 0 else 1.0)
        return vec

    def _band_parameters(self, vec, problem: Problem) -> None:
        """Put the band's weights and steps into ``vec``: each tolerance of
        :attr:`cadcam.problem.Problem.tolerance` as the step of the NLP's numbers it allows."""
        p, tol = self.p, problem.tolerance
        for i in self.banded:
            p.put(vec, f"wband{i}", problem.joints[i].band_weight)
        k = np.array([s.rate for s in problem.springs])
        p.put(vec, "dk", tol["rate"] * k)
        # a preload's and a spring end's error both move the force by a constant
        p.put(vec, "dF", tol["preload"] * np.abs([s.preload for s in problem.springs]) + tol["placement"] * k)
        for u, mech in enumerate(problem.mechanisms):
            p.put(vec, f"dq{u}", mech.placement_steps(LENGTH_SCALE))
        p.put(vec, "tol", [tol["placement"] / LENGTH_SCALE, tol["profile"] / LENGTH_SCALE])

    def band_half_width(self, w, pv) -> dict[int, np.ndarray]:
        """Per joint that weighs its band, the band's first-order half-width [N·m] at its grid
        angles that the NLP point ``w`` holds (the other joints' angles averaged where a
        spring joins it to them), with parameters ``pv``: Σ |each part| (:func:`_band_rows`)."""
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
            raise SpecError(f"solver.objective = 'minimax' needs each target to depend on its own "
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
        v.put(lbx, "x0", np.where(np.isnan(fixed), 0.0, fixed))
        v.put(ubx, "x0", np.where(np.isnan(fixed), np.inf, fixed))
        for i, j in self.pairs:
            v.put(lbx, f"sp{i}_{j}", 0)
            v.put(lbx, f"sn{i}_{j}", 0)
        for _, pos, neg in self._band_splits:
            v.put(lbx, pos, 0)
            v.put(lbx, neg, 0)
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
        return w0

    def start_point(self, problem: Problem, design: Design, samples) -> tuple[np.ndarray, np.ndarray]:
        """The NLP's start from ``design`` (:meth:`initial_guess`) and the parameters it is
        solved with: :meth:`parameters` of ``problem`` and each high-degree profile's check
        range (``wc``, :func:`_fixed_check_angles`), up to the start's most-wound departure
        plus one grid step's wrap, so that the wrap may grow a step before the rows bind."""
        pv = self.parameters(problem)
        for u, (mech, sl) in enumerate(zip(problem.mechanisms, problem.profile_slices())):
            for k in range(sl.start, sl.stop):
                if f"wc{k}" in self.p.blocks:
                    alpha = samples[u].z[k - sl.start]
                    end = float(mech.wrap_end(alpha[0], alpha[-1], ca.DM(mech.parameter_values())))
                    self.p.put(pv, f"wc{k}", end + abs(alpha[-1] - alpha[0]) / (self.n - 1))
        return self.initial_guess(problem, design, samples, pv), pv

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

    def _imposing_solver(self) -> ca.Function:
        """IPOPT on :attr:`whole_nlp` started warm (:data:`WARM_IPOPT`), built on first use.
        Its derivatives are generated for the whole NLP, not summed from :attr:`solver`'s and
        the deferred rows' (:mod:`.sharing`): that sum differs by rounding, and IPOPT's path
        through these problems is sensitive enough to it to change the optimum reached."""
        if self._imposing is None:
            self._imposing, _ = _ipopt_solver(self.whole_nlp, self.problem.options,
                                              lambda: self._split_graph().whole_nlp, WARM_IPOPT)
        return self._imposing

    def _warm_solver(self) -> ca.Function:
        """IPOPT on :attr:`nlp` started warm (:data:`WARM_IPOPT`), built on first use: from
        the library :attr:`solver` loaded (in milliseconds), else from its derivatives."""
        if self._warm is None:
            opt = self.problem.options
            if self.functions_used in (COMPILED_NOW, COMPILED_CACHED):
                self._warm, _ = _ipopt_solver(self.nlp, opt, self._split_nlp, WARM_IPOPT, key=self._key)
            else:
                self._warm = sharing_solver(self.solver, self.nlp, _ipopt_options(opt, WARM_IPOPT),
                                            expand=opt.functions != "mapped")
        return self._warm

    def design_of(self, w) -> Design:
        """The design held in an NLP vector."""
        profiles = self.problem.profiles
        return Design([pr.basis for pr in profiles],
                      [self.v.part(w, f"c{k}") * LENGTH_SCALE for k in range(len(profiles))],
                      self.v.part(w, "x0") * LENGTH_SCALE)

    def solve(self, problem: Problem, start: Design, samples, warm: Multipliers | None = None) -> Solve:
        """Run IPOPT from ``start`` (with its ``samples``, see :meth:`initial_guess`) with
        ``problem``'s numbers; with ``warm``, the multipliers of the answer ``start`` is (a
        neighbouring problem's), from them and :data:`WARM_IPOPT`: with the deferred rows
        at once if that answer's solve imposed them."""
        w0, pv = self.start_point(problem, start, samples)
        t0 = time.perf_counter()
        lbg, ubg = self.bounds(problem)
        lbx, ubx = self.variable_bounds(problem)
        wlo, whi = self.whole_bounds(problem)
        runs = []

        def impose(x0, m: Multipliers):
            """The solve with the deferred rows, from ``x0`` and ``m`` (of every row)."""
            sol = self._imposing_solver()(x0=x0, lam_x0=m.lam_x, lam_g0=m.lam_g, p=pv,
                                          lbx=lbx, ubx=ubx, lbg=wlo, ubg=whi)
            runs.append(self._imposing.stats())
            return sol

        with signals_kept(), kept_warnings() as warnings:
            if warm is not None and warm.whole:  # the answer needed the deferred rows: so will this one
                sol = impose(w0, warm)
            else:
                solver = self.solver if warm is None else self._warm_solver()
                sol = solver(x0=w0, p=pv, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg,
                             **({} if warm is None else {"lam_x0": warm.lam_x, "lam_g0": warm.lam_g}))
                runs.append(solver.stats())
                if self._breaks_deferred(problem, sol["x"], pv):
                    lam_g0 = np.r_[np.asarray(sol["lam_g"]).ravel(), np.zeros(wlo.size - lbg.size)]
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
            multipliers=Multipliers(np.asarray(sol["lam_x"]).ravel(), lam_g, lam_g.size > lbg.size))


def _apart(options: Options, f: ca.Function, n: int | None = None):
    """``f`` (mapped over ``n`` columns, if given) as the NLP calls it: a callable returning
    its outputs in order. Where the NLP's functions are evaluated as the MX graph (``mapped``,
    and the graph compiled functions are generated from: :meth:`Transcription._split_graph`),
    each output comes from a call of its own, a function rebuilt from ``f``'s graph.

    CasADi's reverse mode through one MX call of a function with several outputs seeds each
    unused output with a dense zero, so the Hessian of anything using that call counts every
    output's second derivatives: a dense block over all of the call's inputs (on a cable
    robot's pair, every pose's unknowns coupled to all of both profiles' coefficients). A call
    per output keeps the sparsity exact, and an output nothing uses is never evaluated.
    Expanded into SX the sparsity is exact anyway, and one call shares its outputs' common
    work; this one-call graph also names a compiled library (:mod:`cadcam.solve.compiled`)."""
    if options.functions != "mapped":
        return f if n is None else f.map(n)
    parts = _output_functions(f, n)
    return lambda *values: [part(*values) for part in parts]


@lru_cache(maxsize=256)
def _output_functions(f: ca.Function, n: int | None) -> tuple[ca.Function, ...]:
    """One function per output of ``f``, rebuilt from its graph (mapped over ``n`` columns if
    given): kept, since the band's rows ask for the same ones once per tolerance."""
    args = f.sx_in() if f.is_a("SXFunction") else f.mx_in()
    outs = f.call(args)
    parts = [ca.Function(f"{f.name()}_{f.name_out(o)}", args, [outs[o]], f.name_in(), [f.name_out(o)])
             for o in range(f.n_out())]
    return tuple(part if n is None else part.map(n) for part in parts)


def _start_order(problem: Problem) -> int:
    """Gauss–Legendre order of the wrapped lengths the NLP starts from, each over its whole
    wrap (:meth:`Transcription.start_order`)."""
    return 4 * problem.options.quadrature_order


# -- building the NLP, step by step (Transcription.__init__ calls them in this order) ----------
def _equal(problem: Problem) -> tuple[float, float]:
    """Bounds of equality rows."""
    return 0.0, 0.0


def _nonnegative(problem: Problem) -> tuple[float, float]:
    """Bounds of rows that are margins, met when ≥ 0."""
    return 0.0, np.inf


class _Rows:
    """The NLP's constraint rows in the order they were added, with their bounds, and the
    definitions of the lifted variables (in the order they were lifted).

    Parameters
    ----------
    v : _Vars
        The decision variables, to which :meth:`lift` adds.
    """

    def __init__(self, v: _Vars):
        self.v, self.g, self.bounds, self.lifted = v, [], [], []
        self.deferred_g, self.deferred_bounds = [], []

    def constrain(self, expr, bounds, deferred: bool = False):
        """Add constraint rows; ``bounds(problem) -> (lo, hi)`` gives their numbers at
        solve time, so limits change between cases without a rebuild. ``deferred`` rows are
        imposed only where the optimum without them breaks them (:meth:`Transcription.solve`)."""
        (self.deferred_g if deferred else self.g).append(expr)
        (self.deferred_bounds if deferred else self.bounds).append((expr.shape[0], bounds))

    def tie(self, family: str, row_of, start, scale, *index):
        """A new variable of ``family`` at ``index`` defined implicitly, by the rows
        ``row_of(value) = 0`` (``value``: the variable in its units), where solving for it
        outright would put a dense expression in the NLP; ``start`` is its value at the start
        (the solution of the rows, or near it). Returns it in its units, ``scale`` (a number
        or a column) times the variable."""
        var = self.v.add(family, start.shape[0], *index)
        self.constrain(row_of(scale * var), _equal)
        self.lifted.append((block_name(family, index), start / scale))
        return scale * var

    def lift(self, family: str, expr, scale: float, *index):
        """A new variable of ``family`` at ``index`` tied to ``expr`` by an equality: keeps the
        Hessian sparse where ``expr`` would couple many variables through a large graph.
        Returns it in ``expr``'s units (the variable is ``expr / scale``)."""
        var = self.v.add(family, expr.shape[0], *index)
        name = block_name(family, index)
        self.constrain(var - expr / scale, _equal)
        self.lifted.append((name, expr / scale))
        return scale * var


def _parameter_blocks(problem: Problem) -> _Vars:
    """The NLP's parameters, in the order :meth:`Transcription.parameters` fills them: per joint
    its grid, weights and target marginals, per mechanism its numbers q and output law, the
    springs' rates and preloads and the objective's scale, and where a joint weighs its
    tolerance band, the band's weights and steps (the curvature limits ``rc`` follow, added by
    :func:`_profile_rows`)."""
    opt, m, S = problem.options, len(problem.joints), len(problem.springs)
    n = opt.grid
    p = _Vars("p")
    for i in range(m):
        for name, size in (("theta", n), ("weights", 1), ("wsens", S), ("rt", n), ("td2", 1)):
            p.add(name, size, i)
        if opt.objective == "minimax":
            p.add("td", n, i)
        for c in range(m):
            if c != i:
                p.add("Mt", n * n, i, c)
    for u, mech in enumerate(problem.mechanisms):
        p.add("q", len(mech.parameter_names), u)
        if mech.output_target is not None:  # the output law's samples and scale
            p.add("xd", n, u)
            p.add("xs", 1, u)
    p.add("k", S)
    p.add("F0", S)
    p.add("obj_scale", 1)
    if any(c.band_weight > 0 for c in problem.joints):  # the band's weights and steps
        for i, c in enumerate(problem.joints):
            if c.band_weight > 0:
                p.add("wband", 1, i)
        p.add("dk", S)
        p.add("dF", S)
        for u, mech in enumerate(problem.mechanisms):
            p.add("dq", len(mech.parameter_names), u)
        p.add("tol", 2)
    return p


@dataclass(frozen=True)
class _MechanismSymbols:
    """One mechanism's symbols in the NLP: its profiles' stacked coefficients ``c`` [m], its
    departure unknowns ``z`` at its joint's grid angles ``theta`` [rad] (unknowns × n) and
    ``ref`` at its reference angle, and its numbers ``q`` (SI)."""

    c: ca.MX
    z: ca.MX
    ref: ca.MX
    theta: ca.MX
    q: ca.MX


@dataclass(frozen=True)
class _Pose:
    """One mechanism's poses in the NLP: its symbols, its profiles' ``wrapped`` lengths on the
    grid [m] (profiles × n) and its wound lengths ``wound_ref`` at the reference pose [m]
    (zeros where no closure row reads them)."""

    s: _MechanismSymbols
    wrapped: ca.MX
    wound_ref: ca.MX


def _mechanism_rows(rows: _Rows, p: _Vars, problem: Problem, u: int, first_profile: int):
    """Variables and rows of mechanism ``u``, whose profiles start at ``first_profile``.

    Returns
    -------
    d, arm : casadi.MX
        Its port displacements and moment arms [m] on the grid (ports × n).
    output : casadi.MX or None
        Its output unknown on the grid (n), where it has an output law.
    pose : _Pose
        Its poses on the grid, for the tolerance band's rows.
    """
    mech, n, v = problem.mechanisms[u], problem.options.grid, rows.v
    c = ca.vertcat(*[LENGTH_SCALE * v.add("c", b.size, first_profile + k)
                     for k, b in enumerate(mech.bases)])
    z = ca.vertcat(*[v.add("z", n, u, name).T for name in mech.unknowns])
    s = _MechanismSymbols(c, z, v.add("ref", len(mech.unknowns), u),
                          p[f"theta{mech.joint}"], p[f"q{u}"])
    output = z[mech.unknowns.index(mech.output), :].T if mech.output_target is not None else None
    wrapped = _wrapped_length_rows(rows, problem, mech, first_profile, s)
    # lengths wound from each anchor, for closure rows (a constant cable length): the
    # wound length at the reference pose plus the lifted wrapped lengths
    wound_ref = (rows.lift("wound", wound_lengths(mech.bases, s.ref, c), LENGTH_SCALE, u)
                 if mech.closure_rows else ca.MX.zeros(len(mech.bases)))
    d, arm = _departure_rows(rows, problem, mech, s, wrapped, wound_ref)
    _profile_rows(rows, p, problem, mech, first_profile, s)
    if mech.limits:
        _limit_rows(rows, n, mech, s, arm)
    return d, arm, output, _Pose(s, wrapped, wound_ref)


def _first_segment_order(problem: Problem, mech: Mechanism) -> int:
    """Gauss–Legendre order of the segment from ``mech``'s reference angle to its joint's first
    grid angle: the per-step order times that span in grid steps, at most
    :data:`FIRST_SEGMENT_MAX_ORDER`."""
    opt, joint = problem.options, problem.joints[mech.joint]
    h = (joint.theta_range[1] - joint.theta_range[0]) / (opt.grid - 1)
    return min(FIRST_SEGMENT_MAX_ORDER, opt.quadrature_order * int(np.ceil(max(
        abs(joint.theta_range[0] - mech.reference_angle) / h, 1))))


def _wrapped_length_rows(rows: _Rows, problem: Problem, mech: Mechanism, first_profile: int,
                         s: _MechanismSymbols):
    """Each profile's wrapped length [m] at the grid angles (profiles × n) as lifted variables,
    the running sum of Gauss–Legendre segment lengths (Johnston2023 Eq. 10, 14)."""
    n, L = problem.options.grid, LENGTH_SCALE
    first = _first_segment_order(problem, mech)
    # wrapped lengths are lifted to variables, tied segment by segment (Johnston2023
    # Eq. 10, 14), which keeps the Lagrangian Hessian banded instead of dense
    wrapped = []
    for k, (b, ck) in enumerate(zip(mech.bases, split_coefficients(mech.bases, s.c))):
        lk = L * rows.v.add("len", n, first_profile + k)
        seg = segment_lengths(b, problem.options.quadrature_order, first, s.ref[k], s.z[k, :].T, ck)
        rows.constrain((lk - ca.vertcat(0, lk[:n - 1]) - seg) / L, _equal)
        wrapped.append(lk.T)
    return ca.vertcat(*wrapped)


def _departure_rows(rows: _Rows, problem: Problem, mech: Mechanism, s: _MechanismSymbols,
                    wrapped, wound_ref):
    """The mechanism's residuals R = 0 at every grid angle and at its reference pose, given its
    ``wrapped`` lengths on the grid and its wound lengths ``wound_ref`` at the reference pose.

    Returns
    -------
    d, arm : casadi.MX
        The port displacements and moment arms [m] on the grid (ports × n).
    """
    n, structure = problem.options.grid, mech.structure()
    ports = _apart(problem.options, port_function(structure, problem.torque_model,
                                 FRICTION_ORDER * problem.options.quadrature_order, "closed-form"), n)
    d, arm, res, _ = ports(s.theta.T, s.z, s.ref, wrapped, ca.repmat(wound_ref, 1, n) + wrapped,
                           s.c, s.q)
    residual = _apart(problem.options, pose_residual_function(structure))
    res_ref = residual(mech.reference_angle, s.ref, wound_ref, s.c, s.q)[0]
    for r, unit in enumerate(mech.residual_units):  # the mechanism's R = 0 everywhere
        rows.constrain(ca.vertcat(res[r, :].T, res_ref[r]) / (LENGTH_SCALE if unit == "m" else 1.0),
                       _equal)
    return d, arm


def _profile_rows(rows: _Rows, p: _Vars, problem: Problem, mech: Mechanism, first_profile: int,
                  s: _MechanismSymbols):
    """Convexity, ρ-bound and curvature rows of the mechanism's profiles (Johnston2023
    Eq. 40); a profile with a curvature limit adds it as a parameter ``rc``."""
    n, M, L = problem.options.grid, problem.options.convexity_points, LENGTH_SCALE
    # convexity and ρ bounds over each wrapped range [0, α(most wound)] (Johnston2023
    # Eq. 40; a high-degree profile's over [0, φ_c] ⊇ it), and the radius of curvature (ρ² + ρ′²)^{3/2} / margin ≥ r_c where asked
    for k, (b, ck) in enumerate(zip(mech.bases, split_coefficients(mech.bases, s.c))):
        end = mech.wrap_end(s.z[k, 0], s.z[k, n - 1], s.q)
        pk = first_profile + k
        phi = (_fixed_check_angles(rows, p, end, M, pk) if b.size > FIXED_RANGE_SIZE
               else end * ca.DM(np.linspace(0, 1, M)).T)
        if b.size > LIFTED_PROFILE_SIZE:
            rho, drho, ddrho = _lifted_profile(rows, problem.options, b, phi, ck, pk)
            conv = convexity_margin(rho, drho, ddrho)  # Johnston2023 Eq. 40
        else:
            rho, drho, _, conv = (v.T for v in _apart(problem.options, profile_function(b), M)(phi, ck))
        rows.constrain(conv / L**2, lambda pr, pk=pk: (
            pr.options.convexity_epsilon * (pr.profiles[pk].rho_min / L) ** 2, np.inf))
        rows.constrain(rho / L, lambda pr, pk=pk: (
            pr.profiles[pk].rho_min * (1 + pr.options.limit_margin) / L,
            pr.profiles[pk].rho_max * (1 - pr.options.limit_margin) / L))
        if mech.planar():
            _outline_rows(rows, phi.T, rho, drho, conv)
        if mech.profiles[k].min_curvature_radius > 0:
            rc = p.add("rc", 1, pk)
            rows.constrain(((rho**2 + drho**2) ** 1.5 - rc * conv) / L**3, _nonnegative)


def _outline_rows(rows: _Rows, phi, rho, drho, conv):
    """Rows that let the designed arc, given as ρ, ρ′ and the Eq. 40 margin at the check angles
    ``phi`` [rad] from its anchor φ = 0 to its most-wound end (columns), be closed into a
    convex outline round the hub once cut a cable's radius inside it: the convex hull of the
    arc and the hub's disk keeps the whole arc on its boundary (every free cable span a tangent
    of a convex part, clear of it) when each tangent line passes outside the hub and has both
    ends of the arc inside it; the anchor lies far enough out for the anchor hole, a wall deep,
    to clear the hub; and the arc bends no tighter than the cable's radius and a cutter's."""
    L = LENGTH_SCALE
    rows.constrain(support_distance(rho, drho) / L,
                   lambda pr: ((pr.workshop.hub_radius + pr.workshop.cable_radius) / L, np.inf), True)
    rows.constrain(rho[0] / L, lambda pr: ((pr.workshop.anchor_radius + pr.workshop.cable_radius) / L, np.inf), True)
    for inner, end in ((slice(1, None), 0), (slice(None, -1), -1)):
        rows.constrain(inside_tangent(rho[inner], drho[inner], rho[end], phi[inner] - phi[end]) / L**2,
                       _nonnegative, True)
    rows.constrain(curvature(rho, drho, conv) * L, lambda pr: (-np.inf, pr.workshop.greatest_curvature * L), True)


def _fixed_check_angles(rows: _Rows, p: _Vars, end, M: int, pk: int):
    """``M`` check angles of profile ``pk`` spread over [0, φ_c] [rad] (a row), φ_c a parameter
    (``wc``, set from the start by :meth:`Transcription.start_point`), with a row that keeps the
    wrap's most-wound end ``end`` inside.

    Angles that scale with the unknown ``end`` (as a low-degree profile's do) move these rows'
    feasible set with every iterate, and on the cable robot's degree-30 pairs IPOPT's iteration
    count then swung several-fold with settings that should not matter. Fixed up to the basis domain's end instead, the rows bind
    the profile beyond its wrap, which pulled the end effector off its path wherever a
    profile's departure neared that end."""
    hi = p.add("wc", 1, pk)
    rows.constrain(hi - end, _nonnegative)
    return hi * ca.DM(np.linspace(0.0, 1.0, M)).T


def _lifted_profile(rows: _Rows, options: Options, basis, phi, c, pk: int):
    """ρ, ρ′ and ρ″ of profile ``pk`` at the angles ``phi`` (a row) as lifted variables [m,
    m/rad, m/rad²] (columns), tied to the coefficients ``c`` (Johnston2023 Eq. 38): each tie is
    linear in ``c`` at a given angle, so the rows written on them (Eq. 40) hold no product of
    two coefficients: their second derivatives grow with the degree, not with its square."""
    rho, drho, ddrho, _ = _apart(options, profile_function(basis), phi.shape[1])(phi, c)
    return tuple(rows.lift(family, value.T, LENGTH_SCALE, pk)
                 for family, value in (("rho", rho), ("drho", drho), ("ddrho", ddrho)))


def _limit_rows(rows: _Rows, n: int, mech: Mechanism, s: _MechanismSymbols, arm):
    """The mechanism's own per-pose limits (moment arm, span…) at the ``n`` grid angles, given
    its moment arms ``arm`` there; each margin ≥ 0 in units of its limit's scale."""
    marg = margin_function(mech.structure()).map(n)(s.theta.T, s.z, s.c, s.q, arm)
    scale = ca.DM([lim.nlp_scale for lim in mech.limits])
    rows.constrain(ca.vec((marg / ca.repmat(scale, 1, n)).T), _nonnegative)


def _spring_network_rows(rows: _Rows, p: _Vars, net: Network, x0, d: list, arm: list):
    """Travel rows of every spring and the torque terms of every joint, given the pre-extensions
    ``x0`` [m] and per joint its ports' displacements ``d`` and moment arms ``arm`` [m].

    Returns
    -------
    e : dict
        (spring j, joint c) → e_jc(θ_c) [m], joint c's share of spring j's extension.
    terms : list
        Per joint i, (U_i, {(j, c): V_ij}) of τ_i = U_i(θ_i) + Σ V_ij(θ_i) e_jc(θ_c).
    """
    # Every spring's extension is a sum of one-angle shares e_jc(θ_c) (Network.term), so its
    # range over the tensor grid is the sum of the shares' ranges, and every joint torque is
    # τ_i = U_i(θ_i) + Σ V_ij(θ_i) e_jc(θ_c) (Network.torque_terms). Shares of springs that
    # join several joints, and the terms that couple joints, are lifted.
    e = net.shares(d)
    terms = [net.torque_terms(i, p["k"], p["F0"], x0, arm[i], e) for i in range(net.m)]
    for j in range(net.S):
        joints = net.joints_of(j)
        if len(joints) == 1:  # Johnston2023 Eq. 46: 0 ≤ x_j ≤ x_j,max on the grid
            rows.constrain((x0[j] + e[j, joints[0]]) / LENGTH_SCALE, lambda pr, j=j: _travel(pr, j))
        else:
            e.update(_coupled_travel_rows(rows, j, joints, x0, e))
    for i, (U, V) in enumerate(terms):
        if V:
            terms[i] = (rows.lift("U", U, TORQUE_SCALE, i),
                        {q: rows.lift("V", Vq, FORCE_SCALE, i, *q) for q, Vq in V.items()})
    return e, terms


def _coupled_travel_rows(rows: _Rows, j: int, joints: list, x0, e: dict) -> dict:
    """Travel rows of spring ``j`` that joins several ``joints``: its extension ranges over
    x₀ + Σ_c [lo_c, hi_c] on the tensor grid, with lifted bounds lo_c ≤ e_jc ≤ hi_c of its
    shares (Johnston2023 Eq. 46). Returns its shares in ``e`` lifted, by (j, c)."""
    L = LENGTH_SCALE
    lifted = {(j, c): rows.lift("e", e[j, c], L, j, c) for c in joints}
    hi, lo = rows.v.add("hi", len(joints), j), rows.v.add("lo", len(joints), j)  # share ranges
    for k, c in enumerate(joints):
        rows.constrain(ca.vertcat(L * hi[k] - lifted[j, c], lifted[j, c] - L * lo[k]) / L,
                       _nonnegative)
    rows.constrain(ca.vertcat(x0[j] / L + ca.sum1(lo), x0[j] / L + ca.sum1(hi)),
                   lambda pr: ([_travel(pr, j)[0], -np.inf], [np.inf, _travel(pr, j)[1]]))
    return lifted


def _tracking_terms(rows: _Rows, p: _Vars, problem: Problem, terms: list, e: dict, w: list,
                    span: list) -> list:
    """The objective's torque-tracking term of each joint (Johnston2023 Eq. 46 term 1, Eq. 47
    term 1), given its torque ``terms``, the spring shares ``e``, the joints' trapezoidal
    weights ``w`` and their sums ``span``: ∫(τ_d,i − τ_i)² exactly, or for objective
    ``minimax`` max |τ_i − τ_d,i| over the grid as an epigraph variable t_i."""
    n, m = problem.options.grid, len(problem.joints)
    out = []
    for i in range(m):  # Johnston2023 Eq. 46 term 1, Eq. 47 term 1: ∫(τ_d,i − τ_i)² exactly
        U, V = terms[i]
        if problem.joints[i].tracking_weight == 0:
            continue  # no torque goal on this joint (an output law may drive it; it may have no springs)
        if problem.options.objective == "minimax":  # max |τ_i − τ_d,i| over the grid: an epigraph t_i
            if V:
                raise SpecError(f"solver.objective = 'minimax' needs joint torques that each depend "
                                f"on their own joint's angle; {problem.joints[i].name!r} is coupled "
                                f"to other joints by a spring: use 'least_squares'")
            t = rows.v.add("t", 1, i)
            err = (U - p[f"td{i}"]) / TORQUE_SCALE
            rows.constrain(ca.vertcat(t - err, t + err), _nonnegative)
            out.append(p[f"weights{i}"] * TORQUE_SCALE * t)
            continue
        mt = {c: ca.reshape(p[f"Mt{i}_{c}"], n, n) for c in range(m) if c != i}
        out.append(p[f"weights{i}"] * _squared_error(U, V, e, w, span, i, p[f"rt{i}"], mt,
                                                     p[f"td2{i}"], rows.lift))
    return out


def _sensitivity_rows(rows: _Rows, p: _Vars, net: Network, pairs: list, x0, e: dict, arm: list,
                      w: list, span: list) -> tuple[list, list]:
    """The rate-sensitivity split rows of each (joint i, spring j) in ``pairs`` and their
    objective terms (Johnston2023 Eq. 46 terms 2–3, Eq. 47 terms 2–7), given the
    pre-extensions ``x0`` [m], the spring shares ``e``, the joints' moment arms ``arm``, their
    trapezoidal weights ``w`` and the sums ``span``.

    Returns
    -------
    sens : list
        x̄_j a_ij per pair, in units of :data:`SENSITIVITY_SCALE` (the start of s±).
    terms : list
        The objective's term of each pair.
    """
    # Eq. 46/47 sensitivity terms: ∂τ_i/∂k_j = x_j a_ij(θ_i), and the integral over the other
    # joints' angles of |x_j a_ij| = x_j |a_ij| (x_j ≥ 0 is a constraint) is separable: x̄_j
    # |a_ij| with x̄_j the mean of x_j = x₀_j + Σ_c e_jc over the other joints' grids. Its
    # value is split, x̄_j a_ij = s⁺ − s⁻ with s± ≥ 0, and s⁺ + s⁻ is minimised (no abs). The
    # split is of the product, not of a_ij weighted by x̄_j: where x̄_j reaches 0 (a spring
    # slack at some angle), s± of a_ij alone cost nothing, and IPOPT's barrier drove both up
    # together (steps of 10⁷ on the 1-DOF spec).
    sens, terms = [], []
    for i, j in pairs:
        n = w[i].numel()
        sp, sn = rows.v.add("sp", n, i, j), rows.v.add("sn", n, i, j)
        others = [c for c in range(net.m) if c != i]
        s_ij = _mean_extension(x0, e, w, span, i, j) * net.term(j, i, arm[i]) / SENSITIVITY_SCALE
        rows.constrain(sp - sn - s_ij, _equal)
        sens.append(s_ij)
        integral = SENSITIVITY_SCALE * ca.dot(w[i], sp + sn)
        for c in others:
            integral = integral * span[c]
        terms.append(p[f"wsens{i}"][j] * integral)  # Eq. 46 terms 2–3, Eq. 47 terms 2–7
    return sens, terms


def _mean_extension(x0, e: dict, w: list, span: list, i: int, j: int):
    """Spring ``j``'s extension x_j = x₀_j + Σ_c e_jc(θ_c) [m] at joint ``i``'s grid angles,
    averaged over the other joints' angles with their trapezoidal weights ``w`` (sums
    ``span``): what an integral over them of a term linear in x_j takes."""
    return x0[j] + e[j, i] + sum(ca.dot(w[c], e[j, c]) / span[c] for c in range(len(w)) if c != i and (j, c) in e)


def _band_rows(rows: _Rows, p: _Vars, problem: Problem, banded: list, x0, e: dict, d: list, arm: list,
               poses: list, w: list, span: list) -> tuple[list, list, list]:
    """The tolerance band's split rows and objective terms of each joint in ``banded``: the
    band's first-order half-width w(θ) = Σ_p |∂τ/∂p| Δp (:mod:`cadcam.verify.tolerance`),
    integrated over the grid and weighed by the joint's ``band_weight``.

    Each part ∂τ/∂p Δp is split, v = s⁺ − s⁻ with s± ≥ 0, and s⁺ + s⁻ is minimised: |v| at
    the optimum without an ``abs``. The term is ∫w, not ∫w²: linear in s±, it pushes each
    split with the same weight wherever the band is narrow (the square's push 2w vanishes
    there and leaves s⁺ and s⁻ to IPOPT's barrier, as :func:`_sensitivity_rows` found), and its
    rate part is Δk_j times Johnston2023's ∫|∂τ/∂k_j|. Given the pre-extensions ``x0``, the
    spring shares ``e``, the joints' port displacements ``d`` and moment arms ``arm``, the
    mechanisms' ``poses`` (:class:`_Pose`), the trapezoidal weights ``w`` and their sums ``span``.

    Returns
    -------
    splits : list
        (joint, positive block, negative block) of each part.
    values : list
        Each part's value on its joint's grid, in units of :data:`BAND_SCALE`.
    terms : list
        Each joint's objective term.
    """
    net = problem.network()
    splits, values, terms = [], [], []
    for i in banded:
        springs = [j for j in range(net.S) if i in net.joints_of(j)]
        if not springs:
            continue  # no spring, no band
        parts = _band_spring_parts(p, net, i, x0, e, arm, w, span)
        if all(net.joints_of(j) == [i] for j in springs):
            parts += _band_part_changes(rows, p, problem, net, i, x0, d[i], arm[i], poses)
        total = 0
        for family, index, value in parts:
            n = value.shape[0]
            pos, neg = rows.v.add(family + "p", n, i, *index), rows.v.add(family + "n", n, i, *index)
            rows.constrain(pos - neg - value / BAND_SCALE, _equal)
            splits.append((i, block_name(family + "p", (i, *index)), block_name(family + "n", (i, *index))))
            values.append(value / BAND_SCALE)
            total = total + pos + neg
        integral = BAND_SCALE * ca.dot(w[i], total)
        for c in range(len(w)):
            if c != i:
                integral = integral * span[c]
        terms.append(p[f"wband{i}"] * integral)
    return splits, values, terms


def _band_spring_parts(p: _Vars, net, i: int, x0, e: dict, arm: list, w: list, span: list) -> list:
    """The band's parts of joint ``i`` from each spring j on it: ∂τ_i/∂k_j = x_j a_ij,
    ∂τ_i/∂F0_j = a_ij and ∂τ_i/∂x₀_j = k_j a_ij (Johnston2023 Eq. 36, 43;
    :meth:`cadcam.physics.springs.Network.term`), whose sum over the three tolerances is
    |a_ij| (Δk_j x_j + ΔF0_j + k_j Δx₀), x_j ≥ 0 being a row: one split (family ``bs``) of
    (Δk_j x̄_j + ΔF) a_ij, x̄_j averaged over the other joints' angles (exact in the integral)."""
    return [("bs", (j,), (p["dk"][j] * _mean_extension(x0, e, w, span, i, j) + p["dF"][j]) * net.term(j, i, arm[i]))
            for j in range(net.S) if i in net.joints_of(j)]


def _band_part_changes(rows: _Rows, p: _Vars, problem: Problem, net, i: int, x0, d_i: list, arm_i: list,
                       poses: list) -> list:
    """The band's parts of joint ``i`` (whose springs act on it alone) from each placed number
    of its mechanisms and a uniform offset of each of their profiles (:func:`_band_columns`):
    ∂τ_i/∂p Δp at its grid angles. Per millimetre of each, the poses' change at the grid
    angles and at the reference angle and the change of the wrapped lengths at fixed ends are
    lifted variables tied by linear rows (:func:`_pose_changes`); the ports' change follows
    (:func:`cadcam.mechanisms.base.port_change_function`), and the torque's by
    :meth:`cadcam.physics.springs.Network.torque_terms` differentiated.

    A mechanism with closure rows (a cable of constant length, whose poses at every angle hang
    on the lengths wound from its anchors) is left out: there the change of every pose hangs on
    each profile's whole coefficient vector through those lengths, and the exact Hessian of its
    rows grows too large to build."""
    n, order = problem.options.grid, FRICTION_ORDER * problem.options.quadrature_order
    change = _torque_change_function(net, i).map(n)
    own = [u for u, mech in enumerate(problem.mechanisms) if mech.joint == i]
    first_port = [int(a) for a in np.cumsum([0] + [len(problem.mechanisms[u].ports) for u in own])]
    parts = []
    for slot, u in enumerate(own):
        mech, pose, s = problem.mechanisms[u], poses[u], poses[u].s
        if mech.closure_rows:
            continue
        ports = _apart(problem.options,
                       port_change_function(mech.structure(), problem.torque_model, order, "closed-form"), n)
        for family, index, label, dc, dq, tol in _band_columns(p, problem, u):
            dz, dz_ref, dW, dW_ref = _pose_changes(rows, problem, u, pose, label, dc, dq)
            dd, darm = ports(s.theta.T, s.z, s.ref, pose.wrapped, ca.repmat(pose.wound_ref, 1, n) + pose.wrapped,
                             s.c, s.q, dz, dz_ref, dW, dW_ref, dc, dq)
            dd_i, darm_i = ca.MX.zeros(first_port[-1], n), ca.MX.zeros(first_port[-1], n)
            own_ports = slice(first_port[slot], first_port[slot + 1])  # the others' do not change
            dd_i[own_ports, :], darm_i[own_ports, :] = dd, darm
            per_mm = change(ca.horzcat(*arm_i).T, ca.horzcat(*d_i).T, darm_i, dd_i, p["k"], p["F0"], x0).T
            parts.append((family, index, tol * per_mm))
    return parts


def _band_columns(p: _Vars, problem: Problem, u: int) -> list:
    """Mechanism ``u``'s tolerances other than its springs', per millimetre: (family, index,
    label, dc, dq, tolerance [mm]) of each placed number (``bq``, index mechanism and name;
    steps ``dq{u}`` per mm of misplacement, :meth:`cadcam.mechanisms.base.Mechanism.placement_steps`)
    and of a uniform offset of each of its profiles by a millimetre (``bf``, index profile)."""
    mech = problem.mechanisms[u]
    nc, nq = sum(b.size for b in mech.bases), len(mech.parameters)
    first = problem.profile_slices()[u].start
    columns = [("bq", (u, quantity.name), quantity.name, ca.DM.zeros(nc), p[f"dq{u}"][r] * ca.DM.eye(nq)[:, r],
                p["tol"][0]) for r, quantity in enumerate(mech.parameters) if quantity.placed]
    for k in range(len(mech.bases)):
        offset = np.concatenate([b.offset(LENGTH_SCALE if kk == k else 0.0) for kk, b in enumerate(mech.bases)])
        columns.append(("bf", (first + k,), f"profile{first + k + 1}", ca.DM(offset), ca.DM.zeros(nq), p["tol"][1]))
    return columns


def _pose_changes(rows: _Rows, problem: Problem, u: int, pose: _Pose, label: str, dc, dq):
    """Mechanism ``u``'s change per millimetre of a tolerance (``label`` names its blocks) that
    changes its coefficients by ``dc`` and its numbers by ``dq`` (per mm): its unknowns' at the
    grid angles ``dz`` (unknowns × n) and at its reference angle ``dz_ref``, lifted variables
    tied by the linearised
    residuals (:func:`cadcam.mechanisms.base.pose_change_function`), and its wound lengths'
    own change there, ``dW`` (profiles × n) and ``dW_ref`` [m]: at the reference angle by
    their quadrature, on from there by the change of the wrapped lengths at fixed ends, lifted
    and summed segment by segment like the lengths themselves (Johnston2023 Eq. 10, 14)."""
    mech, s, n, L = problem.mechanisms[u], pose.s, problem.options.grid, LENGTH_SCALE
    structure, nz = mech.structure(), len(mech.unknowns)
    dW_ref = wound_change_function(structure)(s.ref, s.c, dc)
    dW = ca.repmat(dW_ref, 1, n)
    if np.any(np.asarray(dc)):
        order = problem.options.quadrature_order
        for k, (b, ck, dck) in enumerate(zip(mech.bases, split_coefficients(mech.bases, s.c),
                                             split_coefficients(mech.bases, dc))):
            if np.any(np.asarray(dck)):  # the profile that is offset: its wrapped length grows
                seg = segment_lengths(b, order, _first_segment_order(problem, mech), s.ref[k], s.z[k, :].T, ck, dck)
                start = length_change_function(b, _start_order(problem)).map(n)(s.ref[k], s.z[k, :], ck, dck).T
                dl = rows.tie("bl", lambda v: (v - ca.vertcat(0, v[:n - 1]) - seg) / L, start, L, u, label)
                dW[k, :] += dl.T
    scale = ca.DM([L if unit == "m" else 1.0 for unit in mech.unknown_units])  # per mm: mm/mm or rad/mm
    residual = ca.DM([L if unit == "m" else 1.0 for unit in mech.residual_units])
    change = _apart(problem.options, pose_change_function(structure))
    ref_angle = mech.reference_angle
    at_ref = (ref_angle, s.ref, pose.wound_ref, s.c, s.q)
    dz_ref = rows.tie("bzr", lambda v: change(*at_ref, v, dW_ref, dc, dq)[0] / residual,
                      change(*at_ref, ca.MX.zeros(nz), dW_ref, dc, dq)[1], scale, u, label)
    grid = _apart(problem.options, pose_change_function(structure), n)
    at_grid = (s.theta.T, s.z, ca.repmat(pose.wound_ref, 1, n) + pose.wrapped, s.c, s.q)
    dz = rows.tie("bz", lambda v: ca.vec(grid(*at_grid, ca.reshape(v, nz, n), dW, dc, dq)[0] / ca.repmat(residual, 1, n)),
                  ca.vec(grid(*at_grid, ca.MX.zeros(nz, n), dW, dc, dq)[1]), ca.repmat(scale, n, 1), u, label)
    return ca.reshape(dz, nz, n), dz_ref, dW, dW_ref


def _torque_change_function(net, i: int) -> ca.Function:
    """``change(arm, d, darm, dd, k, F0, x0) -> dtau``: the first-order change of joint ``i``'s
    torque [N·m] when its ports' moment arms and displacements (its port order) change by
    ``darm`` and ``dd``, for a joint whose springs act on it alone: τ_i of
    :meth:`cadcam.physics.springs.Network.torque_terms` differentiated."""
    P = len(net.joint_ports[i])
    arm, d, darm, dd = (ca.SX.sym(name, P) for name in ("arm", "d", "darm", "dd"))
    k, F0, x0 = (ca.SX.sym(name, net.S) for name in ("k", "F0", "x0"))
    shares = {(j, i): net.term(j, i, d) for j in range(net.S) if i in net.joints_of(j)}
    tau, _ = net.torque_terms(i, k, F0, x0, arm, shares)
    dtau = ca.jtimes(tau, ca.vertcat(arm, d), ca.vertcat(darm, dd))
    return ca.Function("torque_change", [arm, d, darm, dd, k, F0, x0], [dtau],
                       ["arm", "d", "darm", "dd", "k", "F0", "x0"], ["dtau"])


def _output_law_terms(rows: _Rows, p: _Vars, minimax: bool, outputs: list, w: list) -> list:
    """The objective's term of each mechanism's output law x_d(θ), given ``outputs`` (mechanism,
    its joint, its output unknown on the grid) and the joints' trapezoidal weights ``w``:
    ∫(x − x_d)², or with ``minimax`` max |x − x_d| as an epigraph variable (mm in the NLP).

    Returns
    -------
    list of (casadi.MX, casadi.MX)
        Per output law, its term in SI units and its term scaled by the law's own parameter.
    """
    # scaled by its own parameter so that it weighs as much as a torque term whatever the units
    L = LENGTH_SCALE
    out = []
    for u, i, xu in outputs:
        err = (xu - p[f"xd{u}"]) / L
        if minimax:
            t = rows.v.add("to", 1, u)
            rows.constrain(ca.vertcat(t - err, t + err), _nonnegative)
            out.append((L * t, p[f"xs{u}"] * t))
        else:
            sq = ca.dot(w[i], err * err)
            out.append((L**2 * sq, p[f"xs{u}"] * sq))
    return out


def _ipopt_solver(nlp: dict, opt: Options, split=None, extra: dict | None = None,
                  key: str | None = None) -> tuple[ca.Function, str]:
    """IPOPT on ``nlp``, its functions evaluated as ``opt.functions`` says (with the ``extra``
    CasADi options), and how they were. ``split()``, if given, is the NLP written as compiled
    functions are generated from (:meth:`Transcription._split_graph`), built only to compile
    them (else ``nlp``); their library is named by ``nlp``'s graph (its key ``key``, if the caller
    has it). ``auto`` loads the library the cache holds, else expands ``nlp`` while the library
    compiles in the background where it can
    (:func:`cadcam.solve.compiled.compile_in_background`); ``compiled`` expands it where the
    cache may not be used (:func:`cadcam.solve.compiled.library`)."""
    ipopt = _ipopt_options(opt, extra)
    used = opt.functions
    if used == "compiled":
        lib, compiled_now = compiled.library(nlp, split)
        if lib is not None:
            return ca.nlpsol("cadcam", "ipopt", str(lib), ipopt), COMPILED_NOW if compiled_now else COMPILED_CACHED
        used = "expanded"  # the cache may not be used: compiled.library said why
    elif used == "auto":
        key = key or compiled.key_of(nlp)
        lib = compiled.cached_library(key)
        if lib is not None:
            return ca.nlpsol("cadcam", "ipopt", str(lib), ipopt), COMPILED_CACHED
        used = EXPANDED_COMPILING if compiled.compile_in_background(nlp, split, key) else "expanded"
    return ca.nlpsol("cadcam", "ipopt", nlp, {**ipopt, "expand": used != "mapped"}), used


def _ipopt_options(opt: Options, extra: dict | None = None) -> dict:
    """CasADi's ``nlpsol`` options of an IPOPT solve with ``opt``'s settings and ``extra``."""
    # show_eval_warnings: CasADi's warning of a NaN at a trial point (IPOPT's to handle: it
    # shortens the step) is kept in the result by Transcription.solve, not printed
    return {"print_time": False, "show_eval_warnings": True, "ipopt.print_level": 0, "ipopt.sb": "yes",
            "ipopt.max_iter": opt.max_iter, "ipopt.tol": opt.tol,
            "ipopt.mu_strategy": "adaptive", "ipopt.mu_max": MU_MAX, **{f"ipopt.{k}": v for k, v in opt.ipopt},
            **(extra or {})}


#: How a build's functions were evaluated (:attr:`Transcription.functions_used`), beyond
#: ``expanded`` and ``mapped``; ``auto`` (:data:`cadcam.problem.FUNCTIONS`) is one of the
#: last two or ``expanded``.
COMPILED_NOW = "compiled (now)"
COMPILED_CACHED = "compiled (from the cache)"
EXPANDED_COMPILING = "expanded (compiling in the background for the next build)"


@contextlib.contextmanager
def signals_kept():
    """Raise again, after the block, what a Python handler of SIGINT or SIGTERM raised inside
    it (Ctrl-C's KeyboardInterrupt; ``cadcam``'s SIGTERM handler raises the same).

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
        for s in (signal.SIGINT, signal.SIGTERM):
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


def _displacements(problem: Problem, samples) -> list[list[np.ndarray]]:
    """Per joint, the port displacements ``d`` of its mechanisms' ports in global port order."""
    out = [[] for _ in problem.joints]
    for mech, s in zip(problem.mechanisms, samples):
        out[mech.joint] += list(s.d)
    return out


def _travel(problem: Problem, j: int) -> tuple[float, float]:
    """Bounds of spring j's extension [mm] with the limit margin kept in reserve (below a
    fixed pre-extension only down to it: the extension equals it at the reference pose)."""
    spring, margin = problem.springs[j], problem.options.limit_margin
    lo = margin * spring.travel
    if spring.preextension is not None:
        lo = min(lo, spring.preextension)
    return lo / LENGTH_SCALE, (1 - margin) * spring.travel / LENGTH_SCALE


def _squared_error(U, V, e, w, span, i, rt, mt, td2, lift):
    """∫(τ_d,i − τ_i)² over the tensor grid of all cams with trapezoidal weights, exactly.

    With τ_i = U(θ_i) + Σ_q V_q(θ_i) e_q(θ_c(q)) (q = (spring j, cam c), see
    :func:`cadcam.physics.springs.torque_terms`) the square expands into one-angle sums and bilinear
    forms V_qᵀ M̃_ic e_q with the target's weighted marginals (``rt``, ``mt``, ``td2``; see
    :meth:`Transcription.parameters`): O(n²) constants instead of O(n^m) model evaluations.
    The products that couple two cams' angles go through lifted variables (``lift``:
    M̃_ic e_q and the one-angle moments), so the Hessian stays sparse.
    """
    def others(*cams):
        out = 1
        for c, s in enumerate(span):
            if c != i and c not in cams:
                out = out * s
        return out

    wi = w[i]
    moment = {q: lift("mom", ca.dot(w[q[1]], e[q]), LENGTH_SCALE, i, *q) for q in V}
    total = td2 - 2 * ca.dot(U, rt) + others() * ca.dot(wi, U * U)
    for q, Vq in V.items():
        c = q[1]
        y = lift("Me", ca.mtimes(mt[c], e[q]), LENGTH_SCALE, i, *q)
        total += -2 * ca.dot(Vq, y)
        total += 2 * others(c) * lift("UV", ca.dot(wi, U * Vq), 1.0, i, *q) * moment[q]
        for r, Vr in V.items():
            cr = r[1]
            vv = lift("VV", ca.dot(wi, Vq * Vr), FORCE_SCALE**2, i, *q, *r)
            if cr == c:
                total += others(c) * vv * lift("ee", ca.dot(w[c], e[q] * e[r]), LENGTH_SCALE**2,
                                               i, *q, *r)
            else:
                total += others(c, cr) * vv * moment[q] * moment[r]
    return total

