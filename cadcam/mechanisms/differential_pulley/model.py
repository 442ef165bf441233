"""The differential pair of noncircular pulleys (Fedorov2018): two profiles on one shaft and
one cable of constant length that winds on one while it unwinds from the other, over an idler
of radius q whose centre P rides a straight slider through the shaft axis.

The cable runs from its anchor on profile 1, wound on it, tangentially to the idler, around
it, and back tangentially to profile 2, wound on that one to its anchor (Fedorov2018 Fig. 4;
each half is the single pulley of Fig. 1, Eq. 1–11). Both profiles turn with the joint by
``sense``·θ; the slider's line leaves the shaft at world angle ``slider_angle``; the idler
centre sits at distance x from the shaft along it, x being the pair's output.

Canonical frames. Profile k is anchored at φ = 0, which lies at world angle ``anchor_angles[k]``
when θ = 0, and its cable is wound from there in the direction w_k: profile 1 in ``winding``,
profile 2 the other way (w₂ = −w₁; Fig. 4's serial routing). In profile k's own frame,
mirrored when w_k = −1, the cable is wound counter-clockwise and the idler centre sits at
P_k = x (cos χ_k, sin χ_k), χ_k = χ₀ₖ + σ_k θ with χ₀ₖ = w_k (slider_angle − anchor_angle_k)
and σ_k = −w_k·sense: as σ_k θ grows the cable winds on profile k. Since σ₂ = −σ₁, one profile
winds while the other unwinds.

Unknowns z = (α₁, α₂, x): the departure angles and the idler's distance. Residuals:

- tangency on each profile: the cable leaves p(α_k) along the tangent t and touches the idler
  with the idler on its left, so the angle from t to P − p is asin(q/|P − p|) (Fedorov2018
  Eq. 4a–5 in angle form; for q = 0 the anchored pulley's residual);
- constant cable length (Fedorov2018 Eq. 6a–6c for both halves): the wound lengths
  W_k(α_k) = ∫₀^α_k √(ρ² + ρ′²) dφ, the free spans √(|P − p|² − q²) and the idler arc q·ω sum
  to ``cable_length``, where ω = π + χ₀₁ + χ₀₂ − ∠t₁ − ∠t₂ (wrapped to (0, 2π)) is the angle
  the cable turns on the idler (∠t_k the tangent's angle in frame k).

Port ``slider``: x(θ) − x(θ_ref) [m]; a spring on the slider stores energy, and the energy
torque is its derivative through x(θ) by the implicit function theorem (Fedorov2018 Eq. 12,
16). dx/dθ is Fedorov2018 Eq. 11 summed over both halves; the tests check that.

``groove = "flat"``: each wrap stays under one turn (0 ≤ α_k ≤ 2π: the cable does not run over
its own anchor). ``"helical"``: the groove is a spiral that climbs the drum's axis, one planar
turn after another, so α_k may exceed 2π (the planar model neglects the groove's pitch;
Fedorov2018 Sec. 4.1 names that as an error source at high rotation angles).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import casadi as ca
import numpy as np

from ...physics.profile import profile_function
from ...keys import PART_SIZE, REACH, Key, KeyTable
from ..base import DesignMethod, Limit, Mechanism, Quantity, register, split_coefficients
from .file_model import differential_output, differential_spans
from .robot_path import robot_path
from .starts import envelope_start

WINDING = {"ccw": 1.0, "cw": -1.0}
GROOVES = ("flat", "helical")

#: Its own keys of a ``[[mechanisms]]`` table.
SPEC_KEYS = KeyTable('kind = "differential_pulley"', "Fedorov2018's differential pair: two profiles (design.cams k and k + 1, both of this basis and these limits) on one shaft and one cable of constant length over an idler whose centre rides a slider. A third party recomputes x(θ) from the two outlines and these fields: at joint angle θ turn both outlines by sense·θ about the shaft (the origin); profile 1's point at polar angle φ lies at world angle anchor_angles[0] + w₁φ (w₁ = +1 for winding \"ccw\", −1 for \"cw\"), profile 2's at anchor_angles[1] − w₁φ; the idler (radius idler_radius) is centred at x·(cos slider_angle, sin slider_angle); the cable leaves each outline tangentially, touching the idler with the idler on its left as seen in that profile's winding frame; x is where the cable length — both wound lengths from the anchors (φ = 0), both free spans and the arc on the idler — equals cable_length.", (
    Key("sense", "", "the shaft turns by sense·θ, counter-clockwise positive", "choice", choices=(1, -1), default=1),
    Key("winding", "", "profile 1's winding from its anchor (profile 2 is wound the other way)", "choice",
        choices=tuple(WINDING), default="ccw"),
    Key("groove", "", "'flat': each wrap under one turn; 'helical': a spiral groove, wraps beyond one turn "
        "(planar per turn)", "choice", choices=GROOVES, default="flat"),
    Key("idler_radius", "m", "the idler's radius q (0: a point)", low=0, default=0.0, plausible=PART_SIZE),
    Key("slider_range", "m", "[x_min, x_max]: the slider's travel from the shaft axis, 0 < x_min < x_max, x_min > "
        "rho_max + idler_radius (the idler clears both pulleys)", "numbers", length=2, low=0, open_low=True,
        check=lambda v: v[0] < v[1], words="x_min < x_max", plausible=PART_SIZE),
    Key("slider_angle", "rad", "the world angle of the slider's line from the shaft", default=0.0),
    Key("reference_angle", "rad", "the joint angle at which the slider port is zero", default=None,
        default_text="the range's first angle"),
    Key("min_free_span", "m", "the shortest straight cable between a pulley and the idler", low=0, default=0.0,
        plausible=PART_SIZE),
    Key("rolling_radius", "m", "the cable transferred per radian by the start design", low=0, open_low=True,
        default=0.0, default_text="mid-range of ρ", plausible=PART_SIZE),
    Key("anchor_angles", "rad", "[a1, a2]: the world angles of both anchors (φ = 0) at θ = 0", "numbers", length=2,
        default=None, default_text="set by the start design"),
    Key("cable_length", "m", "the cable's length from anchor to anchor", low=0, open_low=True, default=None,
        default_text="set by the start design", plausible=REACH),
))
#: Sweeps of the closed-form guess of α at a fixed x (exact for a circle after one).
GUESS_SWEEPS = 6


def _pose(theta, alpha, rho, drho, x, chi0, sigma):
    """Frame-k departure point p(α), tangent t = dp/dφ and u = P_k − p [m] from the profile's
    ρ and ρ′ at α."""
    ca_, sa = ca.cos(alpha), ca.sin(alpha)
    px, py = rho * ca_, rho * sa
    tx, ty = drho * ca_ - rho * sa, drho * sa + rho * ca_  # dp/dφ (Johnston2023 Eq. 3)
    chi = chi0 + sigma * theta
    return (px, py), (tx, ty), (x * ca.cos(chi) - px, x * ca.sin(chi) - py)


@register
@dataclass(frozen=True)
class DifferentialPulley(Mechanism):
    """Two noncircular pulleys on one shaft, one cable over an idler on a slider.

    Fields (SI): ``slider_angle`` [rad] the world direction of the slider's line from the
    shaft; ``idler_radius`` q [m]; ``sense`` (±1) the shaft turns by sense·θ; ``winding``
    ("ccw"/"cw") of profile 1 from its anchor (profile 2 the other way); ``anchor_angles``
    [rad] the world angles of both anchors (φ = 0) at θ = 0; ``cable_length`` [m] from anchor
    to anchor; ``reference_angle`` [rad] where the slider port is zero; ``slider_range`` [m]
    (x_min, x_max) the slider's travel; ``min_free_span`` [m] the shortest straight cable
    between a pulley and the idler; ``groove`` "flat" or "helical"; ``output_target`` the
    law x(θ) [m] the NLP tracks (a :class:`cadcam.targets.Target`, or None); ``rolling_radius``
    [m] the cable transferred per radian between the profiles by the start design.
    """

    slider_angle: float = 0.0
    idler_radius: float = 0.0
    sense: float = 1.0
    winding: str = "ccw"
    anchor_angles: tuple[float, float] = (0.0, 0.0)
    cable_length: float = 0.0
    reference_angle: float = 0.0
    slider_range: tuple[float, float] = (0.0, np.inf)
    min_free_span: float = 0.0
    groove: str = "flat"
    output_target: object = None
    rolling_radius: float = 0.0

    kind = "differential_pulley"
    citation = "Fedorov2018"
    spec_keys = SPEC_KEYS
    n_profiles: ClassVar[int] = 2
    closure_rows: ClassVar[int] = 1
    ports = ("slider",)
    per_angle = (Quantity("alpha1", "rad", "the departure angle α₁ on profile 1"),
                 Quantity("alpha2", "rad", "the departure angle α₂ on profile 2"),
                 Quantity("x", "m", "the idler centre's distance from the shaft (the output)"),
                 Quantity("rho1", "m", "ρ₁(α₁), lifted"), Quantity("drho1", "m/rad", "ρ₁′(α₁), lifted"),
                 Quantity("rho2", "m", "ρ₂(α₂), lifted"), Quantity("drho2", "m/rad", "ρ₂′(α₂), lifted"))
    output = "x"
    residual_rows = (Quantity("tangency1", "rad", "the cable tangent to profile 1 and the idler (Eq. 4a–5)"),
                     Quantity("tangency2", "rad", "the cable tangent to profile 2 and the idler (Eq. 4a–5)"),
                     Quantity("lift_rho1", "m", "ρ₁ at α₁"), Quantity("lift_drho1", "m", "ρ₁′ at α₁"),
                     Quantity("lift_rho2", "m", "ρ₂ at α₂"), Quantity("lift_drho2", "m", "ρ₂′ at α₂"),
                     Quantity("cable_length", "m", "the cable keeps its length (Eq. 6a–6c)"))
    parameters = (Quantity("chi0_1", "rad", "χ₀₁: the idler's angle in profile 1's frame at θ = 0"),
                  Quantity("chi0_2", "rad", "χ₀₂: the idler's angle in profile 2's frame at θ = 0"),
                  Quantity("sigma_1", "-", "σ₁ = ±1: the idler turns by σ₁θ around profile 1"),
                  Quantity("sigma_2", "-", "σ₂ = −σ₁"),
                  Quantity("idler_radius", "m", "the idler's radius q"),
                  Quantity("cable_length", "m", "the cable's length from anchor to anchor"),
                  Quantity("theta_ref", "rad", "the joint angle where the slider port is zero"),
                  Quantity("slider_min", "m", "the slider's least distance"),
                  Quantity("slider_max", "m", "the slider's greatest distance (1 km for none)"),
                  Quantity("min_free_span", "m", "the shortest free cable allowed"),
                  Quantity("wrap_max", "rad", "the largest wrap: 2π for a flat groove"),
                  Quantity("slider_start", "m", "the idler's distance in the closed-form guess"))
    methods = (DesignMethod("envelope", "Fedorov2018 envelope synthesis (no NLP)",
                            "differential pairs for their output laws only",
                            'kind = "differential_pulley" and a [mechanisms.output_target]'),)
    limits = (Limit("free_span_1", "free cable span", "min_free_span", profile=1),
              Limit("free_span_2", "free cable span", "min_free_span", profile=2),
              Limit("slider_min", "idler position", "slider_range[0]"),
              Limit("slider_max", "idler position", "slider_range[1]", sense=-1))

    # -- derived numbers -------------------------------------------------------------------------
    @property
    def windings(self) -> tuple[float, float]:
        """w₁, w₂ = ±1: each profile's winding direction from its anchor (w₂ = −w₁)."""
        w = WINDING[self.winding]
        return w, -w

    @property
    def sigmas(self) -> tuple[float, float]:
        """σ_k = −w_k·sense: the idler turns by σ_k θ around profile k in its frame."""
        return tuple(-w * self.sense for w in self.windings)

    @property
    def unknown_bounds(self):
        """0 ≤ α_k (the cable never unwinds past its anchor) and, for a flat groove, α_k ≤ 2π."""
        hi = 2 * np.pi if self.groove == "flat" else np.inf
        return ((0.0, hi), (0.0, hi), (0.0, np.inf)) + ((-np.inf, np.inf),) * 4

    def chi0(self) -> tuple[float, float]:
        """χ₀ₖ = w_k (slider_angle − anchor_angle_k) [rad]."""
        return tuple(w * (self.slider_angle - a) for w, a in zip(self.windings, self.anchor_angles))

    def parameter_values(self) -> tuple[float, ...]:
        lo, hi = self.slider_range
        return (*self.chi0(), *self.sigmas, float(self.idler_radius), float(self.cable_length),
                float(self.reference_angle), float(lo), float(min(hi, 1e3)),
                float(self.min_free_span), 2 * np.pi if self.groove == "flat" else 1e3,
                float(self.slider_start()))

    def slider_start(self) -> float:
        """The idler's distance at the reference angle for the closed-form guess [m]: the
        output target's value there, else mid-travel."""
        if self.output_target is not None:
            return float(self.output_target.function(1, 0)(self.reference_angle))
        lo, hi = self.slider_range
        return 0.5 * (lo + hi) if np.isfinite(hi) else 2 * lo

    def max_span(self) -> float:
        """One turn on a flat groove; a helical groove climbs the drum turn after turn."""
        return np.inf if self.groove == "helical" else super().max_span()

    def offers(self, method: str) -> bool:
        """The envelope method shapes a pair for its output law: only with one."""
        return super().offers(method) and self.output_target is not None

    @classmethod
    def prepare_start(cls, problem, design):
        """Fedorov's envelope pulleys for every pair without a cable length
        (:func:`.starts.envelope_start`), which also sets it."""
        return envelope_start(cls, problem, design)

    @classmethod
    def summary_lines(cls, evaluation) -> list[str]:
        """A cable robot's end-effector deviation from its path (:func:`.robot_path.robot_path`)."""
        path = robot_path(evaluation)
        if path is None:
            return []
        return [f"  cable robot: the end effector deviates from its path by {1e3 * path.error.mean():.3g} mm "
                f"on average, {1e3 * path.error.max():.3g} mm at most (re-check grid)"]

    # -- the symbolic model --------------------------------------------------------------------
    @classmethod
    def _profile_unknowns(cls, z, k: int):
        """(α_k, ρ_k, ρ′_k) of profile k (0-based) among the unknowns."""
        u = cls.named_unknowns(z)
        return getattr(u, f"alpha{k + 1}"), getattr(u, f"rho{k + 1}"), getattr(u, f"drho{k + 1}")

    @classmethod
    def _frame(cls, q, k: int):
        """(χ₀ₖ, σ_k) of profile k (0-based)."""
        p = cls.named_parameters(q)
        return getattr(p, f"chi0_{k + 1}"), getattr(p, f"sigma_{k + 1}")

    @classmethod
    def _halves(cls, theta, z, q):
        """Per profile: (p, t, u) in its frame, from the unknowns α_k, x, ρ_k and ρ′_k."""
        x = cls.named_unknowns(z).x
        return [_pose(theta, *cls._profile_unknowns(z, k), x, *cls._frame(q, k)) for k in range(2)]

    @classmethod
    def _spans(cls, halves, q):
        """√(|P − p|² − q²) of each half [m] (Fedorov2018 Eq. 6b)."""
        r = cls.named_parameters(q).idler_radius
        return [ca.sqrt(ca.fmax(u[0]**2 + u[1]**2 - r**2, 0)) for _, _, u in halves]

    @classmethod
    def free_spans(cls, bases, theta, z, c, q):
        """The straight cable between each profile and the idler [m] (Fedorov2018 Eq. 6b)."""
        return cls._spans(cls._halves(theta, z, q), q)

    @classmethod
    def _idler_wrap(cls, halves, q):
        """ω: the angle the cable turns on the idler [rad], in (0, 2π) (Fedorov2018 Eq. 6c for
        both halves)."""
        (_, t1, _), (_, t2, _) = halves
        p = cls.named_parameters(q)
        delta = p.chi0_1 + p.chi0_2 - ca.atan2(t1[1], t1[0]) - ca.atan2(t2[1], t2[0])
        return ca.pi + ca.atan2(ca.sin(delta), ca.cos(delta))

    @classmethod
    def cable_path(cls, bases, theta, z, wound, c, q):
        """The cable length from anchor to anchor at the pose [m]: both wound lengths
        ``wound``, both free spans and the idler arc (Fedorov2018 Eq. 6a–6c)."""
        halves = cls._halves(theta, z, q)
        r = cls.named_parameters(q).idler_radius
        return wound[0] + wound[1] + sum(cls._spans(halves, q)) + r * cls._idler_wrap(halves, q)

    @classmethod
    def residual(cls, bases, theta, z, c, q):
        """Tangency on both profiles (the angle from t to P − p minus asin(q/|P − p|)), and
        ρ_k, ρ′_k at α_k: lifted into unknowns so that the tangency and length rows see the
        coefficients only through them (a small Hessian in the NLP)."""
        p = cls.named_parameters(q)
        rows, lifted, branch = [], [], 0
        for k, (_, (tx, ty), (ux, uy)) in enumerate(cls._halves(theta, z, q)):
            alpha = cls._profile_unknowns(z, k)[0]
            dist = ca.sqrt(ux**2 + uy**2)
            rows.append(ca.atan2(tx * uy - ty * ux, tx * ux + ty * uy) - ca.asin(ca.fmin(p.idler_radius / dist, 1)))
            cosine = (tx * ux + ty * uy) / (ca.sqrt(tx**2 + ty**2) * dist)
            branch = (branch + ca.fmax(0, -cosine) + ca.fmax(0, -alpha) + ca.fmax(0, alpha - p.wrap_max)
                      + ca.fmax(0, p.idler_radius - dist))
        for k, (b, ck) in enumerate(zip(bases, split_coefficients(bases, c))):
            alpha, rho_k, drho_k = cls._profile_unknowns(z, k)
            rho, drho, _, _ = profile_function(b)(alpha, ck)
            lifted += [rho_k - rho, drho_k - drho]
        return ca.vertcat(*rows, *lifted), branch + ca.fmax(0, -cls.named_unknowns(z).x)

    @classmethod
    def closure(cls, bases, theta, z, wound, c, q):
        """The cable keeps its length (Fedorov2018 Sec. 2.2, mode 2: constant l) [m]."""
        return cls.cable_path(bases, theta, z, wound, c, q) - cls.named_parameters(q).cable_length

    @classmethod
    def guess(cls, bases, theta, c, q):
        """x at its start value; each α by the tangent from the idler to the profile's pedal
        curve at that x (as the anchored pulley's guess, with the idler's radius: the tangent
        line at α lies at h = ρ²/√(ρ² + ρ′²) from the shaft and at q from the idler's centre on
        the shaft's side, so its normal makes acos((h − q)/x) with the idler's direction χ):
        exact for circles. χ = χ₀ + σθ is not reduced modulo 2π: χ₀ fixes the turn."""
        p = cls.named_parameters(q)
        x = p.slider_start
        alphas = []
        for k, (b, ck) in enumerate(zip(bases, split_coefficients(bases, c))):
            prof = profile_function(b)
            chi0, sigma = cls._frame(q, k)
            chi = chi0 + sigma * theta
            alpha = chi - ca.pi / 2
            for _ in range(GUESS_SWEEPS):
                rho, drho, _, _ = prof(alpha, ck)
                h = rho**2 / ca.sqrt(rho**2 + drho**2)
                alpha = chi - ca.acos(ca.fmin((h - p.idler_radius) / x, 1)) + ca.atan2(drho, rho)
            alphas.append(alpha)
        values = []
        for alpha, b, ck in zip(alphas, bases, split_coefficients(bases, c)):
            values += list(profile_function(b)(alpha, ck)[:2])
        return ca.vertcat(*alphas, x, *values)

    @classmethod
    def displacements(cls, bases, theta, z, z_ref, wrapped, c, q):
        return cls.named_unknowns(z).x - cls.named_unknowns(z_ref).x

    @classmethod
    def moment_arms(cls, bases, theta, z, c, q):
        """r sin α_F of each half: the distance from the shaft to its cable line [m]
        (Fedorov2018 Eq. 8), signed by σ_k."""
        return [cls._frame(q, k)[1] * (px * ty - py * tx) / ca.sqrt(tx**2 + ty**2)
                for k, ((px, py), (tx, ty), _) in enumerate(cls._halves(theta, z, q))]

    @classmethod
    def slider_cosines(cls, bases, theta, z, c, q):
        """cos β of each half: the cosine between the cable at the idler and the slider's line
        (Fedorov2018 Eq. 10: ∂l/∂x)."""
        out = []
        for k, (_, (tx, ty), _) in enumerate(cls._halves(theta, z, q)):
            chi0, sigma = cls._frame(q, k)
            chi = chi0 + sigma * theta
            out.append((tx * ca.cos(chi) + ty * ca.sin(chi)) / ca.sqrt(tx**2 + ty**2))
        return out

    @classmethod
    def margins(cls, bases, theta, z, c, q, arm):
        """Free spans − min_free_span, x − x_min and x_max − x [m], ≥ 0 when met."""
        spans, p, x = cls.free_spans(bases, theta, z, c, q), cls.named_parameters(q), cls.named_unknowns(z).x
        return ca.vertcat(spans[0] - p.min_free_span, spans[1] - p.min_free_span, x - p.slider_min, p.slider_max - x)

    @classmethod
    def wrap_end(cls, first, last, q):
        """The most-wound departure angle of a profile: the larger of the range's ends (each
        profile winds or unwinds monotonically)."""
        return ca.fmax(first, last)

    @classmethod
    def profile_domain(cls, theta_range) -> tuple[float, float]:
        """α runs over about the joint's span from a small wrap at the least-wound pose."""
        return (0.0, theta_range[1] - theta_range[0] + np.pi / 2)

    # -- drawing -------------------------------------------------------------------------------
    def world_points(self, theta, phi, rho, k: int = 0):
        """World coordinates [m] of points (φ, ρ) of profile ``k`` at joint angle θ."""
        ang = self.anchor_angles[k] + self.sense * theta + self.windings[k] * np.asarray(phi)
        return rho * np.cos(ang), rho * np.sin(ang)

    def link_rotation(self, theta):
        """The link is fixed to the shaft, which turns by sense·θ."""
        return self.sense * theta

    def idler_centre(self, x) -> np.ndarray:
        """World position of the idler centre at distance ``x`` [m]."""
        return float(x) * np.array([np.cos(self.slider_angle), np.sin(self.slider_angle)])

    def circles(self, theta, z, c):
        """The idler at its pose."""
        return [(self.idler_centre(self.named_unknowns(z).x), float(self.idler_radius))]

    def spring_line(self, theta, z, c, port, sign):
        """A spring on the slider pulls the idler's centre along the slider's line: it runs
        from the centre away from the way that stretches it (towards the shaft when x growing
        stretches it, outward when ``sign`` = −1), as far as it likes."""
        direction = np.array([np.cos(self.slider_angle), np.sin(self.slider_angle)])
        return self.idler_centre(self.named_unknowns(z).x), -sign * direction, np.inf

    def segments(self, theta, z, c):
        """Both free spans, from each departure point to its tangent point on the idler."""
        out = []
        P = self.idler_centre(self.named_unknowns(z).x)
        for k, (b, ck) in enumerate(zip(self.bases, split_coefficients(self.bases, np.asarray(c)))):
            alpha = self._profile_unknowns(z, k)[0]
            rho = float(profile_function(b)(alpha, ck)[0])
            p = np.array(self.world_points(theta, alpha, rho, k), dtype=float)
            d = P - p
            dist = np.hypot(*d)
            span = np.sqrt(max(dist**2 - self.idler_radius**2, 0.0))
            turn = -self.windings[k] * np.arcsin(min(self.idler_radius / dist, 1.0))
            cs, sn = np.cos(turn), np.sin(turn)
            direction = np.array([cs * d[0] - sn * d[1], sn * d[0] + cs * d[1]]) / dist
            out.append((p, p + span * direction))
        return out

    def start_radius(self, profile):
        """The rolling radius if given, else mid-range of ρ."""
        r = self.rolling_radius or 0.5 * (profile.rho_min + profile.rho_max)
        return max(r, profile.rho_min * (1 + 1e-3))

    # -- spec ------------------------------------------------------------------------------------
    @classmethod
    def from_spec(cls, reader, name, joint, profiles, theta_range=(0.0, 0.0)):
        keys = SPEC_KEYS
        sense, winding, groove, q = (reader.read(keys[k]) for k in ("sense", "winding", "groove", "idler_radius"))
        rng = reader.read(keys["slider_range"])
        if not rng[0] > max(p.rho_max for p in profiles) + q:
            reader.fail(reader.key("slider_range"), rng, keys["slider_range"].form())
        mech = cls(name=name, joint=joint, profiles=profiles, sense=float(sense), winding=winding,
                   groove=groove, idler_radius=float(q), slider_range=(float(rng[0]), float(rng[1])),
                   slider_angle=float(reader.read(keys["slider_angle"])),
                   reference_angle=float(reader.read(keys["reference_angle"], theta_range[0])),
                   min_free_span=float(reader.read(keys["min_free_span"])),
                   rolling_radius=float(reader.read(keys["rolling_radius"])))
        anchors = reader.read(keys["anchor_angles"])
        length = reader.read(keys["cable_length"])
        if anchors is not None:
            mech = replace(mech, anchor_angles=(float(anchors[0]), float(anchors[1])))
        if length is not None:
            mech = replace(mech, cable_length=float(length))
        return mech

    def spec_fields(self) -> dict:
        out = {"slider_angle": self.slider_angle, "idler_radius": self.idler_radius,
               "sense": int(self.sense), "winding": self.winding,
               "anchor_angles": list(self.anchor_angles),
               "reference_angle": self.reference_angle, "slider_range": list(self.slider_range),
               "min_free_span": self.min_free_span, "groove": self.groove}
        if self.rolling_radius:
            out["rolling_radius"] = self.rolling_radius
        if self.cable_length:  # 0: not set yet (.starts.envelope_start sets it)
            out["cable_length"] = self.cable_length
        if self.output_target is not None:
            out["output_target"] = self.output_target.to_dict()
        return out

    def port_length_from_file(self, outlines, port, theta):
        """The slider's port is the output x (:meth:`output_from_file`)."""
        return self.output_from_file(outlines, np.atleast_1d(np.asarray(theta, dtype=float)))

    def output_from_file(self, outlines, theta):
        """The idler distance that gives the cable its length
        (:func:`.file_model.differential_output`)."""
        return differential_output(outlines, self, theta)

    def free_spans_from_file(self, outlines, theta):
        """Both spans from the outlines to the idler at the output x found from the files
        (:func:`.file_model.differential_spans`)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        spans = differential_spans(outlines, self, theta, differential_output(outlines, self, theta))
        return [(point, far) for point, far, _, _ in spans]
