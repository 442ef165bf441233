"""Capstan friction between the wire and the cam (Johnston2023, Sec. 4.1, Eq. 22–35).

Quasi-static wire on the profile from the anchor φ = 0 to the departure angle α, per unit
departure tension η(α) = 1 (every load here scales with η(α) = k₁x₁).

Two variants of the tangent derivative, selected by name (the wire cam's ``force`` and
``force-as-printed`` torque models use them):

``corrected``
    Eq. 33 with the correct derivative of the unit tangent,
    t̂′ = (r″ − r′ (r′ᵀr″)/(r′ᵀr′)) / ‖r′‖. Integrating Eq. 35 by parts (r′ × ψ = 0) gives
    τ₁,₁ = ẑ·(r_p × η(α) t̂) exactly, for every μ: on an anchored wire friction changes the
    tension along the wrap and the anchor load, not the torque (docs/physics.md).
``as-printed``
    Eq. 33 exactly as the paper prints it, with r′(r′ᵀr′)³(r″ᵀr′); dimensionally wrong, but it
    is what reproduces the published Tables 3–5.
"""
from __future__ import annotations

import casadi as ca

from ...physics.profile import Basis, profile_function
from ...physics.quadrature import gauss_legendre

FRICTION_MODELS = ("corrected", "as-printed")


def check_friction_model(name: str) -> str:
    """Return ``name`` if it is a known friction model, else raise ValueError."""
    if name not in FRICTION_MODELS:
        raise ValueError(f"unknown friction model {name!r}; expected one of {FRICTION_MODELS}")
    return name


def curve(phi, rho, drho, ddrho):
    """r(φ), r′(φ), r″(φ) in the cam frame [m, m/rad, m/rad²] (Johnston2023 Eq. 26)."""
    c, s = ca.cos(phi), ca.sin(phi)
    r0 = ca.vertcat(rho * c, rho * s)  # Johnston2023 Eq. 26
    r1 = ca.vertcat(drho * c - rho * s, drho * s + rho * c)
    r2 = ca.vertcat(ddrho * c - 2 * drho * s - rho * c, ddrho * s + 2 * drho * c - rho * s)
    return r0, r1, r2


def tangent_derivative(r1, r2, model: str):
    """dt̂/dφ [1/rad] of the unit tangent t̂ = r′/‖r′‖, in the chosen friction model.

    ``corrected``: (r″ − r′ (r′ᵀr″)/(r′ᵀr′)) / ‖r′‖. ``as-printed``: the bracket of Johnston2023's
    Eq. 33 as printed, (r″ − r′ (r′ᵀr′)³ (r″ᵀr′)) / ‖r′‖.
    """
    check_friction_model(model)
    nrm = ca.norm_2(r1)
    if model == "corrected":
        return (r2 - r1 * ca.dot(r1, r2) / ca.dot(r1, r1)) / nrm
    return (r2 - r1 * ca.dot(r1, r1) ** 3 * ca.dot(r2, r1)) / nrm  # Johnston2023 Eq. 33 as printed


def tension(phi, alpha, mu):
    """Wire tension η(φ)/η(α) = e^{μ(φ−α)} [-] for φ ∈ [0, α] (Johnston2023 Eq. 31)."""
    return ca.exp(mu * (phi - alpha))  # Johnston2023 Eq. 31


def internal_force_derivative(phi, alpha, mu, r1, r2, model: str):
    """ψ′(φ) per unit departure tension [1/rad] (Johnston2023 Eq. 32–33).

    ψ = η t̂ (Eq. 25, 32), so ψ′ = η (μ t̂ + t̂′) with η from Eq. 31.
    """
    return tension(phi, alpha, mu) * (mu * r1 / ca.norm_2(r1) + tangent_derivative(r1, r2, model))


def _cross_z(a, b):
    return a[0] * b[1] - a[1] * b[0]


def loads_function(basis: Basis, model: str) -> ca.Function:
    """Wire loads along the wrap per unit departure tension, as a CasADi Function.

    ``loads(phi, alpha, c, mu) -> (tension, normal, friction, moment)``: the tension ratio of
    Eq. 31 [-]; the distributed load on the *wire* f = −ψ′ of Eq. 34 split into its component
    along the inward normal ẑ × t̂ (``normal``) and along t̂ (``friction``), both [1/rad]; and
    the moment density ẑ·(r × ψ′) [m/rad] that Eq. 35 integrates.
    """
    phi, alpha, mu = ca.SX.sym("phi"), ca.SX.sym("alpha"), ca.SX.sym("mu")
    c = ca.SX.sym("c", basis.size)
    rho, drho, ddrho, _ = profile_function(basis)(phi, c)
    r0, r1, r2 = curve(phi, rho, drho, ddrho)
    dpsi = internal_force_derivative(phi, alpha, mu, r1, r2, model)
    f = -dpsi  # Johnston2023 Eq. 24 and 34
    t = r1 / ca.norm_2(r1)
    n = ca.vertcat(-t[1], t[0])
    return ca.Function(
        "capstan_loads", [phi, alpha, c, mu],
        [tension(phi, alpha, mu), ca.dot(f, n), ca.dot(f, t), _cross_z(r0, dpsi)],
        ["phi", "alpha", "c", "mu"], ["tension", "normal", "friction", "moment"],
    )


def anchor_load(alpha, mu, t0):
    """ψ(0) per unit departure tension: e^{−μα} t̂(0), the pull on the anchor (Johnston2023 Eq. 32)."""
    return tension(0, alpha, mu) * t0


def wire_torque_function(basis: Basis, model: str, order: int) -> ca.Function:
    """``wire_torque(alpha, c, mu) -> τ₁,₁ / η(α)`` [m] by Gauss–Legendre quadrature.

    Johnston2023, Eq. 35: τ₁,₁ = ẑ·(r(0) × ψ(0)) + ∫₀^α ẑ·(r(σ) × −f(σ)) dσ with −f = ψ′.
    Under ``corrected`` it equals the departure moment ẑ·(r_p × t̂) to quadrature precision.
    """
    alpha, mu = ca.SX.sym("alpha"), ca.SX.sym("mu")
    c = ca.SX.sym("c", basis.size)
    prof = profile_function(basis)
    rho0, drho0, ddrho0, _ = prof(0, c)
    r00, r01, _ = curve(0, rho0, drho0, ddrho0)
    anchor = _cross_z(r00, anchor_load(alpha, mu, r01 / ca.norm_2(r01)))
    s, w = gauss_legendre(order)
    phi = alpha * ca.DM(s).T
    moment = loads_function(basis, model).map(order)(phi, alpha, c, mu)[3]
    total = anchor + alpha * ca.mtimes(moment, ca.DM(w))  # Johnston2023 Eq. 35
    return ca.Function("wire_torque", [alpha, c, mu], [total], ["alpha", "c", "mu"], ["arm"])
