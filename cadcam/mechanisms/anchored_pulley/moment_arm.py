"""A minimax design of the anchored-spring pulleys of one joint in the coefficients of their
moment arms r_m(θ), the parametrisation of Ludovico2021 Sec. III, under the profile NLP's limits.

Each pulley's moment arm is a Chebyshev series in the joint angle on the joint's range. Its
spring extends by du/dθ = σ r_m from u0 at the pulley's reference angle (virtual work,
Ludovico2021 Sec. II), so u is linear in the coefficients, and the pulley gives the torque
∂V/∂θ = σ(k u + F0) r_m (Ludovico2021 Eq. 1 with Endo2010's preload): the net torque of the
joint is a quadratic in the coefficients. The limits are those of cadcam's profile NLP, read
through Kim & Deshpande's envelope of the cable lines (:func:`.kim_deshpande.cable_line`):
moment arm ≥ ``min_moment_arm``, spring inside its travel, the cable line turning the winding
way (Eq. 6) with a radius of curvature ≥ ``min_curvature_radius`` (Eq. 30), free span ≥
``min_free_span`` and the departure point within [ρ_min, ρ_max]; each kept inside by the
problem's ``limit_margin``. The largest torque error over the grid is minimised by an epigraph
variable, with IPOPT.

The answer is a moment-arm law and its pulley as an envelope (points), not a profile
polynomial ρ(φ): the pulleys it finds can have a departure point that sweeps a wide polar
angle over a small joint angle, or stalls at a tight corner, which a polynomial in φ follows
poorly. :func:`moment_arm_synthesis` (the design method ``moment_arm``) makes them profiles:
each envelope, continued a little past the joint's range, fitted as a polynomial in φ of its
mechanism's order on the polar range it wraps, with its anchor placed just before the
least-wound departure point; the synthesis keeps room in the radius of curvature
(:data:`CURVATURE_RESERVE`) for the fit to follow the envelope's tightest turns.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np
from numpy.polynomial import Chebyshev

from ...errors import SpecError
from ...library_files import ipopt_options
from ...physics.profile import Basis, fit_profile, profile_function
from .kim_deshpande import Envelope, SpringState, cable_line, envelope
from .model import ANCHOR_WRAP, WINDING, AnchoredPulley
from .starts import own_spring, own_target

#: Least rate σν′ = 1 + σφ′ [-] at which the cable line turns the winding way: Ludovico2021
#: Eq. 6 asks > 0; where it nears 0 the departure point runs off to infinity (dh/dν = r′/ν′),
#: which ρ_max forbids long before, so the bound only keeps IPOPT's iterates off that pole.
MIN_TURN = 0.05
#: How many times its limit the moment-arm synthesis keeps each pulley's radius of curvature:
#: where the envelope turns at the limit itself, a polynomial in φ cannot follow the corner
#: without breaking the limit between its samples (with a smaller reserve the fitted pulleys of
#: Ludovico2021's generic torque fail their re-check).
CURVATURE_RESERVE = 1.5
#: Joint angle [rad] by which each moment-arm law is continued past its joint's range, so that
#: the profile runs on smoothly past the extreme departure points (to its anchor on one side).
CONTINUATION = np.radians(10.0)
#: Polar angle [rad] the fitted profile reaches past the most-wound departure point.
TAIL = 0.05
#: Envelope samples per pulley from which its profile is fitted.
FIT_SAMPLES = 4001


@dataclass(frozen=True)
class MomentArmDesign:
    """Moment-arm laws of the anchored pulleys of one joint and what they give on ``theta``.

    Attributes
    ----------
    theta : ndarray
        Joint angles of the design grid [rad].
    basis : Basis
        The Chebyshev basis of the moment arms, on the joint's range [rad].
    mechanisms : tuple of int
        Indices of the pulleys (the problem's mechanisms) designed, in order.
    coefficients : tuple of ndarray
        Each pulley's moment-arm coefficients in ``basis`` [m].
    states : tuple of SpringState
        Each pulley's spring extension, force and moment arm on ``theta``.
    envelopes : tuple of Envelope
        Each pulley as the envelope of its cable lines on ``theta`` (canonical frame).
    torque : ndarray
        The joint's torque ∂V/∂θ from all its pulleys [N·m].
    target : ndarray
        The joint's target [N·m].
    status : str
        IPOPT's return status.
    """

    theta: np.ndarray
    basis: Basis
    mechanisms: tuple[int, ...]
    coefficients: tuple[np.ndarray, ...]
    states: tuple[SpringState, ...]
    envelopes: tuple[Envelope, ...]
    torque: np.ndarray
    target: np.ndarray
    status: str

    @property
    def max_abs_error(self) -> float:
        """Largest |torque − target| on ``theta`` [N·m]."""
        return float(np.max(np.abs(self.torque - self.target)))


def spring_force(spring, u):
    """F = k u + F0 [N] of ``spring`` at extension u [m] (Endo2010's preloaded spring)."""
    return spring.rate * u + spring.preload


def pulley_torque(sigma, force, r):
    """∂V/∂θ = σ F r_m [N·m] of a pulley whose spring pulls with ``force`` [N] at moment arm
    r [m] (Ludovico2021 Eq. 1)."""
    return sigma * force * r  # Ludovico2021 Eq. 1


def _extension_map(basis: Basis, theta0: float) -> tuple[Basis, np.ndarray]:
    """(B, A): ∫_{θ0}^{θ} r_m dα = Σ (A c)_j B_j(θ) for r_m = Σ c_j T_j(θ) in ``basis``, B the
    Chebyshev basis one degree higher on the same range (exact)."""
    columns = [Chebyshev(e, domain=list(basis.domain)).integ(lbnd=theta0).coef
               for e in np.eye(basis.size)]
    return Basis("chebyshev", basis.order + 1, basis.domain), np.column_stack(columns)


def _arm(basis: Basis, theta: np.ndarray, c):
    """r_m, r′_m and r″_m [m, m/rad, m/rad²] on ``theta`` as rows (symbolic or numeric ``c``)."""
    r, dr, d2r, _ = profile_function(basis).map(theta.size)(theta[None, :], c)
    return r, dr, d2r


def _extension(basis: Basis, theta: np.ndarray, c, sigma: float, theta0: float, u0: float):
    """u = u0 + σ∫_{θ0}^{θ} r_m dα [m] on ``theta`` (du/dθ = σ r_m, virtual work)."""
    higher, A = _extension_map(basis, theta0)
    return u0 + sigma * profile_function(higher).map(theta.size)(theta[None, :], ca.mtimes(A, c))[0]


def _pulleys(problem, joint: int) -> list[int]:
    """The mechanisms on ``joint``; ValueError unless all are anchored pulleys."""
    on_joint = [u for u, m in enumerate(problem.mechanisms) if m.joint == joint]
    if not on_joint or not all(isinstance(problem.mechanisms[u], AnchoredPulley) for u in on_joint):
        raise ValueError(f"joint {joint + 1}: a moment-arm design needs anchored pulleys only on it")
    return on_joint


def _limit_rows(problem, mech, spring, r, dr, d2r, x):
    """Rows ≥ 0 of a pulley's limits, each kept ``limit_margin`` inside, in SI units (left to
    IPOPT's gradient-based scaling).

    Those of the envelope are multiplied by the positive rate σν′ (or its square or cube),
    which takes away their pole at ν′ = 0 (dh/dν = r′/ν′): (R − R_min)·(σν′)³,
    (span − span_min)·σν′ and (ρ² − ρ_lim²)·ν′², with R·(σν′)³ the regularity, span·σν′ =
    √(ℓ² − r²)·σν′ − σr′ and ρ²ν′² = r²ν′² + r′² (the departure point at distance
    √(h² + h_ν²) from O).
    """
    ell, _, sigma = mech.parameter_values()[:3]
    margin = problem.options.limit_margin
    prof = mech.profiles[0]
    _, dnu, regularity, _, _, _ = cable_line(r, dr, d2r, ell, sigma)
    turn = sigma * dnu  # > 0: the cable line turns the winding way (Ludovico2021 Eq. 6)
    span_turn = ca.sqrt(ell**2 - r**2) * turn - sigma * dr
    rho2_turn2 = (r * dnu)**2 + dr**2
    lo, hi = prof.rho_min * (1 + margin), prof.rho_max * (1 - margin)
    return [turn - MIN_TURN,
            regularity - prof.min_curvature_radius * (1 + margin) * turn**3,
            r - mech.min_moment_arm * (1 + margin),
            spring.travel * (1 - margin) - x,
            span_turn - mech.min_free_span * (1 + margin) * turn,
            rho2_turn2 - (lo * dnu)**2, (hi * dnu)**2 - rho2_turn2]


def design_moment_arms(problem, joint: int = 0, degree: int = 5, grid: int | None = None) -> MomentArmDesign:
    """Minimax design of the moment arms of the anchored pulleys on ``joint`` (module docstring).

    Parameters
    ----------
    problem : cadcam.problem.Problem
        Every mechanism on ``joint`` is an anchored pulley with a spring of its own on its
        ``cable`` port, whose fixed pre-extension (else 10 % of travel) is u0 at the pulley's
        reference angle; the joint's target depends on its own angle only.
    joint : int
        The joint (0-based).
    degree : int
        Degree of each moment arm's Chebyshev series, ≥ 1.
    grid : int, optional
        Equally spaced joint angles of the objective and the limits (default: the problem's
        fine re-check grid).

    Returns
    -------
    MomentArmDesign
    """
    if degree < 1:
        raise ValueError(f"degree must be at least 1, got {degree}")
    units = _pulleys(problem, joint)
    lo, hi = problem.joints[joint].theta_range
    theta = np.linspace(lo, hi, grid or problem.options.recheck_grid)
    target = own_target(problem, joint)(theta)
    basis = Basis("chebyshev", degree, (lo, hi))
    c = ca.SX.sym("c", basis.size, len(units))
    t = ca.SX.sym("t")
    rows, torque = [], 0
    for col, u in enumerate(units):
        mech = problem.mechanisms[u]
        spring, u0 = own_spring(problem, u)
        sigma = mech.sigma
        arm = _arm(basis, theta, c[:, col])
        x = _extension(basis, theta, c[:, col], sigma, mech.reference_angle, u0)
        torque = torque + pulley_torque(sigma, spring_force(spring, x), arm[0])
        rows += _limit_rows(problem, mech, spring, *arm, x)
    rows += [t - (torque - target[None, :]), t + (torque - target[None, :])]
    g = ca.vertcat(*[ca.vec(row) for row in rows])
    solver = ca.nlpsol("moment_arm", "ipopt", {"x": ca.vertcat(ca.vec(c), t), "f": t, "g": g},
                       ipopt_options({"ipopt.tol": problem.options.tol,
                                      "ipopt.max_iter": problem.options.max_iter}))
    start = np.zeros((basis.size, len(units)))
    start[0] = [problem.mechanisms[u].start_radius(problem.mechanisms[u].profiles[0])
                for u in units]  # circles
    t0 = np.max(np.abs(target))  # the circles' error is of the target's size
    sol = solver(x0=np.append(start.ravel(order="F"), t0), lbg=0, ubg=np.inf)
    coefficients = np.asarray(sol["x"][:-1]).reshape(start.shape, order="F")
    return sample_moment_arms(problem, joint, basis, coefficients.T, theta,
                              solver.stats().get("return_status", "unknown"))


def sample_moment_arms(problem, joint: int, basis: Basis, coefficients, theta,
                       status: str = "") -> MomentArmDesign:
    """The :class:`MomentArmDesign` of moment-arm ``coefficients`` (one row per anchored
    pulley on ``joint``, in ``basis``) on the joint angles ``theta`` [rad]."""
    units = _pulleys(problem, joint)
    theta = np.asarray(theta, dtype=float)
    coefficients = np.asarray(coefficients, dtype=float).T
    target = own_target(problem, joint)(theta)
    states, envelopes, torque = [], [], np.zeros_like(theta)
    for col, u in enumerate(units):
        mech = problem.mechanisms[u]
        spring, u0 = own_spring(problem, u)
        ell, chi0, sigma = mech.parameter_values()[:3]
        r, dr, d2r = (np.asarray(a, dtype=float).ravel() for a in _arm(basis, theta, coefficients[:, col]))
        x = np.asarray(_extension(basis, theta, coefficients[:, col], sigma, mech.reference_angle, u0),
                       dtype=float).ravel()
        force = spring_force(spring, x)
        torque += pulley_torque(sigma, force, r)
        states.append(SpringState(theta, int(sigma), x, force, r))
        envelopes.append(envelope(theta, r, dr, d2r, ell, chi0, int(sigma)))
    return MomentArmDesign(theta=theta, basis=basis, mechanisms=tuple(units),
                           coefficients=tuple(coefficients.T.copy()), states=tuple(states),
                           envelopes=tuple(envelopes), torque=torque, target=target, status=status)


def moment_arm_synthesis(problem, start):
    """The design method ``moment_arm``: every joint's anchored pulleys designed in their
    moment arms (:func:`design_moment_arms`, of degree ``solver.moment_arm_degree`` on the
    design grid, with :data:`CURVATURE_RESERVE`) and made profiles (:func:`fitted_pulley`).

    Parameters
    ----------
    problem : cadcam.problem.Problem
        Only anchored pulleys, each with a spring of its own on its ``cable`` port; each
        joint's target a function of its own angle.
    start : cadcam.designs.Design
        The circles of :func:`cadcam.designs.default_start` (its pre-extensions are kept).

    Returns
    -------
    (Problem, Design)
        The problem with each pulley's anchor angle and profile basis those of its fit, and the
        fitted profiles.

    Raises
    ------
    SpecError
        Where a pulley has no spring of its own, or a joint's target depends on another
        joint's angle (before any design is made).

    Notes
    -----
    The fitted profiles are judged as any design is, by their fine re-check; IPOPT's status on
    the moment-arm NLP is not the verdict (a stop short of its optimum gives profiles that miss
    the target or break a limit, which the re-check reports).
    """
    reserved = replace(problem, mechanisms=tuple(
        replace(m, profiles=tuple(replace(p, min_curvature_radius=CURVATURE_RESERVE * p.min_curvature_radius)
                                  for p in m.profiles)) for m in problem.mechanisms))
    joints = sorted({m.joint for m in problem.mechanisms})
    for joint in joints:
        _refuse_coupled_target(problem, joint)
    mechanisms, bases, coefficients = list(problem.mechanisms), list(start.bases), list(start.coefficients)
    poses = [None] * len(mechanisms)
    for joint in joints:
        try:
            laws = design_moment_arms(reserved, joint, problem.options.moment_arm_degree, problem.options.grid)
        except ValueError as exc:
            raise SpecError(f"solver.method = 'moment_arm': {exc}") from None
        lo, hi = problem.joints[joint].theta_range
        continued = sample_moment_arms(problem, joint, laws.basis, laws.coefficients,
                                       np.linspace(lo - CONTINUATION, hi + CONTINUATION, FIT_SAMPLES))
        for u in laws.mechanisms:
            mechanisms[u], bases[u], coefficients[u], poses[u] = fitted_pulley(problem, continued, u)
    return (replace(problem, mechanisms=tuple(mechanisms)),
            replace(start, bases=bases, coefficients=coefficients, poses=poses))


def _refuse_coupled_target(problem, joint: int) -> None:
    """SpecError where ``joint``'s target depends on another joint's angle: the moment arms of
    one joint's pulleys can only follow a torque of that joint's own angle."""
    joints = problem.joints
    others = joints[joint].target.coupled_joints(len(joints), joint)
    if others:
        raise SpecError(f"solver.method = 'moment_arm': the target of joint {joints[joint].name!r} depends on "
                        f"the angle of joint {', '.join(repr(joints[i].name) for i in others)}; the method "
                        f"designs each joint's pulleys for a torque of that joint's own angle: use method 'nlp'")


def fitted_pulley(problem, continued: MomentArmDesign, u: int):
    """Pulley ``u`` of the moment-arm design ``continued`` (sampled past its joint's range by
    :data:`CONTINUATION` on :data:`FIT_SAMPLES` angles) as a profile: its envelope
    (:func:`continued_envelope`) from :data:`ANCHOR_WRAP` before the least-wound departure point
    to :data:`TAIL` past the most-wound one, resampled uniformly in φ and fitted by least squares
    in its profile's basis kind and order on that polar range, measured from its start, where
    the anchor goes.

    Returns
    -------
    (AnchoredPulley, Basis, ndarray, (ndarray, ndarray))
        The mechanism with that anchor angle and basis, the basis, the coefficients [m], and
        the departure angles α [rad] of the envelope at the joint angles θ [rad] it was fitted
        from, as :attr:`cadcam.designs.Design.poses` holds them: the evaluation's rootfinder
        starts there (from its closed-form guess it can leave a short polar range, outside
        which a polynomial of high order is meaningless).
    """
    mech = problem.mechanisms[u]
    prof = mech.profiles[0]
    theta, env, wound = continued_envelope(problem, continued, u)
    window = (env.phi_polar >= env.phi_polar[wound].min() - ANCHOR_WRAP) & \
        (env.phi_polar <= env.phi_polar[wound].max() + TAIL)
    order = np.argsort(env.phi_polar[window])
    phi, rho = env.phi_polar[window][order], env.rho[window][order]
    anchor = phi[0]
    even = np.linspace(0.0, phi[-1] - anchor, FIT_SAMPLES)
    basis = Basis(prof.basis.name, prof.basis.order, (0.0, float(even[-1])))
    c = fit_profile(basis, even, np.interp(even, phi - anchor, rho))
    # φ measured from the new anchor is the canonical angle less ``anchor``: χ₀ = w(ψ₀ − anchor
    # angle) falls by ``anchor``
    placed = replace(mech, anchor_angle=mech.anchor_angle + WINDING[mech.winding] * anchor,
                     profiles=(replace(prof, basis=basis),))
    return placed, basis, c, (theta, (env.phi_polar - anchor)[None, :])


def continued_envelope(problem, continued: MomentArmDesign, u: int):
    """Pulley ``u``'s envelope (canonical frame) in ``continued`` on its joint's range and past
    it as far as it stays regular, convex and inside [ρ_min, ρ_max].

    Returns
    -------
    (ndarray, Envelope, ndarray)
        The joint angles [rad], the envelope on them, and the mask of those in the joint's range.
    """
    mech = problem.mechanisms[u]
    prof = mech.profiles[0]
    lo, hi = problem.joints[mech.joint].theta_range
    theta = continued.theta
    env = continued.envelopes[continued.mechanisms.index(u)]
    inside = (theta >= lo) & (theta <= hi)
    usable = inside | ((env.radius_of_curvature >= prof.min_curvature_radius) & (mech.sigma * env.dnu > 0)
                       & (env.rho >= prof.rho_min) & (env.rho <= prof.rho_max))
    first, last = np.flatnonzero(inside)[[0, -1]]
    while first > 0 and usable[first - 1]:
        first -= 1
    while last < theta.size - 1 and usable[last + 1]:
        last += 1
    run = slice(first, last + 1)
    return theta[run], _envelope_slice(env, run), inside[run]


def _envelope_slice(env: Envelope, run: slice) -> Envelope:
    """``env`` on the joint angles ``run`` only."""
    return Envelope(**{name: getattr(env, name)[run] for name in Envelope.__dataclass_fields__})
