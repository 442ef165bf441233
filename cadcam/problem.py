"""The resolved design problem: cams, springs, targets and options, in SI units.

A :class:`Problem` is what a spec file (:mod:`cadcam.spec`) becomes after validation; its
:meth:`Problem.to_dict` is a spec again, with tables inlined, so that every result carries the
problem it solved and can be re-evaluated without the original file.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .physics.profile import Basis
from .physics.springs import Spring
from .targets import Target


@dataclass(frozen=True)
class Options:
    """Transcription and solver options.

    grid : int
        Cam angles per cam on the uniform design grid (including both ends).
    quadrature_order : int
        Gauss–Legendre points per segment of the wrapped length between neighbouring grid
        contacts, and 8× that over the whole wrap for the as-printed friction integral.
    convexity_points : int
        Profile samples, spread over the whole wrapped range [0, α(θ_max)], at which convexity
        and ρ bounds are imposed.
    convexity_epsilon : float
        Required convexity margin as a fraction of ρ_min² (Eq. 40 asks for > 0).
    limit_margin : float
        Fraction of every limit (spring travel, ρ_min, ρ_max) the NLP keeps in reserve, so
        that what happens between grid points stays inside the limit on the re-check.
    multistart : int
        Extra randomised starts besides the default one (0 = single start).
    seed : int
        Seed of the multistart generator.
    max_iter : int
        IPOPT iteration limit.
    tol : float
        IPOPT tolerance.
    recheck_factor : int
        The re-check grid is this many times finer than the design grid.
    """

    grid: int = 46
    quadrature_order: int = 2
    convexity_points: int = 120
    convexity_epsilon: float = 1e-3
    limit_margin: float = 1e-4
    multistart: int = 0
    seed: int = 0
    max_iter: int = 500
    tol: float = 1e-8
    recheck_factor: int = 10


@dataclass(frozen=True)
class Cam:
    """One wire cam with its follower idler, target and weights (seed 003, Fig. 1).

    Lengths [m], angles [rad]. ``theta_range`` is the range of cam angles to balance;
    ``idler_radius`` r and ``idler_offset`` a₀ place the idler (Eq. 7); ``mu`` is the wire–cam
    friction coefficient; ``tracking_weight`` is w₁ and ``sensitivity_weights`` the w of
    ∫|∂τ/∂k_j| for each spring j (Eq. 46, 47).
    """

    name: str
    basis: Basis
    theta_range: tuple[float, float]
    rho_min: float
    rho_max: float
    idler_radius: float
    idler_offset: float
    mu: float
    target: Target
    tracking_weight: float
    sensitivity_weights: tuple[float, ...]

    def grid(self, n: int) -> np.ndarray:
        """Uniform grid of ``n`` cam angles [rad] over ``theta_range``."""
        return np.linspace(*self.theta_range, n)


@dataclass(frozen=True)
class Problem:
    """A cam-design problem: cams, springs joined by ports, friction model and options."""

    name: str
    source: str
    cams: tuple[Cam, ...]
    springs: tuple[Spring, ...]
    friction_model: str = "exact"
    options: Options = field(default_factory=Options)
    notes: str = ""

    def with_options(self, **kw) -> "Problem":
        """Copy with some :class:`Options` fields changed."""
        return replace(self, options=replace(self.options, **kw))

    def with_friction_model(self, name: str) -> "Problem":
        """Copy solved or evaluated under another friction model."""
        return replace(self, friction_model=name)

    def with_spring_rates(self, factor: float, springs=None) -> "Problem":
        """Copy with the rates of ``springs`` (indices; default every spring, as seed 003's
        Table 5 study does) multiplied by ``factor``."""
        return replace(self, springs=tuple(
            replace(s, rate=s.rate * factor) if springs is None or j in springs else s
            for j, s in enumerate(self.springs)))

    def with_weights(self, tracking: float | None = None, sensitivity=None) -> "Problem":
        """Copy with every cam's tracking weight and/or sensitivity weights replaced."""
        cams = tuple(replace(c, tracking_weight=c.tracking_weight if tracking is None else tracking,
                             sensitivity_weights=c.sensitivity_weights if sensitivity is None
                             else tuple(sensitivity)) for c in self.cams)
        return replace(self, cams=cams)

    def to_dict(self) -> dict:
        """The fully resolved problem in the spec format (SI units; tables inlined)."""
        return {
            "name": self.name, "source": self.source, "notes": self.notes,
            "friction_model": self.friction_model,
            "solver": dict(vars(self.options)),
            "cams": [{
                "name": c.name,
                "theta_range_deg": [float(np.degrees(t)) for t in c.theta_range],
                "basis": c.basis.name, "order": c.basis.order,
                "rho_min": c.rho_min, "rho_max": c.rho_max, "mu": c.mu,
                "tracking_weight": c.tracking_weight,
                "sensitivity_weights": list(c.sensitivity_weights),
                "idler": {"radius": c.idler_radius, "offset": c.idler_offset},
                "target": c.target.to_dict(),
            } for c in self.cams],
            "springs": [{
                "name": s.name, "rate": s.rate, "travel": s.travel,
                "ports": [("-" if p.sign < 0 else "") + f"{p.kind}:{p.cam + 1}" for p in s.ports],
            } for s in self.springs],
        }
