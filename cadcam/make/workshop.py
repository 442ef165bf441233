"""From a designed profile to files a workshop can cut, print or mill.

The optimiser designs ρ(φ) only over the wrapped range φ ∈ [0, α_max]. :func:`closed_outline`
completes it into a closed, convex, C2 outline; :func:`polyline` turns that into a polygon
within a chordal tolerance; the writers export it as DXF, SVG, CSV and a watertight binary STL.
Everything is in SI units (metres) inside; the files are in millimetres. The writers' libraries
(ezdxf, manifold3d) are imported where they write, so that the processes that draw a part's
sheets from its outline do not load them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np
from numpy.polynomial import Legendre, Polynomial

from ..files import atomic_path, write_csv as write_table, write_text
from ..library_files import libraries_imported
from ..physics.outline import NOTCH
from ..physics.profile import Basis, convexity_margin, curvature, profile_function
from ..problem import MIN_WALL
from .biarc import (ArcChain, arc_geometry, biarc_fit, concavity, segment_distance, signed_distance, support,
                    tangent_angles)
from ..units import MM

if TYPE_CHECKING:
    from manifold3d import CrossSection

TWO_PI = 2 * np.pi
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
"""Interior samples per chord at which :func:`polyline` measures the sag (odd: with the middle)."""
SVG_BOX_SAMPLES = 64
"""Points per arc from which the SVG's box is taken (an arc's sag between them is (1/64)²/8 of its own)."""
GROOVE_ROWS = 20_000
"""Most rows of a helical groove's centre line (:func:`helical_groove`): a CSV a workshop opens."""
GROOVE_SCAN = 8192
"""Points at which :func:`helical_groove` finds the spiral's tightest bend."""


# --------------------------------------------------------------------------------------- outline

@dataclass
class Outline:
    """A closed convex cam outline as cut: the designed arc and the arc that closes it.

    The designed arc is ρ(φ) of the optimised profile for φ ∈ [0, ``phi_end``], the cable's
    centre line, cut ``offset`` (the cable's radius) inside it: p(φ) − offset·n̂(φ), n̂ the
    outward unit normal. The closing arc is ρ = 1/u in the polar angle ψ, u given by ``closing``:
    a :class:`SmoothClosing` closes the designed arc itself (C2 at both joints) and is cut the
    same offset inside; a :class:`HullClosing` closes the cut arc, from its end round to its
    anchor, and the parameter φ ∈ [φ_end, 2π] runs over it at a constant rate of ψ (ψ = φ
    without offset). Angles outside [0, 2π) are taken modulo 2π.

    Attributes
    ----------
    profile : casadi.Function
        ``profile(phi, c) -> (rho, drho, ddrho, convexity)`` of the design's basis.
    coefficients : ndarray
        The designed profile's coefficients [m].
    phi_end : float
        Angle where the designed (wrapped) arc ends and the closing arc begins [rad].
    closing : SmoothClosing or HullClosing
        u = 1/ρ [1/m] and its ψ-derivatives on the closing arc.
    offset : float
        How far inside the designed arc the cut arc lies [m] (a cable's radius; 0: on it).
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
    offset: float = 0.0
    samples: int = 2048
    phi: np.ndarray = field(init=False, repr=False)
    points: np.ndarray = field(init=False, repr=False)
    # what :meth:`arcs` and :func:`holes` found, by their arguments: the DXF, the SVG, their
    # checks and the drawing sheets (pickled with the outline to the processes that draw them)
    # all ask for the same fit
    _found: dict = field(init=False, repr=False, compare=False, default_factory=dict)

    def __post_init__(self):
        #: the closing arc's own offset [m]: a smooth closure's is the arc's, a hull's none
        self.closing_offset = self.offset if isinstance(self.closing, SmoothClosing) else 0.0
        self.closing_angles = closing_angles(self.profile, self.coefficients, self.phi_end,
                                             self.offset - self.closing_offset)
        grid = np.linspace(0.0, TWO_PI, self.samples, endpoint=False)
        self.phi = np.union1d(grid, [self.phi_end])
        self.points = self.xy(self.phi)

    @property
    def closing_span(self) -> float:
        """Angle 2π − φ_end of the parameter covered by the closing arc [rad]."""
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
        """ρ, ρ′, ρ″ [m, m/rad, m/rad²] at the polar angles ``phi``, as a (3, N) array, of an
        outline cut on its designed arc (``offset`` 0), where φ is the polar angle."""
        if self.offset:
            raise ValueError("an outline cut a cable's radius inside its designed arc is not ρ(φ)")
        phi = np.mod(np.atleast_1d(np.asarray(phi, dtype=float)), TWO_PI)
        out = np.empty((3, phi.size))
        on = self.designed(phi)
        if on.any():
            out[:, on] = designed_values(self.profile, self.coefficients, phi[on])[:3]
        if not on.all():
            out[:, ~on] = _rho_from_u(*self.closing.u(phi[~on]))
        return out

    def rho(self, phi) -> np.ndarray:
        """ρ(φ) [m] on the full circle (``offset`` 0)."""
        return self.derivatives(phi)[0]

    def margin(self, phi) -> np.ndarray:
        """Convexity margin ρ² + 2ρ′² − ρρ″ [m²] on the full circle (Johnston2023 Eq. 40;
        ``offset`` 0)."""
        return convexity_margin(*self.derivatives(phi))

    def radius_at(self, angle: float) -> float:
        """Distance [m] from the axis to the outline along the ray at polar ``angle`` [rad]."""
        if not self.offset:
            return float(self.rho(angle)[0])
        polar = np.unwrap(np.arctan2(self.points[:, 1], self.points[:, 0]))
        return float(np.interp(np.mod(angle - polar[0], TWO_PI) + polar[0], polar, np.hypot(*self.points.T),
                               period=TWO_PI))

    def arcs(self, tolerance: float) -> ArcChain:
        """The outline as biarcs within ``tolerance`` [m] (:func:`cadcam.make.biarc.biarc_fit`),
        fitted once for each tolerance; its arrays are read-only."""
        return self._once(("arcs", tolerance), lambda: biarc_fit(self, tolerance))

    def _once(self, key: tuple, find):
        """``find()``, computed once for ``key`` (an error is raised each time, not kept), its
        arrays made read-only: the value is shared."""
        if key not in self._found:
            value = find()
            for array in _arrays(value):
                array.flags.writeable = False
            self._found[key] = value
        return self._found[key]

    @property
    def closing_joints(self) -> np.ndarray:
        """Parameters φ [rad] inside (φ_end, 2π) where the closing arc passes from one piece to
        the next (a hull closure's line to the hub's arc and on: its curvature jumps there);
        none for a smooth closure."""
        if not isinstance(self.closing, HullClosing):
            return np.zeros(0)
        start, stop = self.closing_angles
        return self.phi_end + (self.closing.starts[1:] - start) * self.closing_span / (stop - start)

    def _psi(self, phi) -> np.ndarray:
        """Polar angle ψ [rad] of the closing arc at parameter φ ∈ [φ_end, 2π]."""
        start, stop = self.closing_angles
        return start + (np.asarray(phi, dtype=float) - self.phi_end) * (stop - start) / self.closing_span

    def xy(self, phi) -> np.ndarray:
        """Points [m] of the outline at the parameters ``phi``, shape (N, 2)."""
        phi = np.mod(np.atleast_1d(np.asarray(phi, dtype=float)), TWO_PI)
        out = np.empty((phi.size, 2))
        on = self.designed(phi)
        if on.any():
            out[on] = cut_points(self.profile, self.coefficients, phi[on], self.offset)
        if not on.all():
            psi = self._psi(phi[~on])
            rho, drho, _ = _rho_from_u(*self.closing.u(psi))
            out[~on] = _offset_inward(psi, rho, drho, self.closing_offset)
        return out

    def unit_tangents(self, phi, closing: bool) -> np.ndarray:
        """Unit tangents (N, 2) of the designed arc (``closing`` False) or of the closing arc at
        the parameters ``phi`` [rad] in [0, φ_end] or [φ_end, 2π]: one-sided at the joints,
        where a hull closure has corners. An offset arc's tangent is its designed arc's."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        if closing:
            psi = self._psi(phi)
            rho, drho, _ = _rho_from_u(*self.closing.u(psi))
        else:
            psi = phi
            rho, drho = designed_values(self.profile, self.coefficients, phi)[:2]
        t = _polar_tangent(psi, rho, drho)
        return t / np.linalg.norm(t, axis=1, keepdims=True)

    def speed_curvature(self, phi) -> tuple[np.ndarray, np.ndarray]:
        """|dp/dφ| [m/rad] and the curvature κ [1/m] of the outline at the parameters ``phi``
        in [0, 2π] (the designed arc's where φ = φ_end). Johnston2023 Eq. 40: κ is the margin
        over the speed cubed; an offset d inside a curve of curvature κ has speed s(1 − dκ)
        and curvature κ/(1 − dκ)."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        on = phi <= self.phi_end
        speed, kappa = np.empty(phi.size), np.empty(phi.size)
        if on.any():
            rho, drho, _, margin = designed_values(self.profile, self.coefficients, phi[on])
            s, k = np.hypot(rho, drho), curvature(rho, drho, margin)
            speed[on], kappa[on] = s * (1 - self.offset * k), k / (1 - self.offset * k)
        if not on.all():
            rho, drho, ddrho = _rho_from_u(*self.closing.u(self._psi(phi[~on])))
            s, k = np.hypot(rho, drho), curvature(rho, drho, convexity_margin(rho, drho, ddrho))
            start, stop = self.closing_angles
            speed[~on] = s * (1 - self.closing_offset * k) * (stop - start) / self.closing_span
            kappa[~on] = k / (1 - self.closing_offset * k)
        return speed, kappa


def _polar_tangent(phi, rho, drho) -> np.ndarray:
    """dp/dφ (N, 2) of the polar curve (ρ cos φ, ρ sin φ) (Johnston2023 Eq. 3)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.column_stack((drho * c - rho * s, drho * s + rho * c))


def _offset_inward(phi, rho, drho, offset: float) -> np.ndarray:
    """Points (N, 2) [m] of the polar curve ρ(φ) moved ``offset`` [m] along its inward normal:
    the tangent (Johnston2023 Eq. 3) turned by +90°."""
    t = _polar_tangent(phi, rho, drho)
    inward = np.column_stack((-t[:, 1], t[:, 0])) / np.linalg.norm(t, axis=1, keepdims=True)
    return np.column_stack((rho * np.cos(phi), rho * np.sin(phi))) + offset * inward


def cut_points(profile: ca.Function, coefficients, phi, offset: float) -> np.ndarray:
    """Points (N, 2) [m] of the designed arc at ``phi`` cut ``offset`` [m] inside it."""
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    rho, drho = designed_values(profile, coefficients, phi)[:2]
    return _offset_inward(phi, rho, drho, offset)


def closing_angles(profile: ca.Function, coefficients, phi_end: float, offset: float) -> tuple[float, float]:
    """Polar angles [rad] where the closing arc of an outline cut ``offset`` inside its designed
    arc starts (the cut arc's end) and stops (its anchor, a turn on): (φ_end, 2π) without offset."""
    if not offset:
        return float(phi_end), TWO_PI
    end, anchor = cut_points(profile, coefficients, [phi_end, 0.0], offset)
    start = float(np.arctan2(end[1], end[0]))
    stop = float(np.arctan2(anchor[1], anchor[0])) + TWO_PI
    return start, stop - TWO_PI * np.floor((stop - start) / TWO_PI)


def designed_values(profile: ca.Function, coefficients, phi) -> np.ndarray:
    """ρ, ρ′, ρ″ and the Eq. 40 margin of the designed profile at ``phi``, shape (4, N)."""
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    # a row of angles: CasADi evaluates the function at each (a map without building one per call)
    out = profile(phi.reshape(1, -1), np.asarray(coefficients, dtype=float))
    return np.array([np.asarray(v).ravel() for v in out])


def _u_from_rho(rho, drho, ddrho) -> np.ndarray:
    """u = 1/ρ and its first two φ-derivatives."""
    return np.array([1 / rho, -drho / rho**2, (2 * drho**2 - rho * ddrho) / rho**3])


def _rho_from_u(u, du, ddu) -> np.ndarray:
    """ρ = 1/u and its first two φ-derivatives (the inverse of :func:`_u_from_rho`)."""
    return np.array([1 / u, -du / u**2, (2 * du**2 - u * ddu) / u**3])


def closed_outline(basis: Basis, coefficients, phi_max: float, rho_bounds=None,
                   free: int = CLOSURE_FREE, offset: float = 0.0) -> Outline:
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
    outline = Outline(profile, np.asarray(coefficients, dtype=float), float(phi_max), closing, offset)
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


def hull_outline(basis: Basis, coefficients, phi_max: float, hub_radius: float, offset: float = 0.0) -> Outline:
    """Close the designed arc ρ(φ), φ ∈ [0, ``phi_max``], cut ``offset`` [m] inside it (a cable's
    radius), by the convex hull of that cut arc and the hub, a disk of ``hub_radius`` [m] about
    the axis.

    From the arc's end the hull runs straight to its anchor where that chord passes outside the
    hub; otherwise straight to the hub, round it, and straight on to the anchor, each line a
    tangent of the hub. The design NLP's outline rows (every tangent of the designed arc a
    cable's radius outside the hub, both of the arc's ends inside it, no bend tighter than the
    cable) keep the whole cut arc on the hull, so the hull exists for a design that met them:
    it is checked here.

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
    start, stop = closing_angles(profile, coefficients, phi_max, offset)
    end, anchor = np.hypot(*cut_points(profile, coefficients, [phi_max, 0.0], offset).T)
    closing = HullClosing.around(start, end, stop, anchor, _positive("hub_radius", hub_radius))
    outline = Outline(profile, np.asarray(coefficients, dtype=float), float(phi_max), closing, offset)
    _check_on_hull(outline)
    return outline


@dataclass(frozen=True)
class HullClosing:
    """u = 1/ρ [1/m] of a closing arc made of lines and an arc of the hub in the polar angle ψ:
    piece j covers ψ ∈ [``starts[j]``, ``starts[j + 1]``) and is u = ``a[j]`` cos ψ + ``b[j]`` sin ψ
    (a line: u + u″ = 0) or, with a = b = 0, the hub's circle u = ``level[j]``."""

    starts: np.ndarray
    a: np.ndarray
    b: np.ndarray
    level: np.ndarray

    @classmethod
    def around(cls, start: float, rho_end: float, stop: float, rho_anchor: float, hub: float) -> HullClosing:
        """The hull's closing arc from the arc's end (ρ_end, ψ = ``start``) to its anchor
        (ρ_anchor, ψ = ``stop``, a turn on from the anchor's own angle) round a hub of radius
        ``hub`` [m]: the chord if it clears the hub, else tangent, hub arc, tangent."""
        p1 = rho_end * np.array([np.cos(start), np.sin(start)])
        p0 = rho_anchor * np.array([np.cos(stop), np.sin(stop)])
        normal = np.array([p0[1] - p1[1], p1[0] - p0[0]])  # the chord's line: normal · p = level
        level = float(normal @ p0)
        if level >= hub * np.hypot(*normal):
            return cls(np.array([start]), normal[:1] / level, normal[1:] / level, np.zeros(1))
        leave = start + np.arccos(min(1.0, hub / rho_end))      # where the tangent from the
        arrive = stop - np.arccos(min(1.0, hub / rho_anchor))   # end and to the anchor touch
        return cls(np.array([start, leave, arrive]),
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


def cut_outline(basis: Basis, coefficients, phi_max: float, hub_radius: float, cable_radius: float = 0.0,
                fit: float = 0.0) -> Outline:
    """The outline a workshop cuts: the designed arc, the centre line of a cable of
    ``cable_radius`` [m], cut that far inside it and closed round the hub of ``hub_radius`` [m]:
    by the smoothest convex C2 arc that keeps the cut outline ``fit`` [m] clear of the hub (the
    loosest tolerance of the files' arcs, which may stray that far inside it) and bends no
    tighter than the cable (:func:`closed_outline`) where one exists, else by the hull of the
    cut arc and the hub (:func:`hull_outline`), which the design NLP's outline rows guarantee
    (its lines and hub arc are written exactly: :func:`cadcam.make.biarc.biarc_fit`)."""
    try:
        return closed_outline(basis, coefficients, phi_max, rho_bounds=(hub_radius + cable_radius + fit, np.inf),
                              offset=cable_radius)
    except ValueError:
        return hull_outline(basis, coefficients, phi_max, hub_radius, cable_radius)


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
    """Raise ValueError unless u > 0 and u + u″ > 0 on a fine grid of the closing arc, and its
    radius of curvature exceeds the outline's offset (the cut curve has no cusp)."""
    u, _, ddu = outline.closing.u(np.linspace(outline.phi_end, TWO_PI, CHECK_GRID))
    if np.any(u <= 0) or np.any(u + ddu <= 0):
        raise ValueError("the closing arc found is not convex between its grid points; "
                         "try a different number of free coefficients")
    _, kappa = outline.speed_curvature(np.linspace(outline.phi_end, TWO_PI, CHECK_GRID))
    if outline.offset and np.any(kappa <= 0):  # κ/(1 − dκ) turns negative past 1/d
        raise ValueError("the closing arc found bends tighter than the cable's radius")


# -------------------------------------------------------------------------------------- polyline

def polyline(outline: Outline, tolerance: float = DEFAULT_TOLERANCE, turn: float | None = None) -> np.ndarray:
    """Vertices [m] of a polygon inscribed in ``outline`` whose chords are within ``tolerance``
    and, given ``turn`` [rad], whose chords each span at most that turn of the outline's
    tangent (:func:`polyline_knots`).

    Returns
    -------
    ndarray, shape (N, 2)
        Counter-clockwise from φ = 0; the first vertex is not repeated.
    """
    return outline.xy(polyline_knots(outline, tolerance, turn)[:-1])


def polyline_knots(outline: Outline, tolerance: float = DEFAULT_TOLERANCE, turn: float | None = None) -> np.ndarray:
    """Parameters [rad] of :func:`polyline`'s vertices, from 0 up to 2π (repeating the first).

    The sag of a chord (the largest distance from the outline between its ends to the chord)
    is about ℓ²κ/8 for a chord of length ℓ where the curvature is κ, so the first vertices are
    spread evenly in ∫ √(κ/8·tolerance) ds, each arc on its own, with φ = 0 and φ_end as
    vertices: the designed arc is covered by chords of its own. Every chord whose sag still
    exceeds ``tolerance`` is then split evenly into ⌈√(sag/tolerance)⌉ chords until none does.
    Given ``turn``, every chord over which the outline's tangent turns (:func:`chord_turn`)
    by more is then split evenly into ⌈turning/turn⌉: the chord's direction is within that turn
    of the outline's all along it, where a follower pressed onto a polygon takes its direction
    from (a chord within a tolerance of the outline can lie √(8κ·tolerance) off its direction);
    a convex arc's chord split so sags no more than before.

    Parameters
    ----------
    outline : Outline
    tolerance : float
        Largest allowed distance between the outline and a chord [m].
    turn : float, optional
        Largest turn [rad] of the outline's tangent over one chord.
    """
    tolerance = _positive("tolerance", tolerance)
    designed = _even_chords(outline, 0.0, outline.phi_end, tolerance)
    closing = _even_chords(outline, outline.phi_end, TWO_PI, tolerance)
    knots = np.concatenate((designed[:-1], closing))
    knots = _split_until(knots, lambda k: np.ceil(np.sqrt(chord_sag(outline, k) / tolerance)))
    if turn is None:
        return knots
    turn = _positive("turn", turn)

    def pieces(k):
        # the designed arc's chords and the closing arc's two that meet its ends: a follower on
        # an end of the range leans on both chords of the end's vertex
        near = (k[1:] <= outline.phi_end) | (k[:-1] == outline.phi_end)
        near[-1] = True
        return np.where(near, np.ceil(chord_turn(outline, k) / turn), 1)

    return _split_until(knots, pieces)


def _split_until(knots, pieces) -> np.ndarray:
    """``knots`` with each chord split evenly into the number ``pieces(knots)`` gives it (at
    least 1) until it gives 1 for every chord."""
    while True:
        count = np.maximum(1, pieces(knots)).astype(int)
        if count.max() == 1:
            return knots
        j = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)  # each piece's index in its chord
        knots = np.append(np.repeat(knots[:-1], count) + j * np.repeat(np.diff(knots) / count, count), knots[-1])


def chord_turn(outline: Outline, knots) -> np.ndarray:
    """Turn [rad] of the outline's tangent over each chord between consecutive ``knots``
    [rad]: ∫ κ |dp/dφ| dφ by Simpson's rule from both ends and the middle (the smooth
    turning: a hull closure's corner inside a chord is no turn a split could lessen)."""
    knots = np.asarray(knots, dtype=float)
    # φ_end ends a chord of the designed arc and starts one of the closing arc: its rate on each
    end = int(np.searchsorted(knots, outline.phi_end))
    phi = np.concatenate([knots, (knots[:-1] + knots[1:]) / 2, [np.nextafter(outline.phi_end, np.inf)]])
    rate = np.prod(outline.speed_curvature(phi), axis=0)
    ends, middle = rate[:len(knots)], rate[len(knots):-1]
    starts = ends[:-1].copy()
    if end < len(knots) - 1 and knots[end] == outline.phi_end:
        starts[end] = rate[-1]
    return np.diff(knots) * (starts + 4 * middle + ends[1:]) / 6


def _even_chords(outline, start, stop, tolerance) -> np.ndarray:
    """Parameters from ``start`` to ``stop`` [rad] spreading chords evenly in ∫ √(κ/8·tolerance) ds:
    the chord count per radian is |dp/dφ| √(κ/8·tolerance) (:meth:`Outline.speed_curvature`)."""
    phi = np.linspace(start, stop, 513)
    speed, kappa = outline.speed_curvature(phi)
    # a straight chord (κ 0, rounding either side) needs no vertices of its own
    density = speed * np.sqrt(np.maximum(kappa, 0) / (8 * tolerance))
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

#: Support lines, at evenly spread normals round the circle, that bound the part where the
#: anchor hole's first place does not fit (:func:`_nearest_place`), beside those at the ends of
#: each segment: 0.25° apart, so that between them an arc of radius R is bounded within
#: R(1 − cos 0.125°) ≈ 2.4e-6 R of it (a line, whose normal is among the ends', exactly); the
#: place found is then measured against the exact arcs, and the program asked the shortfall more.
PLACEMENT_DIRECTIONS = 1440
#: Programs :func:`_nearest_place` solves, each asking the last one's shortfall more, before it
#: gives up.
PLACEMENT_ROUNDS = 4


def hole_walls(chain, centre, diameter: float, bore_diameter: float) -> tuple[float, float]:
    """Material [m] between a hole of ``diameter`` about ``centre`` [m] and the outline
    ``chain`` (closed, with ``vertices`` and ``bulges``: an ArcChain written, a FileOutline read
    back) — its signed distance to the exact arcs less its radius, negative where the hole's
    edge lies outside the part — and between it and the bore of ``bore_diameter`` about the axis."""
    centre = np.asarray(centre, dtype=float)
    to_outline = signed_distance(centre[None], chain.vertices, chain.bulges)[0] - diameter / 2
    return float(to_outline), float(np.hypot(*centre) - (diameter + bore_diameter) / 2)


def anchor_centre(outline: Outline, chain: ArcChain, anchor_diameter: float, bore_diameter: float) -> np.ndarray:
    """Centre [m] of the wire's anchor hole: where it leaves MIN_WALL of material to the cut
    outline and to the bore, measured with a sign against ``chain``, the outline's arcs as its
    files hold them (its biarc fit).

    A wall and the hole's radius inside the anchor point φ = 0 along the outline's inward
    normal there, where that fits (the place the NLP's anchor row makes room for:
    :attr:`cadcam.problem.Workshop.anchor_radius`); else the place nearest the anchor point
    that leaves both walls (:func:`_nearest_place`), such as into the sharp corner a hull
    closure makes at the anchor, where the normal runs out of the part.

    Raises
    ------
    ValueError
        Naming ``anchor_diameter`` where no place in the part leaves both walls, with the
        largest hole that would fit.
    """
    radius = _positive("anchor_diameter", anchor_diameter) / 2
    point = outline.xy(0.0)[0]
    tx, ty = outline.unit_tangents(0.0, closing=False)[0]
    centre = point - (radius + MIN_WALL) * np.array([ty, -tx])  # the tangent turned by −90°: outward
    if min(hole_walls(chain, centre, anchor_diameter, bore_diameter)) >= MIN_WALL - ROUNDING:
        return centre
    centre = _nearest_place(chain, point, radius, bore_diameter / 2)
    if centre is None:
        largest = 2 * _widest_place(chain, point, bore_diameter / 2)
        raise ValueError(f"anchor_diameter = {_length(anchor_diameter)} does not fit: no place in the part leaves "
                         f"{_length(MIN_WALL)} of wall to the profile and to the bore; "
                         + (f"the largest hole that does is {_length(largest)}" if largest > 0 else
                            "no hole does (a smaller bore_diameter or a larger rho_min makes room)"))
    return centre


def _support_lines(chain: ArcChain) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (K, 2) — :data:`PLACEMENT_DIRECTIONS` round the circle and the outward
    normals at both ends of each of the convex chain's segments — and its support h(n) [m] at
    each: the part lies within n·x ≤ h(n) for every one."""
    leave, arrive, _ = tangent_angles(chain.vertices, chain.bulges)
    angle = np.concatenate([np.linspace(0.0, TWO_PI, PLACEMENT_DIRECTIONS, endpoint=False),
                            leave - np.pi / 2, arrive - np.pi / 2])  # the tangents turned by −90°
    normals = np.column_stack([np.cos(angle), np.sin(angle)])
    return normals, support(normals, chain.vertices, chain.bulges)


def _nearest_place(chain: ArcChain, point, radius: float, bore_radius: float) -> np.ndarray | None:
    """The centre [m] nearest ``point`` (the anchor) of a hole of ``radius`` [m] that leaves
    MIN_WALL to the convex chain's exact arcs and to the bore of ``bore_radius``; None where the
    program finds none.

    A quadratic program in millimetres: min |x − point|² with x a wall and the radius inside
    each support line of :func:`_support_lines` (their polygon holds the part's inner parallel
    body at that depth, a convex set) and beyond the bore's wall along the anchor's direction u
    (u·x ≥ bore radius + wall + radius, which keeps |x| so too). The polygon reaches a little
    outside the part, so the place is measured against the exact arcs and the program solved
    again asking its shortfall more, up to :data:`PLACEMENT_ROUNDS` times."""
    normals, h = _support_lines(chain)
    depth, u = radius + MIN_WALL, point / np.hypot(*point)
    rows = np.vstack([normals, u])
    extra = 0.0
    for _ in range(PLACEMENT_ROUNDS):
        x = _solve_qp(2 * np.eye(2), -2 * point * MM, rows, np.r_[np.full(len(h), -np.inf), (bore_radius + depth) * MM],
                      np.r_[(h - depth - extra) * MM, np.inf])
        if x is None:
            return None
        centre = x / MM
        to_outline = signed_distance(centre[None], chain.vertices, chain.bulges)[0] - depth
        if to_outline >= 0 and np.hypot(*centre) - bore_radius - depth >= -ROUNDING:
            return centre
        extra += max(-to_outline, ROUNDING)
    return None


def _widest_place(chain: ArcChain, point, bore_radius: float) -> float:
    """The radius [m] of the largest hole that leaves MIN_WALL to the support lines of
    :func:`_support_lines` and to the bore (along the anchor's direction, as
    :func:`_nearest_place`): a linear program in the centre and the radius (0 if none)."""
    normals, h = _support_lines(chain)
    u = point / np.hypot(*point)
    rows = np.vstack([np.column_stack([normals, np.ones(len(h))]), [u[0], u[1], -1.0]])
    x = _solve_qp(np.zeros((3, 3)), np.array([0.0, 0.0, -1.0]), rows,
                  np.r_[np.full(len(h), -np.inf), (bore_radius + MIN_WALL) * MM], np.r_[(h - MIN_WALL) * MM, np.inf])
    return 0.0 if x is None else max(float(x[2]) / MM, 0.0)


def holes(outline: Outline, bore_diameter: float, anchor_diameter: float,
          tolerance: float = DEFAULT_TOLERANCE) -> list[tuple[np.ndarray, float]]:
    """The bore and the anchor hole as (centre [m], diameter [m]) pairs, each leaving MIN_WALL
    of material to the cut outline and to the other hole, measured with a sign against the arcs
    its files hold (the biarc fit within ``tolerance`` [m]), whose convexity is checked first
    (:func:`cadcam.make.biarc.concavity`: the anchor's place is found in a convex part).

    Raises
    ------
    ValueError
        Naming ``bore_diameter`` or ``anchor_diameter`` when a size is not positive or a hole
        leaves less than MIN_WALL of material to the profile or to the other hole; saying so
        when the outline's arcs are not convex.
    """
    return outline._once(("holes", bore_diameter, anchor_diameter, tolerance),
                         lambda: _holes(outline, bore_diameter, anchor_diameter, tolerance))


def _holes(outline: Outline, bore_diameter: float, anchor_diameter: float,
           tolerance: float) -> list[tuple[np.ndarray, float]]:
    """:func:`holes`, found."""
    chain = outline.arcs(tolerance)
    inwards = concavity(chain.vertices, chain.bulges)
    if inwards > NOTCH:
        raise ValueError(f"the cut outline is not convex: its arcs turn inwards, reaching {_length(inwards)} "
                         "beyond their tangent (the closure or the fit failed: please report it)")
    _check_bore(signed_distance(np.zeros((1, 2)), chain.vertices, chain.bulges)[0], bore_diameter)
    return [(np.zeros(2), bore_diameter), (anchor_centre(outline, chain, anchor_diameter, bore_diameter),
                                           anchor_diameter)]


def _arrays(value) -> list[np.ndarray]:
    """The arrays a value :meth:`Outline._once` keeps holds: an array's, a fit's, those in a
    list or tuple (the holes' centres)."""
    if isinstance(value, np.ndarray):
        return [value]
    if isinstance(value, ArcChain):
        return [value.vertices, value.bulges]
    if isinstance(value, (list, tuple)):
        return [array for item in value for array in _arrays(item)]
    return []


def _check_bore(least_radius: float, bore_diameter):
    """ValueError naming ``bore_diameter`` unless the bore leaves MIN_WALL inside the outline's
    ``least_radius`` [m] (its distance from the axis)."""
    if _positive("bore_diameter", bore_diameter) / 2 + MIN_WALL > least_radius + ROUNDING:
        raise ValueError(f"bore_diameter = {_length(bore_diameter)} is too large: with a "
                         f"{_length(MIN_WALL)} wall inside the least outline radius ρ_min = "
                         f"{_length(least_radius)} it may be at most "
                         f"{_length(2 * (least_radius - MIN_WALL))}")


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
              tolerance: float = DEFAULT_TOLERANCE, mirrored: bool = False, mark=None) -> ArcChain:
    """Write the cam as a DXF drawing in millimetres ($INSUNITS = 4), atomically.

    The outline as a closed LWPOLYLINE of circular arcs (bulges) on layer PROFILE, the biarc fit
    of :func:`cadcam.make.biarc.biarc_fit` within ``tolerance`` [m], its first vertex the anchor
    point φ = 0 on the +x axis; the bore (centred on the rotation axis, the origin) and the
    anchor hole (:func:`anchor_centre`) as CIRCLEs on layer HOLES; where ``mirrored`` (a
    clockwise-wound part), :data:`MIRRORED_NOTE` as TEXT on layer NOTES; a datum ``mark`` (its
    ends [m], shape (2, 2): :attr:`cadcam.make.datum.Datum.segment`), to be engraved, as a LINE on
    layer MARK, which no check of the cut part reads. Returns the fitted chain.
    """
    with libraries_imported():  # ezdxf's ezdxf.ini: not from the working folder
        import ezdxf

    circles = holes(outline, bore_diameter, anchor_diameter, tolerance)
    chain = outline.arcs(tolerance)
    doc = ezdxf.new("R2010", units=ezdxf.units.MM)
    doc.layers.add("PROFILE", color=7)
    doc.layers.add("HOLES", color=1)
    msp = doc.modelspace()
    msp.add_lwpolyline(np.column_stack([chain.vertices * MM, chain.bulges]), format="xyb", close=True,
                       dxfattribs={"layer": "PROFILE"})
    for centre, diameter in circles:
        msp.add_circle(tuple(centre * MM), diameter * MM / 2, dxfattribs={"layer": "HOLES"})
    if mark is not None:
        doc.layers.add("MARK", color=5)
        msp.add_line(*(tuple(end * MM) for end in mark), dxfattribs={"layer": "MARK"})
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
    circles = holes(outline, bore_diameter, anchor_diameter, tolerance)
    flip = np.array([MM, -MM])
    chain = outline.arcs(tolerance)
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
                   tolerance: float = DEFAULT_TOLERANCE) -> np.ndarray:
    """The centre line of a helical groove (a drum whose cable wraps more than one turn,
    Fedorov2018 Sec. 4.1): the designed spiral ρ(φ), φ from 0 to a step past ``phi_max``,
    climbing the drum's axis by ``pitch`` [m] per turn.

    The rows are equal steps Δφ whose chords stay within ``tolerance`` [m] of the spiral: a
    chord ℓ ≈ |dp/dφ|Δφ long sags κℓ²/8 where the curvature is κ, so
    Δφ = √(8·tolerance / max κ|dp/dφ|²) (ρΔφ²/8 on a circle), shortened so that ``phi_max`` is a
    row; at most :data:`GROOVE_ROWS` rows. The groove runs on a step past ``phi_max``, the
    most-wound departure, so that the cable leaving there still lies in it (a groove ending at
    the departure would turn its last chord half a step short of the cable's tangent there).

    Returns
    -------
    ndarray (n, 5)
        φ [rad], ρ [m] and the points x, y, z [m] (z along the shaft from the anchor's turn);
        the planar design model is the projection on z = 0.
    """
    profile = profile_function(basis)
    rho, drho, _, margin = designed_values(profile, coefficients, np.linspace(0.0, phi_max, GROOVE_SCAN))
    # κ|dp/dφ|² = margin/|dp/dφ| (Johnston2023 Eq. 40)
    bend = float(np.max(margin / np.hypot(rho, drho)))
    steps = min(GROOVE_ROWS - 2, int(np.ceil(phi_max * np.sqrt(bend / (8 * _positive("tolerance", tolerance))))))
    phi = np.arange(steps + 2) * (phi_max / steps)
    rho = designed_values(profile, coefficients, phi)[0]
    return np.column_stack([phi, rho, rho * np.cos(phi), rho * np.sin(phi), pitch * phi / TWO_PI])


def write_groove_csv(path, groove: np.ndarray) -> None:
    """Write :func:`helical_groove` as CSV ``phi_rad,rho_mm,x_mm,y_mm,z_mm``, atomically."""
    write_table(path, ["phi_rad", "rho_mm", "x_mm", "y_mm", "z_mm"],
                np.column_stack([groove[:, 0], groove[:, 1:] * MM]))


def write_points_csv(path, outline: Outline, tolerance: float = DEFAULT_TOLERANCE, turn: float | None = None) -> int:
    """Write the vertices of :func:`polyline` (within ``tolerance``, each chord of the designed
    arc turning at most ``turn``) as CSV ``x_mm,y_mm``, atomically; returns their number."""
    points = polyline(outline, tolerance, turn)
    write_table(path, ["x_mm", "y_mm"], points * MM)
    return len(points)


def write_stl(path, outline: Outline, thickness: float, holes: list, groove_depth: float = 0.0,
              groove_width: float = 0.0, tolerance: float = DEFAULT_TOLERANCE) -> float:
    """Write the cam as a watertight binary STL in millimetres, atomically.

    The profile of :func:`polyline` extruded along z by ``thickness`` with every hole through
    it (each a regular polygon circumscribing its circle within ``tolerance``, so that a shaft
    or pin of its diameter fits). With a groove, a cable groove ``groove_width`` wide, centred
    in the thickness, is cut all round: there the section is the profile offset inward by
    ``groove_depth``. manifold3d builds the solid by extrusion and boolean difference, which
    always yield a closed 2-manifold.

    Parameters
    ----------
    path : path-like
    outline : Outline
    thickness : float
        Cam thickness along z [m].
    holes : list of (ndarray, float)
        Centre [m] and diameter [m] of each hole, the bore (about the axis) first:
        :func:`holes`, as the DXF places them.
    groove_depth, groove_width : float
        Cable groove [m]; both 0 (no groove) or both positive.
    tolerance : float
        Chordal tolerance of the profile and the holes [m].

    Returns
    -------
    float
        Volume of the solid [m³].
    """
    from manifold3d import CrossSection, JoinType, Manifold

    _check_solid(outline, thickness, holes[0][1], groove_depth, groove_width)
    profile = CrossSection([polyline(outline, tolerance) * MM])
    section = profile
    for centre, diameter in holes:
        section = section - _hole_section(centre, diameter / 2, tolerance)
    solid = Manifold.extrude(section, thickness * MM)
    if groove_depth > 0:  # round the outline, not the holes
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
    _check_bore(outline.rho_range[0], bore_diameter)
    if groove_depth == 0 and groove_width == 0:
        return
    depth, width = _positive("groove_depth", groove_depth), _positive("groove_width", groove_width)
    if width >= thickness:
        raise ValueError(f"groove_width = {_length(width)} must be less than thickness = "
                         f"{_length(thickness)}")
    deepest = outline.rho_range[0] - bore_diameter / 2 - MIN_WALL
    if depth > deepest + ROUNDING:
        raise ValueError(f"groove_depth = {_length(depth)} is too deep: it may be at most "
                         f"ρ_min − bore radius − wall = {_length(deepest)}")


def _hole_section(centre, radius: float, tolerance: float) -> CrossSection:
    """A regular polygon [mm] around the circle of ``radius`` [m] about ``centre`` [m], corners
    within ``tolerance``."""
    from manifold3d import CrossSection

    sides = max(8, int(np.ceil(np.pi / np.arccos(radius / (radius + tolerance)))))
    return CrossSection.circle(radius / np.cos(np.pi / sides) * MM, sides).translate(tuple(np.asarray(centre) * MM))


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
