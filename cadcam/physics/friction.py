"""Friction where it acts, declared once (a spec's ``[friction]``, :data:`FRICTION_KEYS`), and
the band of torques it lets a built device hold still (docs/physics.md, "Friction").

A design's torque is frictionless: each spring j pulls its cable with the tension
T_j = F0_j + k_j x_j and joint i feels τ_i = Σ T_j P_jp a_p over the cable paths (spring j,
port p) on it, a_p the port's moment arm (:mod:`cadcam.physics.springs`). Friction splits it in
two: τ⁺(θ), the torque that turns the joint towards +θ, and τ⁻(θ), the torque below which it
turns towards −θ. Any external torque (a payload) between them is held still, so the band
[τ⁻, τ⁺] is what a built device does, and τ⁺ − τ⁻ its hysteresis. Quasi-statically, to first
order in the losses, it is computed from the frictionless state:

* **A fixed guide or post** (:class:`Guide`) the cable slides over, wrapping it by β: the
  tension on its two sides differs by the capstan ratio e^{μβ} (the Euler–Eytelwein equation;
  Johnston2023 Eq. 31 is the same law along a wrap). Where the turn stretches the spring the
  profile's side is the taut one, T_j e^{μβ}; where it lets the spring shorten, T_j e^{−μβ}.
* **An idler on a bearing** (:class:`Idler`): its bearing's friction torque μ_b r_b |F| on the
  resultant F of the two tensions, |F| = (T_h + T_l) sin(β/2) (exact at β = 180°, to first
  order in the loss elsewhere), makes T_h − T_l = c (T_h + T_l) sin(β/2) with
  c = μ_b r_b / R: a tension ratio (1 + ε)/(1 − ε), ε = c sin(β/2).
* **The joint's own bearing** (:class:`JointBearing`): a friction torque τ_b, a constant (seals,
  the payload's weight) plus μ_b r_b times the tensions of the cables that pull on the joint.

The elements on one path multiply their ratios (r = e^L, L = Σ μβ + Σ ln((1+ε)/(1−ε))), so a
path's term t = T_j P_jp a_p becomes t e^{±L sgn t} and

    τ± = Σ t e^{±L sgn t} ± τ_b                    (:func:`band_edges`)

which with no friction is τ. The band's centre is Σ t cosh L: the frictionless torque only
where no cable slides (bearings alone). Tracking the centre instead (``centre = true``) weights
each path's arm by cosh L in the torque the NLP matches to its target
(:meth:`Friction.arm_scales`), so the target sits mid-band and the band's half-width
Σ |t| sinh L + τ_b is the largest error of a held payload.

A wire wound on its own profile does not slide on it: its capstan friction (the wire cam's
``mu``, which its force models read) changes the tension along the wrap and the anchor's load,
not the torque (docs/physics.md), and is no part of the band.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..keys import Key, KeyTable, Plausible
from .springs import Port

#: Where a friction coefficient [-] is plausible: dry polymer on steel reaches about 0.5, a
#: rope over a rough post about 1.
COEFFICIENT = Plausible(high=1.0, what="friction coefficients")
#: Where a cable's wrap [deg] on a guide is plausible: a few turns round a post.
WRAP = Plausible(high=1080.0, what="wraps of a cable on a guide (three turns)")
#: Where a joint bearing's friction torque [N·m] is plausible: up to a large plain bearing's.
BEARING_TORQUE = Plausible(high=10.0, what="a joint bearing's friction torques")

_SPRING = Key("spring", "", "the spring whose cable runs over it, as the spring's 1-based number", "integer", low=1)
_PORT = Key("port", "", "the spring's port whose cable runs over it, as the spring's ports write it ('wire:1')",
            "string", min_length=1, default=None, default_text="the spring's only port")

#: A ``[[friction.guides]]`` table's keys.
GUIDE_KEYS = KeyTable("[[friction.guides]]", "A fixed guide or post a spring's cable slides over between the "
                      "spring and its profile: its tension changes by the capstan ratio e^(mu beta) across it "
                      "(Euler–Eytelwein).", (
    _SPRING, _PORT,
    Key("mu", "-", "the friction coefficient μ between the cable and the guide (a rope over a steel post: "
        "about 0.16)", low=0, plausible=COEFFICIENT),
    Key("wrap_deg", "deg", "the angle β the cable wraps the guide", low=0, plausible=WRAP),
))

#: An ``[[friction.idlers]]`` table's keys.
IDLER_KEYS = KeyTable("[[friction.idlers]]", "An idler pulley on a bearing a spring's cable runs over between the "
                      "spring and its profile: the bearing's friction on the resultant of the two tensions.", (
    _SPRING, _PORT,
    Key("coefficient", "-", "the bearing's friction coefficient times its bore radius over the pulley's radius, "
        "c = μ_b r_b / R (from a measured efficiency η over a wrap β: c = (1 − η)/((1 + η) sin(β/2)); a small "
        "ball-bearing pulley losing 11 % over 180°: 0.058)", low=0, high=1, open_high=True, plausible=COEFFICIENT),
    Key("wrap_deg", "deg", "the angle β the cable wraps the idler", low=0, high=360),
))

#: A ``[[friction.joints]]`` table's keys.
BEARING_KEYS = KeyTable("[[friction.joints]]", "A joint's own bearing: a friction torque, constant and in "
                        "proportion to the tensions of the cables pulling on the joint.", (
    Key("joint", "", "the joint, 1-based", "integer", low=1),
    Key("torque", "N·m", "a constant friction torque (seals, the payload's weight on the bearing)", low=0,
        default=0.0, plausible=BEARING_TORQUE),
    Key("coefficient", "-", "the bearing's friction coefficient μ_b (a ball bearing about 0.002, a plain "
        "bearing 0.1–0.3)", low=0, default=0.0, plausible=COEFFICIENT),
    Key("radius", "m", "the radius r_b at which the bearing's friction acts (half its bore)", low=0, default=0.0,
        plausible=Plausible(high=0.1, what="bearing radii")),
))

#: A ``[friction]`` table's keys.
FRICTION_KEYS = KeyTable("[friction]", "Friction where it acts: the fixed guides and the idlers on bearings a "
                         "spring's cable runs over, and the joints' bearings. It splits each joint's torque into "
                         "the torques that turn it either way, the band a built device holds any payload still in "
                         "(result.json's friction_band, the summary, the torque figure). A wire wound on its own "
                         "profile does not slide on it and adds nothing (the wire cam's mu is its force models').", (
    Key("centre", "", "whether the torque matched to the target is the friction band's centre (each cable path's "
        "arm weighted by cosh(L), L its log tension ratio) rather than the frictionless torque", "choice",
        default=False, choices=(False, True)),
    Key("guides", "", "fixed guides and posts (see [[friction.guides]])", "tables", default=[]),
    Key("idlers", "", "idlers on bearings (see [[friction.idlers]])", "tables", default=[]),
    Key("joints", "", "joints' bearings (see [[friction.joints]])", "tables", default=[]),
))


def capstan_log_ratio(mu, wrap):
    """ln(T_high/T_low) = μβ [-] of a cable sliding over a fixed guide it wraps by ``wrap`` β
    [rad] with friction coefficient ``mu`` (the Euler–Eytelwein capstan equation; Johnston2023
    Eq. 31 along a wrap). Numbers or arrays (one per build)."""
    return np.multiply(mu, wrap)  # Euler–Eytelwein: T_high = T_low e^{μβ}


def idler_log_ratio(coefficient, wrap):
    """ln(T_high/T_low) = ln((1 + ε)/(1 − ε)), ε = c sin(β/2) [-], of a cable over an idler on a
    bearing: the bearing's friction torque μ_b r_b |F| on the resultant |F| = (T_h + T_l) sin(β/2)
    over the pulley's radius R balances T_h − T_l, with c = μ_b r_b / R (``coefficient``) and β
    (``wrap`` [rad]). Numbers or arrays."""
    eps = np.multiply(coefficient, np.sin(np.multiply(wrap, 0.5)))
    return np.log1p(eps) - np.log1p(-eps)


def band_edges(terms, log_ratios, bearing=0.0):
    """τ⁺ and τ⁻ [N·m] of one joint: the torques that turn it towards +θ and −θ.

    Parameters
    ----------
    terms : array (K, ...)
        The frictionless torque t_k = T_j P_jp a_p [N·m] of each cable path k on the joint (a
        spring's tension times its port's signed arm), at any number of points (and builds).
    log_ratios : array (K,) or broadcastable to ``terms``
        ln of each path's tension ratio, L_k ≥ 0 (:func:`capstan_log_ratio`, :func:`idler_log_ratio`,
        summed along the path).
    bearing : float or array broadcastable to ``terms[0]``
        The joint bearing's friction torque τ_b ≥ 0 [N·m].

    Returns
    -------
    (ndarray, ndarray)
        τ⁺ = Σ t e^{L sgn t} + τ_b and τ⁻ = Σ t e^{−L sgn t} − τ_b: where a turn stretches a
        path's spring (t > 0 turning towards +θ) its profile's side carries the larger tension.
    """
    t = np.asarray(terms, dtype=float)
    L = np.asarray(log_ratios, dtype=float).reshape(np.shape(log_ratios) + (1,) * (t.ndim - np.ndim(log_ratios)))
    lift = L * np.sign(t)
    return (t * np.exp(lift)).sum(axis=0) + bearing, (t * np.exp(-lift)).sum(axis=0) - bearing


def _number(value):
    """``value`` as a float where it is one number, else the array."""
    return float(value) if np.ndim(value) == 0 else value


@dataclass(frozen=True)
class Guide:
    """A fixed guide or post on spring ``spring``'s cable to ``port`` (0-based spring; the port
    as the spring names it): friction coefficient ``mu`` [-], wrap ``wrap`` [rad]."""

    spring: int
    port: Port
    mu: float
    wrap: float

    def log_ratio(self, factor=1.0):
        """ln of its tension ratio, μβ (:func:`capstan_log_ratio`), with μ times ``factor`` (a
        number, or an array: one per build)."""
        return _number(capstan_log_ratio(self.mu * np.asarray(factor), self.wrap))

    def to_dict(self) -> dict:
        """The spec form."""
        return {"spring": self.spring + 1, "port": self.port.label(), "mu": self.mu,
                "wrap_deg": math.degrees(self.wrap)}


@dataclass(frozen=True)
class Idler:
    """An idler on a bearing on spring ``spring``'s cable to ``port``: c = μ_b r_b / R
    (``coefficient``) [-], wrap ``wrap`` [rad]."""

    spring: int
    port: Port
    coefficient: float
    wrap: float

    def log_ratio(self, factor=1.0):
        """ln of its tension ratio (:func:`idler_log_ratio`), with c times ``factor`` (a number,
        or an array: one per build)."""
        return _number(idler_log_ratio(self.coefficient * np.asarray(factor), self.wrap))

    def to_dict(self) -> dict:
        """The spec form."""
        return {"spring": self.spring + 1, "port": self.port.label(), "coefficient": self.coefficient,
                "wrap_deg": math.degrees(self.wrap)}


@dataclass(frozen=True)
class JointBearing:
    """Joint ``joint``'s bearing (0-based): a constant ``torque`` [N·m] and ``coefficient`` μ_b
    [-] times ``radius`` r_b [m] times the tensions of the cables pulling on the joint."""

    joint: int
    torque: float = 0.0
    coefficient: float = 0.0
    radius: float = 0.0

    def friction_torque(self, load):
        """τ_b = torque + μ_b r_b |load| [N·m] at a bearing ``load`` [N] (numbers or arrays)."""
        return self.torque + self.coefficient * self.radius * np.abs(load)

    def to_dict(self) -> dict:
        """The spec form."""
        return {"joint": self.joint + 1, "torque": self.torque, "coefficient": self.coefficient,
                "radius": self.radius}


@dataclass(frozen=True)
class Friction:
    """A problem's friction (a spec's ``[friction]``).

    Attributes
    ----------
    guides, idlers, joints : tuple
        Its :class:`Guide`, :class:`Idler` and :class:`JointBearing` elements.
    centre : bool
        Whether the torque matched to the target is the band's centre (:meth:`arm_scales`).
    """

    guides: tuple[Guide, ...] = ()
    idlers: tuple[Idler, ...] = ()
    joints: tuple[JointBearing, ...] = ()
    centre: bool = False

    def path_log_ratios(self) -> dict[tuple[int, int, str], float]:
        """(spring, mechanism, port name) → L, the log tension ratio of every cable path that
        has a guide or an idler: the sum of its elements' (their ratios multiply)."""
        out: dict[tuple[int, int, str], float] = {}
        for element in (*self.guides, *self.idlers):
            key = (element.spring, element.port.mechanism, element.port.name)
            out[key] = out.get(key, 0.0) + element.log_ratio()
        return out

    def arm_scales(self) -> dict[tuple[int, int, str], float]:
        """(spring, mechanism, port name) → cosh L, the weight of each sliding path's arm in the
        torque matched to the target when it is the band's centre; empty when it is not
        (``centre`` false): the band's centre is Σ t cosh L (:func:`band_edges`)."""
        return {key: math.cosh(L) for key, L in self.path_log_ratios().items()} if self.centre else {}

    def bearing(self, joint: int) -> JointBearing:
        """Joint ``joint``'s bearing (a spec gives at most one per joint); none: a frictionless one."""
        return next((b for b in self.joints if b.joint == joint), JointBearing(joint))

    def scaled(self, factor: float) -> "Friction":
        """Every coefficient and friction torque times ``factor`` (a build's friction from the
        declared one: 0 is frictionless)."""
        return replace(self, guides=tuple(replace(g, mu=g.mu * factor) for g in self.guides),
                       idlers=tuple(replace(i, coefficient=i.coefficient * factor) for i in self.idlers),
                       joints=tuple(replace(b, torque=b.torque * factor, coefficient=b.coefficient * factor)
                                    for b in self.joints))

    def to_dict(self) -> dict:
        """The spec form."""
        return {"centre": self.centre, "guides": [g.to_dict() for g in self.guides],
                "idlers": [i.to_dict() for i in self.idlers], "joints": [b.to_dict() for b in self.joints]}
