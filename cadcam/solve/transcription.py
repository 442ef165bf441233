"""The design NLP of Johnston2023 (Eq. 46, 47) for IPOPT, for any mechanisms, built once and
solved with parameters.

Transcription: a uniform grid of n angles per joint; every mechanism's departure unknowns z at
every grid angle of its joint and at its reference angle are NLP variables constrained by the
mechanism's residuals (simultaneous approach); wrapped lengths by Gauss–Legendre integrals
along each profile, lifted segment by segment; trapezoidal integrals over the angle grid;
∂τ/∂k split into non-negative parts s⁺ − s⁻ whose sum is minimised (no ``abs`` in the NLP).

Everything that is a number of the problem rather than its structure — grid angles, spring
rates and preloads, the mechanisms' numbers (idler radius and offset, μ, …), weights, target
samples — is a CasADi parameter, and every limit (travels, ρ bounds, convexity margin, fixed
pre-extensions) a bound passed at solve time, so one built solver serves every case of a
parameter sweep.

Scaling: lengths in millimetres (coefficients, pre-extensions, closure and travel constraints),
convexity margins in mm², sensitivities in units of :data:`SENSITIVITY_SCALE`, and the objective
divided by the tracking weight times ∫τ_d² and multiplied by :data:`OBJECTIVE_SCALE`.
"""
from __future__ import annotations

import contextlib
import signal
import threading
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..designs import Design
from . import compiled
from ..mechanisms.base import (margin_function, port_function, pose_residual_function,
                               split_coefficients, wound_lengths)
from ..physics.profile import profile_function
from ..physics.quadrature import trapezoid_weights, trapezoid_weights_sx
from ..physics.wrap import length_function, segment_lengths
from ..problem import Problem

LENGTH_SCALE = 1e-3  # m: NLP lengths are in millimetres
#: m²: scale of the sensitivities ∂τ/∂k = x·a in the NLP (a few hundred units at most). Measured
#: on the 60-case 1-DOF sweep of ``make bench`` against 1e-4 and 1e-3: the fewest iterations
#: (median 26 against 48 and 44); the local optimum IPOPT reaches changes with the scale.
SENSITIVITY_SCALE = 1e-5
FRICTION_ORDER = 8   # the as-printed friction integral spans the whole wrap: 8× the points
#: Gauss–Legendre points of the segment from the reference pose to the grid's first angle, at
#: most: the rule grows with that segment's length in grid steps, which a narrow range far from
#: the reference pose would make unbounded (the re-check's own quadrature judges the accuracy).
FIRST_SEGMENT_MAX_ORDER = 256
TORQUE_SCALE = 1.0   # N·m: scale of lifted one-angle torque terms
FORCE_SCALE = 100.0  # N: scale of lifted coupling terms k_j a_ij
#: The objective is scaled so that a zero torque scores this much. The barrier terms of
#: IPOPT's ~10³ inequality rows must not swamp it: at a scale of 1, started from Johnston2023's
#: feasible Table 4 design (Eq. 47 value 6.01), IPOPT ends at 17.8; at 1000 it reaches 5.55
#: (and the 1-DOF and Sec. 10.4 problems converge in fewer iterations).
OBJECTIVE_SCALE = 1000.0

IPOPT_STATUS = {
    "Solve_Succeeded": "converged", "Solved_To_Acceptable_Level": "converged",
    "Infeasible_Problem_Detected": "infeasible", "Maximum_Iterations_Exceeded": "max_iterations",
    "Restoration_Failed": "restoration_failed", "Maximum_CpuTime_Exceeded": "max_time",
    "Diverging_Iterates": "diverging", "Search_Direction_Becomes_Too_Small": "stalled",
    "Error_In_Step_Computation": "step_failed", "Invalid_Number_Detected": "invalid_number",
}


@dataclass
class Solve:
    """One IPOPT run: the design found and what the solver said."""

    design: Design
    status: str             # "converged" or one word for the failure
    return_status: str      # IPOPT's own words
    iterations: int
    solve_time_s: float
    objective: float        # Eq. 46/47 value in SI units
    z: list[np.ndarray]     # NLP's departure unknowns per mechanism (unknowns × n)
    start: int = 0
    trials: list[dict] = field(default_factory=list)
    #: IPOPT's iterates: ``iteration``, ``objective`` (the scaled NLP objective), ``inf_pr``,
    #: ``inf_du``, ``mu``, ``d_norm`` and ``alpha_pr`` per iteration (empty lists without an NLP)
    history: dict = field(default_factory=lambda: iteration_history({}))


class _Vars:
    """Named blocks of symbols, stacked into one vector in the order they were added."""

    def __init__(self, kind: str):
        self.kind, self.blocks, self.syms, self.size = kind, {}, {}, 0

    def add(self, name: str, n: int):
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
        model, grid size, quadrature order, convexity points, which sensitivity weights are
        non-zero).

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
    compiled_now : bool
        Whether this build compiled the NLP's library (False: found in the cache, or functions
        not ``compiled``).
    """

    def __init__(self, problem: Problem):
        t0 = time.perf_counter()
        self.problem = problem
        opt = problem.options
        m, S, n = len(problem.joints), len(problem.springs), opt.grid
        self.m, self.S, self.n = m, S, n
        self.N = n**m
        net = problem.network()
        self.pairs = [(i, j) for i, c in enumerate(problem.joints)
                      for j, w in enumerate(c.sensitivity_weights)
                      if w > 0 and i in net.joints_of(j)]  # others have ∂τ_i/∂k_j ≡ 0
        v, p = _Vars("w"), _Vars("p")
        self.v, self.p = v, p
        for i in range(m):
            for name, size in (("theta", n), ("weights", 1), ("wsens", S), ("rt", n), ("td2", 1)):
                p.add(f"{name}{i}", size)
            if opt.objective == "minimax":
                p.add(f"td{i}", n)
            for c in range(m):
                if c != i:
                    p.add(f"Mt{i}_{c}", n * n)
        for u, mech in enumerate(problem.mechanisms):
            p.add(f"q{u}", len(mech.parameter_names))
            if mech.output_target is not None:  # the output law's samples and scale
                p.add(f"xd{u}", n)
                p.add(f"xs{u}", 1)
        p.add("k", S)
        p.add("F0", S)
        p.add("obj_scale", 1)
        L = LENGTH_SCALE
        g, self._bounds, self._lifted = [], [], []

        def constrain(expr, bounds):
            """Add constraint rows; ``bounds(problem) -> (lo, hi)`` gives their numbers at
            solve time, so limits change between cases without a rebuild."""
            g.append(expr)
            self._bounds.append((expr.shape[0], bounds))

        zero = lambda pr: (0.0, 0.0)  # noqa: E731

        def lift(name, expr, scale):
            """A new variable tied to ``expr`` by an equality: keeps the Hessian sparse where
            ``expr`` would couple many variables through a large graph."""
            var = v.add(name, expr.shape[0])
            constrain(var - expr / scale, zero)
            self._lifted.append((name, expr / scale))
            return scale * var

        # -- per mechanism and per angle: O(n) --------------------------------------------------
        d = [[] for _ in range(m)]
        arm = [[] for _ in range(m)]
        outputs = []  # (mechanism, its joint, the output unknown on the grid)
        for u, (mech, sl) in enumerate(zip(problem.mechanisms, problem.profile_slices())):
            i = mech.joint
            joint = problem.joints[i]
            bases = mech.bases
            structure = mech.structure()
            c = ca.vertcat(*[L * v.add(f"c{k}", b.size) for k, b in zip(range(sl.start, sl.stop), bases)])
            Z = ca.vertcat(*[v.add(f"z{u}_{name}", n).T for name in mech.unknowns])
            ref = v.add(f"ref{u}", len(mech.unknowns))
            if mech.output_target is not None:
                outputs.append((u, i, Z[mech.unknowns.index(mech.output), :].T))
            theta, q = p[f"theta{i}"], p[f"q{u}"]
            h = (joint.theta_range[1] - joint.theta_range[0]) / (n - 1)
            first = min(FIRST_SEGMENT_MAX_ORDER, opt.quadrature_order * int(np.ceil(max(
                abs(joint.theta_range[0] - mech.reference_angle) / h, 1))))
            # wrapped lengths are lifted to variables, tied segment by segment (Johnston2023
            # Eq. 10, 14), which keeps the Lagrangian Hessian banded instead of dense
            wrapped = []
            for k, (b, ck) in enumerate(zip(bases, split_coefficients(bases, c))):
                lk = L * v.add(f"len{sl.start + k}", n)
                seg = segment_lengths(b, opt.quadrature_order, first, ref[k], Z[k, :].T, ck)
                constrain((lk - ca.vertcat(0, lk[:n - 1]) - seg) / L, zero)
                wrapped.append(lk.T)
            wrapped = ca.vertcat(*wrapped)
            # lengths wound from each anchor, for closure rows (a constant cable length): the
            # wound length at the reference pose plus the lifted wrapped lengths
            wound_ref = (lift(f"wound{u}", wound_lengths(bases, ref, c), L) if mech.closure_rows
                         else ca.MX.zeros(len(bases)))
            ports = port_function(structure, problem.torque_model,
                                  FRICTION_ORDER * opt.quadrature_order, "closed-form").map(n)
            du, au, res, _ = ports(theta.T, Z, ref, wrapped, ca.repmat(wound_ref, 1, n) + wrapped, c, q)
            res_ref = pose_residual_function(structure)(mech.reference_angle, ref, wound_ref, c, q)[0]
            for r, unit in enumerate(mech.residual_units):  # the mechanism's R = 0 everywhere
                constrain(ca.vertcat(res[r, :].T, res_ref[r]) / (L if unit == "m" else 1.0), zero)
            # convexity and ρ bounds over each wrapped range [0, α(most wound)] (Johnston2023
            # Eq. 40), and the radius of curvature (ρ² + ρ′²)^{3/2} / margin ≥ r_c where asked
            M = opt.convexity_points
            for k, (b, ck) in enumerate(zip(bases, split_coefficients(bases, c))):
                phi = mech.wrap_end(Z[k, 0], Z[k, n - 1], q) * ca.DM(np.linspace(0, 1, M)).T
                rho, drho, _, conv = profile_function(b).map(M)(phi, ck)
                pk = sl.start + k
                constrain(conv.T / L**2, lambda pr, pk=pk: (
                    pr.options.convexity_epsilon * (pr.profiles[pk].rho_min / L) ** 2, np.inf))
                constrain(rho.T / L, lambda pr, pk=pk: (
                    pr.profiles[pk].rho_min * (1 + pr.options.limit_margin) / L,
                    pr.profiles[pk].rho_max * (1 - pr.options.limit_margin) / L))
                if mech.profiles[k].min_curvature_radius > 0:
                    rc = p.add(f"rc{pk}", 1)
                    constrain(((rho**2 + drho**2) ** 1.5 - rc * conv).T / L**3,
                              lambda pr: (0.0, np.inf))
            if mech.limits:  # the mechanism's own per-pose limits (moment arm, span…)
                marg = margin_function(structure).map(n)(theta.T, Z, c, q, au)
                scale = ca.DM([lim.nlp_scale for lim in mech.limits])
                constrain(ca.vec((marg / ca.repmat(scale, 1, n)).T), lambda pr: (0.0, np.inf))
            d[i] += [du[r, :].T for r in range(du.shape[0])]
            arm[i] += [au[r, :].T for r in range(au.shape[0])]
        w = [trapezoid_weights_sx(p[f"theta{i}"]).T for i in range(m)]
        x0 = L * v.add("x0", S)

        # -- the spring network over the grid of all joints: still O(n) -------------------------
        # Every spring's extension is a sum of one-angle shares e_jc(θ_c) (Network.term), so its
        # range over the tensor grid is the sum of the shares' ranges, and every joint torque is
        # τ_i = U_i(θ_i) + Σ V_ij(θ_i) e_jc(θ_c) (Network.torque_terms). Shares of springs that
        # join several joints, and the terms that couple joints, are lifted.
        e = net.shares(d)
        terms = [net.torque_terms(i, p["k"], p["F0"], x0, arm[i], e) for i in range(m)]
        for j in range(S):
            joints = net.joints_of(j)
            if len(joints) == 1:  # Johnston2023 Eq. 46: 0 ≤ x_j ≤ x_j,max on the grid
                constrain((x0[j] + e[j, joints[0]]) / L, lambda pr, j=j: _travel(pr, j))
                continue
            for c in joints:
                e[j, c] = lift(f"e{j}_{c}", e[j, c], L)
            hi, lo = v.add(f"hi{j}", len(joints)), v.add(f"lo{j}", len(joints))  # share ranges
            for k, c in enumerate(joints):
                constrain(ca.vertcat(L * hi[k] - e[j, c], e[j, c] - L * lo[k]) / L,
                          lambda pr: (0.0, np.inf))
            constrain(ca.vertcat(x0[j] / L + ca.sum1(lo), x0[j] / L + ca.sum1(hi)),
                      lambda pr, j=j: ([_travel(pr, j)[0], -np.inf], [np.inf, _travel(pr, j)[1]]))
        for i, (U, V) in enumerate(terms):
            if V:
                terms[i] = (lift(f"U{i}", U, TORQUE_SCALE),
                            {q: lift(f"V{i}_{q[0]}_{q[1]}", Vq, FORCE_SCALE) for q, Vq in V.items()})

        span = [ca.sum1(wc) for wc in w]
        objective = 0
        for i in range(m):  # Johnston2023 Eq. 46 term 1, Eq. 47 term 1: ∫(τ_d,i − τ_i)² exactly
            U, V = terms[i]
            if opt.objective == "minimax":  # max |τ_i − τ_d,i| over the grid: an epigraph t_i
                if problem.joints[i].tracking_weight == 0:
                    continue  # no torque goal on this joint (an output law may drive it)
                if V:
                    raise ValueError(f"objective 'minimax' needs joint torques that each depend "
                                     f"on their own joint's angle; {problem.joints[i].name!r} is "
                                     f"coupled to other joints by a spring: use 'least_squares'")
                t = v.add(f"t{i}", 1)
                err = (U - p[f"td{i}"]) / TORQUE_SCALE
                constrain(ca.vertcat(t - err, t + err), lambda pr: (0.0, np.inf))
                objective += p[f"weights{i}"] * TORQUE_SCALE * t
                continue
            mt = {c: ca.reshape(p[f"Mt{i}_{c}"], n, n) for c in range(m) if c != i}
            objective += p[f"weights{i}"] * _squared_error(U, V, e, w, span, i, p[f"rt{i}"], mt,
                                                           p[f"td2{i}"], lift)

        # Eq. 46/47 sensitivity terms: ∂τ_i/∂k_j = x_j a_ij(θ_i), and the integral over the other
        # joints' angles of |x_j a_ij| = x_j |a_ij| (x_j ≥ 0 is a constraint) is separable: x̄_j
        # |a_ij| with x̄_j the mean of x_j = x₀_j + Σ_c e_jc over the other joints' grids. Its
        # value is split, x̄_j a_ij = s⁺ − s⁻ with s± ≥ 0, and s⁺ + s⁻ is minimised (no abs). The
        # split is of the product, not of a_ij weighted by x̄_j: where x̄_j reaches 0 (a spring
        # slack at some angle), s± of a_ij alone cost nothing, and IPOPT's barrier drove both up
        # together (steps of 10⁷ on the 1-DOF spec).
        sens = []
        for i, j in self.pairs:
            sp, sn = v.add(f"sp{i}_{j}", n), v.add(f"sn{i}_{j}", n)
            others = [c for c in range(m) if c != i]
            x_mean = x0[j] + e[j, i] + sum(ca.dot(w[c], e[j, c]) / span[c]
                                           for c in others if (j, c) in e)
            s_ij = x_mean * net.term(j, i, arm[i]) / SENSITIVITY_SCALE
            constrain(sp - sn - s_ij, zero)
            sens.append(s_ij)
            integral = SENSITIVITY_SCALE * ca.dot(w[i], sp + sn)
            for c in others:
                integral = integral * span[c]
            objective += p[f"wsens{i}"][j] * integral  # Eq. 46 terms 2–3, Eq. 47 terms 2–7

        torque_objective = objective
        # a mechanism's output law x_d(θ): ∫(x − x_d)² or max |x − x_d| (mm in the NLP), scaled
        # by its own parameter so that it weighs as much as a torque term whatever the units
        scaled = 0
        for u, i, xu in outputs:
            err = (xu - p[f"xd{u}"]) / L
            if opt.objective == "minimax":
                t = v.add(f"to{u}", 1)
                constrain(ca.vertcat(t - err, t + err), lambda pr: (0.0, np.inf))
                objective += L * t
                scaled += p[f"xs{u}"] * t
            else:
                sq = ca.dot(w[i], err * err)
                objective += L**2 * sq
                scaled += p[f"xs{u}"] * sq
        x, P = v.vector(), p.vector()
        self.objective = ca.Function("objective", [x, P], [objective])
        self._lifted_fn = [(name, ca.Function(f"lift_{name}", [x, P], [expr]))
                           for name, expr in self._lifted]
        self._sensitivity_fn = ca.Function("sensitivity", [x, P], [ca.vertcat(*sens, ca.MX(0, 1))])
        self.nlp = {"x": x, "p": P, "f": torque_objective * p["obj_scale"] + scaled, "g": ca.vertcat(*g)}
        ipopt = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                 "ipopt.max_iter": opt.max_iter, "ipopt.tol": opt.tol,
                 "ipopt.mu_strategy": "adaptive", **{f"ipopt.{k}": v for k, v in opt.ipopt}}
        self.compiled_now = False
        if opt.functions == "compiled":
            lib, self.compiled_now = compiled.library(self.nlp)
            self.solver = ca.nlpsol("cadcam", "ipopt", str(lib), ipopt)
        else:
            self.solver = ca.nlpsol("cadcam", "ipopt", self.nlp,
                                    {**ipopt, "expand": opt.functions == "expanded"})
        self.build_time_s = time.perf_counter() - t0

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
        scale = minimax_scale if problem.options.objective == "minimax" else energy
        p.put(vec, "obj_scale", OBJECTIVE_SCALE / scale if scale > 0 else 1.0)
        return vec

    def _own_target(self, vec, i: int, joint, td: np.ndarray) -> float:
        """Put joint i's target samples ``td`` (the tensor grid) on its own angles into ``vec``
        for the minimax rows; ValueError if it depends on the other joints' angles. Returns its
        RMS [N·m], the minimax objective's scale."""
        own = np.moveaxis(td, i, 0).reshape(self.n, -1)
        if np.ptp(own, axis=1).max() > 1e-9 * (1 + np.abs(td).max()):
            raise ValueError(f"objective 'minimax' needs each target to depend on its own "
                             f"joint's angle only; {joint.name!r}'s depends on the others: "
                             f"use 'least_squares'")
        self.p.put(vec, f"td{i}", own[:, 0])
        return float(np.sqrt(np.mean(td**2)))

    def bounds(self, problem: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the constraint rows for ``problem``'s limits."""
        lo, hi = zip(*[np.broadcast_arrays(*(np.broadcast_to(b, (size,)) for b in fn(problem)))
                       for size, fn in self._bounds])
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
        return lbx, ubx

    def start_order(self) -> int:
        """Gauss–Legendre order the samples handed to :meth:`initial_guess` should use."""
        return 4 * self.problem.options.quadrature_order

    def initial_guess(self, problem: Problem, design: Design, samples, pv=None) -> np.ndarray:
        """NLP start from a design and its per-mechanism ``samples`` on the design grid.

        ``samples`` holds, per mechanism, the departure unknowns ``z`` and ``z_ref``, the port
        displacements ``d`` and moment arms ``arm`` at the grid angles, as
        :func:`cadcam.verify.evaluate.mechanism_samples` computes them with the rootfinder
        (order :meth:`start_order`); the wrapped lengths follow from the angles, and every
        lifted variable, then s± (the split of the NLP's own x̄·a), start on their definition
        (the start's moment arms are not used). ``pv`` is
        :meth:`parameters` of ``problem`` if the caller has it already.
        """
        v, n = self.v, self.n
        order = self.start_order()
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
        return w0

    def design_of(self, w) -> Design:
        """The design held in an NLP vector."""
        profiles = self.problem.profiles
        return Design([pr.basis for pr in profiles],
                      [self.v.part(w, f"c{k}") * LENGTH_SCALE for k in range(len(profiles))],
                      self.v.part(w, "x0") * LENGTH_SCALE)

    def solve(self, problem: Problem, start: Design, samples) -> Solve:
        """Run IPOPT from ``start`` (with its ``samples``, see :meth:`initial_guess`) with
        ``problem``'s numbers."""
        pv = self.parameters(problem)
        w0 = self.initial_guess(problem, start, samples, pv)
        t0 = time.perf_counter()
        lbg, ubg = self.bounds(problem)
        lbx, ubx = self.variable_bounds(problem)
        with signals_kept():
            sol = self.solver(x0=w0, p=pv, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        elapsed = time.perf_counter() - t0
        stats = self.solver.stats()
        w = np.asarray(sol["x"]).ravel()
        ret = stats.get("return_status", "unknown")
        return Solve(
            design=self.design_of(w), status=IPOPT_STATUS.get(ret, "solver_error"),
            return_status=ret, iterations=int(stats.get("iter_count", -1)),
            solve_time_s=elapsed, objective=float(self.objective(w, pv)),
            z=[np.vstack([self.v.part(w, f"z{u}_{name}") for name in mech.unknowns])
               for u, mech in enumerate(problem.mechanisms)],
            history=iteration_history(stats))


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
    tag = lambda *parts: "_".join(str(x) for x in (i,) + parts)  # noqa: E731
    moment = {q: lift(f"mom{tag(*q)}", ca.dot(w[q[1]], e[q]), LENGTH_SCALE) for q in V}
    total = td2 - 2 * ca.dot(U, rt) + others() * ca.dot(wi, U * U)
    for q, Vq in V.items():
        c = q[1]
        y = lift(f"Me{tag(*q)}", ca.mtimes(mt[c], e[q]), LENGTH_SCALE)
        total += -2 * ca.dot(Vq, y)
        total += 2 * others(c) * lift(f"UV{tag(*q)}", ca.dot(wi, U * Vq), 1.0) * moment[q]
        for r, Vr in V.items():
            cr = r[1]
            vv = lift(f"VV{tag(*q, *r)}", ca.dot(wi, Vq * Vr), FORCE_SCALE**2)
            if cr == c:
                total += others(c) * vv * lift(f"ee{tag(*q, *r)}", ca.dot(w[c], e[q] * e[r]),
                                               LENGTH_SCALE**2)
            else:
                total += others(c, cr) * vv * moment[q] * moment[r]
    return total

