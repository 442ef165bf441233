"""The papers' way of solving a design problem, for the side-by-side benchmark.

Johnston2023 solved Eq. 47 with MATLAB's fmincon driving finite differences over a nested
Levenberg–Marquardt solve of the tangency (Eq. 8, ``lsqnonlin``) at every angle, with its force
model of the torque (Eq. 19–21). The faithful Python analogue: scipy's SLSQP with
finite-difference gradients over the design variables (monomial β of each cam and the
pre-extensions, scaled by their start's magnitudes: :meth:`NestedBaseline.solve`), and at
every evaluation ``least_squares`` (method ``lm``) on Eq. 8's residual
at each of the n angles of each cam. Everything after the tangency (wrapped length, port
displacements, the force model's arms, springs) calls cadcam's own model functions, so cadcam
solving the same problem under the same torque model (``force``, or ``force-as-printed``)
differs from this baseline only in how.

The baseline is a force-model baseline: it refuses the ``energy`` torque model (whose arms
need the implicit-function derivative of the departure, which the papers' way never computes)
and problems with sensitivity terms (its objective is Eq. 47's tracking part).
"""
from __future__ import annotations

import time

import casadi as ca
import numpy as np
from scipy.optimize import least_squares, minimize

from cadcam.designs import Design
from cadcam.mechanisms.base import port_function
from cadcam.mechanisms.wire_cam.model import WireCam
from cadcam.mechanisms.wire_cam.departure import cam_tangent, tangency_residuals
from cadcam.physics.profile import Basis, profile_function
from cadcam.physics.quadrature import trapezoid_weights
from cadcam.physics.wrap import length_function, whole_wrap_order


#: Model evaluations kept (first in, first out): more than one finite-difference stencil.
CACHE_SIZE = 64
#: The least scale of a design variable [m, m/rad^k]: SLSQP works on each variable divided by
#: its start's magnitude, or by this where the start's is smaller (a circle's zero β_k).
VARIABLE_SCALE_FLOOR = 1e-3


class TimeCap(Exception):
    """The baseline ran out of its time budget."""


def _eq8_function(basis: Basis) -> ca.Function:
    """Residuals of Johnston2023's Eq. 8, [t̂(α) + t̂(γ); (ρ sin(α − θ) − r sin γ − a₀)/mm], from
    cadcam's symbolic tangency functions, and their Jacobian with respect to (α, γ) (given to
    Levenberg–Marquardt: it makes the baseline faster, never slower, than finite differences)."""
    theta, alpha, gamma, r, a0 = (ca.SX.sym(n) for n in ("theta", "alpha", "gamma", "r", "a0"))
    c = ca.SX.sym("c", basis.size)
    rho, drho, _, _ = profile_function(basis)(alpha, c)
    tx, ty = cam_tangent(theta, alpha, rho, drho)
    closure = tangency_residuals(theta, alpha, gamma, rho, drho, r, a0)[1]
    res = ca.vertcat(tx - ca.sin(gamma), ty + ca.cos(gamma), closure / 1e-3)
    return ca.Function("eq8", [theta, alpha, gamma, c, r, a0],
                       [res, ca.jacobian(res, ca.vertcat(alpha, gamma))])


class NestedBaseline:
    """SLSQP + finite differences + per-angle Levenberg–Marquardt on a cadcam problem of wire
    cams (one profile each) under one of Johnston2023's force models.

    Raises ValueError for another torque model, another mechanism or sensitivity terms.
    """

    def __init__(self, problem):
        if problem.torque_model not in WireCam.force_models:
            raise ValueError(f"the nested baseline reimplements Johnston2023's force model; got torque "
                             f"model {problem.torque_model!r} (use problem.with_torque_model('force'))")
        if not all(isinstance(mech, WireCam) and len(mech.profiles) == 1 for mech in problem.mechanisms):
            raise ValueError("the nested baseline handles wire cams with one profile each")
        if any(w > 0 for j in problem.joints for w in j.sensitivity_weights):
            raise ValueError("the nested baseline's objective is Eq. 47's tracking part: no sensitivity terms")
        self.problem = problem
        self.n = problem.options.grid
        self.m = len(problem.joints)
        self.mechs = problem.mechanisms
        self.bases = [Basis("monomial", pr.basis.order, pr.basis.domain) for pr in problem.profiles]
        self.sizes = [b.size for b in self.bases]
        self.M = problem.options.convexity_points  # the same samples as cadcam's NLP
        self.net = problem.network().function().map(self.n ** self.m)
        grids = [j.grid(self.n) for j in problem.joints]
        mesh = np.meshgrid(*grids, indexing="ij")
        self.theta = np.vstack([t.ravel() for t in mesh])
        self.idx = np.indices((self.n,) * self.m).reshape(self.m, -1)
        self.W = np.prod([trapezoid_weights(g)[i] for g, i in zip(grids, self.idx)], axis=0)
        self.tau_d = np.vstack([np.asarray(j.target.function(self.m, i).map(self.theta.shape[1])(self.theta)).ravel()
                                for i, j in enumerate(problem.joints)])
        self.eq8 = [_eq8_function(b) for b in self.bases]
        # per-angle port displacements and the force model's arms, from cadcam's wire cam
        self.ports = [port_function((type(mech), (b,)), problem.torque_model, whole_wrap_order(self.bases),
                                    "closed-form").map(self.n)
                      for mech, b in zip(self.mechs, self.bases)]
        self.evaluations = 0
        self.lm_solves = 0
        self._cache = {}
        self.deadline = np.inf

    def split(self, z):
        out, k = [], 0
        for s in self.sizes:
            out.append(z[k:k + s])
            k += s
        return out, z[k:]

    def tangency(self, i, theta, c, guess):
        """Eq. 8 by Levenberg–Marquardt: ‖t̂(α) + t̂(γ)‖² + (closure)² → 0."""
        mech = self.mechs[i]
        eq8 = self.eq8[i]
        self.lm_solves += 1
        r, a0 = mech.idler_radius, mech.idler_offset
        return least_squares(lambda z: np.asarray(eq8(theta, z[0], z[1], c, r, a0)[0]).ravel(), guess,
                             jac=lambda z: np.asarray(eq8(theta, z[0], z[1], c, r, a0)[1]),
                             method="lm", xtol=1e-12, ftol=1e-12).x

    def model(self, z):
        """Torques and spring extensions on the grid, and profile samples, for design ``z``."""
        key = z.tobytes()
        if key in self._cache:  # SLSQP's finite differences of the objective and the constraints
            return self._cache[key]  # visit the same points: evaluate the model once per point
        if time.perf_counter() > self.deadline:
            raise TimeCap
        self.evaluations += 1
        cs, x0 = self.split(z)
        D, A, prof = [], [], []
        for i, (mech, c) in enumerate(zip(self.mechs, cs)):
            th = np.concatenate([[mech.reference_angle], self.problem.joints[mech.joint].grid(self.n)])
            sol, guess = [], np.array([np.arcsin(mech.idler_offset / (2 * mech.idler_radius)), np.pi])
            for t in th:  # one LM solve per angle, warm-started from the previous angle
                guess = self.tangency(i, t, c, guess + [th[1] - th[0] if t > th[0] else 0, 0])
                sol.append(guess)
            z = np.array(sol).T  # rows α, γ; column 0 the reference pose
            a = z[0]
            wrapped = length_function(self.bases[i], 48).map(self.n)(a[0], a[1:], c)
            d, arm, _, _ = self.ports[i](th[1:], z[:, 1:], z[:, 0], wrapped, 0, c,
                                          mech.parameter_values())
            D.append(np.asarray(d)[:, self.idx[mech.joint]])
            A.append(np.asarray(arm)[:, self.idx[mech.joint]])
            phi = np.linspace(0, a.max(), self.M)
            rho, _, _, conv = (np.asarray(v).ravel() for v in profile_function(self.bases[i]).map(self.M)(phi, c))
            prof.append((rho, conv))
        k = np.array([s.rate for s in self.problem.springs])
        F0 = np.array([s.preload for s in self.problem.springs])
        x, tau, _ = (np.asarray(v) for v in self.net(np.vstack(D), np.vstack(A), k, x0, F0))
        out = (tau, x, prof)
        if len(self._cache) >= CACHE_SIZE:
            self._cache.pop(next(iter(self._cache)))
        self._cache[key] = out
        return out

    def objective(self, z):
        tau, _, _ = self.model(z)
        return float(sum(j.tracking_weight * np.dot(self.W, (self.tau_d[i] - tau[i]) ** 2)
                         for i, j in enumerate(self.problem.joints)))

    def constraints(self, z):
        """Eq. 47's constraints as g(z) ≥ 0 (mm and mm² scales), with the same margins as
        cadcam's NLP (``limit_margin``, ``convexity_epsilon``) so both solve one problem."""
        tau, x, prof = self.model(z)
        opt = self.problem.options
        travel = np.array([s.travel for s in self.problem.springs])[:, None]
        out = [((1 - opt.limit_margin) * travel - x).ravel() / 1e-3,
               (x - opt.limit_margin * travel).ravel() / 1e-3]
        for (rho, conv), pr in zip(prof, self.problem.profiles):
            out += [(conv - opt.convexity_epsilon * pr.rho_min**2) / 1e-6,
                    (rho - (1 + opt.limit_margin) * pr.rho_min) / 1e-3,
                    ((1 - opt.limit_margin) * pr.rho_max - rho) / 1e-3]
        return np.concatenate(out)

    def solve(self, start: Design, time_cap: float = 300.0, max_iter: int = 200):
        """Run SLSQP from ``start`` for at most ``time_cap`` seconds.

        SLSQP works on the variables divided by their start's magnitudes (at least
        :data:`VARIABLE_SCALE_FLOOR`) and on the objective divided by its start value, as a
        careful user of fmincon scales a problem: unscaled, the gradient of Eq. 47 in the raw
        monomial coefficients is of order 1e4, SLSQP's first steps (identity Hessian) leave the
        domain where the tangency has a solution, and it stops at its start.

        Returns (design, objective [Eq. 47], iterations, wall time [s], finished: bool,
        SLSQP's exit message, or the time cap's).
        """
        z0 = np.concatenate([b.to_monomial(c) for b, c in zip(start.bases, start.coefficients)]
                            + [start.preextension])
        scale = np.maximum(np.abs(z0), VARIABLE_SCALE_FLOOR)
        f0 = self.objective(z0)
        best = {"z": z0, "nit": 0}

        def callback(u):
            best["z"], best["nit"] = u * scale, best["nit"] + 1

        bounds = [(None, None)] * sum(self.sizes) + [(0, None)] * len(self.problem.springs)
        t0 = time.perf_counter()
        self.deadline = t0 + time_cap
        finished = True
        try:
            res = minimize(lambda u: self.objective(u * scale) / f0, z0 / scale, method="SLSQP", bounds=bounds,
                           callback=callback, constraints=[{"type": "ineq", "fun": lambda u: self.constraints(u * scale)}],
                           options={"maxiter": max_iter, "ftol": 1e-10})
            message = f"SLSQP exit {res.status}: {res.message}"
            best["z"] = res.x * scale
        except TimeCap:
            finished, message = False, f"stopped by the time cap of {time_cap:g} s"
        elapsed = time.perf_counter() - t0
        self.deadline = np.inf
        cs, x0 = self.split(best["z"])
        design = Design(self.bases, cs, x0)
        return design, self.objective(best["z"]), best["nit"], elapsed, finished, message
