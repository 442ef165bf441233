"""The anchored-spring pulley: a cable anchored on a convex pulley, wound on it, leaving it
tangentially towards the end of a spring in line with it (Ludovico2021 Sec. II after Kim &
Deshpande; Endo2010 Sec. II).

Which body turns with the joint is data:

- ``turning = "pulley"`` (Endo2010 Fig. 2–3): the pulley is fixed to the arm link and turns by
  ``sense``·θ; the spring end (Endo's P₀ at (a, b)) is fixed to the base;
- ``turning = "spring_end"`` (Ludovico2021 Fig. 1): the pulley is fixed to ground; the spring is
  attached to the link at R, at distance L from the joint, and turns by ``sense``·θ.

The cable is anchored on the profile at φ = 0 and wound from there in the direction
``winding`` ("ccw" or "cw", seen in the pulley's own frame); the pulley's polar axis φ = 0 lies
at world angle ``anchor_angle`` when θ = 0. ``spring_end`` = (x, y) is the spring end's world
position at θ = 0 [m]; the spring acts along the cable (zero-radius idler).

Canonical frame. All equations are written in the pulley's frame, mirrored for a clockwise
winding, so that the cable is always wound counter-clockwise (increasing φ). There the spring
end sits at S(θ) = ℓ (cos χ, sin χ) with χ = χ₀ + σθ, where ℓ = |spring_end|, χ₀ = w(ψ₀ − anchor
angle) (ψ₀ the polar angle of ``spring_end``, w = ±1 the winding) and σ = w·s·(−1 if the pulley
turns else +1) (s = ``sense``). As σθ grows, S moves counter-clockwise around the pulley and
winds cable on: the path from the anchor to S, and the spring's extension, grow.

Port ``cable``: the change, from the reference angle θ_ref, of the path length from the anchor
to S, i.e. the wrapped length plus the free span |S − p(α)| (a constant cable length, so the
spring's extension changes by exactly that). Unknown: the departure angle α. Residual: the
signed angle from the profile tangent at α to the cable S − p, atan2(t × u, t · u) — zero only on
the tangent on which the cable leaves in its winding direction.

Force model ``force``: F·r_m, the spring force times the distance from O to the cable line
(Ludovico2021 Eq. 1, Endo2010 Eq. 1–2), the hand-derived form the energy torque is checked
against (by virtual work they agree exactly: dd/dθ = σ r_m).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from ...physics.mapped import direct
from ...physics.profile import profile_function
from ...keys import PART_SIZE, Key, KeyTable
from ..base import DesignMethod, Limit, Mechanism, Quantity, register
from .file_model import anchored_path, anchored_span

#: Fixed-point sweeps of the closed-form guess of α (exact for a circle after one).
GUESS_SWEEPS = 6
#: Default wrap [rad] left on the pulley, at the least-wound pose, between the anchor and the
#: departure point of the circular start (sets the default ``anchor_angle``).
ANCHOR_WRAP = 0.3
TURNING = ("pulley", "spring_end")
WINDING = {"ccw": 1.0, "cw": -1.0}

#: Its own keys of a ``[[mechanisms]]`` table.
SPEC_KEYS = KeyTable('kind = "anchored_pulley"', "Ludovico2021 / Endo2010's pulley: the cable is anchored on the profile at φ = 0 (the outline's point at polar angle anchor_angle, i.e. (ρ(0) cos anchor_angle, ρ(0) sin anchor_angle) in the world frame at θ = 0), wound on it in the direction `winding`, and leaves it tangentially straight to the spring end, the spring acting along the cable; port \"cable\" is the change of the path length anchor → spring end from the joint angle reference_angle. A third party recomputes the torque from the outline and these fields: at joint angle θ, turn the body `turning` by sense·θ about the joint (the origin), find the tangent from the spring end to the outline on the side the cable winds, x = x₀ + (wrapped length + free span)(θ) − (same)(reference_angle), V = ½k x² + F0 x, τ = dV/dθ.", (
    Key("spring_end", "m", "the spring end's world position [x, y] at θ = 0 (Endo2010's (a, b); Ludovico2021's R "
        "at distance L), outside rho_max", "numbers", length=2, plausible=PART_SIZE),
    Key("turning", "", "the body that turns with the joint: 'pulley' (Endo2010: the spring end is fixed) or "
        "'spring_end' (Ludovico2021: the pulley is fixed)", "choice", choices=TURNING),
    Key("sense", "", "the turning body rotates by sense·θ about the joint, counter-clockwise positive", "choice",
        choices=(1, -1), default=1),
    Key("winding", "", "the cable's direction on the pulley from its anchor, seen in the pulley's frame: 'ccw' "
        "(the profile point at polar angle φ is at angle anchor_angle + φ) or 'cw' (at anchor_angle − φ)",
        "choice", choices=tuple(WINDING), default="ccw"),
    Key("initial_radius", "m", "the radius of the NLP's circular start, inside (rho_min, rho_max)", low=0,
        open_low=True, default=0.0, default_text="mid-range of ρ, at most 40 % of the spring end's distance",
        plausible=PART_SIZE),
    Key("reference_angle", "rad", "the joint angle at which the spring's extension is its pre-extension x₀",
        default=None, default_text="the end of the range where the spring is shortest"),
    Key("anchor_angle", "rad", "the world angle of the anchor direction φ = 0 at θ = 0", default=None,
        default_text="the anchor leaves the cable wound at the range's shortest end"),
    Key("min_moment_arm", "m", "the smallest moment arm (the distance from the joint to the cable line)", low=0,
        default=0.0, plausible=PART_SIZE),
    Key("min_free_span", "m", "the shortest straight cable between the pulley and the spring end", low=0,
        default=0.0, plausible=PART_SIZE),
    Key("mount_distance", "m", "a range [least, largest] of the spring end's distance from the joint: the design "
        "places the spring end there (starting from spring_end, which must lie in it) and states where",
        "numbers", length=2, default=None, default_text="none (the spring end is fixed)", plausible=PART_SIZE),
    Key("mount_angle", "rad", "a range [least, largest] of the spring end's world angle at θ = 0: the design "
        "places the spring end there (starting from spring_end, which must lie in it) and states where",
        "numbers", length=2, default=None, default_text="none (the spring end is fixed)"),
))


def _unwrapped_into(angle: float, bounds) -> float:
    """``angle`` [rad] shifted by whole turns into [bounds[0], bounds[1]] where it can be (else
    the shift nearest the range's middle)."""
    middle = 0.5 * (bounds[0] + bounds[1])
    return angle + 2 * np.pi * round((middle - angle) / (2 * np.pi))


def _mount_region(reader, end, rho_max: float) -> tuple[tuple | None, tuple | None]:
    """The spec's ``mount_distance`` and ``mount_angle`` ranges, each (least, largest) holding
    the spring end ``end`` (its start), the distances beyond ``rho_max``; None where not given."""
    keys, out = SPEC_KEYS, []
    here = (float(np.hypot(*end)), float(np.arctan2(end[1], end[0])))
    for name, value in zip(("mount_distance", "mount_angle"), here):
        bounds = reader.read(keys[name])
        if bounds is None:
            out.append(None)
            continue
        lo, hi = float(bounds[0]), float(bounds[1])
        if name == "mount_angle":
            value = _unwrapped_into(value, (lo, hi))
        least = rho_max if name == "mount_distance" else -np.inf
        if not (least < lo <= value <= hi):
            reader.fail(reader.key(name), bounds, f"[least, largest] with least ≤ the spring end's own "
                        f"{'distance' if name == 'mount_distance' else 'angle'} ({value:.6g}) ≤ largest"
                        + (f", least above rho_max = {rho_max:g} m" if name == "mount_distance" else ""))
        out.append((lo, hi))
    return out[0], out[1]


def _pose(bases, theta, alpha, c, q):
    """Canonical-frame departure point p(α), tangent t = dp/dφ and u = S(θ) − p [m]."""
    q = AnchoredPulley.named_parameters(q)
    rho, drho, _, _ = profile_function(bases[0])(alpha, c)
    ca_, sa = ca.cos(alpha), ca.sin(alpha)
    px, py = rho * ca_, rho * sa
    tx, ty = drho * ca_ - rho * sa, drho * sa + rho * ca_  # dp/dφ (Johnston2023 Eq. 3)
    chi = q.chi0 + q.sigma * theta
    return (px, py), (tx, ty), (q.ell * ca.cos(chi) - px, q.ell * ca.sin(chi) - py)


@register
@dataclass(frozen=True)
class AnchoredPulley(Mechanism):
    """A pulley with its cable anchored on it and a spring in line with the cable.

    Fields (SI): ``spring_end_x``, ``spring_end_y`` [m] the spring end's world position at θ = 0;
    ``turning`` ("pulley" or "spring_end") the body that turns with the joint, by ``sense``·θ
    (±1, counter-clockwise positive); ``winding`` ("ccw"/"cw") the cable's direction on the
    pulley from its anchor; ``anchor_angle`` [rad] the world angle of the anchor direction φ = 0
    at θ = 0; ``reference_angle`` [rad] the joint angle at which the spring's extension is its
    pre-extension x₀; ``min_moment_arm`` [m] and ``min_free_span`` [m] lower limits of the
    moment arm and of the straight cable between pulley and spring end; ``initial_radius`` [m]
    the circular start's radius (0: the default of :meth:`start_radius`).
    """

    spring_end_x: float = 0.0
    spring_end_y: float = 0.0
    turning: str = "pulley"
    sense: float = 1.0
    winding: str = "ccw"
    anchor_angle: float = 0.0
    reference_angle: float = 0.0
    min_moment_arm: float = 0.0
    min_free_span: float = 0.0
    initial_radius: float = 0.0
    mount_distance: tuple[float, float] | None = None
    mount_angle: tuple[float, float] | None = None

    kind = "anchored_pulley"
    citation = "Ludovico2021"
    spec_keys = SPEC_KEYS
    ports = ("cable",)
    fixed_sign_ports = {"cable": ("winding", "sense")}  # the cable's line never crosses the axis
    mounted_ports = ("cable",)  # the spring hangs from the spring end along the free span
    parameters = (Quantity("ell", "m", "the distance ℓ from the joint to the spring end", placed="length"),
                  Quantity("chi0", "rad", "the spring end's canonical angle χ₀ at θ = 0", placed="angle:ell"),
                  Quantity("sigma", "-", "σ = ±1: the spring end turns by σθ around the pulley"),
                  Quantity("theta_ref", "rad", "the joint angle where the spring has its pre-extension"),
                  Quantity("min_moment_arm", "m", "the least moment arm allowed"),
                  Quantity("min_free_span", "m", "the shortest free cable allowed"))
    per_angle = (Quantity("alpha", "rad", "the departure angle α of the cable on the pulley"),)
    residual_rows = (Quantity("tangency", "rad", "the angle from the profile's tangent to the cable"),)
    unknown_bounds = ((0.0, np.inf),)  # the cable never leaves before its anchor
    force_models = ("force",)
    methods = (DesignMethod("moment_arm", "Ludovico2021 moment-arm synthesis (minimax in r_m(θ), profiles fitted)",
                            "anchored pulleys, each with a spring of its own, for joint targets of their own angle",
                            'kind = "anchored_pulley" and a spring of its own on its cable port',
                            sets=("anchor_angle", "initial_radius")),)
    limits = (Limit("moment_arm", "moment arm", "min_moment_arm"),
              Limit("free_span", "free cable span", "min_free_span"))

    # -- derived numbers -------------------------------------------------------------------------
    def citations(self) -> tuple[str, ...]:
        """Ludovico2021 (Kim & Deshpande's pulley, the closed form), and Endo2010 for a pulley
        turning with its link."""
        return ("Ludovico2021", "Endo2010") if self.turning == "pulley" else ("Ludovico2021",)

    @property
    def windings(self) -> tuple[float]:
        """The cable's winding on the pulley seen from the front: +1 ``ccw``, −1 ``cw``."""
        return (WINDING[self.winding],)

    @property
    def sigma(self) -> float:
        """σ = ±1: the canonical spring end turns by σθ around the pulley."""
        turn = -1.0 if self.turning == "pulley" else 1.0
        return WINDING[self.winding] * self.sense * turn

    @property
    def ell(self) -> float:
        """Distance ℓ from the joint to the spring end [m]."""
        return float(np.hypot(self.spring_end_x, self.spring_end_y))

    def placement_region(self) -> dict[str, tuple[float, float]]:
        """ℓ within ``mount_distance`` and χ₀ within the canonical image of ``mount_angle``
        (χ₀ = w(ψ − anchor_angle), ψ the spring end's world angle, unwrapped into the range)."""
        out = {}
        if self.mount_distance is not None:
            out["ell"] = (float(self.mount_distance[0]), float(self.mount_distance[1]))
        if self.mount_angle is not None:
            w, chi0 = WINDING[self.winding], self.parameter_values()[1]
            psi = _unwrapped_into(float(np.arctan2(self.spring_end_y, self.spring_end_x)), self.mount_angle)
            ends = sorted(chi0 + w * (a - psi) for a in self.mount_angle)
            out["chi0"] = (float(ends[0]), float(ends[1]))
        return out

    def placed(self, values: dict[str, float]) -> "AnchoredPulley":
        """The spring end at the distance ``ell`` and canonical angle ``chi0`` the NLP placed it."""
        ell, chi0 = values.get("ell", self.ell), values.get("chi0", self.parameter_values()[1])
        psi = self.anchor_angle + WINDING[self.winding] * chi0
        return replace(self, spring_end_x=float(ell * np.cos(psi)), spring_end_y=float(ell * np.sin(psi)))

    def largest_arm(self, port: str) -> float | None:
        """The largest ``rho_max``: the cable leaves a profile tangentially, so its line passes
        the joint at most the profile's radius there away."""
        return float(max(f.rho_max for f in self.profiles)) if port == "cable" else None

    def mount_room(self, port: str, arms: np.ndarray) -> np.ndarray | None:
        """√(ℓ² − h²) + √(r_max² − h²): the foot of the joint on the cable's line splits the
        line from the spring end, at ℓ from the joint (the largest of ``mount_distance`` where
        the NLP places it), to the departure point, within r_max of it, into two legs of a
        right triangle each; both fall as h grows."""
        if port not in self.mounted_ports:
            return None
        ell = float(self.mount_distance[1] if self.mount_distance is not None else self.ell)
        h = np.asarray(arms, dtype=float)
        return np.sqrt(np.maximum(ell**2 - h**2, 0.0)) + np.sqrt(np.maximum(self.largest_arm(port)**2 - h**2, 0.0))

    def parameter_values(self) -> tuple[float, ...]:
        w = WINDING[self.winding]
        chi0 = w * (np.arctan2(self.spring_end_y, self.spring_end_x) - self.anchor_angle)
        return (self.ell, float(chi0), self.sigma, float(self.reference_angle),
                float(self.min_moment_arm), float(self.min_free_span))

    # -- the symbolic model --------------------------------------------------------------------
    @classmethod
    def residual(cls, bases, theta, z, c, q):
        alpha = cls.named_unknowns(z).alpha
        _, (tx, ty), (ux, uy) = _pose(bases, theta, alpha, c, q)
        cross, dot = tx * uy - ty * ux, tx * ux + ty * uy
        cosine = dot / (ca.sqrt(tx**2 + ty**2) * ca.sqrt(ux**2 + uy**2))
        return ca.atan2(cross, dot), ca.fmax(0, 1 - cosine) + ca.fmax(0, -alpha)

    @classmethod
    def guess(cls, bases, theta, c, q):
        """Tangent from S to the pedal curve: the tangent line at α lies at distance
        h = ρ²/√(ρ² + ρ′²) from O with outward normal at angle α − atan(ρ′/ρ); it passes through
        S when that angle is χ − acos(h/ℓ). Iterated with ρ, ρ′ at α from α = χ − π/2 (where a
        far spring end's tangent touches), so that a profile is never evaluated far outside
        its wrapped range; exact for a circle."""
        prof = profile_function(bases[0])
        q = cls.named_parameters(q)
        chi = q.chi0 + q.sigma * theta
        alpha = chi - ca.pi / 2  # the tangent point for a far spring end: inside the wrap
        for _ in range(GUESS_SWEEPS):
            rho, drho, _, _ = prof(alpha, c)
            h = rho**2 / ca.sqrt(rho**2 + drho**2)
            alpha = chi - ca.acos(ca.fmin(h / q.ell, 1)) + ca.atan2(drho, rho)
        return alpha

    @classmethod
    def free_span(cls, bases, theta, z, c, q):
        """|S − p(α)| [m]: the straight cable from the departure point to the spring end."""
        _, _, (ux, uy) = _pose(bases, theta, cls.named_unknowns(z).alpha, c, q)
        return ca.sqrt(ux**2 + uy**2)

    @classmethod
    def spring_room(cls, bases, theta, z, c, q, port):
        """The free span: the spring hangs from the spring end S towards the departure point."""
        return cls.free_span(bases, theta, z, c, q)

    @classmethod
    def displacements(cls, bases, theta, z, z_ref, wrapped, c, q):
        return (wrapped[0] + cls.free_span(bases, theta, z, c, q)
                - cls.free_span(bases, cls.named_parameters(q).theta_ref, z_ref, c, q))

    @classmethod
    def moment_arm(cls, bases, theta, z, c, q):
        """r_m = p × t̂ [m]: the distance from O to the cable line (Ludovico2021 Fig. 1)."""
        (px, py), (tx, ty), _ = _pose(bases, theta, cls.named_unknowns(z).alpha, c, q)
        return (px * ty - py * tx) / ca.sqrt(tx**2 + ty**2)

    @classmethod
    def force_arms(cls, bases, model, theta, z, c, q, order, integrals):
        """σ·r_m: τ = F r_m (Ludovico2021 Eq. 1, Endo2010 Eq. 1–2) with the spring's sense."""
        return cls.named_parameters(q).sigma * cls.moment_arm(bases, theta, z, c, q)

    @classmethod
    def margins(cls, bases, theta, z, c, q, arm):
        """σ·arm − r_min (moment arm) and |S − p| − span_min (free span) [m], ≥ 0 when met."""
        p = cls.named_parameters(q)
        return ca.vertcat(p.sigma * arm[0] - p.min_moment_arm, cls.free_span(bases, theta, z, c, q) - p.min_free_span)

    @classmethod
    def wrap_end(cls, first, last, q):
        """The departure angle at the most-wound end of the range: the last grid angle when
        σ = +1, the first when σ = −1."""
        sigma = cls.named_parameters(q).sigma
        return 0.5 * (1 + sigma) * last + 0.5 * (1 - sigma) * first

    @classmethod
    def prepare_start(cls, problem, design):
        """With ``solver.method = "moment_arm"``, the pulleys of the moment-arm synthesis
        (:func:`.moment_arm.moment_arm_synthesis`), anchors and bases included; else the
        circles."""
        if problem.options.method != "moment_arm":
            return problem, design
        from .moment_arm import moment_arm_synthesis  # it builds on this model: imported here, not above
        return moment_arm_synthesis(problem, design)

    @classmethod
    def profile_domain(cls, theta_range) -> tuple[float, float]:
        """α runs over about the joint's span from a small wrap at the least-wound pose."""
        return (0.0, theta_range[1] - theta_range[0] + np.pi / 2)

    # -- drawing -------------------------------------------------------------------------------
    def world_points(self, theta, phi, rho, k: int = 0):
        """World coordinates [m] of profile points (φ, ρ) at joint angle θ."""
        turn = self.sense * theta if self.turning == "pulley" else 0.0
        ang = self.anchor_angle + turn + WINDING[self.winding] * np.asarray(phi)
        return rho * np.cos(ang), rho * np.sin(ang)

    def spring_end(self, theta) -> np.ndarray:
        """World position of the spring end at joint angle θ [m]."""
        turn = self.sense * theta if self.turning == "spring_end" else 0.0
        c, s = np.cos(turn), np.sin(turn)
        return np.array([c * self.spring_end_x - s * self.spring_end_y,
                         s * self.spring_end_x + c * self.spring_end_y])

    def circles(self, theta, z, c):
        """The spring end (a point)."""
        return [(self.spring_end(theta), 0.0)]

    def segments(self, theta, z, c):
        """The free cable from the departure point to the spring end."""
        alpha = self.named_unknowns(z).alpha
        rho = direct(profile_function(self.bases[0]))(alpha, c)[0].item()
        p = np.array(self.world_points(theta, alpha, rho), dtype=float)
        return [(p, self.spring_end(theta))]

    def spring_line(self, theta, z, c, port, sign):
        """The spring hangs from its end S along the free cable towards the departure point:
        the cable's path from the anchor to S (constant but for the spring) grows by the
        spring's extension. Its room is the free span."""
        (p, end), = self.segments(theta, z, c)
        span = float(np.hypot(*(p - end)))
        return end, (p - end) / span, span

    def link_rotation(self, theta):
        """The link carries the turning body (the pulley, or the spring end): sense·θ."""
        return self.sense * theta

    def start_radius(self, profile):
        """``initial_radius`` if given, else mid-range of ρ, at most 40 % of the spring end's
        distance."""
        r = self.initial_radius or min(0.5 * (profile.rho_min + profile.rho_max), 0.4 * self.ell)
        return max(r, profile.rho_min * (1 + 1e-3))

    # -- spec ------------------------------------------------------------------------------------
    @classmethod
    def from_spec(cls, reader, name, joint, profiles, theta_range=(0.0, 0.0)):
        keys = SPEC_KEYS
        end = reader.read(keys["spring_end"])
        if not np.hypot(*end) > max(p.rho_max for p in profiles):
            reader.fail(reader.key("spring_end"), end, keys["spring_end"].form())
        turning, sense, winding = (reader.read(keys[k]) for k in ("turning", "sense", "winding"))
        p = profiles[0]
        start = reader.read(keys["initial_radius"].within(low=p.rho_min, high=p.rho_max, open_high=True))
        mech = cls(name=name, joint=joint, profiles=profiles, spring_end_x=float(end[0]),
                   spring_end_y=float(end[1]), turning=turning, sense=float(sense), winding=winding,
                   initial_radius=float(start))
        least = theta_range[0] if mech.sigma > 0 else theta_range[1]
        ref = reader.read(keys["reference_angle"], least)
        anchor = reader.read(keys["anchor_angle"], mech._default_anchor(least, profiles[0]))
        arm = reader.read(keys["min_moment_arm"])
        span = reader.read(keys["min_free_span"])
        distance, angle = _mount_region(reader, end, max(p.rho_max for p in profiles))
        return replace(mech, reference_angle=float(ref), anchor_angle=float(anchor),
                       min_moment_arm=float(arm), min_free_span=float(span), mount_distance=distance,
                       mount_angle=angle)

    @classmethod
    def advice(cls, problem) -> list[str]:
        """Endo2010's convexity bound, where it applies: a pulley turning with a pendulum whose
        only spring is unstretched (x = 0) at the range's first angle θ0 has a convex envelope
        there only if F0² ≤ 2k·m·g·l·(1 − cos θ0) (F0 the preload, k the rate, m g l the
        pendulum's)."""
        notes = []
        for u, mech in enumerate(problem.mechanisms):
            springs = [s for s in problem.springs if any(p.mechanism == u for p in s.ports)]
            joint = problem.joints[mech.joint]
            if not (isinstance(mech, cls) and mech.turning == "pulley" and len(springs) == 1
                    and joint.target.kind == "pendulum" and joint.target.data.get("phase", 0.0) == 0.0
                    and springs[0].preextension == 0.0
                    and mech.reference_angle == joint.theta_range[0] and springs[0].preload > 0):
                continue
            spring, data = springs[0], joint.target.data
            mgl = data["mass"] * data["g"] * data["length"]
            least = float(np.arccos(1 - spring.preload**2 / (2 * spring.rate * mgl))) \
                if spring.preload**2 < 4 * spring.rate * mgl else np.pi
            if joint.theta_range[0] < least:  # Endo2010 Sec. II.C
                notes.append(f"mechanism {mech.name!r}: its range starts at {np.degrees(joint.theta_range[0]):.3g}°, "
                             f"below Endo2010's convexity bound θ0 ≥ {np.degrees(least):.3g}° for this spring "
                             "(F0² ≤ 2k·m·g·l·(1 − cos θ0)): no convex pulley balances it exactly there; start "
                             "the range later, or take a spring with less preload or a higher rate")
        return notes

    def _default_anchor(self, least: float, profile) -> float:
        """The anchor angle that leaves :data:`ANCHOR_WRAP` of wrap on the circular start at
        the least-wound joint angle ``least``: the circle's departure point is at canonical
        angle χ(θ) − acos(r₀/ℓ)."""
        w = WINDING[self.winding]
        chi0 = ANCHOR_WRAP + np.arccos(self.start_radius(profile) / self.ell) - self.sigma * least
        return float(np.arctan2(self.spring_end_y, self.spring_end_x) - w * chi0)

    def spec_fields(self) -> dict:
        region = {k: list(v) for k, v in (("mount_distance", self.mount_distance), ("mount_angle", self.mount_angle))
                  if v is not None}
        return {"spring_end": [self.spring_end_x, self.spring_end_y], "turning": self.turning,
                "sense": int(self.sense), "winding": self.winding,
                "anchor_angle": self.anchor_angle, "reference_angle": self.reference_angle,
                "min_moment_arm": self.min_moment_arm, "min_free_span": self.min_free_span,
                **({"initial_radius": self.initial_radius} if self.initial_radius else {}), **region}

    def port_length_from_file(self, outlines, port, theta):
        """The cable from the anchor round the outline to the spring end
        (:func:`.file_model.anchored_path`)."""
        return anchored_path(outlines[0], self, theta)

    def free_spans_from_file(self, outlines, theta):
        """The cable's span from the outline to the spring end (:func:`.file_model.anchored_span`)."""
        return [anchored_span(outlines[0], self, theta)[:2]]
