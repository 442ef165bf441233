"""Where the wire leaves the cam for the follower idler (Johnston2023, Sec. 2 and 4).

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

import casadi as ca


def cam_tangent(theta, alpha, rho, drho):
    """Unit tangent t̂(α) of the cam in the world frame (Johnston2023 Eq. 3 and 5)."""
    w = alpha - theta
    tx = drho * ca.cos(w) - rho * ca.sin(w)  # Johnston2023 Eq. 3
    ty = drho * ca.sin(w) + rho * ca.cos(w)
    s = ca.sqrt(rho**2 + drho**2)  # Johnston2023 Eq. 5
    return tx / s, ty / s


def tangency_residuals(theta, alpha, gamma, rho, drho, r, a0):
    """Residuals of the wire–cam–idler tangency (Johnston2023 Eq. 6 and 7).

    Returns
    -------
    cross : t̂(α) × t̂(γ) [-], zero when the tangents are (anti)parallel (Eq. 6).
    closure : ρ(α) sin(α − θ) − r sin γ − a₀ [m] (Eq. 7).
    branch : t̂(α)·t̂(γ) [-], −1 on the physical branch t̂(α) = −t̂(γ).
    """
    tx, ty = cam_tangent(theta, alpha, rho, drho)
    gx, gy = -ca.sin(gamma), ca.cos(gamma)  # Johnston2023 Eq. 4–5: t̂(γ)
    cross = tx * gy - ty * gx  # Johnston2023 Eq. 6 as one scalar condition
    closure = rho * ca.sin(alpha - theta) - r * ca.sin(gamma) - a0  # Johnston2023 Eq. 7
    return cross, closure, tx * gx + ty * gy


def idler_centre_x(theta, alpha, gamma, rho, r):
    """Horizontal position q_x of the idler centre [m] (Johnston2023 Eq. 15)."""
    return rho * ca.cos(alpha - theta) - r * ca.cos(gamma)  # Johnston2023 Eq. 15


def departure_moments(theta, alpha, rho, drho):
    """Moments about the cam centre of unit forces at the contact point p [m].

    ``arm_t`` = ẑ·(r_p × t̂) is the moment of a unit wire tension along t̂ (Eq. 19, 21) and
    ``arm_n`` = ẑ·(r_p × n̂) = ρρ′/√(ρ² + ρ′²) that of a unit idler push along the **unit**
    inward normal n̂ = ẑ × t̂ (Eq. 20, 21).

    These are Johnston2023's force model, not the mechanism's torque: they equal the energy
    model's arms dx/dθ (:func:`cadcam.mechanisms.base.energy_arms`) on a circular cam (ρ′ = 0:
    arm_t = ρ, arm_n = 0) but not in general — Eq. 20 leaves out the wire tension's pull on the
    idler and takes the normal as horizontal (on Table 3's cam 1 the wire arms differ by up to
    0.89 mm, the platform arms by 0.06 mm). cadcam uses them as the named ``force`` model and
    as a check (tests/mechanisms/wire_cam/test_tangency.py, tests/mechanisms/wire_cam/test_energy.py).
    """
    w = alpha - theta
    px, py = rho * ca.cos(w), rho * ca.sin(w)  # Johnston2023 Eq. 2: r_p/o
    tx, ty = cam_tangent(theta, alpha, rho, drho)
    nx, ny = -ty, tx  # n̂ = ẑ × t̂, the unit inward normal
    return px * ty - py * tx, px * ny - py * nx  # Johnston2023 Eq. 21: τ = (r_p × f)ᵀẑ
