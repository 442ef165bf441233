"""Fedorov & Birglen's graphical synthesis of noncircular pulleys (Fedorov2018 Sec. 2.2), for
one pulley and for the differential pair, as cadcam's baseline and start point.

The graphical method draws, in the pulley's frame, a circle of radius s_i around each idler
position P_i (q = 0), or the idler and its involute rotated by σ_i (q ≠ 0); the envelope of
these curves is the involute of the pulley, and the pulley is the envelope of the involute's
normals: the cable lines. Here the same envelope is computed exactly, pose by pose, in terms
of the cable line's normal angle ψ and its support value h (the line's distance from the
shaft). Along the motion, with the pulley-side cable length ℓ (wound + free span − qψ), the
constant total length gives

    t(ψ) · dP/dθ = dℓ/dθ                  (the envelope condition of the circles s_i),
    h = P · n(ψ) + q                      (the line touches the idler, on its left),

with n = (cos ψ, sin ψ), t = (−sin ψ, cos ψ): one equation for ψ per pose, then h. The
pulley's contact point is T = h n + (dh/dψ) t, and its radius of curvature h + d²h/dψ² (> 0:
convex). For the differential pair the cable transferred from one pulley to the other is the
designer's choice; here it is ℓ_k′ = σ_k (R − q) with a rolling radius R (the rate of a
circular pair), which makes mirror-image pulleys for a symmetric law x(θ).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from ..base import residual_function, split_coefficients, wound_lengths
from ...physics.profile import fit_profile, profile_function

#: Wrap [rad] left between the anchor and the least-wound departure point of the start design.
ANCHOR_WRAP = np.radians(0.5)


@dataclass
class Envelope:
    """One pulley by the envelope method, in its own (canonical) frame, at the poses θ.

    ``psi`` [rad] and ``h`` [m]: the cable line's normal angle and distance from the shaft;
    ``points`` (2, n) [m]: the contact points T; ``phi_polar`` [rad] (unwrapped) and ``rho``
    [m]: their polar coordinates; ``curvature_radius`` [m]: h + h″ (> 0 where convex).
    """

    theta: np.ndarray
    psi: np.ndarray
    h: np.ndarray
    points: np.ndarray
    phi_polar: np.ndarray
    rho: np.ndarray
    curvature_radius: np.ndarray

    @property
    def convex(self) -> bool:
        """True if the envelope is a convex curve traversed in one direction."""
        turning = np.diff(self.psi) * np.sign(self.psi[-1] - self.psi[0])
        return bool(np.all(self.curvature_radius > 0) and np.all(turning > 0))


def envelope(theta, x, dx, dl, chi0: float, sigma: float, q: float) -> Envelope:
    """The pulley that moves the idler along x(θ) while its cable length changes at dℓ/dθ.

    Parameters
    ----------
    theta : array (n,)
        Joint angles [rad], increasing.
    x, dx : array (n,)
        The idler's distance from the shaft [m] and dx/dθ [m/rad].
    dl : array (n,)
        dℓ/dθ [m/rad] of the pulley-side cable (wound + free span − qψ); σ(R − q) for a pulley
        that transfers cable at a rolling radius R.
    chi0, sigma : float
        The idler's polar angle in the pulley's frame is χ = χ₀ + σθ [rad].
    q : float
        Idler radius [m].

    Raises
    ------
    ValueError
        Where no cable line satisfies the envelope condition (|dℓ/dθ| > |dP/dθ|).
    """
    theta, x, dx, dl = (np.asarray(v, dtype=float) for v in (theta, x, dx, dl))
    a, b = dx, x * sigma  # dP/dθ in the (radial, tangential) frame of the idler
    amp = np.hypot(a, b)
    if np.any(np.abs(dl) >= amp):
        raise ValueError("the cable cannot change length faster than the idler moves: "
                         "|dl/dtheta| >= |dP/dtheta| somewhere; lower the rolling radius")
    # t·dP/dθ = a sin Δ + b cos Δ = dℓ/dθ with Δ = χ − ψ; the root with the idler ahead
    delta = np.angle(np.exp(1j * (np.arctan2(a, b) + sigma * np.arccos(dl / amp))))  # in (0, π)
    chi = chi0 + sigma * theta
    psi = chi - delta
    h = x * np.cos(delta) + q  # Fedorov2018 Eq. 4a: the line touches the idler
    dh = np.gradient(h, psi, edge_order=2)
    ddh = np.gradient(dh, psi, edge_order=2)
    n = np.array([np.cos(psi), np.sin(psi)])
    t = np.array([-np.sin(psi), np.cos(psi)])
    pts = h * n + dh * t
    # the polar angle of T, continuous in χ (not reduced modulo 2π: χ₀ fixes the turn)
    return Envelope(theta, psi, h, pts, psi + np.arctan2(dh, h), np.hypot(pts[0], pts[1]), h + ddh)


def differential_envelopes(mech, theta, x, dx, rolling_radius: float):
    """Both pulleys of a differential pair ``mech`` (a
    :class:`~cadcam.mechanisms.differential_pulley.model.DifferentialPulley`) for the law x(θ),
    with anchors placed so that the least-wound departure point sits :data:`ANCHOR_WRAP` after
    each anchor.

    Returns the mechanism with those anchor angles and the two :class:`Envelope` (canonical
    frames, polar angles measured from the anchors).
    """
    q = mech.idler_radius
    envs, anchors = [], []
    for w, sigma in zip(mech.windings, mech.sigmas):
        env = envelope(theta, x, dx, np.full_like(theta, sigma * (rolling_radius - q)), 0.0, sigma, q)
        shift = ANCHOR_WRAP - env.phi_polar.min()  # χ₀ turns everything in the frame
        env = replace(env, psi=env.psi + shift, phi_polar=env.phi_polar + shift,
                      points=_rotate(env.points, shift))
        envs.append(env)
        anchors.append(mech.slider_angle - w * shift)  # χ₀ = w (slider_angle − anchor)
    return replace(mech, anchor_angles=tuple(anchors)), envs


def _rotate(points, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([c * points[0] - s * points[1], s * points[0] + c * points[1]])


def fit_pulley(basis, env: Envelope, samples: int = 600) -> np.ndarray:
    """Coefficients of ``basis`` for an envelope's polar samples, resampled uniformly in φ and
    continued along their end tangents over the rest of the basis's domain (down to the anchor
    φ = 0 and up to the domain's end), so that the fit's slope holds to the data's ends."""
    order = np.argsort(env.phi_polar)
    phi, rho = env.phi_polar[order], env.rho[order]
    lo, hi = min(0.0, basis.domain[0]), basis.domain[1]
    step = (phi[-1] - phi[0]) / (samples - 1)
    grid = np.linspace(phi[0], phi[-1], samples)
    values = np.interp(grid, phi, rho)
    head = np.arange(phi[0] - step, lo - step, -step)[::-1]
    tail = np.arange(phi[-1] + step, hi + step, step)
    slopes = np.gradient(values, grid, edge_order=2)[[0, -1]]
    return fit_profile(basis, np.concatenate([head, grid, tail]),
                       np.concatenate([values[0] + slopes[0] * (head - phi[0]), values,
                                       values[-1] + slopes[1] * (tail - phi[-1])]))


#: Largest tangency residual [rad or m] at which :func:`cable_lengths` takes Newton's answer
#: (the departure solver's own, :meth:`cadcam.mechanisms.base.DepartureSolver.solve`).
TANGENCY_TOL = 1e-9


def cable_lengths(mech, coefficients, theta, x, alpha0) -> np.ndarray:
    """The anchor-to-anchor cable length [m] of a pair with the idler at ``x`` at each joint
    angle ``theta``: both tangencies solved by Newton from the departure angles ``alpha0``
    (2 × n) with x held, then Fedorov2018 Eq. 6a–6c; NaN where Newton does not reach
    :data:`TANGENCY_TOL` from its start."""
    theta, x = (np.atleast_1d(np.asarray(v, dtype=float)) for v in (theta, x))
    alpha0 = np.asarray(alpha0, dtype=float).reshape(2, theta.size)
    structure, bases = mech.structure(), mech.bases
    nc = sum(b.size for b in bases)
    a = ca.SX.sym("a", 6)  # α₁, α₂, then ρ, ρ′ of each profile (the unknowns other than x)
    p = ca.SX.sym("p", 2 + nc + len(mech.parameter_names))
    c, q = p[2:2 + nc], p[2 + nc:]
    z = ca.vertcat(a[:2], p[1], a[2:])
    g = ca.Function("g", [a, p], [residual_function(structure)(p[0], z, c, q)[0][:6]])
    rf = ca.rootfinder("tangency", "newton", g, {"abstol": 1e-12, "error_on_fail": False,
                                                 "show_eval_warnings": False})  # judged by the residual
    c_num = np.concatenate([np.asarray(v, dtype=float) for v in coefficients])
    q_num = np.asarray(mech.parameter_values(), dtype=float)
    n = theta.size
    shapes = [np.asarray(profile_function(b).map(n)(a0, ck)[:2]).reshape(2, n)
              for a0, b, ck in zip(alpha0, bases, split_coefficients(bases, c_num))]
    start = np.vstack([alpha0, *shapes])
    params = np.vstack([theta, x, np.tile(c_num[:, None], (1, n)), np.tile(q_num[:, None], (1, n))])
    sol = np.asarray(rf.map(n)(start, params)).reshape(6, n)
    residual = np.abs(np.asarray(g.map(n)(sol, params)).reshape(6, n)).max(axis=0)
    th, zs, cs, qs = ca.SX.sym("theta"), ca.SX.sym("z", len(mech.unknowns)), ca.SX.sym("c", nc), ca.SX.sym("q", q.shape[0])
    path = ca.Function("path", [th, zs, cs, qs], [type(mech).cable_path(
        bases, th, zs, wound_lengths(bases, zs, cs), cs, qs)])
    lengths = np.asarray(path.map(n)(theta, np.vstack([sol[:2], x, sol[2:]]), c_num, q_num)).ravel()
    return np.where(residual <= TANGENCY_TOL, lengths, np.nan)
