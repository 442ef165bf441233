"""The torque model of a design as differentiable CasADi Functions.

``torque(theta[m], c[Σ sizes], k[S], x0[S], F0[S]) -> (tau[m], x[S], z[Σ unknowns])``: joint
angles [rad], every profile's coefficients stacked [m], spring rates [N/m], pre-extensions [m]
and preloads [N] to joint torques [N·m] under the problem's torque model, spring extensions
[m] and every mechanism's departure unknowns at θ (stacked in mechanism order; angles [rad],
other unknowns SI). The unknowns, at θ and at each mechanism's reference angle, are solved
either by a Newton rootfinder in an MX graph (derivatives by the implicit function theorem) or
by a fixed number of unrolled Newton steps in SX (no callback: the form that code-generates),
whose Jacobians (:func:`torque_jacobian_function`) apply the implicit function theorem
explicitly, dz/dp = −R_z⁻¹ R_p at the solution, instead of differentiating the iterations.

Newton starts from a design's solved poses (:func:`solved_poses`) interpolated linearly in θ
where they are given, else from each mechanism's closed-form guess. The guess is exact for
circles but can be far off for a strongly non-circular profile (on Endo2010's inverted
pendulum it sends Newton to a root outside the wrapped range, τ ~ 1e110 N·m), while the poses,
solved by the re-check's rootfinder with continuation along the grid, are near the root at
every angle of the range.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..designs import Design
from ..mechanisms.base import (departure_solver, guess_function, newton_from_function, pose_function,
                               residual_function, split_coefficients)
from ..physics.profile import Basis
from ..physics.wrap import whole_wrap_order
from ..problem import Problem
from .evaluate import mechanism_samples, poses_of

#: Unrolled Newton steps of the exported departure: from the design's poses 4 reach 1e-12 rad
#: where the residual is steep; near a fold of the departure (the end of Endo2010's ordinary
#: pendulum's range) the first steps are shortened (tests check the shipped pulleys).
NEWTON_STEPS = 8
#: Inputs of the torque model, in order.
INPUTS = ("theta", "c", "k", "x0", "F0")


def solved_poses(problem: Problem, design: Design, grid: int | None = None) -> list:
    """Each mechanism's departure unknowns of ``design``, solved as the re-check solves them (the
    rootfinder from the design's own :attr:`~cadcam.designs.Design.poses` where it has them,
    with continuation along the grid) at its joint's ``grid`` angles (default the design grid)
    and at its reference angle, as :func:`cadcam.verify.evaluate.poses_of` lists them: the
    start of the torque model's Newton."""
    units = [mechanism_samples(problem, design, u, problem.joints[mech.joint].grid(grid or problem.options.grid),
                               profile=False, seed=None if design.poses is None else design.poses[u])[0]
             for u, mech in enumerate(problem.mechanisms)]
    return poses_of(problem, units)


def _pose_table(structure, theta: np.ndarray, z: np.ndarray) -> ca.Function:
    """``start(theta, c, q) -> z0``: the poses ``z`` at the angles ``theta`` (see
    :func:`solved_poses`) interpolated linearly in θ, extrapolated beyond its ends."""
    cls, bases = structure
    th = ca.SX.sym("theta")
    c, q = ca.SX.sym("c", sum(b.size for b in bases)), ca.SX.sym("q", len(cls.parameter_names))
    z0 = ca.vertcat(*[ca.pw_lin(th, ca.DM(theta), ca.DM(row)) for row in np.atleast_2d(z)])
    return ca.Function("pose_table", [th, c, q], [z0], ["theta", "c", "q"], ["z0"])


def _mechanism_inputs(problem: Problem, bases: list[Basis], c, q=None, poses=None):
    """Per mechanism: its structure for ``bases`` (the design's), its stacked coefficients
    (symbols cut from ``c``), its parameters: their values, or symbols cut from ``q`` (every
    mechanism's, stacked in mechanism order) where ``q`` is given, and its departure's start
    ``start(theta, c, q) -> z0``: ``poses`` (:func:`solved_poses`) interpolated, else the
    closed-form guess."""
    out, first = [], 0
    pieces = split_coefficients(bases, c)
    for u, (mech, sl) in enumerate(zip(problem.mechanisms, problem.profile_slices())):
        n = len(mech.parameters)
        values = ca.DM(mech.parameter_values()) if q is None else q[first:first + n]
        first += n
        structure = (type(mech), tuple(bases[sl]))
        start = guess_function(structure) if poses is None else _pose_table(structure, *poses[u])
        out.append((structure, ca.vertcat(*pieces[sl]), values, start))
    return out


def _model(problem: Problem, bases: list[Basis], sym, order: int | None, integrals: str, solve=None, q=None,
           poses=None):
    """Symbols (theta, c, k, x0, F0, z), residuals R(z), the unknowns at θ, and (tau, x); the
    wrap integrals on ``order`` points (default :func:`cadcam.physics.wrap.whole_wrap_order`).

    ``z`` stacks [z(θ), z(θ_ref)] per mechanism. With ``solve`` given (structure → solver
    ``(theta, z0, c, q) -> z``), z is replaced by its solution from the start of
    :func:`_mechanism_inputs` (``poses`` or the guess). ``q``: the mechanisms' parameters as
    symbols (see :func:`_mechanism_inputs`), else their values.
    """
    m, S = len(problem.joints), len(problem.springs)
    order = whole_wrap_order(bases) if order is None else order
    theta = sym("theta", m)
    c = sym("c", sum(b.size for b in bases))
    k, x0, F0 = sym("k", S), sym("x0", S), sym("F0", S)
    z = sym("z", 2 * sum(len(mech.unknowns) for mech in problem.mechanisms))
    D, A, R, Z, k0 = [], [], [], [], 0
    for mech, (structure, cu, qu, start) in zip(problem.mechanisms, _mechanism_inputs(problem, bases, c, q, poses)):
        nz, th = len(mech.unknowns), theta[mech.joint]
        if solve is None:
            zu, zr = z[k0:k0 + nz], z[k0 + nz:k0 + 2 * nz]
            k0 += 2 * nz
        else:
            ref = mech.reference_angle
            zu, zr = solve(structure)(th, start(th, cu, qu), cu, qu), solve(structure)(ref, start(ref, cu, qu), cu, qu)
        res = residual_function(structure)
        R += [res(th, zu, cu, qu)[0], res(mech.reference_angle, zr, cu, qu)[0]]
        d, arm, _, _ = pose_function(structure, problem.torque_model, order, integrals)(th, zu, zr, cu, qu)
        D.append(d)
        A.append(arm)
        Z.append(zu)
    x, tau, _ = problem.network().function()(ca.vertcat(*D), ca.vertcat(*A), k, x0, F0)
    return (theta, c, k, x0, F0, z), ca.vertcat(*R), ca.vertcat(*Z), tau, x


def torque_function(problem: Problem, bases: list[Basis], order: int | None = None,
                    tangency: str = "rootfinder", integrals: str = "quadrature", poses=None) -> ca.Function:
    """Build the torque model for designs in ``bases`` (one per profile).

    Uses the problem's mechanisms, torque model and spring network; ``order`` is the
    Gauss–Legendre order of the wrapped-length (and force-model friction) integrals over the
    whole wrap (default the re-check's, :func:`cadcam.physics.wrap.whole_wrap_order`);
    ``tangency`` is ``rootfinder`` (MX, implicit-function derivatives) or ``newton``
    (:data:`NEWTON_STEPS` unrolled steps, SX, code-generable; differentiate it with
    :func:`torque_jacobian_function`); ``integrals`` as in
    :func:`cadcam.mechanisms.base.port_function`; ``poses`` (:func:`solved_poses` of the
    design) start the departure, else the closed-form guess does.
    """
    if tangency == "rootfinder":
        sym = ca.MX.sym

        def solve(s):
            return lambda theta, z0, c, q: departure_solver(s).symbolic(theta, c, q, z0)
    else:
        sym, solve = ca.SX.sym, lambda s: newton_from_function(s, NEWTON_STEPS)
    (theta, c, k, x0, F0, _), _, Z, tau, x = _model(problem, bases, sym, order, integrals, solve, poses=poses)
    return ca.Function("torque", [theta, c, k, x0, F0], [tau, x, Z], list(INPUTS),
                       ["tau", "x", "z"])


def _implicit(R, z, p):
    """R_z⁻¹ R_p: minus the derivative dz/dp of the unknowns that keep R(z, p) = 0 (the implicit
    function theorem)."""
    return ca.solve(ca.jacobian(R, z), ca.jacobian(R, p))


def parameter_model(problem: Problem, bases: list[Basis], order: int | None = None,
                    integrals: str = "quadrature") -> ca.Function:
    """The torque model at given departure unknowns, with the mechanisms' parameters as an
    input, and its derivatives by the implicit function theorem (SX).

    ``model(theta, c, k, x0, F0, q, z) -> (tau, R, dR_dz, dtau_dp)``: ``q`` stacks every
    mechanism's :attr:`~cadcam.mechanisms.base.Mechanism.parameters` in mechanism order, ``z``
    the unknowns at θ and at the reference angle of each mechanism (as :func:`_model`); ``R``
    are their residuals and ``dtau_dp`` the total derivative of τ with respect to
    p = [c; k; x0; F0; q], ∂τ/∂p − ∂τ/∂z R_z⁻¹ R_p, exact where R(z) = 0 — so that a part's
    placement can be varied and differentiated about a solved pose.
    """
    q = ca.SX.sym("q", sum(len(mech.parameters) for mech in problem.mechanisms))
    (theta, c, k, x0, F0, z), R, _, tau, _ = _model(problem, bases, ca.SX.sym, order, integrals, q=q)
    p = ca.vertcat(c, k, x0, F0, q)
    dtau_dp = ca.jacobian(tau, p) - ca.mtimes(ca.jacobian(tau, z), _implicit(R, z, p))
    return ca.Function("parameter_model", [theta, c, k, x0, F0, q, z], [tau, R, ca.jacobian(R, z), dtau_dp],
                       [*INPUTS, "q", "z"], ["tau", "R", "dR_dz", "dtau_dp"])


def torque_jacobian_function(problem: Problem, bases: list[Basis], order: int | None = None,
                             integrals: str = "quadrature", poses=None) -> ca.Function:
    """Jacobians of the Newton torque model by the implicit function theorem (SX).

    ``torque_jacobian(theta, c, k, x0, F0)`` gives ∂(tau, x) with respect to every input and
    ∂z with respect to (theta, c), named ``d<out>_d<in>``: at the departure solution z(p),
    dz/dp = −R_z⁻¹ R_p and d·/dp = ∂·/∂p + ∂·/∂z dz/dp, exact when R(z) = 0. ``poses`` as
    for :func:`torque_function`.
    """
    args, R, _, tau, x = _model(problem, bases, ca.SX.sym, order, integrals)
    *inputs, z = args
    Rz_inv_Rp = {name: _implicit(R, z, p) for name, p in zip(INPUTS, inputs)}
    # the unknowns at θ (not those at the reference angle) of each mechanism
    rows, k0 = [], 0
    for mech in problem.mechanisms:
        nz = len(mech.unknowns)
        rows += list(range(k0, k0 + nz))
        k0 += 2 * nz
    pick = ca.DM.eye(z.shape[0])[rows, :]
    outs, names = [], []
    for out_name, out in (("tau", tau), ("x", x), ("z", None)):
        for in_name, p in zip(INPUTS, inputs):
            if out is None:
                if in_name not in ("theta", "c"):
                    continue  # the departure does not depend on the springs
                outs.append(-ca.mtimes(pick, Rz_inv_Rp[in_name]))
            else:
                outs.append(ca.jacobian(out, p) - ca.mtimes(ca.jacobian(out, z), Rz_inv_Rp[in_name]))
            names.append(f"d{out_name}_d{in_name}")
    # evaluate the derivatives at the departure solution: z = Newton(theta, c)
    theta, c = inputs[0], inputs[1]
    z_star = []
    for mech, (structure, cu, q, start) in zip(problem.mechanisms, _mechanism_inputs(problem, bases, c, poses=poses)):
        newton = newton_from_function(structure, NEWTON_STEPS)
        for th in (theta[mech.joint], mech.reference_angle):
            z_star.append(newton(th, start(th, cu, q), cu, q))
    outs = ca.substitute(outs, [z], [ca.vertcat(*z_star)])
    return ca.Function("torque_jacobian", inputs, [ca.densify(o) for o in outs], list(INPUTS), names)
