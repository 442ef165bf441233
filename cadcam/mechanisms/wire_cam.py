"""The wire-wrapped cam on a follower idler, one angle at a time (seed 003, Sec. 2–4).

Composes the profile, the departure (tangency), the wrapped length and the capstan model into
the two port displacements and two moment arms that the spring network needs
(:mod:`cadcam.physics.springs`). Everything depends on the cam's own angle only, which is what makes
multi-cam grids separable.
"""
from __future__ import annotations

from functools import lru_cache

import casadi as ca

from ..physics.capstan import check_friction_model, wire_torque_function
from ..physics.departure import cam_function
from ..physics.profile import Basis
from ..physics.springs import platform_displacement, wire_displacement


@lru_cache(maxsize=64)
def port_function(basis: Basis, friction_model: str, order: int,
                  wire_arm: str = "closed-form") -> ca.Function:
    """Per-angle port quantities of one cam as a CasADi Function.

    ``ports(theta, alpha, gamma, gamma_ref, qx_ref, wrapped, c, r, a0, mu) ->
    (d[2], arm[2], residual[2], branch)``

    ``wrapped`` is the profile length between α₀ and α [m] (Eq. 10; see
    :func:`cadcam.physics.wrap.length_function`), given as an input so that a caller can integrate it
    per angle (the evaluator) or cumulatively along the grid (the NLP).
    ``d`` = [wire, platform] displacements [m] relative to θ = 0 (Eq. 14, 16), ``arm`` the
    moment arms of unit port forces [m]: the wire term per unit departure tension (Eq. 21 or
    35) and the normal term (Eq. 20–21). ``residual``/``branch`` are the tangency conditions
    at (θ, α, γ) (Eq. 6–7). ``gamma_ref`` and ``qx_ref`` are γ and the idler centre q_x
    (Eq. 15) at θ = 0, computed once per cam by the caller (see :func:`reference`).

    Parameters
    ----------
    basis : Basis
    friction_model : {"exact", "as-printed"}
    order : int
        Gauss–Legendre order of the friction integral (``as-printed`` or ``quadrature``).
    wire_arm : {"closed-form", "quadrature"}
        Under ``exact`` friction the wire arm equals the departure moment ẑ·(r_p × t̂) exactly
        (``closed-form``, cheap); ``quadrature`` integrates Eq. 35 instead, the independent
        path used by the re-check. ``as-printed`` always integrates.
    """
    check_friction_model(friction_model)
    cam = cam_function(basis)
    names = ("theta", "alpha", "gamma", "gamma_ref", "qx_ref", "wrapped", "r", "a0", "mu")
    theta, alpha, gamma, gamma_ref, qx_ref, wrapped, r, a0, mu = (ca.SX.sym(n) for n in names)
    c = ca.SX.sym("c", basis.size)
    res, branch, qx, arm_t, arm_n, *_ = cam(theta, alpha, gamma, c, r, a0)
    if friction_model == "as-printed" or wire_arm == "quadrature":
        arm_t = wire_torque_function(basis, friction_model, order)(alpha, c, mu)
    d = ca.vertcat(wire_displacement(wrapped, r, gamma, gamma_ref),
                   platform_displacement(qx, qx_ref))
    return ca.Function(
        "ports", [theta, alpha, gamma, gamma_ref, qx_ref, wrapped, c, r, a0, mu],
        [d, ca.vertcat(arm_t, arm_n), res, branch],
        ["theta", "alpha", "gamma", "gamma_ref", "qx_ref", "wrapped", "c", "r", "a0", "mu"],
        ["d", "arm", "residual", "branch"],
    )
