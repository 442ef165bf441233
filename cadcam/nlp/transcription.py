"""The design NLP of seed 003 (Eq. 46, 47) for IPOPT, built once and solved with parameters.

Transcription: a uniform grid of n cam angles per cam, with the tangency unknowns (α, γ) of
every grid angle and of θ = 0 as NLP variables constrained by the residuals of Eq. 6–7
(simultaneous approach); Gauss–Legendre integrals along the profile; trapezoidal integrals
over the angle grid; ∂τ/∂k split into non-negative parts s⁺ − s⁻ whose sum is minimised
(no ``abs`` in the NLP).

Everything that is a number of the problem rather than its structure — grid angles, spring
rates, idler radius and offset, μ, weights, target samples — is a CasADi parameter, and every
limit (travels, ρ bounds, convexity margin) a bound passed at solve time, so one built solver
serves every case of a parameter sweep.

Scaling: lengths in millimetres (coefficients, pre-extensions, closure and travel constraints),
convexity margins in mm², moment arms in units of :data:`ARM_SCALE`, and the objective
divided by the tracking weight times ∫τ_d² and multiplied by :data:`OBJECTIVE_SCALE`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..physics.departure import cam_function
from ..design import Design
from ..physics.profile import profile_function
from ..physics.quadrature import trapezoid_weights, trapezoid_weights_sx
from ..physics.wrap import length_function, segment_lengths
from ..mechanisms.wire_cam import port_function
from ..problem import Problem
from ..physics.springs import cam_term, cams_of, incidence, torque_terms

LENGTH_SCALE = 1e-3  # m: NLP lengths are in millimetres
ARM_SCALE = 1e-2     # m: scale of the moment arms in the sensitivity terms
FRICTION_ORDER = 8   # the as-printed friction integral spans the whole wrap: 8× the points
TORQUE_SCALE = 1.0   # N·m: scale of lifted one-angle torque terms
FORCE_SCALE = 100.0  # N: scale of lifted coupling terms k_j a_ij
#: The objective is scaled so that a zero torque scores this much. The barrier terms of
#: IPOPT's ~10³ inequality rows must not swamp it: at a scale of 1, started from seed 003's
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
    alpha: list[np.ndarray]  # NLP's tangency angles per cam [rad]
    gamma: list[np.ndarray]
    start: int = 0
    trials: list[dict] = field(default_factory=list)


class _Vars:
    """Named blocks of symbols, stacked into one vector in the order they were added."""

    def __init__(self, kind: str):
        self.kind, self.blocks, self.syms, self.size = kind, {}, {}, 0

    def add(self, name: str, n: int):
        self.blocks[name] = (self.size, n)
        self.syms[name] = ca.SX.sym(f"{self.kind}_{name}", n)
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
        Supplies the structure (cams and bases, springs and ports, friction model, grid size,
        quadrature order, convexity points, which sensitivity weights are non-zero).

    Attributes
    ----------
    build_time_s : float
        Wall time of building the symbolic NLP and the IPOPT solver [s].
    """

    def __init__(self, problem: Problem):
        t0 = time.perf_counter()
        self.problem = problem
        opt = problem.options
        m, S, n = len(problem.cams), len(problem.springs), opt.grid
        self.m, self.S, self.n = m, S, n
        self.N = n**m
        inc = incidence(list(problem.springs), m)
        self.pairs = [(i, j) for i, c in enumerate(problem.cams)
                      for j, w in enumerate(c.sensitivity_weights)
                      if w > 0 and i in cams_of(inc, j)]  # others have ∂τ_i/∂k_j ≡ 0
        v, p = _Vars("w"), _Vars("p")
        self.v, self.p = v, p
        for i in range(m):
            for name, size in (("theta", n), ("cam", 4), ("wsens", S), ("rt", n), ("td2", 1)):
                p.add(f"{name}{i}", size)
            for c in range(m):
                if c != i:
                    p.add(f"Mt{i}_{c}", n * n)
        p.add("k", S)
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

        # -- per cam and per angle: O(n) ------------------------------------------------------
        d, arm, w = [], [], []
        for i, cam in enumerate(problem.cams):
            c = L * v.add(f"c{i}", cam.basis.size)
            alpha, gamma, ref = v.add(f"alpha{i}", n), v.add(f"gamma{i}", n), v.add(f"ref{i}", 2)
            theta = p[f"theta{i}"]
            r, a0, mu, _ = (p[f"cam{i}"][k] for k in range(4))
            ports = port_function(cam.basis, problem.friction_model,
                                         FRICTION_ORDER * opt.quadrature_order, "closed-form").map(n)
            h = (cam.theta_range[1] - cam.theta_range[0]) / (n - 1)
            first = opt.quadrature_order * int(np.ceil(max(abs(cam.theta_range[0]) / h, 1)))
            # wrapped lengths are lifted to variables, tied segment by segment (Eq. 10, 14),
            # which keeps the Lagrangian Hessian banded instead of dense
            wrapped = L * v.add(f"len{i}", n)
            seg = segment_lengths(cam.basis, opt.quadrature_order, first, ref[0], alpha, c)
            constrain((wrapped - ca.vertcat(0, wrapped[:n - 1]) - seg) / L, zero)
            res_ref, _, qx_ref = cam_function(cam.basis)(0, ref[0], ref[1], c, r, a0)[:3]
            di, ai, res, _ = ports(theta, alpha, gamma, ref[1], qx_ref, wrapped.T, c, r, a0, mu)
            # seed 003, Eq. 6–7 at every grid angle and at θ = 0
            constrain(ca.vertcat(res[0, :].T, res_ref[0]), zero)
            constrain(ca.vertcat(res[1, :].T, res_ref[1]) / L, zero)
            # seed 003, Eq. 40 and ρ bounds over the whole wrapped range [0, α(θ_max)]
            M = opt.convexity_points
            phi = alpha[n - 1] * ca.DM(np.linspace(0, 1, M)).T
            rho, _, _, conv = profile_function(cam.basis).map(M)(phi, c)
            constrain(conv.T / L**2, lambda pr, i=i: (
                pr.options.convexity_epsilon * (pr.cams[i].rho_min / L) ** 2, np.inf))
            constrain(rho.T / L, lambda pr, i=i: (pr.cams[i].rho_min * (1 + pr.options.limit_margin) / L,
                                                  pr.cams[i].rho_max * (1 - pr.options.limit_margin) / L))
            d.append([di[0, :].T, di[1, :].T])
            arm.append([ai[0, :].T, ai[1, :].T])
            w.append(trapezoid_weights_sx(theta).T)
        x0 = L * v.add("x0", S)

        # -- the spring network over the grid of all cams: still O(n) -------------------------
        # Every spring's extension is a sum of one-angle shares e_jc(θ_c) (springs.cam_term),
        # so its range over the tensor grid is the sum of the shares' ranges, and every cam
        # torque is τ_i = U_i(θ_i) + Σ V_ij(θ_i) e_jc(θ_c) (springs.torque_terms). Shares of
        # springs that join several cams, and the terms that couple cams, are lifted.
        e = {(j, c): cam_term(inc, j, c, d[c]) for j in range(S) for c in cams_of(inc, j)}
        terms = [torque_terms(inc, i, p["k"], x0, arm[i], e) for i in range(m)]
        for j in range(S):
            cams = cams_of(inc, j)
            if len(cams) == 1:  # seed 003, Eq. 46: 0 ≤ x_j ≤ x_j,max on the grid
                constrain((x0[j] + e[j, cams[0]]) / L, lambda pr, j=j: _travel(pr, j))
                continue
            for c in cams:
                e[j, c] = lift(f"e{j}_{c}", e[j, c], L)
            hi, lo = v.add(f"hi{j}", len(cams)), v.add(f"lo{j}", len(cams))  # ranges of shares
            for k, c in enumerate(cams):
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
        for i in range(m):  # seed 003, Eq. 46 term 1, Eq. 47 term 1: ∫(τ_d,i − τ_i)² exactly
            U, V = terms[i]
            mt = {c: ca.reshape(p[f"Mt{i}_{c}"], n, n) for c in range(m) if c != i}
            objective += p[f"cam{i}"][3] * _squared_error(U, V, e, w, span, i, p[f"rt{i}"], mt,
                                                          p[f"td2{i}"], lift)

        # Eq. 46/47 sensitivity terms: ∂τ_i/∂k_j = x_j a_ij(θ_i) and x_j ≥ 0 (a constraint), so
        # |∂τ_i/∂k_j| = x_j |a_ij|; |a_ij| = s⁺ + s⁻ with a_ij = s⁺ − s⁻, s± ≥ 0 (no abs), and
        # the integral over the other cams' angles of x_j = x₀_j + Σ_c e_jc is separable.
        for i, j in self.pairs:
            sp, sn = v.add(f"sp{i}_{j}", n), v.add(f"sn{i}_{j}", n)
            constrain(sp - sn - cam_term(inc, j, i, arm[i]) / ARM_SCALE, zero)
            others = [c for c in range(m) if c != i]
            x_mean = x0[j] + e[j, i] + sum(ca.dot(w[c], e[j, c]) / span[c]
                                           for c in others if (j, c) in e)
            integral = ARM_SCALE * ca.dot(w[i], (sp + sn) * x_mean)
            for c in others:
                integral = integral * span[c]
            objective += p[f"wsens{i}"][j] * integral  # Eq. 46 terms 2–3, Eq. 47 terms 2–7

        x, P = v.vector(), p.vector()
        self.objective = ca.Function("objective", [x, P], [objective])
        self._lifted_fn = [(name, ca.Function(f"lift_{name}", [x, P], [expr]))
                           for name, expr in self._lifted]
        nlp = {"x": x, "p": P, "f": objective * p["obj_scale"], "g": ca.vertcat(*g)}
        self.solver = ca.nlpsol("cadcam", "ipopt", nlp, {
            "print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
            "ipopt.max_iter": opt.max_iter, "ipopt.tol": opt.tol,
            "ipopt.mu_strategy": "adaptive",
        })
        self.lbx = np.full(v.size, -np.inf)
        v.put(self.lbx, "x0", 0)  # seed 003, Eq. 46: x₀ ≥ 0
        for i, j in self.pairs:
            v.put(self.lbx, f"sp{i}_{j}", 0)
            v.put(self.lbx, f"sn{i}_{j}", 0)
        self.ubx = np.full(v.size, np.inf)
        self.build_time_s = time.perf_counter() - t0

    # -- numbers of a case -------------------------------------------------------------------
    def parameters(self, problem: Problem) -> np.ndarray:
        """The parameter vector of ``problem`` (same structure as the one built).

        The target enters through its weighted marginals: r̃_i(a) = w_i(a) Σ W′ τ_d,i and
        M̃_ic(a, b) = w_i(a) w_c(b) Σ W″ τ_d,i, summed over the other cams' angles, and
        ∫τ_d,i² — all that :func:`_squared_error` needs.
        """
        p, m, n = self.p, self.m, self.n
        vec = np.zeros(p.size)
        grids = [c.grid(n) for c in problem.cams]
        ws = [trapezoid_weights(g) for g in grids]
        mesh = np.meshgrid(*grids, indexing="ij")
        theta = np.vstack([t.ravel() for t in mesh])
        energy = 0.0
        for i, c in enumerate(problem.cams):
            td = np.asarray(c.target.function(m, i).map(self.N)(theta)).reshape((n,) * m)
            weighted = td
            for ax in range(m):
                weighted = weighted * np.expand_dims(ws[ax], [a for a in range(m) if a != ax])
            td2 = float(np.sum(weighted * td))
            energy += c.tracking_weight * td2
            p.put(vec, f"theta{i}", grids[i])
            p.put(vec, f"cam{i}", [c.idler_radius, c.idler_offset, c.mu, c.tracking_weight])
            p.put(vec, f"wsens{i}", c.sensitivity_weights)
            p.put(vec, f"rt{i}", weighted.sum(axis=tuple(a for a in range(m) if a != i)))
            p.put(vec, f"td2{i}", td2)
            for cc in range(m):
                if cc != i:
                    marg = weighted.sum(axis=tuple(a for a in range(m) if a not in (i, cc)))
                    if i > cc:
                        marg = marg.T  # rows: cam i's angles, columns: cam cc's
                    p.put(vec, f"Mt{i}_{cc}", marg.ravel(order="F"))
        p.put(vec, "k", [s.rate for s in problem.springs])
        p.put(vec, "obj_scale", OBJECTIVE_SCALE / energy if energy > 0 else 1.0)
        return vec

    def bounds(self, problem: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the constraint rows for ``problem``'s limits."""
        lo, hi = zip(*[np.broadcast_arrays(*(np.broadcast_to(b, (size,)) for b in fn(problem)))
                       for size, fn in self._bounds])
        return np.concatenate(lo), np.concatenate(hi)

    def start_order(self) -> int:
        """Gauss–Legendre order the samples handed to :meth:`initial_guess` should use."""
        return 4 * self.problem.options.quadrature_order

    def initial_guess(self, problem: Problem, design: Design, samples, pv=None) -> np.ndarray:
        """NLP start from a design and its per-angle ``samples`` on the design grid.

        ``samples`` holds, per cam, the tangency angles (``alpha``, ``gamma``, ``alpha_ref``,
        ``gamma_ref``), the port displacements ``d`` and moment arms ``arm`` at the grid angles,
        as :func:`cadcam.check.evaluate.cam_samples` computes them with the rootfinder (order
        :meth:`start_order`); the wrapped lengths follow from the angles, s± from the arms,
        and every lifted variable starts on its definition. ``pv`` is :meth:`parameters` of
        ``problem`` if the caller has it already.
        """
        v, n = self.v, self.n
        order = self.start_order()
        w0 = np.zeros(v.size)
        for i, cs in enumerate(samples):
            v.put(w0, f"c{i}", design.coefficients[i] / LENGTH_SCALE)
            v.put(w0, f"alpha{i}", cs.alpha)
            v.put(w0, f"gamma{i}", cs.gamma)
            v.put(w0, f"ref{i}", [cs.alpha_ref, cs.gamma_ref])
            wrapped = length_function(design.bases[i], order).map(n)(
                cs.alpha_ref, cs.alpha, design.coefficients[i])  # seed 003, Eq. 10
            v.put(w0, f"len{i}", np.asarray(wrapped).ravel() / LENGTH_SCALE)
        v.put(w0, "x0", design.preextension / LENGTH_SCALE)
        P = incidence(list(problem.springs), self.m)
        for i, j in self.pairs:  # s⁺ − s⁻ start on a_ij: feasible and tight
            a = cam_term(P, j, i, samples[i].arm) / ARM_SCALE
            v.put(w0, f"sp{i}_{j}", np.maximum(a, 0))
            v.put(w0, f"sn{i}_{j}", np.maximum(-a, 0))
        for j in range(self.S):
            cams = cams_of(P, j)
            if len(cams) > 1:
                shares = [cam_term(P, j, c, samples[c].d) / LENGTH_SCALE for c in cams]
                v.put(w0, f"hi{j}", [s.max() for s in shares])
                v.put(w0, f"lo{j}", [s.min() for s in shares])
        pv = self.parameters(problem) if pv is None else pv
        for name, fn in self._lifted_fn:  # in creation order: later ones use earlier ones
            v.put(w0, name, np.asarray(fn(w0, pv)).ravel())
        return w0

    def design_of(self, w) -> Design:
        """The design held in an NLP vector."""
        return Design([c.basis for c in self.problem.cams],
                      [self.v.part(w, f"c{i}") * LENGTH_SCALE for i in range(self.m)],
                      self.v.part(w, "x0") * LENGTH_SCALE)

    def solve(self, problem: Problem, start: Design, samples) -> Solve:
        """Run IPOPT from ``start`` (with its ``samples``, see :meth:`initial_guess`) with
        ``problem``'s numbers."""
        pv = self.parameters(problem)
        w0 = self.initial_guess(problem, start, samples, pv)
        t0 = time.perf_counter()
        lbg, ubg = self.bounds(problem)
        sol = self.solver(x0=w0, p=pv, lbx=self.lbx, ubx=self.ubx, lbg=lbg, ubg=ubg)
        elapsed = time.perf_counter() - t0
        stats = self.solver.stats()
        w = np.asarray(sol["x"]).ravel()
        ret = stats.get("return_status", "unknown")
        return Solve(
            design=self.design_of(w), status=IPOPT_STATUS.get(ret, "solver_error"),
            return_status=ret, iterations=int(stats.get("iter_count", -1)),
            solve_time_s=elapsed, objective=float(self.objective(w, pv)),
            alpha=[self.v.part(w, f"alpha{i}") for i in range(self.m)],
            gamma=[self.v.part(w, f"gamma{i}") for i in range(self.m)])


def _travel(problem: Problem, j: int) -> tuple[float, float]:
    """Bounds of spring j's extension [mm] with the limit margin kept in reserve."""
    travel, margin = problem.springs[j].travel, problem.options.limit_margin
    return margin * travel / LENGTH_SCALE, (1 - margin) * travel / LENGTH_SCALE


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

