"""Where the wire leaves the cam for the follower idler (seed 003, Sec. 2 and 4).

The idler of radius r [m] rides on a platform that slides horizontally; its centre q is at
height a₀ [m] on the +x side of the cam. The cam is rotated by θ [rad]: the profile point at
polar angle φ sits at world angle φ − θ. The contact point p is at cam angle α on the profile and
at angle γ on the idler (both [rad]).

Unknowns (α, γ) solve two scalar equations: the tangency t̂(α) = −t̂(γ) of Eq. 6, written as the
single condition t̂(α) × t̂(γ) = 0 (the antiparallel branch is fixed by the initial guess and
checked by ``branch`` = t̂(α)·t̂(γ) = −1), and the vertical closure of Eq. 7. Posing both
components of Eq. 6 would over-determine the system.
"""
from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np

from .profile import Basis, profile_function


def cam_tangent(theta, alpha, rho, drho):
    """Unit tangent t̂(α) of the cam in the world frame (seed 003, Eq. 3 and 5)."""
    w = alpha - theta
    tx = drho * ca.cos(w) - rho * ca.sin(w)  # seed 003, Eq. 3
    ty = drho * ca.sin(w) + rho * ca.cos(w)
    s = ca.sqrt(rho**2 + drho**2)  # seed 003, Eq. 5
    return tx / s, ty / s


def tangency_residuals(theta, alpha, gamma, rho, drho, r, a0):
    """Residuals of the wire–cam–idler tangency (seed 003, Eq. 6 and 7).

    Returns
    -------
    cross : t̂(α) × t̂(γ) [-], zero when the tangents are (anti)parallel (Eq. 6).
    closure : ρ(α) sin(α − θ) − r sin γ − a₀ [m] (Eq. 7).
    branch : t̂(α)·t̂(γ) [-], −1 on the physical branch t̂(α) = −t̂(γ).
    """
    tx, ty = cam_tangent(theta, alpha, rho, drho)
    gx, gy = -ca.sin(gamma), ca.cos(gamma)  # seed 003, Eq. 4–5: t̂(γ)
    cross = tx * gy - ty * gx  # seed 003, Eq. 6 as one scalar condition
    closure = rho * ca.sin(alpha - theta) - r * ca.sin(gamma) - a0  # seed 003, Eq. 7
    return cross, closure, tx * gx + ty * gy


def idler_centre_x(theta, alpha, gamma, rho, r):
    """Horizontal position q_x of the idler centre [m] (seed 003, Eq. 15)."""
    return rho * ca.cos(alpha - theta) - r * ca.cos(gamma)  # seed 003, Eq. 15


def departure_moments(theta, alpha, rho, drho):
    """Moments about the cam centre of unit forces at the contact point p [m].

    ``arm_t`` = ẑ·(r_p × t̂) is the moment of a unit wire tension along t̂ (Eq. 19, 21) and
    ``arm_n`` = ẑ·(r_p × n̂) = ρρ′/√(ρ² + ρ′²) that of a unit idler push along the **unit**
    inward normal n̂ = ẑ × t̂ (Eq. 20, 21).
    """
    w = alpha - theta
    px, py = rho * ca.cos(w), rho * ca.sin(w)  # seed 003, Eq. 2: r_p/o
    tx, ty = cam_tangent(theta, alpha, rho, drho)
    nx, ny = -ty, tx  # n̂ = ẑ × t̂, the unit inward normal
    return px * ty - py * tx, px * ny - py * nx  # seed 003, Eq. 21: τ = (r_p × f)ᵀẑ


@lru_cache(maxsize=64)
def cam_function(basis: Basis) -> ca.Function:
    """Per-angle geometry of one wire cam as a CasADi Function.

    ``cam(theta, alpha, gamma, c, r, a0) -> (residual[2], branch, qx, arm_t, arm_n, rho, px, py)``
    with angles [rad], lengths [m]; see :func:`tangency_residuals`, :func:`idler_centre_x` and
    :func:`departure_moments`. ``px, py`` is the contact point in the world frame [m].
    """
    theta, alpha, gamma, r, a0 = (ca.SX.sym(n) for n in ("theta", "alpha", "gamma", "r", "a0"))
    c = ca.SX.sym("c", basis.size)
    rho, drho, _, _ = profile_function(basis)(alpha, c)
    cross, closure, branch = tangency_residuals(theta, alpha, gamma, rho, drho, r, a0)
    arm_t, arm_n = departure_moments(theta, alpha, rho, drho)
    w = alpha - theta
    return ca.Function(
        "cam", [theta, alpha, gamma, c, r, a0],
        [ca.vertcat(cross, closure), branch, idler_centre_x(theta, alpha, gamma, rho, r),
         arm_t, arm_n, rho, rho * ca.cos(w), rho * ca.sin(w)],
        ["theta", "alpha", "gamma", "c", "r", "a0"],
        ["residual", "branch", "qx", "arm_t", "arm_n", "rho", "px", "py"],
    )


def guess_function(basis: Basis, sweeps: int = 6) -> ca.Function:
    """Start for the tangency solve: ``guess(theta, c, r, a0) -> (alpha, gamma)`` [rad].

    The circle solution (ρ + r) sin(α − θ) = a₀ iterated ``sweeps`` times with ρ = ρ(α), then
    γ along the inward normal n̂ = ẑ × t̂(α); exact for a circular cam.
    """
    theta, r, a0 = ca.SX.sym("theta"), ca.SX.sym("r"), ca.SX.sym("a0")
    c = ca.SX.sym("c", basis.size)
    prof = profile_function(basis)
    alpha = theta
    for _ in range(sweeps):
        alpha = theta + ca.asin(a0 / (prof(alpha, c)[0] + r))
    rho, drho, _, _ = prof(alpha, c)
    tx, ty = cam_tangent(theta, alpha, rho, drho)
    gamma = ca.atan2(-tx, ty) + ca.pi  # direction of n̂ = ẑ × t̂ = (−t_y, t_x), kept near π
    return ca.Function("tangency_guess", [theta, c, r, a0], [alpha, gamma],
                       ["theta", "c", "r", "a0"], ["alpha", "gamma"])


def newton_function(basis: Basis, steps: int = 8) -> ca.Function:
    """Tangency by ``steps`` unrolled Newton iterations from :func:`guess_function`.

    ``newton(theta, c, r, a0) -> (alpha, gamma)`` [rad]: a closed-form expression (no
    callback, no loop), so it code-generates and differentiates like any other. Newton
    converges quadratically from the circle guess; tests check that 8 steps agree with the
    converged rootfinder to 1e-12 rad over the designs' ranges.
    """
    theta, r, a0 = ca.SX.sym("theta"), ca.SX.sym("r"), ca.SX.sym("a0")
    c = ca.SX.sym("c", basis.size)
    z = ca.SX.sym("z", 2)
    res = cam_function(basis)(theta, z[0], z[1], c, r, a0)[0]
    step = ca.Function("step", [z, theta, c, r, a0], [z - ca.solve(ca.jacobian(res, z), res)])
    alpha, gamma = guess_function(basis)(theta, c, r, a0)
    zk = ca.vertcat(alpha, gamma)
    for _ in range(steps):
        zk = step(zk, theta, c, r, a0)
    return ca.Function("tangency_newton", [theta, c, r, a0], [zk[0], zk[1]],
                       ["theta", "c", "r", "a0"], ["alpha", "gamma"])


class TangencySolver:
    """Newton rootfinder for (α, γ) of a fixed design at many cam angles.

    The initial guess comes from :func:`guess_function`, exact for a circular cam.
    """

    def __init__(self, basis: Basis, abstol: float = 1e-14, max_iter: int = 50):
        self.basis = basis
        self.cam = cam_function(basis)
        self._guess = guess_function(basis)
        z = ca.SX.sym("z", 2)
        theta, r, a0 = ca.SX.sym("theta"), ca.SX.sym("r"), ca.SX.sym("a0")
        c = ca.SX.sym("c", basis.size)
        res = self.cam(theta, z[0], z[1], c, r, a0)[0]
        g = ca.Function("tangency", [z, ca.vertcat(theta, c, r, a0)], [res])
        self._rf = ca.rootfinder("tangency_newton", "newton", g,
                                 {"abstol": abstol, "max_iter": max_iter, "error_on_fail": False,
                                  "show_eval_warnings": False})  # failures show in the residual

    def guess(self, theta, c, r, a0):
        """Initial (α, γ) [rad] for each θ in ``theta``; see :func:`guess_function`."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        alpha, gamma = self._guess.map(theta.size)(theta, c, r, a0)
        return np.asarray(alpha).ravel(), np.asarray(gamma).ravel()

    def solve(self, theta, c, r, a0, start=None):
        """(α, γ) [rad] and the max residual at each θ; see :func:`tangency_residuals`.

        ``start`` = (α, γ) arrays overrides :meth:`guess` as Newton's starting point (the
        converged root is the same; a better start only helps where the guess is poor).
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        c = np.asarray(c, dtype=float).ravel()
        alpha0, gamma0 = self.guess(theta, c, r, a0) if start is None else start
        n = theta.size
        p = np.vstack([theta, np.tile(c[:, None], (1, n)), np.full(n, r), np.full(n, a0)])
        z = np.asarray(self._rf.map(n)(np.vstack([alpha0, gamma0]), p))
        res = np.asarray(self.cam.map(n)(theta, z[0], z[1], c, r, a0)[0])
        return z[0], z[1], np.abs(res).max(axis=0)
