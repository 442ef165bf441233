"""The friction band of an evaluated design: τ⁺(θ) and τ⁻(θ), the torques that turn each joint
towards +θ and −θ, between which the built device holds any payload still
(:mod:`cadcam.physics.friction` has the physics and the spec's ``[friction]``).

Computed from the design's frictionless state on the evaluation's grid: each spring's tension
T_j = F0_j + k_j x_j and each cable path's arm, so a Monte Carlo of builds can call
:func:`band_of` with its own tensions, arms and friction (:meth:`Friction.scaled`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics.friction import Friction, band_edges
from ..problem import Problem


@dataclass(frozen=True)
class Path:
    """One cable path: spring ``spring`` (0-based) to global port ``port`` on joint ``joint``,
    with its incidence ``sign`` (P_jp) and label (``spring 1 → wire:1``)."""

    spring: int
    port: int
    joint: int
    sign: float
    label: str


def cable_paths(problem: Problem) -> list[Path]:
    """Every (spring, port) pair of the problem's network, in spring then port order."""
    net, ports = problem.network(), problem.ports
    return [Path(j, g, int(net.port_joint[g]), float(net.P[j, g]),
                 f"spring {j + 1} → {ports[g][1]}:{ports[g][0] + 1}")
            for j in range(net.S) for g in range(len(ports)) if net.P[j, g]]


def port_arms(evaluation) -> np.ndarray:
    """Each global port's moment arm a_p [m] (G, N) at the evaluation's grid points, from its
    mechanism's samples on its joint's grid (the energy arm, or the torque model's force arm)."""
    theta, rows = evaluation.theta, []
    for mech, unit in zip(evaluation.problem.mechanisms, evaluation.units):
        at = np.searchsorted(unit.theta, theta[mech.joint])  # the joint's grid index of each point
        rows.append(unit.arm[:, at])
    return np.vstack(rows)


def band_of(problem: Problem, friction: Friction, tension: np.ndarray, arms: np.ndarray):
    """(τ⁺, τ⁻, frictionless τ), each (m, ...) [N·m], of ``problem``'s joints under ``friction``.

    Parameters
    ----------
    problem : Problem
    friction : Friction
        The friction to apply (the problem's, or a build's: :meth:`Friction.scaled`).
    tension : ndarray (S, ...)
        Each spring's tension F0 + k·x [N] at the points (and builds).
    arms : ndarray (G, ...)
        Each global port's moment arm [m] at the same points (:func:`port_arms`).
    """
    ratios, ports, paths = friction.path_log_ratios(), problem.ports, cable_paths(problem)
    points = np.shape(tension)[1:]
    out = []
    for i in range(len(problem.joints)):
        mine = [p for p in paths if p.joint == i]
        terms = np.reshape([p.sign * tension[p.spring] * arms[p.port] for p in mine], (len(mine), *points))
        load = np.reshape([tension[p.spring] for p in mine], (len(mine), *points)).sum(axis=0)  # ≤ their resultant
        L = [ratios.get((p.spring, *ports[p.port]), 0.0) for p in mine]
        plus, minus = band_edges(terms, L, friction.bearing(i).friction_torque(load))
        out.append((plus, minus, terms.sum(axis=0)))
    return tuple(np.array([o[k] for o in out]) for k in range(3))


@dataclass
class FrictionBand:
    """The friction band of a design on its evaluation's grid.

    Attributes
    ----------
    friction : Friction
    theta : ndarray (m, N)
        The grid points [rad].
    plus, minus : ndarray (m, N)
        τ⁺ and τ⁻ [N·m]: the torques that turn each joint towards +θ and −θ.
    frictionless : ndarray (m, N)
        Σ T a [N·m], the torque without friction (the design's τ unless its centre is tracked).
    target : ndarray (m, N)
        τ_d [N·m].
    paths : list of (Path, float)
        Each sliding cable path and the log of its tension ratio L.
    grid : int
        Angles per joint: the points are the tensor grid of ``grid`` angles per joint, in C order.
    """

    friction: Friction
    theta: np.ndarray
    plus: np.ndarray
    minus: np.ndarray
    frictionless: np.ndarray
    target: np.ndarray
    paths: list
    grid: int

    @property
    def width(self) -> np.ndarray:
        """τ⁺ − τ⁻ [N·m] (m, N): the hysteresis, the band's width."""
        return self.plus - self.minus

    @property
    def centre(self) -> np.ndarray:
        """(τ⁺ + τ⁻)/2 [N·m] (m, N)."""
        return 0.5 * (self.plus + self.minus)

    def peaks(self) -> np.ndarray:
        """Each joint's target's peak |τ_d| [N·m] over the grid."""
        return np.abs(self.target).max(axis=1)

    def joints(self) -> list[dict]:
        """Per joint: its widest band ``width_max`` [N·m], that as a share of the target's peak
        (None for a target that vanishes), where (``theta_at_max`` [rad]), the largest distance
        of the band's centre from the target ``centre_offset_max`` [N·m], and the largest
        ``outside_max`` [N·m] by which the target leaves the band (0: inside everywhere)."""
        out = []
        for i, peak in enumerate(self.peaks()):
            n = int(np.argmax(self.width[i]))
            outside = np.maximum(self.target[i] - self.plus[i], self.minus[i] - self.target[i])
            out.append({"width_max": float(self.width[i, n]),
                        "width_max_share": float(self.width[i, n] / peak) if peak > 0 else None,
                        "theta_at_max": [float(t) for t in self.theta[:, n]],
                        "centre_offset_max": float(np.abs(self.centre[i] - self.target[i]).max()),
                        "outside_max": float(max(outside.max(), 0.0))})
        return out

    def to_dict(self, indices: list[int] | None = None) -> dict:
        """result.json's ``friction_band`` (SI): the friction, each sliding path's tension
        ratio, each joint's numbers (:meth:`joints`) and ``samples``: per joint rows
        [θ₁ … θ_m, τ⁻, frictionless τ, τ⁺] at each joint's grid ``indices`` (all by default),
        in C order of the joints' angles."""
        m, n = self.theta.shape[0], self.grid
        keep = np.ix_(*[np.asarray(indices if indices is not None else range(n))] * m)
        cut = lambda a: a.reshape((n,) * m)[keep].ravel()  # noqa: E731
        theta = [cut(t) for t in self.theta]
        samples = [np.column_stack([*theta, cut(self.minus[i]), cut(self.frictionless[i]), cut(self.plus[i])]).tolist()
                   for i in range(m)]
        return {"centre_tracked": self.friction.centre,
                "paths": [{"path": p.label, "log_ratio": L, "ratio": float(np.exp(L))} for p, L in self.paths],
                "joints": self.joints(), "samples": samples}

    def summary_line(self, names: list[str]) -> str:
        """The summary's line: each joint's widest band as a share of its target's peak, and
        whether the target lies inside it (``names``: the joints')."""
        parts = []
        for name, joint in zip(names, self.joints()):
            share = "" if joint["width_max_share"] is None else f" ({100 * joint['width_max_share']:.3g} % of the target's peak)"
            where = ("target inside" if joint["outside_max"] == 0
                     else f"target outside by up to {1e3 * joint['outside_max']:.3g} N·mm")
            parts.append(f"{name} {1e3 * joint['width_max']:.4g} N·mm{share}, {where}")
        centre = ", its centre tracked" if self.friction.centre else ""
        return f"  friction band τ⁺ − τ⁻ (holds any payload still{centre}) at its widest per joint: {'; '.join(parts)}"


def friction_band(evaluation, friction: Friction | None = None) -> FrictionBand:
    """The friction band of an evaluated design (:class:`cadcam.verify.evaluate.Evaluation`) at
    its grid points, under ``friction`` (default the problem's; frictionless without one)."""
    problem = evaluation.problem
    friction = friction if friction is not None else (problem.friction or Friction())
    springs = problem.spring_parameters()
    tension = springs.preload[:, None] + springs.rate[:, None] * evaluation.x
    plus, minus, frictionless = band_of(problem, friction, tension, port_arms(evaluation))
    ratios, ports = friction.path_log_ratios(), problem.ports
    paths = [(p, ratios[key]) for p in cable_paths(problem) if (key := (p.spring, *ports[p.port])) in ratios]
    return FrictionBand(friction, evaluation.theta, plus, minus, frictionless, evaluation.tau_d, paths, evaluation.grid)
