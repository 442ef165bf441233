"""The wire-wrapped cam on a follower idler (Johnston2023, Sec. 2–5).

The cam turns with its joint by θ; the wire anchored at φ = 0 wraps it and leaves it at the
contact with an idler of radius r whose centre q rides a horizontal platform at height a₀
(Johnston2023 Fig. 1). The wire wraps the idler from γ down to 0 and pulls a spring riding on
the platform (port ``wire``, Eq. 14); the platform's travel stretches another (port
``platform``, Eq. 16). Unknowns per angle: the contact angle α on the cam and γ on the idler
(Eq. 6–7). Besides the energy torque it offers the paper's force model (Eq. 19–21) with the
corrected capstan derivative (``force``) or with Eq. 33 as printed (``force-as-printed``).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import casadi as ca
import numpy as np

from .capstan import wire_torque_function
from .departure import cam_tangent, departure_moments, idler_centre_x, tangency_residuals
from .file_model import wire_cam_port
from ...physics.mapped import direct
from ...physics.profile import profile_function
from ...keys import PART_SIZE, Key, KeyTable
from ..base import Mechanism, Quantity, register

#: Circle-solution sweeps of the closed-form guess of α.
GUESS_SWEEPS = 6


def wire_displacement(length, r, gamma, gamma_ref):
    """Change of the wire port [m]: Δl_cam + r(γ − γ₀) (Johnston2023 Eq. 14 without x₁₀)."""
    return length + r * (gamma - gamma_ref)  # Johnston2023 Eq. 14


def platform_displacement(qx, qx_ref):
    """Change of the platform port [m]: Δq_x (Johnston2023 Eq. 16, 18 without x₂₀)."""
    return qx - qx_ref  # Johnston2023 Eq. 16, 18


#: Its own keys of a ``[[mechanisms]]`` table (or of a ``[[cams]]`` entry).
SPEC_KEYS = KeyTable('kind = "wire_cam"', "Johnston2023's wire cam with its follower idler; ports \"wire\" and \"platform\".", (
    Key("idler", "", "the follower idler", "table", fields=KeyTable("idler", "The follower idler.", (
        Key("radius", "m", "the idler's radius r", low=0, open_low=True, plausible=PART_SIZE),
        Key("offset", "m", "the idler's vertical offset a₀ (Johnston2023 Eq. 7)", plausible=PART_SIZE),
    ))),
    Key("mu", "-", "the wire–cam friction coefficient (used by the force models only)", low=0),
))


@register
@dataclass(frozen=True)
class WireCam(Mechanism):
    """A wire cam with its follower idler: ``idler_radius`` r and ``idler_offset`` a₀ [m]
    (Johnston2023 Eq. 7), ``mu`` the wire–cam friction coefficient (force models only)."""

    idler_radius: float = 0.0
    idler_offset: float = 0.0
    mu: float = 0.0

    kind = "wire_cam"
    citation = "Johnston2023"
    spec_keys = SPEC_KEYS
    shorthand = "cams"  # [[cams]]: a wire cam on its own joint (cadcam ≤ 0.1)
    ports = ("wire", "platform")
    fixed_sign_ports = {"wire": ()}  # the wire wraps the cam as θ grows, whatever its profile (Eq. 6)
    parameters = (Quantity("idler_radius", "m", "the idler's radius r (Eq. 7)"),
                  Quantity("idler_offset", "m", "the platform's height a₀ above the cam axis (Eq. 7)",
                           placed="length"),
                  Quantity("mu", "-", "the wire–cam friction coefficient (force models, Eq. 33–35)"))
    per_angle = (Quantity("alpha", "rad", "the wire's contact angle α on the cam (Eq. 6)"),
                 Quantity("gamma", "rad", "the wire's contact angle γ on the idler (Eq. 7)"))
    residual_rows = (Quantity("tangency", "-", "the wire tangent to cam and idler (Eq. 6, a cross product)"),
                     Quantity("closure", "m", "the idler on its platform (Eq. 7)"))
    force_models = ("force", "force-as-printed")
    legacy_force_models = {"exact": "force", "as-printed": "force-as-printed"}

    @classmethod
    def residual(cls, bases, theta, z, c, q):
        u, p = cls.named_unknowns(z), cls.named_parameters(q)
        rho, drho, _, _ = profile_function(bases[0])(u.alpha, c)
        cross, closure, branch = tangency_residuals(theta, u.alpha, u.gamma, rho, drho, p.idler_radius,
                                                    p.idler_offset)
        return ca.vertcat(cross, closure), 1 + branch

    @classmethod
    def guess(cls, bases, theta, c, q):
        """The circle solution (ρ + r) sin(α − θ) = a₀ iterated with ρ = ρ(α), then γ along the
        inward normal ẑ × t̂(α); exact for a circular cam."""
        prof = profile_function(bases[0])
        p = cls.named_parameters(q)
        r, a0 = p.idler_radius, p.idler_offset
        alpha = theta
        for _ in range(GUESS_SWEEPS):
            alpha = theta + ca.asin(a0 / (prof(alpha, c)[0] + r))
        rho, drho, _, _ = prof(alpha, c)
        tx, ty = cam_tangent(theta, alpha, rho, drho)
        return ca.vertcat(alpha, ca.atan2(-tx, ty) + ca.pi)  # n̂ = (−t_y, t_x), γ kept near π

    @classmethod
    def idler_x(cls, bases, theta, z, c, q):
        """Idler centre q_x [m] (Johnston2023 Eq. 15)."""
        u = cls.named_unknowns(z)
        rho = profile_function(bases[0])(u.alpha, c)[0]
        return idler_centre_x(theta, u.alpha, u.gamma, rho, cls.named_parameters(q).idler_radius)

    @classmethod
    def displacements(cls, bases, theta, z, z_ref, wrapped, c, q):
        qx = cls.idler_x(bases, theta, z, c, q)
        qx_ref = cls.idler_x(bases, cls.reference_angle, z_ref, c, q)
        gamma, gamma_ref = cls.named_unknowns(z).gamma, cls.named_unknowns(z_ref).gamma
        return ca.vertcat(wire_displacement(wrapped[0], cls.named_parameters(q).idler_radius, gamma, gamma_ref),
                          platform_displacement(qx, qx_ref))

    @classmethod
    def force_arms(cls, bases, model, theta, z, c, q, order, integrals):
        """Johnston2023 Eq. 19–21: the wire term per unit tension (the departure moment, or
        Eq. 35 by quadrature of the capstan loads) and the unit-normal idler term."""
        alpha = cls.named_unknowns(z).alpha
        rho, drho, _, _ = profile_function(bases[0])(alpha, c)
        arm_t, arm_n = departure_moments(theta, alpha, rho, drho)
        if model == "force-as-printed" or integrals == "quadrature":
            capstan = "as-printed" if model == "force-as-printed" else "corrected"
            arm_t = wire_torque_function(bases[0], capstan, order)(alpha, c, cls.named_parameters(q).mu)
        return ca.vertcat(arm_t, arm_n)

    def start_radius(self, profile):
        """1.2 ρ_min, raised so the idler can touch the cam ((ρ + r) sin(α − θ) = a₀ needs
        ρ + r > a₀), kept inside the mid-range of ρ."""
        reach = 1.2 * (abs(self.idler_offset) - self.idler_radius) + 0.2 * profile.rho_min
        return min(max(1.2 * profile.rho_min, reach), 0.5 * (profile.rho_min + profile.rho_max))

    def circles(self, theta, z, c):
        """The idler at one pose."""
        qx = direct(_idler_x_function(self.bases))(theta, z, c, self.parameter_values()).item()
        return [(np.array([qx, self.idler_offset]), self.idler_radius)]

    def wraps(self, theta, z, c):
        """The wire on the idler, which it wraps from γ down to 0 (Johnston2023 Fig. 1)."""
        (centre, r), = self.circles(theta, z, c)
        if r <= 0:
            return []
        t = np.linspace(float(self.named_unknowns(z).gamma), 0.0, 60)
        return [(centre[0] + r * np.cos(t), centre[1] + r * np.sin(t))]

    def spring_line(self, theta, z, c, port, sign):
        """Spring 1 (``wire``) takes the wire where it leaves the idler (γ = 0) and runs on
        along it; spring 2 (``platform``) holds the idler's centre and runs along the platform
        away from the way that stretches it (Johnston2023 Fig. 1)."""
        (centre, r), = self.circles(theta, z, c)
        if port == "platform":
            return centre, np.array([-sign, 0.0]), np.inf
        wraps = self.wraps(theta, z, c)
        if not wraps:  # a point idler: the wire's way on is not drawn
            return None
        x, y = wraps[0]
        heading = np.array([x[-1] - x[-2], y[-1] - y[-2]])
        return np.array([x[-1], y[-1]]), heading / np.hypot(*heading), np.inf

    @classmethod
    def from_spec(cls, reader, name, joint, profiles, theta_range=(0.0, 0.0)):
        idler_keys = SPEC_KEYS["idler"].fields
        idler = reader.table_reader(SPEC_KEYS["idler"])
        radius = float(idler.read(idler_keys["radius"]))
        offset = float(idler.read(idler_keys["offset"]))
        idler.done()
        mu = float(reader.read(SPEC_KEYS["mu"]))
        return cls(name=name, joint=joint, profiles=profiles, idler_radius=radius,
                   idler_offset=offset, mu=mu)

    def spec_fields(self) -> dict:
        return {"mu": self.mu, "idler": {"radius": self.idler_radius, "offset": self.idler_offset}}

    def port_length_from_file(self, outlines, port, theta):
        """The idler riding the platform on the outline (:func:`.file_model.wire_cam_port`); the
        wire runs onto the idler with no free span."""
        return wire_cam_port(outlines[0], self, port, theta)


@lru_cache(maxsize=64)
def _idler_x_function(bases) -> ca.Function:
    """``qx(theta, z, c, q)``: :meth:`WireCam.idler_x` as a Function, built once per basis."""
    th, z, c, q = ca.SX.sym("theta"), ca.SX.sym("z", 2), ca.SX.sym("c", bases[0].size), ca.SX.sym("q", 3)
    return ca.Function("qx", [th, z, c, q], [WireCam.idler_x(bases, th, z, c, q)])
