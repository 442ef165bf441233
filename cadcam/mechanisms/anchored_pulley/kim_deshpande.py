"""Closed-form anchored-spring pulley (Kim & Deshpande 2014, restated in Ludovico2021 Sec. II).

A convex pulley turns about O relative to a spring end S; a cable anchored on the pulley is
wound on it and leaves it tangentially towards S. Everything here is in the pulley's
**canonical frame**, where the cable is wound counter-clockwise from its anchor and

    S(θ) = ℓ (cos χ, sin χ),    χ(θ) = χ0 + σθ,    σ = ±1,

θ being the joint angle [rad] and ℓ the distance O–S [m] (Ludovico2021's L). The cable path
anchor → S lengthens as σθ increases, at the rate r_m (the moment arm): the spring extends away
from the angle θ0 at which its extension is u0, so σ is the side of θ0 the joint angles lie on.
For Kim & Deshpande's mechanism (pulley fixed to ground, S on the link at world angle θ) the
canonical frame of a pulley wound counter-clockwise is the world frame (χ = θ, σ = +1) and that
of a pulley wound clockwise the mirrored frame (x, −y) (χ = −θ, σ = −1).

The cable leaves along the line with outward unit normal n(ν) = (cos ν, sin ν) at distance
h = r_m from O, S on it and the departure point behind S in counter-clockwise order:

    ν = χ − acos(r_m/ℓ) = χ − π/2 + φ,    φ = asin(r_m/ℓ)            # Ludovico2021 Eq. 2

The pulley is the envelope of these lines, the curve with support function h(ν):
X = h n + h_ν t with t = (−sin ν, cos ν), dX/dν = (h + h_νν) t. It is feasible (convex and
wrapped smoothly) where

* ν′ = σ + φ′ keeps the sign of σ and never vanishes: 1 + σφ′ > 0, Ludovico2021's curvature
  condition 1 + φ′ ≠ 0 (Eq. 6, 13) with φ′ taken along the pulley's own winding direction;
* the radius of curvature R = h + h_νν > 0; a zero of R is a non-regular point (Eq. 18–19),
  the zero of Eq. 30 (last term corrected to 3r′²/(ℓ² − r²), as Eq. 31–32 use it);
* the free cable span from the departure point to S is positive.

Angles are in rad, lengths in m, forces in N and torques in N·m throughout. A target torque is
a vectorised callable τ(θ) [N·m] of an array of any shape (scalars are broadcast).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ...physics.quadrature import gauss_legendre

#: Gauss–Legendre points per sub-interval and the longest sub-interval [rad] of the work
#: integral: the rule is exact for polynomials of degree 15 on 0.05 rad, so the relative error
#: for a smooth τ is far below 1e-12.
QUADRATURE_ORDER = 8
QUADRATURE_STEP = 0.05
#: Step [rad] of the fourth-order central differences for τ′ and τ″ when no derivative is
#: given: truncation ~h⁴τ⁽⁵⁾/30 and ~h⁴τ⁽⁶⁾/90, round-off ~ε|τ|/h and ~5ε|τ|/h², all below
#: 1e-9 relative for a τ varying on the scale of 1 rad. τ is evaluated up to 2h outside θ.
DIFFERENCE_STEP = 2e-3


@dataclass(frozen=True)
class SpringState:
    """Spring state of an anchored-spring pulley along the joint angles ``theta`` [rad].

    Attributes
    ----------
    theta : ndarray
        Joint angles [rad].
    sigma : int
        +1 if the joint angles lie above θ0 (the spring extends as θ increases), −1 if below.
    u : ndarray
        Spring extension [m].
    force : ndarray
        Spring force F = k u + F0 [N].
    r_m : ndarray
        Moment arm τ/F [m] (Ludovico2021 Eq. 1).
    """

    theta: np.ndarray
    sigma: int
    u: np.ndarray
    force: np.ndarray
    r_m: np.ndarray


@dataclass(frozen=True)
class Envelope:
    """The pulley as the envelope of its cable lines, in the canonical frame.

    Attributes
    ----------
    theta : ndarray
        Joint angles [rad].
    nu : ndarray
        Polar angle ν of the outward normal of the cable line [rad].
    dnu : ndarray
        dν/dθ = σ + φ′ [-]; feasible where σ·dν/dθ > 0 (Ludovico2021 Eq. 6).
    radius_of_curvature : ndarray
        R = h + d²h/dν² [m] at the departure point; convex and regular where R > 0.
    regularity : ndarray
        r″ + r(1 + 3σr′/q + 3r′²/q²) with q = √(ℓ² − r²) [m/rad²], the left-hand side of
        Ludovico2021 Eq. 30 (corrected) along the winding direction; R = regularity/(σν′)³, so
        its zeros are the non-regular points, and unlike R it has no poles where ν′ = 0.
    points : ndarray, shape (N, 2)
        Departure points X [m].
    phi_polar : ndarray
        Polar angle of X [rad], unwrapped along θ.
    rho : ndarray
        Polar radius |X| [m].
    span : ndarray
        Free cable length from the departure point to S [m]; must be positive.
    """

    theta: np.ndarray
    nu: np.ndarray
    dnu: np.ndarray
    radius_of_curvature: np.ndarray
    regularity: np.ndarray
    points: np.ndarray
    phi_polar: np.ndarray
    rho: np.ndarray
    span: np.ndarray


@dataclass(frozen=True)
class ClosedForm:
    """Closed-form pulley of a target torque and where it is infeasible.

    Attributes
    ----------
    state : SpringState
        Extension, force and moment arm on the joint angles.
    dr_m, d2r_m : ndarray
        dr_m/dθ [m/rad] and d²r_m/dθ² [m/rad²].
    envelope : Envelope
        The pulley's departure points and curvature (χ0 + σθ as the spring-end angle).
    curvature_zeros : ndarray
        Joint angles [rad] where ν′ = σ + φ′ changes sign (Ludovico2021 Eq. 6).
    nonregular_points : ndarray
        Joint angles [rad] where the regularity (Eq. 30) changes sign: R = 0, a non-regular
        point (Eq. 18–19).
    """

    state: SpringState
    dr_m: np.ndarray
    d2r_m: np.ndarray
    envelope: Envelope
    curvature_zeros: np.ndarray
    nonregular_points: np.ndarray

    @property
    def feasible(self) -> bool:
        """No curvature zero or non-regular point in the range, and σν′ > 0, R > 0 and a
        positive free span on the joint angles."""
        env = self.envelope
        return bool(self.curvature_zeros.size == 0 and self.nonregular_points.size == 0
                    and np.all(self.state.sigma * env.dnu > 0)
                    and np.all(env.radius_of_curvature > 0) and np.all(env.span > 0))


def _angles(theta) -> np.ndarray:
    theta = np.asarray(theta, dtype=float)
    if theta.ndim != 1 or theta.size == 0 or not np.all(np.isfinite(theta)):
        raise ValueError("theta must be a non-empty 1-D array of finite angles [rad]")
    return theta


def _evaluate(f, x: np.ndarray) -> np.ndarray:
    """``f(x)`` as a float array of the shape of ``x`` (a constant is broadcast)."""
    return np.broadcast_to(np.asarray(f(x), dtype=float), x.shape)


def _side(theta: np.ndarray, theta0: float) -> int:
    """+1 if every angle is at or above θ0, −1 if every angle is at or below it."""
    if np.all(theta >= theta0):
        return 1
    if np.all(theta <= theta0):
        return -1
    raise ValueError("theta must lie on one side of theta0: the spring extends away from theta0")


def _integral_from(f, a: float, x: np.ndarray) -> np.ndarray:
    """∫_a^{x_i} f(α) dα [signed] for every x_i, by composite Gauss–Legendre on sub-intervals
    of at most :data:`QUADRATURE_STEP` between the sorted angles, summed cumulatively."""
    knots = np.unique(np.append(x, a))
    widths = np.diff(knots)
    pieces = np.maximum(1, np.ceil(widths / QUADRATURE_STEP)).astype(int)
    owner = np.repeat(np.arange(widths.size), pieces)
    first = np.repeat(np.cumsum(pieces) - pieces, pieces)
    h = widths[owner] / pieces[owner]
    left = knots[owner] + (np.arange(owner.size) - first) * h
    nodes, weights = gauss_legendre(QUADRATURE_ORDER)
    values = _evaluate(f, left[:, None] + h[:, None] * nodes[None, :])
    per_interval = np.bincount(owner, weights=(values @ weights) * h, minlength=widths.size)
    cumulative = np.concatenate([[0.0], np.cumsum(per_interval)])
    return cumulative[np.searchsorted(knots, x)] - cumulative[np.searchsorted(knots, a)]


def spring_state(tau, theta, theta0: float, k: float, u0: float, F0: float = 0.0) -> SpringState:
    """Extension, force and moment arm of a pulley giving the torque magnitude ``tau``.

    The spring has extension u0 at θ0 and extends away from it; the work of τ goes into it:

        ½k u² + F0 u = ½k u0² + F0 u0 + |∫_{θ0}^{θ} τ dα|,

    Ludovico2021 Eq. 1 generalised to a preloaded spring F = k u + F0 (Endo2010). In the force,
    F² = (k u0 + F0)² + 2k|∫τ|, and r_m = τ/F.

    Parameters
    ----------
    tau : callable
        Target torque magnitude τ(θ) ≥ 0 [N·m] this pulley must give, vectorised.
    theta : array_like
        Joint angles [rad], all on one side of ``theta0``.
    theta0 : float
        Joint angle [rad] at which the extension is ``u0``.
    k : float
        Spring rate [N/m], > 0.
    u0 : float
        Extension at θ0 [m], ≥ 0.
    F0 : float
        Preload [N]; the force at θ0, k u0 + F0, must be positive.

    Returns
    -------
    SpringState

    Raises
    ------
    ValueError
        For a non-positive rate or initial force, a negative u0, angles on both sides of θ0, or
        τ < 0 on ``theta``.
    """
    theta = _angles(theta)
    sigma = _side(theta, theta0)
    if not k > 0:
        raise ValueError(f"spring rate k must be positive, got {k}")
    if not u0 >= 0:
        raise ValueError(f"initial extension u0 must be >= 0, got {u0}")
    f_start = k * u0 + F0
    if not f_start > 0:
        raise ValueError(f"spring force at theta0, k*u0 + F0 = {f_start} N, must be positive")
    torque = _evaluate(tau, theta)
    if np.any(torque < 0):
        raise ValueError("tau must be >= 0 on theta: a pulley gives a torque magnitude")
    work = sigma * _integral_from(tau, theta0, theta)  # |∫_{θ0}^{θ} τ dα| for τ ≥ 0
    force = np.sqrt(f_start**2 + 2 * k * work)  # Ludovico2021 Eq. 1 with F = k u + F0 (Endo2010)
    return SpringState(theta, sigma, (force - F0) / k, force, torque / force)


def cable_line(r, dr, d2r, ell, sigma):
    """The cable line of moment arm r and its envelope, in the canonical frame: numbers for
    numpy arrays, CasADi expressions for CasADi symbols (the closed form and the moment-arm
    design, :mod:`.moment_arm`, evaluate the same equations).

    Parameters
    ----------
    r, dr, d2r : array_like or casadi.SX
        Moment arm [m] and its derivatives in θ [m/rad, m/rad²].
    ell : float
        Distance from O to the spring end [m].
    sigma : {1, -1}
        χ = χ0 + σθ.

    Returns
    -------
    phi, dnu, regularity, dh, radius, span
        φ = asin(r/ℓ) [rad] (Ludovico2021 Eq. 2); dν/dθ = σ + φ′ (Eq. 6); the regularity
        r″ + r(1 + 3σφ′ + 3φ′²) [m/rad²] (Eq. 30, corrected, along the winding direction);
        dh/dν = r′/ν′ [m] (the support function h = r); the radius of curvature
        R = h + d²h/dν² = regularity/(σν′)³ [m]; the free span √(ℓ² − r²) − dh/dν [m]. Where
        ν′ = 0 the last three are infinite.
    """
    symbolic = isinstance(r, (ca.SX, ca.MX))
    sqrt, asin = (ca.sqrt, ca.asin) if symbolic else (np.sqrt, np.arcsin)
    q = sqrt(ell**2 - r**2)
    phi = asin(r / ell)  # Ludovico2021 Eq. 2
    dphi = dr / q
    dnu = sigma + dphi  # Ludovico2021 Eq. 6: σν′ = 1 + σφ′
    # Ludovico2021 Eq. 30 (corrected) along the winding direction, = σ(rν′³ + r″ν′ − r′ν″)
    # with ν″ = φ″ = r″/q + r r′²/q³ substituted
    regularity = d2r + r * (1 + 3 * sigma * dphi + 3 * dphi**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        dh = dr / dnu  # dh/dν
        radius = regularity / (sigma * dnu) ** 3  # h + d²h/dν²
    return phi, dnu, regularity, dh, radius, q - dh


def envelope(theta, r_m, dr_m, d2r_m, ell: float, chi0: float, sigma: int) -> Envelope:
    """The pulley of moment arm r_m(θ) as the envelope of its cable lines (canonical frame).

    Parameters
    ----------
    theta : array_like
        Joint angles [rad].
    r_m, dr_m, d2r_m : array_like
        Moment arm [m] and its first and second derivatives in θ [m/rad, m/rad²] on ``theta``.
    ell : float
        Distance from O to the spring end S [m] (Ludovico2021's L); |r_m| < ell.
    chi0 : float
        Polar angle of S at θ = 0 [rad].
    sigma : {1, -1}
        χ = χ0 + σθ; the spring extends as σθ increases.

    Returns
    -------
    Envelope
        Where ν′ = 0 the radius of curvature and the points are infinite.

    Raises
    ------
    ValueError
        For σ not ±1, ell ≤ 0, arrays of different shapes, or |r_m| ≥ ell.
    """
    theta = _angles(theta)
    r, dr, d2r = (np.asarray(a, dtype=float) for a in (r_m, dr_m, d2r_m))
    if sigma not in (1, -1):
        raise ValueError(f"sigma must be +1 or -1, got {sigma}")
    if not ell > 0:
        raise ValueError(f"spring-end distance ell must be positive, got {ell}")
    if not r.shape == dr.shape == d2r.shape == theta.shape:
        raise ValueError("theta, r_m, dr_m and d2r_m must have the same shape")
    if np.any(np.abs(r) >= ell):
        raise ValueError(f"moment arm must stay below ell = {ell} m in magnitude")
    phi, dnu, regularity, dh, radius, span = cable_line(r, dr, d2r, ell, sigma)
    nu = chi0 + sigma * theta - np.pi / 2 + phi  # = χ − acos(r_m/ℓ)
    normal = np.stack([np.cos(nu), np.sin(nu)], axis=-1)
    tangent = np.stack([-np.sin(nu), np.cos(nu)], axis=-1)
    points = r[:, None] * normal + dh[:, None] * tangent
    return Envelope(theta=theta, nu=nu, dnu=dnu, radius_of_curvature=radius,
                    regularity=regularity, points=points,
                    phi_polar=np.unwrap(np.arctan2(points[:, 1], points[:, 0])),
                    rho=np.hypot(points[:, 0], points[:, 1]), span=span)


def _first_difference(f):
    h = DIFFERENCE_STEP
    return lambda x: (_evaluate(f, x - 2 * h) - 8 * _evaluate(f, x - h)
                      + 8 * _evaluate(f, x + h) - _evaluate(f, x + 2 * h)) / (12 * h)


def _second_difference(f):
    h = DIFFERENCE_STEP
    return lambda x: (-_evaluate(f, x - 2 * h) + 16 * _evaluate(f, x - h) - 30 * _evaluate(f, x)
                      + 16 * _evaluate(f, x + h) - _evaluate(f, x + 2 * h)) / (12 * h**2)


def _sign_changes(g, lo: float, hi: float, points: int) -> np.ndarray:
    """Angles in [lo, hi] where g changes sign: brackets on ``points`` equally spaced angles,
    each refined by Brent's method. A zero of even multiplicity is not a sign change."""
    from scipy.optimize import brentq  # imported here: scipy.optimize is slow to import

    x = np.linspace(lo, hi, points)
    y = g(x)
    brackets = np.nonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]
    found = [brentq(lambda t: g(np.array([t]))[0], x[i], x[i + 1], xtol=1e-13) for i in brackets]
    return np.sort(np.concatenate([x[y == 0], found]))


def closed_form(tau, theta, theta0: float, k: float, u0: float, ell: float, F0: float = 0.0,
                chi0: float = 0.0, dtau=None, d2tau=None, search_points: int = 4001) -> ClosedForm:
    """Kim & Deshpande's pulley for the torque magnitude ``tau`` and where it is infeasible.

    The moment arm comes from :func:`spring_state`; its derivatives follow from
    F dF/dθ = σkτ (the derivative of the energy balance):

        r′ = τ′/F − σkτ²/F³,    r″ = τ″/F − 3σkττ′/F³ + 3k²τ³/F⁵,

    and the pulley from :func:`envelope` with χ = χ0 + σθ, σ the side of θ0 the angles lie on.

    Parameters
    ----------
    tau : callable
        Target torque magnitude τ(θ) ≥ 0 [N·m], vectorised.
    theta : array_like
        Joint angles [rad] on one side of ``theta0``.
    theta0, k, u0, F0 : float
        As in :func:`spring_state`.
    ell : float
        Distance from O to the spring end [m].
    chi0 : float
        Polar angle of the spring end at θ = 0 in the canonical frame [rad].
    dtau, d2tau : callable, optional
        τ′ [N·m/rad] and τ″ [N·m/rad²]; by default fourth-order central differences of ``tau``
        with step :data:`DIFFERENCE_STEP`.
    search_points : int
        Equally spaced angles over the range of ``theta`` on which sign changes of ν′ and of
        the regularity are bracketed before Brent's method locates them.

    Returns
    -------
    ClosedForm
    """
    theta = _angles(theta)
    if search_points < 2:
        raise ValueError(f"search_points must be at least 2, got {search_points}")
    d1 = dtau if dtau is not None else _first_difference(tau)
    d2 = d2tau if d2tau is not None else _second_difference(tau)

    def solve(x):
        state = spring_state(tau, x, theta0, k, u0, F0)
        t, f, s = _evaluate(tau, x), state.force, state.sigma
        t1, t2 = _evaluate(d1, x), _evaluate(d2, x)
        dr = t1 / f - s * k * t**2 / f**3
        d2r = t2 / f - 3 * s * k * t * t1 / f**3 + 3 * k**2 * t**3 / f**5
        return state, dr, d2r, envelope(x, state.r_m, dr, d2r, ell, chi0, s)

    state, dr, d2r, env = solve(theta)
    lo, hi = theta.min(), theta.max()
    return ClosedForm(
        state=state, dr_m=dr, d2r_m=d2r, envelope=env,
        curvature_zeros=_sign_changes(lambda x: solve(x)[3].dnu, lo, hi, search_points),
        nonregular_points=_sign_changes(lambda x: solve(x)[3].regularity, lo, hi, search_points))
