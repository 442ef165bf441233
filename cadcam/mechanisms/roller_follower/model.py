"""A radial cam turning with its joint and a translating roller follower pressed onto it by a
spring: the classic cam–follower gravity balancer or nonlinear spring (Norton2009: the radial
cam with an offset translating roller follower). Its equations are in :mod:`.geometry`.

The cam ρ(φ) turns with the joint: a profile point at polar angle φ sits at world angle
φ + γ₀ − θ, γ₀ = ``axis_angle`` the world angle of the cam's polar axis at θ = 0 (how the cam
is keyed on its shaft). The follower slides along a fixed straight line of world direction
``follower_angle`` β, offset by ``offset`` e from the joint axis; its roller of radius
r = ``roller_radius`` rolls on the profile. A spring on the follower (port ``follower``) is
deflected by the follower's travel.

Why γ₀. The engine imposes convexity and the ρ limits on [0, α at the range's end]
(``wrap_end``: a wrapped cable starts at its anchor φ = 0), and the workshop outline keeps the
designed polynomial on the same arc and closes the rest of the turn. The contact angles,
α ≈ β − γ₀ + θ, occupy only [α(θ_min), α(θ_max)]; with γ₀ = 0 and a vertical follower the
profile would have to be convex and inside its ρ limits on a quarter turn no roller ever
touches (on the shipped pendulum: twice the RMS torque error, ρ held at ρ_min there; with a
3 mm pre-deflection, a failed re-check). So γ₀ defaults to β + θ_min − δ_max − :data:`LEAD`
(δ_max of :func:`contact_spread`): the contact starts just after φ = 0. ``axis_angle = 0`` is
the base class's ``profile_rotation`` exactly.

Unknowns per angle z = (α, s): the contact's polar angle on the profile and the roller centre's
position along the line (from the foot of the perpendicular from the axis). With the roller
centre C = p(α) + r n̂(α) (Eq. G3) in line coordinates (a, b) = (C·û, C·v̂ − e):

  (R1)  atan2(b, a) = 0     [rad]: C lies on the line, on the +û side of the axis;
  (R2)  a − s = 0           [m]: s is the roller centre's position.

R1 has one root per turn of α: the pitch curve of a convex profile is convex and surrounds the
foot of the perpendicular e v̂ (|e| + r sin φ_max < ρ_min is checked), so the direction of C − e v̂ turns once
as α does, and atan2 is ±π, not 0, where the line meets the pitch curve on the far side (the
other root of b = 0, the roller pressed from the wrong side). ``branch_error`` = max(0, −n̂·û)
is zero where the normal points towards the follower (|φ_p| < 90°).

Port ``follower``: d = s(θ) − s(θ_ref) [m]; a compression spring behind the roller (or an
extension spring pulling it) deflects by d from its pre-deflection x₀ at ``reference_angle``.
The generic energy torque τ = (k x + F₀) dd/dθ (base.py, implicit function theorem) is the
torque; the ``force`` model is the hand-derived F·ds/dθ with ds/dθ = e − s tan φ_p (Eq. G5).

Limits, each a row of the NLP at every grid angle and a margin of the re-check:

* pressure angle: −φ_max ≤ φ_p ≤ φ_max (``max_pressure_angle``, classic practice ≤ 30° for a
  translating follower), as the margins φ_max − φ_p and φ_max + φ_p [rad];
* pitch-curve radius of curvature: ρ_p = ρ_c + r ≥ λ r (``min_pitch_curvature_ratio`` λ,
  default 2: the classic rule of thumb keeps the pitch curve's least radius of curvature 2–3
  roller radii). The engine keeps the profile convex, and the parallel curve at distance r
  outside a convex profile is convex and regular, so the roller can neither undercut the cam
  nor touch it twice; what the roller adds is contact stress and sharpness: λ = 2 means
  ρ_c ≥ r (the cam is nowhere sharper than its roller; with 1/ρ_eff = 1/ρ_c + 1/r the Hertz
  line-contact stress stays within √2 of the roller's on a flat). λ = 1 is no limit beyond
  convexity.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from ...citations import Paper, register_paper
from ...physics.profile import profile_function
from ...keys import PART_SIZE, Key, KeyTable
from ..base import Limit, Mechanism, Picture, Quantity, register
from .file_model import roller_follower_port
from .geometry import (contact_point, follower_axes, line_coordinates, pitch_curvature_radius,
                       pitch_point, pressure_angle, velocity_ratio)

TWO_PI = 2 * np.pi
#: Circle-solution sweeps of the closed-form guess of α (exact for a circle after one).
GUESS_SWEEPS = 4
#: Sweeps α ← α − R1(α) after them, for a non-circular profile (R1 changes by about 1 per
#: radian of α, so each sweep is nearly a Newton step).
CORRECTION_SWEEPS = 4
#: Default largest pressure angle [rad]: 30°, classic practice for translating followers.
MAX_PRESSURE_ANGLE = np.pi / 6
#: Default least ratio of the pitch curve's radius of curvature to the roller radius.
PITCH_CURVATURE_RATIO = 2.0
#: Polar angle [rad] left before the earliest possible contact by the default ``axis_angle``.
LEAD = 0.1
#: Length of the follower stem drawn beyond the roller centre, in roller radii.
STEM_RADII = 4.0
#: The source of the mechanism's equations, registered under this tag.
SOURCE = register_paper("Norton2009", Paper(
    "R. L. Norton", 2009, "Cam design and manufacturing handbook (2nd edition)",
    "Industrial Press, New York", None))


#: Its own keys of a ``[[mechanisms]]`` table.
SPEC_KEYS = KeyTable('kind = "roller_follower"', "A radial cam turning with its joint and a translating roller follower pressed on it by a spring (port \"follower\"): the roller (radius roller_radius) touches the profile; its centre slides on the line of world direction follower_angle at offset from the axis; the cam's polar axis lies at world angle axis_angle at θ = 0.", (
    Key("roller_radius", "m", "the roller's radius r", low=0, open_low=True, plausible=PART_SIZE),
    Key("follower_angle", "rad", "the world direction β of the follower's travel, away from the cam (π/2: vertical)",
        default=np.pi / 2),
    Key("offset", "m", "the follower line's offset e from the joint axis", default=0.0, plausible=PART_SIZE),
    Key("max_pressure_angle", "rad", "the largest pressure angle φ_max (0.5236: 30°)", low=0, high=np.pi / 2,
        open_low=True, open_high=True, default=MAX_PRESSURE_ANGLE),
    Key("min_pitch_curvature_ratio", "-", "the pitch curve's least radius of curvature in roller radii (1: "
        "convexity only; 2–3 usual)", low=1, default=PITCH_CURVATURE_RATIO),
    Key("reference_angle", "rad", "the joint angle at which the spring has its pre-deflection", default=None,
        default_text="the range's first angle"),
    Key("initial_radius", "m", "the radius of the NLP's circular start, inside (rho_min, rho_max)", low=0,
        open_low=True, default=0.0, default_text="mid-range of ρ", plausible=PART_SIZE),
    Key("axis_angle", "rad", "the world angle γ₀ of the cam's polar axis at θ = 0", default=None,
        default_text="the contact starts a little after φ = 0"),
))


@register
@dataclass(frozen=True)
class RollerFollower(Mechanism):
    """A radial cam with a translating roller follower and a spring on the follower.

    Fields (SI): ``roller_radius`` r [m]; ``follower_angle`` β [rad] the world direction of
    the follower's travel, away from the cam (π/2: vertical, above the cam); ``offset`` e [m]
    of its line from the joint axis, along v̂ = (−sin β, cos β); ``axis_angle`` γ₀ [rad] the
    world angle of the cam's polar axis at θ = 0; ``max_pressure_angle`` φ_max [rad];
    ``min_pitch_curvature_ratio`` λ [-] (ρ_p ≥ λ r); ``reference_angle`` [rad] the joint angle
    at which the port is zero; ``initial_radius`` [m] the circular start's radius (0:
    mid-range of ρ).
    """

    roller_radius: float = 0.0
    follower_angle: float = np.pi / 2
    offset: float = 0.0
    axis_angle: float = 0.0
    max_pressure_angle: float = MAX_PRESSURE_ANGLE
    min_pitch_curvature_ratio: float = PITCH_CURVATURE_RATIO
    reference_angle: float = 0.0
    initial_radius: float = 0.0

    kind = "roller_follower"
    citation = SOURCE
    picture = Picture(title="cam and follower", wound="", free="follower stem", contact="contact point",
                      anchor="profile start (φ = 0)", circle="roller (+ centre)", arc="designed arc",
                      runs_on="the roller touches the red arc only")
    spec_keys = SPEC_KEYS
    ports = ("follower",)
    parameters = (Quantity("roller_radius", "m", "the roller's radius r (Eq. G3)"),
                  Quantity("follower_angle", "rad", "the follower's direction of travel β (world)"),
                  Quantity("offset", "m", "the follower line's offset e from the joint axis, along v̂",
                           placed="length"),
                  Quantity("axis_angle", "rad", "the world angle γ₀ of the cam's polar axis at θ = 0"),
                  Quantity("max_pressure_angle", "rad", "the largest pressure angle φ_max (Eq. G4)"),
                  Quantity("reference_angle", "rad", "the joint angle where the port is zero"),
                  Quantity("min_pitch_curvature_radius", "m",
                           "the least radius of curvature λr of the pitch curve (Eq. G6)"))
    per_angle = (Quantity("alpha", "rad", "the contact's polar angle α on the profile"),
                 Quantity("s", "m", "the roller centre's position along the follower's line"))
    residual_rows = (Quantity("on_line", "rad", "the roller centre on the follower's line, on its side (R1)"),
                     Quantity("position", "m", "s is the roller centre's position (R2)"))
    unknown_bounds = ((0.0, TWO_PI), (-np.inf, np.inf))  # the contact on the designed turn
    force_models = ("force",)
    limits = (Limit("pressure_angle_max", "pressure angle", "max_pressure_angle", sense=-1, unit="rad"),
              Limit("pressure_angle_min", "pressure angle", "min_pressure_angle", sense=+1, unit="rad"),
              Limit("pitch_curvature_radius", "pitch-curve radius of curvature",
                    "min_pitch_curvature_radius"))

    # -- derived numbers -------------------------------------------------------------------------
    @property
    def min_pressure_angle(self) -> float:
        """−φ_max [rad]: the lower limit of the signed pressure angle."""
        return -float(self.max_pressure_angle)

    @property
    def min_pitch_curvature_radius(self) -> float:
        """λ r [m]: the least radius of curvature of the pitch curve at the contact."""
        return float(self.min_pitch_curvature_ratio * self.roller_radius)

    @classmethod
    def summary_lines(cls, evaluation) -> list[str]:
        """Per roller follower: its largest |pressure angle| and the pitch curve's least radius
        of curvature at the contact on the re-check grid, against their limits."""
        lines = []
        for mech, unit in zip(evaluation.problem.mechanisms, evaluation.units):
            if isinstance(mech, cls):
                m = dict(zip(cls.margin_names, unit.margins))
                least = min(m["pressure_angle_max"].min(), m["pressure_angle_min"].min())
                peak = mech.max_pressure_angle - least  # max |φ_p|
                rho_p = mech.min_pitch_curvature_radius + m["pitch_curvature_radius"].min()
                lines.append(f"  {mech.name}: pressure angle up to {np.degrees(peak):.3g}° (limit "
                             f"{np.degrees(mech.max_pressure_angle):.3g}°), pitch-curve radius of curvature "
                             f"down to {1e3 * rho_p:.3g} mm (limit "
                             f"{1e3 * mech.min_pitch_curvature_radius:.3g} mm) on the re-check grid")
        return lines

    # -- the symbolic model --------------------------------------------------------------------
    @classmethod
    def _pose(cls, bases, theta, alpha, c, q):
        """ρ, ρ′, ρ″ and the convexity margin at α, the world point p, normal n̂ and the roller
        centre C (Eq. G1–G3)."""
        p = cls.named_parameters(q)
        rho, drho, ddrho, conv = profile_function(bases[0])(alpha, c)
        point, n, _ = contact_point(theta, alpha, rho, drho, p.axis_angle)
        return (rho, drho, ddrho, conv), point, n, pitch_point(point, n, p.roller_radius)

    @classmethod
    def residual(cls, bases, theta, z, c, q):
        """(R1, R2) of the module docstring and branch_error = max(0, −n̂·û)."""
        u, p = cls.named_unknowns(z), cls.named_parameters(q)
        _, _, n, C = cls._pose(bases, theta, u.alpha, c, q)
        a, b = line_coordinates(C, p.follower_angle, p.offset)
        (ux, uy), _ = follower_axes(p.follower_angle)
        return ca.vertcat(ca.atan2(b, a), a - u.s), ca.fmax(0, -(n[0] * ux + n[1] * uy))

    @classmethod
    def guess(cls, bases, theta, c, q):
        """The circle solution, then corrections; exact for a circle ρ about the axis.

        A circle: the roller centre is on the circle of radius ρ + r, so on the line
        s = √((ρ + r)² − e²), and the contact lies on the radius through it, at world angle
        β + atan2(e, s), i.e. α = θ + β − γ₀ + atan2(e, s). That is iterated with ρ = ρ(α)
        (:data:`GUESS_SWEEPS`), then α ← α − R1(α) (:data:`CORRECTION_SWEEPS`: R1 vanishes on
        a circle, so they keep its exact α), and s = C(α)·û from R2.
        """
        prof = profile_function(bases[0])
        p = cls.named_parameters(q)
        r, beta, e = p.roller_radius, p.follower_angle, p.offset
        ahead = theta + beta - p.axis_angle  # the polar angle facing the follower
        alpha = ahead
        for _ in range(GUESS_SWEEPS):
            s = ca.sqrt(ca.fmax((prof(alpha, c)[0] + r) ** 2 - e**2, 0))
            alpha = ahead + ca.atan2(e, s)
        for _ in range(CORRECTION_SWEEPS):
            a, b = line_coordinates(cls._pose(bases, theta, alpha, c, q)[3], beta, e)
            alpha = alpha - ca.atan2(b, a)
        return ca.vertcat(alpha, line_coordinates(cls._pose(bases, theta, alpha, c, q)[3], beta, e)[0])

    @classmethod
    def displacements(cls, bases, theta, z, z_ref, wrapped, c, q):
        """d = s(θ) − s(θ_ref) [m]: the follower's travel from the reference pose."""
        return cls.named_unknowns(z).s - cls.named_unknowns(z_ref).s

    @classmethod
    def force_arms(cls, bases, model, theta, z, c, q, order, integrals):
        """ds/dθ = e − s tan φ_p [m/rad] (Eq. G5): τ = F ds/dθ by virtual work."""
        u, p = cls.named_unknowns(z), cls.named_parameters(q)
        n = cls._pose(bases, theta, u.alpha, c, q)[2]
        return velocity_ratio(n, u.s, p.follower_angle, p.offset)

    @classmethod
    def margins(cls, bases, theta, z, c, q, arm):
        """φ_max − φ_p and φ_max + φ_p [rad], ρ_p − λ r [m] (Eq. G4, G6), ≥ 0 when met."""
        p = cls.named_parameters(q)
        (rho, drho, _, conv), _, n, _ = cls._pose(bases, theta, cls.named_unknowns(z).alpha, c, q)
        phi = pressure_angle(n, p.follower_angle)
        rho_p = pitch_curvature_radius(rho, drho, conv, p.roller_radius)
        return ca.vertcat(p.max_pressure_angle - phi, p.max_pressure_angle + phi,
                          rho_p - p.min_pitch_curvature_radius)

    @classmethod
    def wrap_end(cls, first, last, q):
        """The contact angle at the range's end: α = β − γ₀ + θ + δ(θ) grows with θ (δ, the
        contact's angle from β, changes far more slowly than θ), so convexity and ρ limits
        hold over [0, α(θ_max)], which covers every contact."""
        return last

    @classmethod
    def profile_domain(cls, theta_range) -> tuple[float, float]:
        """(0, θ_max − θ_min + π/2): the contact angles run over the joint's span from just
        after φ = 0 (the default ``axis_angle``), spread by :func:`contact_spread` either way;
        :meth:`from_spec` checks that they stay inside. A tight interval keeps a Chebyshev
        basis well conditioned over the arc the roller touches (on (0, span + π), order 9
        did not converge on the shipped pendulum)."""
        return (0.0, float(theta_range[1] - theta_range[0]) + np.pi / 2)

    # -- drawing -------------------------------------------------------------------------------
    def world_points(self, theta, phi, rho, k: int = 0):
        """World coordinates [m] of profile points (φ, ρ) at joint angle θ: world angle
        φ + γ₀ − θ."""
        ang = np.asarray(phi) + self.axis_angle - theta
        return rho * np.cos(ang), rho * np.sin(ang)

    def roller_centre(self, z) -> np.ndarray:
        """World position [m] of the roller centre C = e v̂ + s û at unknowns ``z``."""
        b = self.follower_angle
        u, v = np.array([np.cos(b), np.sin(b)]), np.array([-np.sin(b), np.cos(b)])
        return float(self.named_unknowns(z).s) * u + self.offset * v

    def circles(self, theta, z, c):
        """The roller at the pose."""
        return [(self.roller_centre(z), float(self.roller_radius))]

    def segments(self, theta, z, c):
        """The follower stem, from the roller centre outward along its line."""
        C = self.roller_centre(z)
        b = self.follower_angle
        return [(C, C + STEM_RADII * self.roller_radius * np.array([np.cos(b), np.sin(b)]))]

    def start_radius(self, profile):
        """``initial_radius`` if given, else mid-range of ρ."""
        r = self.initial_radius or 0.5 * (profile.rho_min + profile.rho_max)
        return max(r, profile.rho_min * (1 + 1e-3))

    # -- spec ------------------------------------------------------------------------------------
    @classmethod
    def from_spec(cls, reader, name, joint, profiles, theta_range=(0.0, 0.0)):
        """Its keys (:data:`SPEC_KEYS`), then the checks of :func:`_placed`."""
        keys, p = SPEC_KEYS, profiles[0]
        mech = cls(
            name=name, joint=joint, profiles=profiles,
            **{k: float(reader.read(keys[k])) for k in ("roller_radius", "follower_angle", "offset",
                                                         "max_pressure_angle", "min_pitch_curvature_ratio")},
            reference_angle=float(reader.read(keys["reference_angle"], theta_range[0])),
            initial_radius=float(reader.read(keys["initial_radius"].within(
                low=p.rho_min, high=p.rho_max, open_high=True))))
        axis = reader.read(keys["axis_angle"])
        return _placed(reader, mech, theta_range, axis)

    def spec_fields(self) -> dict:
        return {"roller_radius": self.roller_radius, "follower_angle": self.follower_angle,
                "offset": self.offset, "axis_angle": self.axis_angle,
                "max_pressure_angle": self.max_pressure_angle,
                "min_pitch_curvature_ratio": self.min_pitch_curvature_ratio,
                "reference_angle": self.reference_angle,
                **({"initial_radius": self.initial_radius} if self.initial_radius else {})}

    def port_length_from_file(self, outlines, port, theta):
        """The roller pressed onto the outline along its stem
        (:func:`.file_model.roller_follower_port`); it carries no cable."""
        return roller_follower_port(outlines[0], self, theta)


def contact_spread(mech: RollerFollower) -> float:
    """The most the contact's world angle can differ from the follower direction β [rad] on
    a profile with ρ ≥ ρ_min and |φ_p| ≤ φ_max: the contact p = C − r n̂ has
    p·v̂ = e − r sin φ_p and |p| ≥ ρ_min, so |sin δ| ≤ (|e| + r sin φ_max)/ρ_min (inf if
    that reaches 1)."""
    reach = ((abs(mech.offset) + mech.roller_radius * np.sin(mech.max_pressure_angle))
             / mech.profiles[0].rho_min)
    return float(np.arcsin(reach)) if reach < 1 else np.inf


def _placed(reader, mech: RollerFollower, theta_range, axis) -> RollerFollower:
    """``mech`` with its ``axis_angle``: ``axis`` moved by whole turns (default: the contact
    starts :data:`LEAD` after φ = 0), so that the contact angles α ∈ β − γ₀ + θ ± δ
    (δ = :func:`contact_spread`, θ over the joint range and the reference angle) lie inside
    (0, min(2π, the basis's domain)); one-line SpecErrors where the offset leaves the
    follower's line off the cam, or no γ₀ holds them."""
    delta = contact_spread(mech)
    if not np.isfinite(delta):
        reader.fail(reader.key("offset"), mech.offset, f"an offset with |offset| + roller_radius·"
                    f"sin(max_pressure_angle) below rho_min = {mech.profiles[0].rho_min} [m] "
                    "(the follower's line must cross the cam)")
    lo, hi = min(theta_range[0], mech.reference_angle), max(theta_range[1], mech.reference_angle)
    start = mech.follower_angle + lo - delta  # α + γ₀ at the earliest contact
    gamma = start - LEAD if axis is None else float(axis)
    gamma += TWO_PI * np.floor((start - gamma) / TWO_PI)  # whole turns: α ≥ 0 at the earliest
    end = mech.follower_angle + hi + delta - gamma
    top = min(TWO_PI, mech.profile_domain(theta_range)[1])
    if not end < top:
        where = reader.key("axis_angle") if axis is not None else reader.key("follower_angle")
        reader.fail(where, axis if axis is not None else mech.follower_angle,
                    f"a placement whose contact angles follower_angle − axis_angle + theta ± {delta:.3g} "
                    f"rad stay inside (0, {top:.4g}) rad of the profile (they reach {end:.4g}; omit "
                    "axis_angle for the default, or narrow the joint range, the reference angle "
                    "or the offset)")
    return replace(mech, axis_angle=float(gamma))

