"""From a designed profile to files a workshop can cut, print or mill.

The optimiser designs ρ(φ) only over the wrapped range φ ∈ [0, α_max]. :func:`closed_outline`
completes it into a closed, convex, C2 outline; :func:`polyline` turns that into a polygon
within a chordal tolerance; the writers export it as DXF, SVG, CSV and a watertight binary STL.
Everything is in SI units (metres) inside; the files are in millimetres.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import ezdxf
import numpy as np
from manifold3d import CrossSection, JoinType, Manifold
from numpy.polynomial import Legendre, Polynomial

from ..files import atomic_path, write_csv as write_table, write_text
from ..physics.profile import Basis, convexity_margin, profile_function
from ..problem import MIN_WALL
from .biarc import ArcChain, arc_geometry, biarc_fit, segment_distance

TWO_PI = 2 * np.pi
MM = 1e3
"""Millimetres per metre: the length unit of every exported file."""
DEFAULT_TOLERANCE = 1e-5
"""Default chordal tolerance [m] (0.01 mm)."""
CLOSURE_FREE = 8
"""Free coefficients of the closing polynomial beyond the six matching conditions."""
CLOSURE_GRID = 400
"""Points of the closing arc at which the programs of :func:`closed_outline` impose constraints."""
ROUNDING = 1e-9
"""Shortfall [m] of a wall that is rounding, not a thinner wall (a hull closure runs on the hub)."""
CHECK_GRID = 8000
"""Points at which the designed arc and the closing arc found are checked to be convex."""
CHORD_SPARE = 1.05
"""Chords :func:`polyline` first lays per chord an exact estimate would need (sag ≈ 0.9 tol)."""
SAG_SAMPLES = 31
SVG_BOX_SAMPLES = 64
"""Points per arc from which the SVG's box is taken (an arc's sag between them is (1/64)²/8 of its own)."""
"""Interior samples per chord at which :func:`polyline` measures the sag (odd: with the middle)."""


# --------------------------------------------------------------------------------------- outline

@dataclass
class Outline:
    """A closed convex cam outline: the designed arc and the arc that closes it.

    The designed arc is ρ(φ) of the optimised profile for φ ∈ [0, ``phi_end``]; the closing arc
    is ρ = 1/u with u given by ``closing`` (:class:`SmoothClosing` or :class:`HullClosing`).
    Angles outside [0, 2π) are taken modulo 2π.

    Attributes
    ----------
    profile : casadi.Function
        ``profile(phi, c) -> (rho, drho, ddrho, convexity)`` of the design's basis.
    coefficients : ndarray
        The designed profile's coefficients [m].
    phi_end : float
        Angle where the designed (wrapped) arc ends and the closing arc begins [rad].
    closing : SmoothClosing or HullClosing
        u = 1/ρ [1/m] and its φ-derivatives on the closing arc.
    samples : int
        Number of points of the dense sample.
    phi : ndarray
        Angles of the dense sample [rad], increasing in [0, 2π), including ``phi_end``.
    points : ndarray, shape (N, 2)
        Dense sample of the outline [m], counter-clockwise.
    """

    profile: ca.Function = field(repr=False)
    coefficients: np.ndarray
    phi_end: float
    closing: SmoothClosing | HullClosing
    samples: int = 2048
    phi: np.ndarray = field(init=False, repr=False)
    points: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        grid = np.linspace(0.0, TWO_PI, self.samples, endpoint=False)
        self.phi = np.union1d(grid, [self.phi_end])
        self.points = self.xy(self.phi)

    @property
    def closing_span(self) -> float:
        """Angle 2π − φ_end covered by the closing arc [rad]."""
        return TWO_PI - self.phi_end

    @property
    def rho_range(self) -> tuple[float, float]:
        """Least and greatest radius of the dense sample [m]."""
        r = np.hypot(*self.points.T)
        return float(r.min()), float(r.max())

    def designed(self, phi) -> np.ndarray:
        """True where φ (modulo 2π) lies on the designed arc."""
        return np.mod(np.asarray(phi, dtype=float), TWO_PI) <= self.phi_end

    def derivatives(self, phi) -> np.ndarray:
        """ρ, ρ′, ρ″ [m, m/rad, m/rad²] at the angles ``phi``, as a (3, N) array."""
        phi = np.mod(np.atleast_1d(np.asarray(phi, dtype=float)), TWO_PI)
        out = np.empty((3, phi.size))
        on = self.designed(phi)
        if on.any():
            out[:, on] = designed_values(self.profile, self.coefficients, phi[on])[:3]
        if not on.all():
            out[:, ~on] = _rho_from_u(*self.closing.u(phi[~on]))
        return out

    def piece_derivatives(self, phi, closing: bool) -> np.ndarray:
        """ρ, ρ′, ρ″ of the designed arc (``closing`` False) or of the closing arc's polynomial
        at ``phi`` [rad] in [0, φ_end] or [φ_end, 2π]: one-sided at the joints, where a chord
        closure has corners."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        if closing:
            return _rho_from_u(*self.closing.u(phi))
        return designed_values(self.profile, self.coefficients, phi)[:3]

    def rho(self, phi) -> np.ndarray:
        """ρ(φ) [m] on the full circle."""
        return self.derivatives(phi)[0]

    def margin(self, phi) -> np.ndarray:
        """Convexity margin ρ² + 2ρ′² − ρρ″ [m²] on the full circle (Johnston2023 Eq. 40)."""
        return convexity_margin(*self.derivatives(phi))

    def xy(self, phi) -> np.ndarray:
        """Points (ρ cos φ, ρ sin φ) [m] of the outline, shape (N, 2)."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        rho = self.rho(phi)
        return np.column_stack((rho * np.cos(phi), rho * np.sin(phi)))


def designed_values(profile: ca.Function, coefficients, phi) -> np.ndarray:
    """ρ, ρ′, ρ″ and the Eq. 40 margin of the designed profile at ``phi``, shape (4, N)."""
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    out = profile.map(phi.size)(phi.reshape(1, -1), np.asarray(coefficients, dtype=float))
    return np.array([np.asarray(v).ravel() for v in out])


def _u_from_rho(rho, drho, ddrho) -> np.ndarray:
    """u = 1/ρ and its first two φ-derivatives."""
    return np.array([1 / rho, -drho / rho**2, (2 * drho**2 - rho * ddrho) / rho**3])


def _rho_from_u(u, du, ddu) -> np.ndarray:
    """ρ = 1/u and its first two φ-derivatives (the inverse of :func:`_u_from_rho`)."""
    return np.array([1 / u, -du / u**2, (2 * du**2 - u * ddu) / u**3])


def closed_outline(basis: Basis, coefficients, phi_max: float, rho_bounds=None,
                   free: int = CLOSURE_FREE) -> Outline:
    """Close the designed arc ρ(φ), φ ∈ [0, ``phi_max``], into a convex C2 outline.

    Method. In u = 1/ρ a polar curve is convex where u + u″ > 0: u + u″ is the Eq. 40 margin
    divided by ρ³ (Johnston2023 Eq. 40), and it is linear in u. The closing arc is a polynomial
    u(x) in x = (φ − φ_max)/(2π − φ_max): a quintic Hermite part matches u, u′, u″ of the
    designed profile at φ_max (x = 0) and at φ = 2π ≡ 0 (x = 1), so the outline is C2 at both
    joints, and ``free`` further terms x³(1 − x)³ P_j(2x − 1) (Legendre P_j) leave those
    conditions untouched. Two small programs on a grid of the closing arc pick them:

    1. a linear program: the largest t* with u + u″ ≥ t* everywhere — if t* ≤ 0 (or no u
       meets the bounds) no convex closure exists and a ValueError is raised;
    2. a quadratic program: among closures with u + u″ ≥ t*/2, the one minimising
       ∫ ((u + u″)′)² dφ. u + u″ constant is a conic with a focus on the rotation axis (a
       circle about it when u′ = 0), so the closing arc is as near such an ellipse as the end
       conditions allow: smooth and round, without bulges.

    Both programs keep ρ within ``rho_bounds`` (u > 0 otherwise) and are solved by HiGHS
    through CasADi; the result is then verified on a grid 20× finer.

    Parameters
    ----------
    basis : Basis
        Basis of the designed profile.
    coefficients : array_like
        Its coefficients [m].
    phi_max : float
        End of the designed (wrapped) range, α_max [rad], 0 < phi_max < 2π.
    rho_bounds : tuple of float, optional
        (ρ_lo, ρ_hi) [m] the closing arc must stay within, e.g. the spec's radius limits.
    free : int
        Free coefficients of the closing polynomial (≥ 1; its degree is 5 + ``free``).

    Returns
    -------
    Outline

    Raises
    ------
    ValueError
        If ``phi_max`` is outside (0, 2π), ``free`` < 1, the designed arc is not positive and
        convex, or no convex closure within ``rho_bounds`` exists.
    """
    if not 0 < phi_max < TWO_PI:
        raise ValueError(f"phi_max = {phi_max!r} rad must lie in (0, 2π)")
    if free < 1:
        raise ValueError(f"free = {free!r} must be at least 1")
    profile = profile_function(basis)
    _check_designed_arc(profile, coefficients, phi_max)
    closing = SmoothClosing(_closing_polynomial(profile, coefficients, phi_max, rho_bounds, free), float(phi_max))
    outline = Outline(profile, np.asarray(coefficients, dtype=float), float(phi_max), closing)
    _check_closing_arc(outline)
    return outline


def _closing_polynomial(profile, coefficients, phi_max: float, rho_bounds, free: int) -> Polynomial:
    """u = 1/ρ [1/m] of the closing arc of :func:`closed_outline` as a polynomial in
    x = (φ − φ_max)/(2π − φ_max): its Hermite part and ``free`` bubble terms, weighted by the
    two programs of :func:`_closure_coefficients`."""
    span = TWO_PI - phi_max
    ends = [_u_from_rho(*designed_values(profile, coefficients, phi)[:3, 0]) * span ** np.arange(3)
            for phi in (phi_max, 0.0)]  # u, du/dx, d²u/dx² at x = 0 and x = 1
    scale = ends[1][0]  # u(0): the programs work with u/u(0), of order one
    hermite = _hermite(ends[0] / scale, ends[1] / scale)
    bubble = Polynomial([0, 0, 0, 1]) * Polynomial([1, -1]) ** 3
    terms = [bubble * Legendre.basis(j, domain=[0, 1]).convert(kind=Polynomial)
             for j in range(free)]
    a = _closure_coefficients(hermite, terms, span, _u_bounds(rho_bounds, scale))
    return scale * (hermite + sum((aj * t for aj, t in zip(a, terms)), Polynomial([0.0])))


def hull_outline(basis: Basis, coefficients, phi_max: float, hub_radius: float) -> Outline:
    """Close the designed arc ρ(φ), φ ∈ [0, ``phi_max``], by the convex hull of the arc and the
    hub, a disk of ``hub_radius`` [m] about the axis.

    From the arc's end the hull runs straight to its anchor at φ = 2π ≡ 0 where that chord
    passes outside the hub; otherwise straight to the hub, round it, and straight on to the
    anchor, each line a tangent of the hub. The design NLP's outline rows (every tangent of the
    arc outside the hub, with both of the arc's ends inside it) keep the whole arc on the hull,
    so the hull always exists for a design that met them: it is checked here.

    Raises
    ------
    ValueError
        If ``phi_max`` is outside (0, 2π), the designed arc is not positive and convex, or
        part of it falls inside the hull (a design that breaks the outline rows).
    """
    if not 0 < phi_max < TWO_PI:
        raise ValueError(f"phi_max = {phi_max!r} rad must lie in (0, 2π)")
    profile = profile_function(basis)
    _check_designed_arc(profile, coefficients, phi_max)
    (r1,), (r0,) = (designed_values(profile, coefficients, phi)[:1, 0] for phi in (phi_max, 0.0))
    outline = Outline(profile, np.asarray(coefficients, dtype=float), float(phi_max),
                      HullClosing.around(phi_max, r1, r0, _positive("hub_radius", hub_radius)))
    _check_on_hull(outline)
    return outline


@dataclass(frozen=True)
class HullClosing:
    """u = 1/ρ [1/m] of a closing arc made of lines and an arc of the hub: piece j covers
    φ ∈ [``starts[j]``, ``starts[j + 1]``) and is u = ``a[j]`` cos φ + ``b[j]`` sin φ (a line:
    u + u″ = 0) or, with a = b = 0, the hub's circle u = ``level[j]``."""

    starts: np.ndarray
    a: np.ndarray
    b: np.ndarray
    level: np.ndarray

    @classmethod
    def around(cls, phi_end: float, rho_end: float, rho_anchor: float, hub: float) -> HullClosing:
        """The hull's closing arc from (ρ_end, φ_end) to (ρ_anchor, 2π) round a hub of radius
        ``hub`` [m]: the chord if it clears the hub, else tangent, hub arc, tangent."""
        p1 = rho_end * np.array([np.cos(phi_end), np.sin(phi_end)])
        p0 = np.array([rho_anchor, 0.0])
        normal = np.array([p0[1] - p1[1], p1[0] - p0[0]])  # the chord's line: normal · p = level
        level = float(normal @ p0)
        if level >= hub * np.hypot(*normal):
            return cls(np.array([phi_end]), normal[:1] / level, normal[1:] / level, np.zeros(1))
        leave = phi_end + np.arccos(min(1.0, hub / rho_end))      # where the tangent from the
        arrive = TWO_PI - np.arccos(min(1.0, hub / rho_anchor))    # end and to the anchor touch
        return cls(np.array([phi_end, leave, arrive]),
                   np.array([np.cos(leave), 0.0, np.cos(arrive)]) / hub,
                   np.array([np.sin(leave), 0.0, np.sin(arrive)]) / hub, np.array([0.0, 1 / hub, 0.0]))

    def u(self, phi) -> np.ndarray:
        """u, u′, u″ [1/m, 1/(m·rad), 1/(m·rad²)] at ``phi`` [rad] on the closing arc, (3, N)."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        j = np.clip(np.searchsorted(self.starts, phi, side="right") - 1, 0, self.starts.size - 1)
        a, b, c, s = self.a[j], self.b[j], np.cos(phi), np.sin(phi)
        line = a * c + b * s
        return np.array([line + self.level[j], b * c - a * s, -line])


@dataclass(frozen=True)
class SmoothClosing:
    """u = 1/ρ [1/m] of a closing arc given as a polynomial ``poly`` of
    x = (φ − ``phi_end``)/(2π − ``phi_end``) ∈ [0, 1] (:func:`closed_outline`)."""

    poly: Polynomial
    phi_end: float

    def u(self, phi) -> np.ndarray:
        """u, u′, u″ [1/m, 1/(m·rad), 1/(m·rad²)] at ``phi`` [rad] on the closing arc, (3, N)."""
        span = TWO_PI - self.phi_end
        x = (np.atleast_1d(np.asarray(phi, dtype=float)) - self.phi_end) / span
        p = self.poly
        return np.array([p(x), p.deriv(1)(x) / span, p.deriv(2)(x) / span**2])


def cut_outline(basis: Basis, coefficients, phi_max: float, hub_radius: float) -> Outline:
    """The outline a workshop cuts: the designed arc closed by the smoothest convex C2 arc that
    stays outside the hub of ``hub_radius`` [m] (:func:`closed_outline`) where one exists, else
    by the hull of the arc and the hub (:func:`hull_outline`), which the design NLP's outline
    rows guarantee."""
    try:
        return closed_outline(basis, coefficients, phi_max, rho_bounds=(hub_radius, np.inf))
    except ValueError:
        return hull_outline(basis, coefficients, phi_max, hub_radius)


def _check_on_hull(outline: Outline) -> None:
    """ValueError unless every point of the designed arc is on the outline's convex hull (to
    rounding): the whole outline turns one way (its edges' cross products ≥ 0)."""
    phi = np.union1d(np.linspace(0.0, TWO_PI, CHECK_GRID, endpoint=False), [outline.phi_end])
    p = outline.xy(phi)
    edge = np.diff(np.vstack((p, p[:1])), axis=0)
    turn = edge[:, 0] * np.roll(edge[:, 1], -1) - edge[:, 1] * np.roll(edge[:, 0], -1)
    scale = np.linalg.norm(edge, axis=1) * np.roll(np.linalg.norm(edge, axis=1), -1)
    bad = turn < -HULL_TOLERANCE * scale
    if bad.any():
        raise ValueError(f"the designed arc does not lie on the convex hull of itself and the hub "
                         f"near φ = {phi[(np.flatnonzero(bad)[0] + 1) % phi.size]:.4f} rad: "
                         "the design breaks its outline rows (design it again with this bore)")


#: Least turn, as a share of the product of two edges' lengths, that counts as turning the
#: wrong way in :func:`_check_on_hull` (rounding of a straight stretch is far smaller).
HULL_TOLERANCE = 1e-9


#: Relative margin by which ρ bounds are tightened on the closure's grid, so that the curve
#: between grid points stays inside them.
RHO_BOUND_MARGIN = 1e-5


def _u_bounds(rho_bounds, scale) -> tuple[float, float]:
    """Bounds on u/u(0) from (ρ_lo, ρ_hi) [m]; u > 0 only when ``rho_bounds`` is None."""
    if rho_bounds is None:
        return 0.0, np.inf
    lo, hi = (float(v) for v in rho_bounds)
    if not 0 < lo < hi:
        raise ValueError(f"rho_bounds = {rho_bounds!r} must be (ρ_lo, ρ_hi) [m], 0 < ρ_lo < ρ_hi "
                         "(ρ_hi may be inf)")
    return 1 / (hi * (1 - RHO_BOUND_MARGIN) * scale), 1 / (lo * (1 + RHO_BOUND_MARGIN) * scale)


def _check_designed_arc(profile, coefficients, phi_max):
    """Raise ValueError unless ρ > 0 and the Eq. 40 margin > 0 on [0, phi_max]."""
    phi = np.linspace(0.0, phi_max, CHECK_GRID)
    rho, _, _, margin = designed_values(profile, coefficients, phi)
    bad = (rho <= 0) | (margin <= 0)
    if bad.any():
        raise ValueError(f"the designed profile is not positive and convex at φ = "
                         f"{phi[bad][0]:.4f} rad (Johnston2023 Eq. 40 margin "
                         f"{margin[bad][0]:.3g} m²); "
                         "it cannot be closed into a convex outline")


def _hermite(start, end) -> Polynomial:
    """The quintic p(x) with p, p′, p″ equal to ``start`` at x = 0 and ``end`` at x = 1."""
    monomials = [Polynomial.basis(k) for k in range(6)]
    rows = [[m.deriv(d)(x) for m in monomials] for x in (0.0, 1.0) for d in range(3)]
    return Polynomial(np.linalg.solve(np.array(rows), np.concatenate((start, end))))


def _closure_coefficients(hermite, terms, span, u_bounds) -> np.ndarray:
    """Free coefficients of the closing arc by the two programs of :func:`closed_outline`."""
    x = np.linspace(0.0, 1.0, CLOSURE_GRID)

    def rows(p):  # u, u + u″ and (u + u″)′ with respect to φ on the grid
        return np.array([p(x), p(x) + p.deriv(2)(x) / span**2,
                         p.deriv(1)(x) / span + p.deriv(3)(x) / span**3])

    (u0, c0, v0), cols = rows(hermite), np.array([rows(t) for t in terms])
    u, c, v = (cols[:, k].T for k in range(3))
    n, ones = len(terms), np.ones((x.size, 1))
    # 1. maximise t subject to u + u″ ≥ t (variables: the free coefficients and t)
    best = _solve_qp(np.zeros((n + 1, n + 1)), np.r_[np.zeros(n), -1.0],
                     np.vstack((np.hstack((c, -ones)), np.hstack((u, 0 * ones)))),
                     np.concatenate((-c0, u_bounds[0] - u0)),
                     np.concatenate((np.full(x.size, np.inf), u_bounds[1] - u0)))
    if best is None or best[-1] <= 0:
        raise ValueError("no convex closure of the designed arc exists: over the remaining "
                         "angle no u = 1/ρ keeps u + u″ > 0 (Johnston2023 Eq. 40), matches ρ, ρ′, ρ″ "
                         "of the designed arc at both ends and stays within rho_bounds")
    # 2. minimise ∫ ((u + u″)′)² dx subject to u + u″ ≥ t*/2
    smooth = _solve_qp(2 * v.T @ v / x.size, 2 * v.T @ v0 / x.size, np.vstack((c, u)),
                       np.concatenate((best[-1] / 2 - c0, u_bounds[0] - u0)),
                       np.concatenate((np.full(x.size, np.inf), u_bounds[1] - u0)))
    return best[:n] if smooth is None else smooth


def _solve_qp(h, g, a, lba, uba):
    """argmin ½zᵀhz + gᵀz subject to lba ≤ az ≤ uba with HiGHS through CasADi; None if it fails."""
    solver = ca.conic("closure", "highs", {"h": ca.Sparsity.dense(*h.shape),
                                           "a": ca.Sparsity.dense(*a.shape)},
                      {"highs": {"output_flag": False}, "error_on_fail": False})
    out = solver(h=h, g=g, a=a, lba=lba, uba=uba)
    return np.asarray(out["x"]).ravel() if solver.stats()["success"] else None


def _check_closing_arc(outline):
    """Raise ValueError unless u > 0 and u + u″ > 0 on a fine grid of the closing arc."""
    u, _, ddu = outline.closing.u(np.linspace(outline.phi_end, TWO_PI, CHECK_GRID))
    if np.any(u <= 0) or np.any(u + ddu <= 0):
        raise ValueError("the closing arc found is not convex between its grid points; "
                         "try a different number of free coefficients")


# -------------------------------------------------------------------------------------- polyline

def polyline(outline: Outline, tolerance: float = DEFAULT_TOLERANCE) -> np.ndarray:
    """Vertices [m] of a polygon inscribed in ``outline`` whose chords are within ``tolerance``.

    The sag of a chord (the largest distance from the outline between its ends to the chord)
    is about ℓ²κ/8 for a chord of length ℓ where the curvature is κ, so the first vertices are
    spread evenly in ∫ √(κ/8·tolerance) ds, each arc on its own, with φ = 0 and φ_end as
    vertices: the designed arc is covered by chords of its own. Every chord whose sag still
    exceeds ``tolerance`` is then split evenly into ⌈√(sag/tolerance)⌉ chords until none does.

    Parameters
    ----------
    outline : Outline
    tolerance : float
        Largest allowed distance between the outline and a chord [m].

    Returns
    -------
    ndarray, shape (N, 2)
        Counter-clockwise from φ = 0; the first vertex is not repeated.
    """
    tolerance = _positive("tolerance", tolerance)
    designed = _even_chords(outline, 0.0, outline.phi_end, tolerance)
    closing = _even_chords(outline, outline.phi_end, TWO_PI, tolerance)
    knots = np.concatenate((designed[:-1], closing))
    while True:
        pieces = np.maximum(1, np.ceil(np.sqrt(chord_sag(outline, knots) / tolerance))).astype(int)
        if pieces.max() == 1:
            return outline.xy(knots[:-1])
        knots = np.append(np.concatenate([np.linspace(a, b, p, endpoint=False) for a, b, p
                                          in zip(knots[:-1], knots[1:], pieces)]), TWO_PI)


def _even_chords(outline, start, stop, tolerance) -> np.ndarray:
    """Angles from ``start`` to ``stop`` [rad] spreading chords evenly in ∫ √(κ/8·tolerance) ds.

    With ds/dφ = √(ρ² + ρ′²) and κ = (ρ² + 2ρ′² − ρρ″)/(ρ² + ρ′²)^(3/2) (Johnston2023 Eq. 40),
    the chord count per radian is √(margin/8·tolerance)/(ρ² + ρ′²)^(1/4).
    """
    phi = np.linspace(start, stop, 513)
    rho, drho, ddrho = outline.derivatives(phi)
    margin = convexity_margin(rho, drho, ddrho)  # Johnston2023 Eq. 40
    # a straight chord (margin 0, rounding either side) needs no vertices of its own
    density = np.sqrt(np.maximum(margin, 0) / (8 * tolerance)) / (rho**2 + drho**2) ** 0.25
    count = np.concatenate(([0.0], np.cumsum((density[1:] + density[:-1]) / 2 * np.diff(phi))))
    chords = max(1, int(np.ceil(CHORD_SPARE * count[-1])))
    if count[-1] == 0:
        return np.array([start, stop])
    return np.interp(np.linspace(0.0, count[-1], chords + 1), count, phi)


def chord_sag(outline: Outline, knots) -> np.ndarray:
    """Largest distance [m] from the outline to each chord between consecutive ``knots`` [rad].

    Measured at SAG_SAMPLES evenly spaced interior angles and multiplied by 1 + h² (h the
    sample spacing as a fraction of the chord): the most a sampled maximum can miss of a
    parabolic sag, which is what a short convex arc has.
    """
    knots = np.asarray(knots, dtype=float)
    s = np.arange(1, SAG_SAMPLES + 1) / (SAG_SAMPLES + 1)
    start, step = knots[:-1, None], np.diff(knots)[:, None]
    inner = outline.xy((start + step * s).ravel()).reshape(step.size, s.size, 2)
    ends = outline.xy(knots)
    return segment_distance(inner, ends[:-1, None], ends[1:, None]).max(axis=1) * (1 + s[0] ** 2)


# ---------------------------------------------------------------------------------------- holes

def anchor_centre(outline: Outline, anchor_diameter: float) -> np.ndarray:
    """Centre [m] of the wire's anchor hole.

    On the inward normal of the outline at the anchor point φ = 0, deep enough to leave
    MIN_WALL of material between the hole and the profile (deeper where a corner of the
    outline, such as a chord closure's, comes near).
    """
    rho, drho, _ = outline.derivatives(0.0)[:, 0]
    outward = np.array([rho, -drho]) / np.hypot(rho, drho)  # tangent (ρ′, ρ) turned by −90°
    radius = anchor_diameter / 2
    depths = radius + MIN_WALL + np.linspace(0.0, max(rho - radius - MIN_WALL, 0.0), 200)
    for depth in depths:  # the first depth that leaves the wall to the whole outline
        centre = np.array([rho, 0.0]) - depth * outward
        if np.min(np.hypot(*(outline.points - centre).T)) - radius >= MIN_WALL - ROUNDING:
            return centre
    return np.array([rho, 0.0]) - depths[0] * outward  # none: holes() names the shortfall


def holes(outline: Outline, bore_diameter: float,
          anchor_diameter: float) -> list[tuple[np.ndarray, float]]:
    """The bore and the anchor hole as (centre [m], diameter [m]) pairs, checked to fit.

    Raises
    ------
    ValueError
        Naming ``bore_diameter`` or ``anchor_diameter`` when a size is not positive or a hole
        leaves less than MIN_WALL of material to the profile or to the other hole.
    """
    _check_bore(outline, bore_diameter)
    anchor = anchor_centre(outline, _positive("anchor_diameter", anchor_diameter))
    to_bore = np.hypot(*anchor) - (anchor_diameter + bore_diameter) / 2
    to_profile = np.min(np.hypot(*(outline.points - anchor).T)) - anchor_diameter / 2
    if min(to_bore, to_profile) < MIN_WALL - ROUNDING:
        raise ValueError(f"anchor_diameter = {_length(anchor_diameter)} does not fit near the "
                         f"anchor point: it leaves {_length(min(to_bore, to_profile))} of wall "
                         f"to the {'bore' if to_bore < to_profile else 'profile'}; at least "
                         f"{_length(MIN_WALL)} is needed")
    return [(np.zeros(2), bore_diameter), (anchor, anchor_diameter)]


def _check_bore(outline, bore_diameter):
    """ValueError naming ``bore_diameter`` unless the bore leaves MIN_WALL inside ρ_min."""
    rho_min = outline.rho_range[0]
    if _positive("bore_diameter", bore_diameter) / 2 + MIN_WALL > rho_min + ROUNDING:
        raise ValueError(f"bore_diameter = {_length(bore_diameter)} is too large: with a "
                         f"{_length(MIN_WALL)} wall inside the least outline radius ρ_min = "
                         f"{_length(rho_min)} it may be at most "
                         f"{_length(2 * (rho_min - MIN_WALL))}")


def _length(value: float) -> str:
    """A length [m] for messages, with millimetres."""
    return f"{value:.6g} m ({value * MM:.4g} mm)"


def _positive(name: str, value) -> float:
    """``value`` as a float; ValueError naming ``name`` unless it is finite and > 0."""
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive length [m], got {value!r}")
    return value


# --------------------------------------------------------------------------------------- writers

#: What a DXF or SVG says of an outline drawn in its own frame where the cable winds clockwise
#: on the part: the frame has the cable wound counter-clockwise, so the drawing is the part seen
#: from its back.
MIRRORED_NOTE = ("SEEN FROM THE BACK: the cable winds clockwise on this part, so this outline "
                 "(drawn with the cable counter-clockwise) is its mirror image; cut it and turn it over")


def write_dxf(path, outline: Outline, bore_diameter: float, anchor_diameter: float,
              tolerance: float = DEFAULT_TOLERANCE, mirrored: bool = False) -> ArcChain:
    """Write the cam as a DXF drawing in millimetres ($INSUNITS = 4), atomically.

    The outline as a closed LWPOLYLINE of circular arcs (bulges) on layer PROFILE, the biarc fit
    of :func:`cadcam.make.biarc.biarc_fit` within ``tolerance`` [m], its first vertex the anchor
    point φ = 0 on the +x axis; the bore (centred on the rotation axis, the origin) and the
    anchor hole (:func:`anchor_centre`) as CIRCLEs on layer HOLES; where ``mirrored`` (a
    clockwise-wound part), :data:`MIRRORED_NOTE` as TEXT on layer NOTES. Returns the fitted chain.
    """
    circles = holes(outline, bore_diameter, anchor_diameter)
    chain = biarc_fit(outline, tolerance)
    doc = ezdxf.new("R2010", units=ezdxf.units.MM)
    doc.layers.add("PROFILE", color=7)
    doc.layers.add("HOLES", color=1)
    msp = doc.modelspace()
    msp.add_lwpolyline(np.column_stack([chain.vertices * MM, chain.bulges]), format="xyb", close=True,
                       dxfattribs={"layer": "PROFILE"})
    for centre, diameter in circles:
        msp.add_circle(tuple(centre * MM), diameter * MM / 2, dxfattribs={"layer": "HOLES"})
    if mirrored:
        doc.layers.add("NOTES", color=3)
        low = chain.sample(SVG_BOX_SAMPLES).min(axis=0) * MM
        msp.add_text(MIRRORED_NOTE, height=2.0, dxfattribs={"layer": "NOTES", "insert": (low[0], low[1] - 5.0)})
    with atomic_path(path) as tmp:
        doc.saveas(tmp)
    return chain


def _svg_arcs(chain: ArcChain, flip) -> str:
    """SVG path data of ``chain`` in millimetres with y negated: M, then one A (arc) or L
    (straight) command per segment, then Z. Negating y turns a counter-clockwise arc into SVG's
    positive-angle sweep (its y axis points down)."""
    ends = np.roll(chain.vertices, -1, axis=0)
    out = [f"M {chain.vertices[0, 0] * flip[0] + 0.0:.9f},{chain.vertices[0, 1] * flip[1] + 0.0:.9f}"]
    for a, b, bulge in zip(chain.vertices, ends, chain.bulges):
        x, y = b * flip + 0.0  # + 0.0: no '-0.000000'
        if abs(bulge) < 1e-12:
            out.append(f"L {x:.9f},{y:.9f}")
            continue
        _, radius, sweep = arc_geometry(a, b, bulge)
        r = abs(radius) * MM
        out.append(f"A {r:.9f},{r:.9f} 0 {int(abs(sweep) > np.pi)} {int(sweep > 0)} {x:.9f},{y:.9f}")
    return " ".join(out) + " Z"


def write_svg(path, outline: Outline, bore_diameter: float, anchor_diameter: float,
              tolerance: float = DEFAULT_TOLERANCE, mirrored: bool = False) -> None:
    """Write the cam as an SVG at 1:1 scale, atomically.

    ``width`` and ``height`` are in millimetres and the viewBox, in millimetres, is the bounding
    box of the profile, seen from +z (SVG's y axis points down, so y is negated). One path for
    the profile — the same biarcs as the DXF (:func:`cadcam.make.biarc.biarc_fit` within
    ``tolerance``), as SVG arcs — and one circle per hole, as hairlines for a laser cutter;
    where ``mirrored``, :data:`MIRRORED_NOTE` as the drawing's title (not cut).
    """
    circles = holes(outline, bore_diameter, anchor_diameter)
    flip = np.array([MM, -MM])
    chain = biarc_fit(outline, tolerance)
    points = chain.sample(SVG_BOX_SAMPLES) * flip + 0.0
    centres = np.array([centre for centre, _ in circles]) * flip + 0.0
    lo, size = points.min(axis=0), np.ptp(points, axis=0)
    shapes = [f'  <path d="{_svg_arcs(chain, flip)}"/>'] + [
        f'  <circle cx="{x:.6f}" cy="{y:.6f}" r="{diameter * MM / 2:.6f}"/>'
        for (x, y), (_, diameter) in zip(centres, circles)]
    write_text(path, "\n".join([
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{size[0]:.6f}mm" '
        f'height="{size[1]:.6f}mm" viewBox="{lo[0]:.6f} {lo[1]:.6f} {size[0]:.6f} {size[1]:.6f}">',
        *([f"<title>{MIRRORED_NOTE}</title>"] if mirrored else []),
        '<g fill="none" stroke="black" stroke-width="0.05">', *shapes, "</g>", "</svg>", ""]))


def helical_groove(basis: Basis, coefficients, phi_max: float, pitch: float,
                   step: float = np.radians(1.0)) -> np.ndarray:
    """The centre line of a helical groove (a drum whose cable wraps more than one turn,
    Fedorov2018 Sec. 4.1): the designed spiral ρ(φ), φ ∈ [0, ``phi_max``], climbing the drum's
    axis by ``pitch`` [m] per turn.

    Returns
    -------
    ndarray (n, 5)
        φ [rad], ρ [m] and the points x, y, z [m] (z along the shaft from the anchor's turn);
        the planar design model is the projection on z = 0.
    """
    phi = np.linspace(0.0, phi_max, int(np.ceil(phi_max / step)) + 1)
    rho = designed_values(profile_function(basis), coefficients, phi)[0]
    return np.column_stack([phi, rho, rho * np.cos(phi), rho * np.sin(phi), pitch * phi / TWO_PI])


def write_groove_csv(path, groove: np.ndarray) -> None:
    """Write :func:`helical_groove` as CSV ``phi_rad,rho_mm,x_mm,y_mm,z_mm``, atomically."""
    write_table(path, ["phi_rad", "rho_mm", "x_mm", "y_mm", "z_mm"],
                np.column_stack([groove[:, 0], groove[:, 1:] * MM]))


def write_points_csv(path, outline: Outline, tolerance: float = DEFAULT_TOLERANCE) -> None:
    """Write the vertices of :func:`polyline` as CSV ``x_mm,y_mm``, atomically."""
    write_table(path, ["x_mm", "y_mm"], polyline(outline, tolerance) * MM)


def write_stl(path, outline: Outline, thickness: float, bore_diameter: float,
              groove_depth: float = 0.0, groove_width: float = 0.0,
              tolerance: float = DEFAULT_TOLERANCE) -> float:
    """Write the cam as a watertight binary STL in millimetres, atomically.

    The profile of :func:`polyline` extruded along z by ``thickness`` with the bore through it
    (a regular polygon circumscribing the circle within ``tolerance``, so that a shaft of
    ``bore_diameter`` fits). With a groove, a cable groove ``groove_width`` wide, centred in
    the thickness, is cut all round: there the section is the profile offset inward by
    ``groove_depth``. manifold3d builds the solid by extrusion and boolean difference, which
    always yield a closed 2-manifold.

    Parameters
    ----------
    path : path-like
    outline : Outline
    thickness : float
        Cam thickness along z [m].
    bore_diameter : float
        [m]
    groove_depth, groove_width : float
        Cable groove [m]; both 0 (no groove) or both positive.
    tolerance : float
        Chordal tolerance of the profile and the bore [m].

    Returns
    -------
    float
        Volume of the solid [m³].
    """
    _check_solid(outline, thickness, bore_diameter, groove_depth, groove_width)
    profile = CrossSection([polyline(outline, tolerance) * MM])
    bore = _bore_section(bore_diameter / 2, tolerance)
    solid = Manifold.extrude(profile - bore, thickness * MM)
    if groove_depth > 0:
        ring = (profile.offset(groove_depth * MM, JoinType.Round)
                - profile.offset(-groove_depth * MM, JoinType.Miter))
        groove = Manifold.extrude(ring, groove_width * MM)
        solid = solid - groove.translate((0.0, 0.0, (thickness - groove_width) / 2 * MM))
    mesh = solid.to_mesh()
    _write_binary_stl(path, np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts))
    return solid.volume() / MM**3


def _check_solid(outline, thickness, bore_diameter, groove_depth, groove_width):
    """ValueError naming the parameter unless the solid of :func:`write_stl` can be made."""
    thickness = _positive("thickness", thickness)
    _check_bore(outline, bore_diameter)
    if groove_depth == 0 and groove_width == 0:
        return
    depth, width = _positive("groove_depth", groove_depth), _positive("groove_width", groove_width)
    if width >= thickness:
        raise ValueError(f"groove_width = {_length(width)} must be less than thickness = "
                         f"{_length(thickness)}")
    deepest = outline.rho_range[0] - bore_diameter / 2 - MIN_WALL
    if depth >= deepest:
        raise ValueError(f"groove_depth = {_length(depth)} is too deep: it must be less than "
                         f"ρ_min − bore radius − wall = {_length(deepest)}")


def _bore_section(radius: float, tolerance: float) -> CrossSection:
    """A regular polygon [mm] around the circle of ``radius`` [m], corners within ``tolerance``."""
    sides = max(8, int(np.ceil(np.pi / np.arccos(radius / (radius + tolerance)))))
    return CrossSection.circle(radius / np.cos(np.pi / sides) * MM, sides)


def _write_binary_stl(path, vertices, triangles):
    """Write triangles (index triples into ``vertices`` [mm]) as a binary STL, atomically."""
    corners = vertices[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), np.finfo(float).tiny)
    records = np.zeros(len(corners), dtype=[("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)),
                                            ("attribute", "<u2")])
    records["normal"], records["corners"] = normals, corners
    with atomic_path(path) as tmp, open(tmp, "wb") as out:
        out.write(b"cadcam cam, millimetres".ljust(80, b" "))
        out.write(np.uint32(len(records)).tobytes())
        out.write(records.tobytes())
