"""The torque model of a design as one differentiable CasADi Function.

``torque(theta[m], c[Σ nᵢ+1], k[S], x0[S]) -> (tau[m], x[S])``: cam angles [rad], all cams'
coefficients stacked [m], spring rates [N/m] and pre-extensions [m] to cam torques [N·m] and
spring extensions [m]. The tangency is solved by a Newton rootfinder embedded in the graph, so
derivatives with respect to every input follow from the implicit function theorem; this is the
model a controller or another optimizer would call.
"""
from __future__ import annotations

import casadi as ca

from .departure import cam_function
from .problem import Problem
from .profile import Basis, profile_function
from .springs import network_function
from .wirecam import port_function
from .wrap import length_function


def _tangency_rootfinder(basis: Basis) -> ca.Function:
    z = ca.MX.sym("z", 2)
    theta, r, a0 = ca.MX.sym("theta"), ca.MX.sym("r"), ca.MX.sym("a0")
    c = ca.MX.sym("c", basis.size)
    res = cam_function(basis)(theta, z[0], z[1], c, r, a0)[0]
    g = ca.Function("g", [z, ca.vertcat(theta, c, r, a0)], [res])
    return ca.rootfinder("tangency", "newton", g, {"abstol": 1e-14, "max_iter": 50})


def _circle_guess(basis: Basis, theta, c, r, a0):
    """(α, γ) of the circle through ρ near the contact: the rootfinder's start."""
    rho = profile_function(basis)(theta + 0.3, c)[0]
    alpha = theta + ca.asin(a0 / (rho + r))
    return ca.vertcat(alpha, ca.pi + alpha - theta)


def torque_function(problem: Problem, bases: list[Basis], order: int = 48) -> ca.Function:
    """Build the differentiable torque model for designs in ``bases`` (one per cam).

    Uses the problem's idlers, μ, friction model and spring network; ``order`` is the
    Gauss–Legendre order of the wrapped-length and friction integrals over the whole wrap.
    """
    m = len(problem.cams)
    theta = ca.MX.sym("theta", m)
    cs = [ca.MX.sym(f"c{i}", b.size) for i, b in enumerate(bases)]
    k, x0 = ca.MX.sym("k", len(problem.springs)), ca.MX.sym("x0", len(problem.springs))
    D, A = [], []
    for i, (cam, b, c) in enumerate(zip(problem.cams, bases, cs)):
        r, a0 = cam.idler_radius, cam.idler_offset
        rf = _tangency_rootfinder(b)
        z = rf(_circle_guess(b, theta[i], c, r, a0), ca.vertcat(theta[i], c, r, a0))
        zr = rf(_circle_guess(b, 0, c, r, a0), ca.vertcat(0, c, r, a0))
        wrapped = length_function(b, order)(zr[0], z[0], c)
        qx_ref = cam_function(b)(0, zr[0], zr[1], c, r, a0)[2]
        d, arm, _, _ = port_function(b, problem.friction_model, order, "quadrature")(
            theta[i], z[0], z[1], zr[1], qx_ref, wrapped, c, r, a0, cam.mu)
        D.append(d)
        A.append(arm)
    x, tau, _ = network_function(list(problem.springs), m)(ca.vertcat(*D), ca.vertcat(*A), k, x0)
    return ca.Function("torque", [theta, ca.vertcat(*cs), k, x0], [tau, x],
                       ["theta", "c", "k", "x0"], ["tau", "x"])
