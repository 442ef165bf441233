"""A mechanism from outside cadcam, installed as a package of its own (``tests/plugin``'s
pyproject.toml names it in the entry-point group ``cadcam.mechanisms``): a noncircular pulley
whose cable runs to a fixed point.

The pulley ρ(φ) turns with its joint (the base class's ``profile_rotation``: the profile point
at polar angle φ sits at world angle φ − θ). The cable is anchored on the profile at φ = 0,
wraps it in the direction of increasing φ (counter-clockwise in the pulley's own frame) up to
the departure angle α, leaves it tangentially and runs straight to a fixed point
A = (ax, ay) — an idler of zero radius — through which it pulls a spring fixed at A. This is
the anchored-spring pulley of Ludovico2021 (Kim & Deshpande's pulley) and Endo2010 (spring end
fixed at (a, b) on the base), simplified to a point idler with the spring acting along the
cable.

Sign convention. With the joint turning by +θ the pulley turns clockwise by θ; the departure
point keeps roughly its world position, so α grows with θ and more cable is wrapped: the cable
length from the anchor to A, and the spring's extension, *increase* with θ. For a circle of
radius R, α − θ is the constant ψ_A − acos(R/|A|) (ψ_A the polar angle of A) and the length
changes by exactly R·θ.

Port ``cable``: the change, from the reference pose θ = 0, of the cable length from the
profile anchor to A, i.e. the wrapped length change plus the change of the free span |A − p(α)|.
Unknown: α. The equations are the library's anchored-spring pulley's
(:class:`cadcam.mechanisms.anchored_pulley.model.AnchoredPulley`), written once there: in its
canonical frame this pulley (turning clockwise with θ, wound counter-clockwise) sees A at
distance |A| and polar angle ψ_A + θ (ℓ = |A|, χ₀ = ψ_A, σ = +1, θ_ref = 0). This module only
maps its own numbers (ax, ay) onto those — a plug-in with its own kind, spec keys and
parameters. No force model: the torque is the generic energy torque τ = (kx + F0) dd/dθ.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from cadcam.keys import Key, KeyTable
from cadcam.mechanisms.anchored_pulley.model import AnchoredPulley
from cadcam.mechanisms.base import Mechanism, Quantity

#: Its own keys of a ``[[mechanisms]]`` table.
SPEC_KEYS = KeyTable('kind = "toy_pulley"', "A pulley turning with its joint, its cable running to a fixed point "
                     "through a spring there.", (
    Key("anchor", "m", "[ax, ay]: the fixed point the cable runs to, outside rho_max", "numbers", length=2),
))


def _canonical(q):
    """The anchored pulley's parameters (ℓ, χ₀, σ, θ_ref, no margins) of the anchor A = q."""
    a = ToyPulley.named_parameters(q)
    return ca.vertcat(ca.sqrt(a.anchor_x ** 2 + a.anchor_y ** 2), ca.atan2(a.anchor_y, a.anchor_x), 1, 0, 0, 0)


@dataclass(frozen=True)
class ToyPulley(Mechanism):
    """A pulley turning with its joint, its cable running to the fixed point
    (``anchor_x``, ``anchor_y``) [m] in the joint's (world) frame, through a spring there."""

    anchor_x: float = 0.0
    anchor_y: float = 0.0

    kind = "toy_pulley"
    #: one tag of cadcam.citations.PAPERS (a result lists it); Endo2010 is cited above only
    citation = "Ludovico2021"
    ports = ("cable",)
    spec_keys = SPEC_KEYS
    parameters = (Quantity("anchor_x", "m", "the fixed point's x"), Quantity("anchor_y", "m", "the fixed point's y"))
    per_angle = AnchoredPulley.per_angle
    residual_rows = AnchoredPulley.residual_rows

    @classmethod
    def residual(cls, bases, theta, z, c, q):
        return AnchoredPulley.residual(bases, theta, z, c, _canonical(q))

    @classmethod
    def guess(cls, bases, theta, c, q):
        return AnchoredPulley.guess(bases, theta, c, _canonical(q))

    @classmethod
    def displacements(cls, bases, theta, z, z_ref, wrapped, c, q):
        return AnchoredPulley.displacements(bases, theta, z, z_ref, wrapped, c, _canonical(q))

    @classmethod
    def profile_domain(cls, theta_range):
        """α − θ = ψ_A − acos(h/|A|) + δ stays below θ + π for anchors at polar angles up to
        about π/2; the anchor itself is not known here (the domain is fixed before
        ``from_spec`` reads it), so the interval is a generous (0, θ_max + π)."""
        return (0.0, max(theta_range[1], 0.0) + np.pi)

    def start_radius(self, profile):
        """1.2 ρ_min, at most mid-range and at most half the anchor's distance (A outside)."""
        dist = float(np.hypot(self.anchor_x, self.anchor_y))
        r = min(1.2 * profile.rho_min, 0.5 * (profile.rho_min + profile.rho_max), 0.5 * dist)
        return max(r, profile.rho_min * (1 + 1e-3))

    def circles(self, theta, z, c):
        """The fixed point A (a zero-radius idler)."""
        return [(np.array([self.anchor_x, self.anchor_y]), 0.0)]

    @classmethod
    def from_spec(cls, reader, name, joint, profiles, theta_range=(0.0, 0.0)):
        anchor = reader.read(SPEC_KEYS["anchor"])
        if not np.hypot(*anchor) > max(p.rho_max for p in profiles):
            reader.fail(reader.key("anchor"), anchor, SPEC_KEYS["anchor"].form())
        return cls(name=name, joint=joint, profiles=profiles,
                   anchor_x=float(anchor[0]), anchor_y=float(anchor[1]))

    def spec_fields(self) -> dict:
        return {"anchor": [self.anchor_x, self.anchor_y]}
