"""The papers' way of solving a design problem, for the side-by-side benchmark.

Johnston2023 solved Eq. 47 with MATLAB's fmincon driving finite differences over a nested
Levenberg–Marquardt solve of the tangency (Eq. 8, ``lsqnonlin``) at every angle. The faithful
Python analogue: scipy's SLSQP with finite-difference gradients over the design variables
(monomial β of each cam and the pre-extensions), and at every evaluation ``least_squares``
(method ``lm``) on Eq. 8's residual at each of the n angles of each cam. Everything after the
tangency (wrapped length, torque, springs) calls cadcam's own model functions, so the two
approaches solve the same problem and differ only in how.
"""
from __future__ import annotations

import time

import casadi as ca
import numpy as np
from scipy.optimize import least_squares, minimize

from cadcam.physics.departure import cam_tangent, tangency_residuals
from cadcam.design import Design
from cadcam.mechanisms.wire_cam import port_function
from cadcam.physics.departure import cam_function
from cadcam.physics.quadrature import trapezoid_weights
from cadcam.physics.wrap import length_function
from cadcam.physics.profile import Basis, profile_function
from cadcam.physics.springs import network_function


class TimeCap(Exception):
    """The baseline ran out of its time budget."""


def _eq8_function(basis: Basis) -> ca.Function:
    """Residuals of Johnston2023's Eq. 8, [t̂(α) + t̂(γ); (ρ sin(α − θ) − r sin γ − a₀)/mm], from
    cadcam's symbolic tangency functions."""
    theta, alpha, gamma, r, a0 = (ca.SX.sym(n) for n in ("theta", "alpha", "gamma", "r", "a0"))
    c = ca.SX.sym("c", basis.size)
    rho, drho, _, _ = profile_function(basis)(alpha, c)
    tx, ty = cam_tangent(theta, alpha, rho, drho)
    closure = tangency_residuals(theta, alpha, gamma, rho, drho, r, a0)[1]
    return ca.Function("eq8", [theta, alpha, gamma, c, r, a0],
                       [ca.vertcat(tx - ca.sin(gamma), ty + ca.cos(gamma), closure / 1e-3)])


class NestedBaseline:
    """SLSQP + finite differences + per-angle Levenberg–Marquardt on a cadcam problem."""

    def __init__(self, problem):
        self.problem = problem
        self.n = problem.options.grid
        self.m = len(problem.cams)
        self.bases = [Basis("monomial", c.basis.order, c.basis.domain) for c in problem.cams]
        self.sizes = [b.size for b in self.bases]
        self.M = problem.options.convexity_points  # the same samples as cadcam's NLP
        self.net = network_function(list(problem.springs), self.m).map(self.n ** self.m)
        grids = [c.grid(self.n) for c in problem.cams]
        mesh = np.meshgrid(*grids, indexing="ij")
        self.theta = np.vstack([t.ravel() for t in mesh])
        self.idx = np.indices((self.n,) * self.m).reshape(self.m, -1)
        self.W = np.prod([trapezoid_weights(g)[i] for g, i in zip(grids, self.idx)], axis=0)
        self.tau_d = np.vstack([np.asarray(c.target.function(self.m, i).map(self.theta.shape[1])(self.theta)).ravel()
                                for i, c in enumerate(problem.cams)])
        self.eq8 = [_eq8_function(b) for b in self.bases]
        self.evaluations = 0
        self.lm_solves = 0
        self._cache = (None, None)
        self.deadline = np.inf

    def split(self, z):
        out, k = [], 0
        for s in self.sizes:
            out.append(z[k:k + s])
            k += s
        return out, z[k:]

    def tangency(self, i, theta, c, guess):
        """Eq. 8 by Levenberg–Marquardt: ‖t̂(α) + t̂(γ)‖² + (closure)² → 0."""
        cam = self.problem.cams[i]
        eq8 = self.eq8[i]
        self.lm_solves += 1
        return least_squares(lambda z: np.asarray(eq8(theta, z[0], z[1], c, cam.idler_radius,
                                                     cam.idler_offset)).ravel(),
                             guess, method="lm", xtol=1e-12, ftol=1e-12).x

    def model(self, z):
        """Torques and spring extensions on the grid, and profile samples, for design ``z``."""
        if self._cache[0] is not None and np.array_equal(self._cache[0], z):
            return self._cache[1]
        if time.perf_counter() > self.deadline:
            raise TimeCap
        self.evaluations += 1
        cs, x0 = self.split(z)
        D, A, prof = [], [], []
        for i, (cam, c) in enumerate(zip(self.problem.cams, cs)):
            th = np.concatenate([[0.0], cam.grid(self.n)])
            sol, guess = [], np.array([np.arcsin(cam.idler_offset / (2 * cam.idler_radius)), np.pi])
            for t in th:  # one LM solve per angle, warm-started from the previous angle
                guess = self.tangency(i, t, c, guess + [th[1] - th[0] if t > 0 else 0, 0])
                sol.append(guess)
            a, g = np.array(sol).T
            wrapped = length_function(self.bases[i], 48).map(self.n)(a[0], a[1:], c)
            qx_ref = float(cam_function(self.bases[i])(0.0, a[0], g[0], c, cam.idler_radius,
                                                              cam.idler_offset)[2])
            d, arm, _, _ = port_function(self.bases[i], self.problem.friction_model, 48, "closed-form"
                                                ).map(self.n)(th[1:], a[1:], g[1:], g[0], qx_ref, wrapped, c,
                                                              cam.idler_radius, cam.idler_offset, cam.mu)
            D.append(np.asarray(d)[:, self.idx[i]])
            A.append(np.asarray(arm)[:, self.idx[i]])
            phi = np.linspace(0, a.max(), self.M)
            rho, _, _, conv = (np.asarray(v).ravel() for v in profile_function(self.bases[i]).map(self.M)(phi, c))
            prof.append((rho, conv))
        k = np.array([s.rate for s in self.problem.springs])
        x, tau, _ = (np.asarray(v) for v in self.net(np.vstack(D), np.vstack(A), k, x0))
        out = (tau, x, prof)
        self._cache = (z.copy(), out)
        return out

    def objective(self, z):
        tau, _, _ = self.model(z)
        return float(sum(c.tracking_weight * np.dot(self.W, (self.tau_d[i] - tau[i]) ** 2)
                         for i, c in enumerate(self.problem.cams)))

    def constraints(self, z):
        """Eq. 47's constraints as g(z) ≥ 0 (mm and mm² scales), with the same margins as
        cadcam's NLP (``limit_margin``, ``convexity_epsilon``) so both solve one problem."""
        tau, x, prof = self.model(z)
        opt = self.problem.options
        travel = np.array([s.travel for s in self.problem.springs])[:, None]
        out = [((1 - opt.limit_margin) * travel - x).ravel() / 1e-3,
               (x - opt.limit_margin * travel).ravel() / 1e-3]
        for (rho, conv), cam in zip(prof, self.problem.cams):
            out += [(conv - opt.convexity_epsilon * cam.rho_min**2) / 1e-6,
                    (rho - (1 + opt.limit_margin) * cam.rho_min) / 1e-3,
                    ((1 - opt.limit_margin) * cam.rho_max - rho) / 1e-3]
        return np.concatenate(out)

    def solve(self, start: Design, time_cap: float = 180.0, max_iter: int = 200):
        """Run SLSQP from ``start`` for at most ``time_cap`` seconds.

        Returns (design, objective [Eq. 47], iterations, wall time [s], finished: bool).
        """
        z0 = np.concatenate([b.to_monomial(c) for b, c in zip(start.bases, start.coefficients)]
                            + [start.preextension])
        best = {"z": z0, "nit": 0}

        def callback(z):
            best["z"], best["nit"] = z.copy(), best["nit"] + 1

        bounds = [(None, None)] * sum(self.sizes) + [(0, None)] * len(self.problem.springs)
        t0 = time.perf_counter()
        self.deadline = t0 + time_cap
        finished = True
        try:
            minimize(self.objective, z0, method="SLSQP", bounds=bounds, callback=callback,
                     constraints=[{"type": "ineq", "fun": self.constraints}],
                     options={"maxiter": max_iter, "ftol": 1e-10})
        except TimeCap:
            finished = False
        elapsed = time.perf_counter() - t0
        self.deadline = np.inf
        cs, x0 = self.split(best["z"])
        design = Design(self.bases, cs, x0)
        return design, self.objective(best["z"]), best["nit"], elapsed, finished
