"""The torque band a built part falls in: the design's torque under the tolerances of its
springs, placements and profiles (:data:`cadcam.problem.TOLERANCES`, or the spec's
``[tolerances]``).

First order, by automatic differentiation of the torque model with its departure rootfinder
(:func:`cadcam.verify.model.parameter_model`): each parameter p at p₀ ± Δp moves
the torque by about |∂τ/∂p| Δp, and the band's half-width at an angle is the sum over the
parameters, each at the end that moves the torque the same way,

    w(θ) = Σ_p |∂τ/∂p(θ)| Δp.

Then the worst corner is re-checked without linearising: at each joint's angle of widest
band, every parameter is set to the end its derivative's sign picks and the torque model is
evaluated there; the band is trustworthy to first order where the two agree.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..problem import TOLERANCES
from ..variation import Layout, directions
from .model import parameter_model


@dataclass
class Band:
    """The tolerance band of a design on a grid of angles.

    Attributes
    ----------
    tolerance : dict
        The tolerances used (:attr:`cadcam.problem.Problem.tolerance`).
    half_width : ndarray
        w (m, N) [N·m]: the torque lies in τ ± w at each grid point, to first order.
    parts : dict
        Each tolerance's share of ``half_width`` (m, N) [N·m].
    corners : list of dict
        Per joint: the grid point of widest band (``theta`` [rad]), its first-order ``predicted``
        half-width and the ``recomputed`` |τ(worst corner) − τ| there [N·m].
    """

    tolerance: dict
    half_width: np.ndarray
    parts: dict
    corners: list
    #: The derivatives the band is made of (what :mod:`cadcam.verify.builds` samples).
    sensitivity: "Sensitivity | None" = None

    def label(self) -> str:
        """The tolerances in words: ``rate ± 10 %, …, profile ± 0.05 mm``."""
        return ", ".join(f"{key} ± {100 * v:g} %" if TOLERANCES[key].unit == "ratio" else f"{key} ± {1e3 * v:g} mm"
                         for key, v in self.tolerance.items())

    def to_dict(self) -> dict:
        """result.json's ``tolerance_band``: the tolerances, each joint's widest half-width,
        its parts there and the worst corner's re-check (SI)."""
        joints = []
        for i, corner in enumerate(self.corners):
            n = int(np.argmax(self.half_width[i]))
            joints.append({"half_width_max": float(self.half_width[i, n]),
                           "half_width_rms": float(np.sqrt(np.mean(self.half_width[i] ** 2))),
                           "parts_at_max": {k: float(v[i, n]) for k, v in self.parts.items()},
                           "worst_corner": corner})
        return {"tolerances": dict(self.tolerance), "joints": joints}


@dataclass
class Sensitivity:
    """The torque's derivatives with respect to every parameter of a design at its grid points,
    and the parameter steps each tolerance allows.

    Attributes
    ----------
    model : casadi.Function
        The torque model with its derivatives (:func:`cadcam.verify.model.parameter_model`).
    layout : Layout
        Where each parameter sits in p = [c; k; x0; F0; q], and the design's values p₀.
    z : ndarray
        The solved unknowns at every grid point (:func:`_unknowns`).
    jacobian : ndarray
        dτ/dp (m, N, P) [N·m per unit of p], the poses re-solved (implicit function theorem).
    directions : dict
        For each tolerance, its parameter steps (P × steps), each its Δp (:func:`cadcam.variation.directions`).
    labels : dict
        For each tolerance, each step's part in words (``spring 1's rate``).
    """

    model: Any
    layout: Layout
    z: np.ndarray
    jacobian: np.ndarray
    directions: dict
    labels: dict


def sensitivity(evaluation, model=None) -> Sensitivity:
    """The :class:`Sensitivity` of an evaluated design (:class:`cadcam.verify.evaluate.Evaluation`)
    at its grid points, about the poses the evaluation solved; ``model``: its
    :func:`cadcam.verify.model.parameter_model`, built here if not given (it depends on the
    problem's structure only, not on its targets or parameter values)."""
    problem, design, theta = evaluation.problem, evaluation.design, evaluation.theta
    layout = Layout(problem, design)
    model = parameter_model(problem, design.bases) if model is None else model
    z = _unknowns(evaluation)
    N = theta.shape[1]
    # the N blocks (m × P) side by side → (m, N, P)
    J = np.stack(np.hsplit(np.asarray(model.map(N)(theta, *layout.split(layout.nominal), z)[3]), N), axis=1)
    return Sensitivity(model, layout, z, J, *directions(problem, design.bases, layout))


def tolerance_band(evaluation) -> Band:
    """The band of an evaluated design (:class:`cadcam.verify.evaluate.Evaluation`) at its grid
    points, about the poses the evaluation solved (see the module)."""
    problem, theta = evaluation.problem, evaluation.theta
    sens = sensitivity(evaluation)
    model, layout, z, J = sens.model, sens.layout, sens.z, sens.jacobian
    parts = {key: np.abs(J @ D).sum(axis=2) for key, D in sens.directions.items()}
    half = sum(parts.values())
    D = np.concatenate(list(sens.directions.values()), axis=1)
    corners = [_worst_corner(model, layout, theta, z, D, J, half, i) for i in range(theta.shape[0])]
    return Band({key: problem.tolerance[key] for key in parts}, half, parts, corners, sens)


def _unknowns(evaluation) -> np.ndarray:
    """The solved unknowns at every grid point (rows: each mechanism's z at θ, then at its
    reference angle, as :func:`cadcam.verify.model.parameter_model` stacks them)."""
    rows = []
    for mech, unit in zip(evaluation.problem.mechanisms, evaluation.units):
        at = np.searchsorted(unit.theta, evaluation.theta[mech.joint])  # the joint's grid index
        rows += [unit.z[:, at], np.repeat(np.reshape(unit.z_ref, (-1, 1)), at.size, axis=1)]
    return np.vstack(rows)


#: Newton steps that re-solve the poses at the worst corner from the nominal ones.
CORNER_NEWTON_STEPS = 8
#: How many times a Newton step at the worst corner is halved before it is given up.
CORNER_HALVINGS = 20


def _damped(z: np.ndarray, step: np.ndarray, now: float, residual) -> np.ndarray:
    """The pose ``z`` less ``step``, halved until its largest ``residual`` is below ``now`` (a
    full Newton step from a pose far from the root, or across a branch of a root-finding
    function, can throw the pose far away and the torque with it); ``z`` itself where no
    halving does better."""
    for k in range(CORNER_HALVINGS):
        trial = z - step / 2**k
        value = np.abs(residual(trial)).max()
        if np.isfinite(value) and value < now:
            return trial
    return z


def _worst_corner(model, layout, theta, z, D, J, half, i: int) -> dict:
    """Joint ``i``'s worst corner re-checked: at its grid point of widest band, every step of
    ``D`` taken to the end that moves τ_i the way its derivative says, the poses re-solved there
    by Newton from the nominal ones, and the torque of ``model``
    (:func:`cadcam.verify.model.parameter_model`) evaluated without linearising."""
    n = int(np.argmax(half[i]))
    corner = layout.nominal + D @ np.sign(J[i, n] @ D)
    at, zc = theta[:, n], z[:, n].copy()

    def residual(pose):
        return np.asarray(model(at, *layout.split(corner), pose)[1]).ravel()

    for _ in range(CORNER_NEWTON_STEPS):
        _, R, Rz, _ = model(at, *layout.split(corner), zc)
        R = np.asarray(R).ravel()
        # least squares: a pose where the residual's Jacobian is singular (a cable leaving at
        # a flat stretch) takes the least step; the residual reported says how far it got
        step = np.linalg.lstsq(np.asarray(Rz), R, rcond=None)[0]
        zc = _damped(zc, step, np.abs(R).max(), residual)
    tau_corner, R = (np.asarray(v).ravel() for v in model(at, *layout.split(corner), zc)[:2])
    tau = np.asarray(model(at, *layout.split(layout.nominal), z[:, n])[0]).ravel()
    return {"theta": [float(t) for t in at], "predicted": float(half[i, n]),
            "recomputed": float(abs(tau_corner[i] - tau[i])), "residual": float(np.abs(R).max())}
