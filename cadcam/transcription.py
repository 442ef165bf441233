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
convexity margins in mm², sensitivities in units of :data:`SENS_SCALE`, and the objective
divided by the tracking weight times ∫τ_d² so that a zero torque scores about 1.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from .departure import cam_function
from .design import Design
from .evaluate import (evaluate, cached_length_function, cached_port_function, cached_profile_function, tangency_solver,
                       trapezoid_weights)
from .wrap import segment_lengths
from .problem import Problem
from .springs import network_function

LENGTH_SCALE = 1e-3  # m: NLP lengths are in millimetres
SENS_SCALE = 1e-3    # m²: scale of ∂τ/∂k
EXTRA = {}

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
    """Named blocks of one symbolic vector."""

    def __init__(self):
        self.blocks, self.size = {}, 0

    def add(self, name, n):
        self.blocks[name] = (self.size, n)
        self.size += n

    def sym(self, name):
        self.x = ca.SX.sym(name, self.size)
        return self.x

    def __getitem__(self, name):
        a, n = self.blocks[name]
        return self.x[a:a + n]

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
        self.pairs = [(i, j) for i, c in enumerate(problem.cams)
                      for j, w in enumerate(c.sensitivity_weights) if w > 0]

        v, p = _Vars(), _Vars()
        for i, cam in enumerate(problem.cams):
            v.add(f"c{i}", cam.basis.size)
            v.add(f"alpha{i}", n)
            v.add(f"gamma{i}", n)
            v.add(f"ref{i}", 2)
            v.add(f"len{i}", n)
        v.add("x0", S)
        for i, j in self.pairs:  # ∂τ_i/∂k_j = s⁺ − s⁻, see below
            v.add(f"sp{i}_{j}", self.N)
            v.add(f"sn{i}_{j}", self.N)
        for i in range(m):
            for name, size in (("theta", n), ("tau_d", self.N), ("cam", 4), ("wsens", S)):
                p.add(f"{name}{i}", size)
        p.add("k", S)
        p.add("obj_scale", 1)
        x, P = v.sym("w"), p.sym("p")
        self.v, self.p = v, p

        L = LENGTH_SCALE
        g, self._bounds = [], []

        def constrain(expr, bounds):
            """Add constraint rows; ``bounds(problem) -> (lo, hi)`` gives their numbers at
            solve time, so limits change between cases without a rebuild."""
            g.append(expr)
            self._bounds.append((expr.shape[0], bounds))

        zero = lambda pr: (0.0, 0.0)  # noqa: E731

        idx = np.indices((n,) * m).reshape(m, -1)
        D, A, tau_d, weights = [], [], [], []
        for i, cam in enumerate(problem.cams):
            c = L * v[f"c{i}"]
            theta = p[f"theta{i}"]
            r, a0, mu, _ = (p[f"cam{i}"][k] for k in range(4))
            alpha, gamma, ref = v[f"alpha{i}"], v[f"gamma{i}"], v[f"ref{i}"]
            ports = cached_port_function(cam.basis, problem.friction_model,
                                         opt.quadrature_order, "closed-form").map(n)
            h = (cam.theta_range[1] - cam.theta_range[0]) / (n - 1)
            first = opt.quadrature_order * int(np.ceil(max(abs(cam.theta_range[0]) / h, 1)))
            # wrapped lengths are lifted to variables, tied segment by segment (Eq. 10, 14),
            # which keeps the Lagrangian Hessian banded instead of dense
            wrapped = L * v[f"len{i}"]
            seg = segment_lengths(cam.basis, opt.quadrature_order, first, ref[0], alpha, c)
            constrain((wrapped - ca.vertcat(0, wrapped[:n - 1]) - seg) / L, zero)
            d, arm, res, _ = ports(theta, alpha, gamma, ref[0], ref[1], wrapped.T, c, r, a0, mu)
            res_ref = cam_function(cam.basis)(0, ref[0], ref[1], c, r, a0)[0]
            # seed 003, Eq. 6–7 at every grid angle and at θ = 0
            constrain(ca.vertcat(res[0, :].T, res_ref[0]), zero)
            constrain(ca.vertcat(res[1, :].T, res_ref[1]) / L, zero)
            # seed 003, Eq. 40 and ρ bounds over the whole wrapped range [0, α(θ_max)]
            M = opt.convexity_points
            phi = alpha[n - 1] * ca.DM(np.linspace(0, 1, M)).T
            rho, _, _, conv = cached_profile_function(cam.basis).map(M)(phi, c)
            constrain(conv.T / L**2, lambda pr, i=i: (
                pr.options.convexity_epsilon * (pr.cams[i].rho_min / L) ** 2, np.inf))
            constrain(rho.T / L, lambda pr, i=i: (pr.cams[i].rho_min / L, pr.cams[i].rho_max / L))
            D.append(d[:, idx[i]])
            A.append(arm[:, idx[i]])
            weights.append(trapezoid_weights_sx(theta)[idx[i]])
            tau_d.append(p[f"tau_d{i}"])

        W = weights[0]
        for w in weights[1:]:
            W = W * w
        net = network_function(list(problem.springs), m).map(self.N)
        xs, tau, jac = net(ca.vertcat(*D), ca.vertcat(*A), p["k"], L * v["x0"])
        # seed 003, Eq. 46: 0 ≤ x_i ≤ x_i,max on the grid
        constrain(ca.vec(xs) / L, lambda pr: (
            0.0, np.tile([s.travel / L for s in pr.springs], self.N)))
        objective = 0
        for i in range(m):
            w_track = p[f"cam{i}"][3]
            objective += w_track * ca.dot(W.T, (tau_d[i] - tau[i, :].T) ** 2)  # Eq. 46 term 1
        for i, j in self.pairs:
            # |∂τ_i/∂k_j| without abs: ∂τ/∂k = s⁺ − s⁻ with s± ≥ 0, and s⁺ + s⁻ is minimised
            sp, sn = v[f"sp{i}_{j}"], v[f"sn{i}_{j}"]
            constrain(sp - sn - jac[i, j::S].T / SENS_SCALE, zero)
            objective += p[f"wsens{i}"][j] * SENS_SCALE * ca.dot(W.T, sp + sn)  # Eq. 46 terms 2–3
        self.objective = ca.Function("objective", [x, P], [objective])
        nlp = {"x": x, "p": P, "f": objective * p["obj_scale"], "g": ca.vertcat(*g)}
        self.solver = ca.nlpsol("cadcam", "ipopt", nlp, {
            "print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
            "ipopt.max_iter": opt.max_iter, "ipopt.tol": opt.tol, **EXTRA,
        })
        self.lbx = np.full(v.size, -np.inf)
        self.lbx[v.blocks["x0"][0]:v.blocks["x0"][0] + S] = 0  # seed 003, Eq. 46: x₀ ≥ 0
        for i, j in self.pairs:
            v.put(self.lbx, f"sp{i}_{j}", 0)
            v.put(self.lbx, f"sn{i}_{j}", 0)
        self.ubx = np.full(v.size, np.inf)
        self.build_time_s = time.perf_counter() - t0

    # -- numbers of a case -------------------------------------------------------------------
    def parameters(self, problem: Problem) -> np.ndarray:
        """The parameter vector of ``problem`` (same structure as the one built)."""
        p, m, n = self.p, self.m, self.n
        vec = np.zeros(p.size)
        grids = [c.grid(n) for c in problem.cams]
        theta = np.vstack([grids[i][g] for i, g in enumerate(np.indices((n,) * m).reshape(m, -1))])
        energy = 0.0
        W = np.prod([trapezoid_weights(grids[i])[g] for i, g in
                     enumerate(np.indices((n,) * m).reshape(m, -1))], axis=0)
        for i, c in enumerate(problem.cams):
            td = np.asarray(c.target.function(m, i).map(self.N)(theta)).ravel()
            energy += c.tracking_weight * np.dot(W, td**2)
            p.put(vec, f"theta{i}", grids[i])
            p.put(vec, f"tau_d{i}", td)
            p.put(vec, f"cam{i}", [c.idler_radius, c.idler_offset, c.mu, c.tracking_weight])
            p.put(vec, f"wsens{i}", c.sensitivity_weights)
        p.put(vec, "k", [s.rate for s in problem.springs])
        p.put(vec, "obj_scale", 1.0 / energy if energy > 0 else 1.0)
        return vec

    def bounds(self, problem: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the constraint rows for ``problem``'s limits."""
        lo, hi = zip(*[np.broadcast_arrays(*(np.broadcast_to(b, (size,)) for b in fn(problem)))
                       for size, fn in self._bounds])
        return np.concatenate(lo), np.concatenate(hi)

    def initial_guess(self, problem: Problem, design: Design) -> np.ndarray:
        """NLP start from a design: tangency angles by the rootfinder, s± from ∂τ/∂k."""
        v, n = self.v, self.n
        w0 = np.zeros(v.size)
        for i, cam in enumerate(problem.cams):
            c = design.coefficients[i]
            th = np.concatenate([[0.0], cam.grid(n)])
            a, g, _ = tangency_solver(cam.basis).solve(th, c, cam.idler_radius, cam.idler_offset)
            v.put(w0, f"c{i}", c / LENGTH_SCALE)
            v.put(w0, f"alpha{i}", a[1:])
            v.put(w0, f"gamma{i}", g[1:])
            v.put(w0, f"ref{i}", [a[0], g[0]])
            wrapped = cached_length_function(cam.basis, 4 * self.problem.options.quadrature_order
                                             ).map(n)(a[0], a[1:], c)
            v.put(w0, f"len{i}", np.asarray(wrapped).ravel() / LENGTH_SCALE)
        v.put(w0, "x0", design.preextension / LENGTH_SCALE)
        if self.pairs:  # s⁺ − s⁻ start on ∂τ/∂k, i.e. feasible and tight
            ev = evaluate(problem, design, grid=n, order=4 * problem.options.quadrature_order,
                          wire_arm="closed-form")
            for i, j in self.pairs:
                J = ev.dtau_dk[i, :, j] / SENS_SCALE
                v.put(w0, f"sp{i}_{j}", np.maximum(J, 0))
                v.put(w0, f"sn{i}_{j}", np.maximum(-J, 0))
        return w0

    def design_of(self, w) -> Design:
        """The design held in an NLP vector."""
        return Design([c.basis for c in self.problem.cams],
                      [self.v.part(w, f"c{i}") * LENGTH_SCALE for i in range(self.m)],
                      self.v.part(w, "x0") * LENGTH_SCALE)

    def solve(self, problem: Problem, start: Design) -> Solve:
        """Run IPOPT from ``start`` with ``problem``'s numbers."""
        pv = self.parameters(problem)
        w0 = self.initial_guess(problem, start)
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


def trapezoid_weights_sx(x):
    """Trapezoidal weights (row vector) on symbolic nodes ``x`` (a column)."""
    n = x.shape[0]
    h = x[1:] - x[:-1]
    w = ca.vertcat(h[0] / 2, (h[:-1] + h[1:]) / 2, h[n - 2] / 2) if n > 2 else ca.vertcat(h / 2, h / 2)
    return w.T
