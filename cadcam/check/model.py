"""The torque model of a design as differentiable CasADi Functions.

``torque(theta[m], c[Σ nᵢ+1], k[S], x0[S]) -> (tau[m], x[S], alpha[m], gamma[m])``: cam angles
[rad], all cams' coefficients stacked [m], spring rates [N/m] and pre-extensions [m] to cam
torques [N·m], spring extensions [m] and the tangency angles [rad]. The tangency unknowns z
(α, γ at θ and at θ = 0 for every cam) are solved either by a Newton rootfinder in an MX graph
(derivatives by the implicit function theorem) or by a fixed number of unrolled Newton steps
in SX (no callback: the form that code-generates), whose Jacobians
(:func:`torque_jacobian_function`) apply the implicit function theorem explicitly,
dz/dp = −R_z⁻¹ R_p at the solution, instead of differentiating the iterations.
"""
from __future__ import annotations

import casadi as ca

from ..physics.departure import cam_function, guess_function, newton_function
from ..problem import Problem
from ..physics.profile import Basis
from ..physics.springs import network_function
from ..mechanisms.wire_cam import port_function
from ..physics.wrap import length_function

#: Unrolled Newton steps of the exported tangency; 4 already reach 1e-12 rad (tests check 6).
NEWTON_STEPS = 6


def _tangency_rootfinder(basis: Basis):
    z = ca.MX.sym("z", 2)
    theta, r, a0 = ca.MX.sym("theta"), ca.MX.sym("r"), ca.MX.sym("a0")
    c = ca.MX.sym("c", basis.size)
    res = cam_function(basis)(theta, z[0], z[1], c, r, a0)[0]
    g = ca.Function("g", [z, ca.vertcat(theta, c, r, a0)], [res])
    rf = ca.rootfinder("tangency", "newton", g, {"abstol": 1e-14, "max_iter": 50})
    guess = guess_function(basis)
    return lambda theta, c, r, a0: ca.vertsplit(
        rf(ca.vertcat(*guess(theta, c, r, a0)), ca.vertcat(theta, c, r, a0)))


def _model(problem: Problem, bases: list[Basis], sym, order: int, wire_arm: str, solve=None):
    """Symbols (theta, c, k, x0, z), residuals R(z) of Eq. 6–7 and (tau, x) given z.

    ``z`` stacks [α, γ, α₀, γ₀] per cam. With ``solve`` given, z is replaced by its solution.
    """
    m, S = len(problem.cams), len(problem.springs)
    theta = sym("theta", m)
    cs = [sym(f"c{i}", b.size) for i, b in enumerate(bases)]
    k, x0 = sym("k", S), sym("x0", S)
    z = sym("z", 4 * m)
    D, A, R, Z = [], [], [], []
    for i, (cam, b, c) in enumerate(zip(problem.cams, bases, cs)):
        r, a0 = cam.idler_radius, cam.idler_offset
        if solve is None:
            alpha, gamma, alpha_ref, gamma_ref = ca.vertsplit(z[4 * i:4 * i + 4])
        else:
            (alpha, gamma), (alpha_ref, gamma_ref) = solve(b)(theta[i], c, r, a0), solve(b)(0, c, r, a0)
        cam_fn = cam_function(b)
        R += [cam_fn(theta[i], alpha, gamma, c, r, a0)[0], cam_fn(0, alpha_ref, gamma_ref, c, r, a0)[0]]
        wrapped = length_function(b, order)(alpha_ref, alpha, c)
        qx_ref = cam_fn(0, alpha_ref, gamma_ref, c, r, a0)[2]
        d, arm, _, _ = port_function(b, problem.friction_model, order, wire_arm)(
            theta[i], alpha, gamma, gamma_ref, qx_ref, wrapped, c, r, a0, cam.mu)
        D.append(d)
        A.append(arm)
        Z += [alpha, gamma, alpha_ref, gamma_ref]
    x, tau, _ = network_function(list(problem.springs), m)(ca.vertcat(*D), ca.vertcat(*A), k, x0)
    return (theta, ca.vertcat(*cs), k, x0, z), ca.vertcat(*R), ca.vertcat(*Z), tau, x


def torque_function(problem: Problem, bases: list[Basis], order: int = 48,
                    tangency: str = "rootfinder", wire_arm: str = "quadrature") -> ca.Function:
    """Build the torque model for designs in ``bases`` (one per cam).

    Uses the problem's idlers, μ, friction model and spring network; ``order`` is the
    Gauss–Legendre order of the wrapped-length and friction integrals over the whole wrap;
    ``tangency`` is ``rootfinder`` (MX, implicit-function derivatives) or ``newton``
    (:data:`NEWTON_STEPS` unrolled steps, SX, code-generable; differentiate it with
    :func:`torque_jacobian_function`); ``wire_arm`` as in :func:`cadcam.mechanisms.wire_cam.port_function`
    (``closed-form`` is exact and cheap under ``exact`` friction).
    """
    if tangency == "rootfinder":
        sym, solve = ca.MX.sym, _tangency_rootfinder
    else:
        sym, solve = ca.SX.sym, lambda b: newton_function(b, NEWTON_STEPS)
    (theta, c, k, x0, _), _, Z, tau, x = _model(problem, bases, sym, order, wire_arm, solve)
    return ca.Function("torque", [theta, c, k, x0],
                       [tau, x, Z[0::4], Z[1::4]],
                       ["theta", "c", "k", "x0"], ["tau", "x", "alpha", "gamma"])


def torque_jacobian_function(problem: Problem, bases: list[Basis], order: int = 48,
                             wire_arm: str = "quadrature") -> ca.Function:
    """Jacobians of the Newton torque model by the implicit function theorem (SX).

    ``torque_jacobian(theta, c, k, x0)`` gives ∂(tau, x) with respect to (theta, c, k, x0) and
    ∂(alpha, gamma) with respect to (theta, c), named ``d<out>_d<in>``: at the tangency
    solution z(p), dz/dp = −R_z⁻¹ R_p and d·/dp = ∂·/∂p + ∂·/∂z dz/dp, exact when R(z) = 0.
    """
    args, R, _, tau, x = _model(problem, bases, ca.SX.sym, order, wire_arm)
    theta, c, k, x0, z = args
    m = len(problem.cams)
    Rz_inv_Rp = {name: ca.solve(ca.jacobian(R, z), ca.jacobian(R, p))
                 for name, p in (("theta", theta), ("c", c), ("k", k), ("x0", x0))}
    outs, names = [], []
    picks = {"alpha": ca.DM.eye(4 * m)[0::4, :], "gamma": ca.DM.eye(4 * m)[1::4, :]}
    for out_name, out in (("tau", tau), ("x", x), ("alpha", None), ("gamma", None)):
        for in_name, p in (("theta", theta), ("c", c), ("k", k), ("x0", x0)):
            if out is None:
                if in_name in ("k", "x0"):
                    continue  # the tangency does not depend on the springs
                outs.append(-ca.mtimes(picks[out_name], Rz_inv_Rp[in_name]))
            else:
                outs.append(ca.jacobian(out, p) - ca.mtimes(ca.jacobian(out, z), Rz_inv_Rp[in_name]))
            names.append(f"d{out_name}_d{in_name}")
    # evaluate the derivatives at the tangency solution: z = Newton(theta, c)
    newton = [newton_function(b, NEWTON_STEPS) for b in bases]
    z_star, k0 = [], 0
    for i, (cam, b) in enumerate(zip(problem.cams, bases)):
        ci = c[k0:k0 + b.size]
        k0 += b.size
        a, g = newton[i](theta[i], ci, cam.idler_radius, cam.idler_offset)
        a0, g0 = newton[i](0, ci, cam.idler_radius, cam.idler_offset)
        z_star += [a, g, a0, g0]
    outs = ca.substitute(outs, [z], [ca.vertcat(*z_star)])
    return ca.Function("torque_jacobian", [theta, c, k, x0], [ca.densify(o) for o in outs],
                       ["theta", "c", "k", "x0"], names)
