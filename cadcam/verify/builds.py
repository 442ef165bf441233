"""Builds, not corners: a Monte Carlo of built devices under the declared tolerances, and the
adjustment that sets each one back.

**The builds.** A build draws every part within its tolerance (the spec's ``[tolerances]``,
:data:`cadcam.problem.TOLERANCES`): each spring's rate and preload, each spring's
pre-extension and each placed parameter of the mechanisms (placement), each profile's offset
— one draw per step of the tolerance band (:attr:`cadcam.verify.tolerance.Sensitivity.directions`)
— and then each friction coefficient that moves the friction band's centre, a guide's μ or an
idler's c (:func:`cadcam.variation.friction_parts`, drawn after the others so that a spec
without friction draws what it drew before), from the distribution ``[builds] distribution``
names (:data:`cadcam.problem.DISTRIBUTIONS`), by a generator seeded with ``[builds] seed``.

**Its torque** is not solved again: it is the design's, moved by a model exact where the
physics is polynomial and second order where it is not (:class:`BuildModel`). With p the
parameters of :func:`cadcam.verify.model.parameter_model`, s ⊂ p the springs' rates (with an
adjustment, their pre-extensions and preloads too) and g the rest,

    τ(p₀ + Δ) ≈ τ + J Δ + Σ_σ∈s Δ_σ (H_σ,g Δ_g + ½ H_σ,s Δ_s) + ½ Σ_u T_u Δ_u²,

J = dτ/dp the band's derivatives and H_σ = ∂(dτ/dp)/∂σ, exact: at a fixed geometry the torque
τ = Σ_j G_j (k_j x_j + F0_j) is of the second degree in the springs' parameters, and the poses
do not depend on them, so that a rate's product with every other deviation (and a screw's)
is kept. T_u is the torque's curvature along a slot u, from the design re-evaluated at the
slot's ends. Left out: the second order in the geometry's own deviations besides a slot's,
and the products of a pre-extension's or a preload's tolerance with the geometry's — tenths
of a millimetre on parts of centimetres (tests/verify/test_builds.py measures what is left
against builds evaluated exactly). A block of builds is then a few matrix products.

**With friction** a build's torque is its friction band's centre, where a payload is held
still midway between rising and sinking (:mod:`cadcam.verify.friction`): each sliding cable
path k adds t_k (cosh L_k − w_k) to the design's torque, t_k = T_j P_jp a_p its frictionless
term at the design's tensions and arms, L_k its log tension ratio at the build's friction
coefficients (exact in them) and w_k its arm's weight in the design's torque (cosh L_k at the
declared coefficients where the design tracks the centre, else 1: then the centre's offset is
every build's error too). Left out: the products of a friction coefficient's deviation with
the other parts' (a share of cosh L_k − w_k of theirs).

**The adjustment** (``[adjustment]``): each spring's tensioning screw shifts its pre-extension
within ± ``preload_travel``; a slot moves each mechanism's spring end within ± ``slot_travel``
along the placed parameter ``slot``. Every build is set twice:

* *at best*: the settings within their ranges that minimise Σ (τ − τ_d)² over the grid (each
  joint's error a share of its scale), by Gauss–Newton steps on the model, the ranges bounds;
* *as set*, what a builder following the adjustment table gets: each spring's rate measured
  before it is fitted and each slot set from the table's row for it (the best setting of a
  build whose only error is that rate; several springs' corrections added), then each screw
  turned until the arm holds still at the stated pose θ* (the torque error there nulled),
  θ* the grid pose that gives the least P95.

**A payload range** (a pendulum target's ``mass_range``): for each of :data:`MASS_ROWS` masses
the setting that meets its target best, by Gauss–Newton steps on the design re-evaluated
exactly at each setting (the moves are too large for the model), and the RMS error there.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from ..designs import Design
from ..physics.friction import Guide
from ..problem import DISTRIBUTIONS, Problem
from ..variation import Setting, draws, friction_parts, joint_scale, settings
from .evaluate import Evaluation, evaluate
from .friction import cable_paths, port_arms
from .tolerance import Sensitivity, sensitivity

#: Most grid points (over the tensor grid of every joint) a build's error is taken at: a larger
#: grid is sampled every k-th angle per joint, both ends kept (a 46² grid at 23², 26³ at 9³).
BUILD_POINTS = 1024
#: Numbers [-] held at once by one block of builds (points × builds × the model's terms, 64 MB):
#: the builds are streamed in blocks.
BLOCK_NUMBERS = 1 << 23
#: Gauss–Newton steps of each build's best setting: the model is quadratic along a slot only.
SETTING_STEPS = 4
#: Passes of the active-set solve of a step within the ranges (A + 1 suffice for A settings
#: whose bounds bind one after another; more cost nothing once none changes).
ACTIVE_SET_PASSES = 8
#: Rows of the adjustment table per spring: measured rates across ± its rate tolerance.
TABLE_ROWS = 11
#: Most poses among which the stated pose θ* of "holds still" is chosen, and the builds
#: (the first of the draws) that choose it.
HOLD_CANDIDATES = 64
HOLD_BUILDS = 2000
#: Masses of a pendulum's mass_range the payload rows set, both ends included.
MASS_ROWS = 6
#: Gauss–Newton steps of a payload's setting, each on the design re-evaluated exactly, and the
#: step [share of each setting's range] below which it has converged.
PAYLOAD_STEPS = 8
PAYLOAD_TOL = 1e-6
#: The percentiles reported.
PERCENTILES = (50, 95)
#: The ``[builds]`` keys the simulation reads and reports (the others are the robust
#: objective's, :mod:`cadcam.solve.robust`).
SIMULATION_KEYS = ("count", "seed", "distribution")


def adjusts(problem: Problem) -> bool:
    """Whether ``problem``'s builds are adjusted: springs, builds to simulate and an
    ``[adjustment]`` with a travel (what writes the adjustment table)."""
    adjust = problem.adjustment
    return bool(problem.springs) and problem.build_options["count"] > 0 and (
        adjust["preload_travel"] > 0 or (bool(adjust["slot"]) and adjust["slot_travel"] > 0))


# -- builds evaluated exactly -------------------------------------------------------------------
def built(problem: Problem, design: Design, layout, step: np.ndarray) -> tuple[Problem, Design]:
    """The problem and design of a build whose parameters p (``layout``:
    :class:`cadcam.variation.Layout`) are the design's moved by ``step`` (P): springs'
    rates and preloads, pre-extensions, placed parameters and profile coefficients — what
    :func:`cadcam.verify.evaluate.evaluate` evaluates exactly.

    Raises ValueError for a step in a mechanism's parameter that is not placed (no build moves
    it), or that its :meth:`~cadcam.mechanisms.base.Mechanism.placed` does not move.
    """
    c, k, x0, F0, q = layout.split(layout.nominal + step)
    springs = tuple(replace(s, rate=float(k[j]), preload=float(F0[j])) for j, s in enumerate(problem.springs))
    mechanisms, first, dq = [], 0, layout.split(step)[4]
    for mech in problem.mechanisms:
        n = len(mech.parameters)
        moved = {quantity.name: float(v) for quantity, v, dv in zip(mech.parameters, q[first:first + n], dq[first:first + n])
                 if dv != 0}
        if any(not quantity.placed for quantity in mech.parameters if quantity.name in moved):
            raise ValueError(f"{mech.name}: only placed parameters move in a build, not {sorted(moved)}")
        placed = mech.placed(moved) if moved else mech
        if not _moved_to(mech, placed, moved):
            raise ValueError(f"{mech.name}: {mech.kind} cannot move {sorted(moved)} (Mechanism.placed)")
        mechanisms.append(placed)
        first += n
    sizes = np.cumsum([b.size for b in design.bases])[:-1]
    coefficients = [np.asarray(v, dtype=float) for v in np.split(c, sizes)]
    return (replace(problem, springs=springs, mechanisms=tuple(mechanisms)),
            Design(design.bases, coefficients, np.asarray(x0, dtype=float), design.poses))


def _moved_to(mech, placed, moved: dict) -> bool:
    """Whether ``placed`` (``mech`` moved) has the parameters ``moved`` asks for (angles up to
    whole turns: a spring end's angle is read back from its position)."""
    now = dict(zip(placed.parameter_names, placed.parameter_values()))
    for quantity in mech.parameters:
        if quantity.name in moved:
            off = now[quantity.name] - moved[quantity.name]
            if quantity.unit == "rad":
                off = (off + np.pi) % (2 * np.pi) - np.pi
            if abs(off) > 1e-12 * max(1.0, abs(moved[quantity.name])):
                return False
    return True


# -- the model --------------------------------------------------------------------------------
@dataclass
class FrictionShift:
    """How a build's friction coefficients move its torque (see the module): rows as
    :class:`BuildModel`'s, one draw per part of :func:`cadcam.variation.friction_parts`."""

    terms: np.ndarray  # (K, rows) each sliding path's frictionless term t_k [N·m], 0 off its joint
    weights: np.ndarray  # (K,) w_k, its arm's weight in the design's torque
    parts: list  # (E,) the guides and idlers drawn
    paths: np.ndarray  # (E,) the sliding path (an index of terms) each part is on

    def shift(self, deviation: np.ndarray) -> np.ndarray:
        """The change (rows, B) [N·m] of the builds' torque whose parts' coefficients are off by
        the shares ``deviation`` (E, B) (each coefficient times 1 + its share)."""
        L = np.zeros((len(self.weights), deviation.shape[1]))
        for part, path, share in zip(self.parts, self.paths, deviation):
            L[path] += part.log_ratio(1.0 + share)
        return self.terms.T @ (np.cosh(L) - self.weights[:, None])


def friction_shift(ev: Evaluation, points: np.ndarray) -> FrictionShift | None:
    """The :class:`FrictionShift` of the evaluated design ``ev`` at the grid ``points`` kept
    (:func:`kept_points`); None without a guide or an idler."""
    problem = ev.problem
    parts = friction_parts(problem)
    if not parts:
        return None
    ports, scales = problem.ports, problem.arm_scales()
    keys = [(part.spring, part.port.mechanism, part.port.name) for part in parts]
    paths = [p for p in cable_paths(problem) if (p.spring, *ports[p.port]) in keys]
    springs = problem.spring_parameters()
    tension = (springs.preload[:, None] + springs.rate[:, None] * ev.x)[:, points]
    arms = port_arms(ev)[:, points]
    N = points.size
    terms = np.zeros((len(paths), len(problem.joints) * N))
    for k, p in enumerate(paths):
        terms[k, p.joint * N:(p.joint + 1) * N] = p.sign * tension[p.spring] * arms[p.port]
    where = [(p.spring, *ports[p.port]) for p in paths]
    return FrictionShift(terms, np.array([scales.get(key, 1.0) for key in where]), parts,
                         np.array([where.index(key) for key in keys]))


@dataclass
class BuildModel:
    """A build's torque error on the grid points kept (:func:`kept_points`) as a function of its
    parameter step Δ (see the module).

    Rows are (joint i, point n) in the order i·N + n, N the points kept; ``weights`` (rows) is
    1 / the row's joint's scale (0 for a joint without a torque goal).
    """

    error0: np.ndarray  # (rows,) τ − τ_d [N·m]
    J: np.ndarray  # (rows, P)
    pairs: np.ndarray  # (s,) the indices in p of the spring parameters σ whose products are kept
    H: np.ndarray  # (s, rows, P): ∂(dτ/dp)/∂σ
    curvature: dict  # parameter index → (rows,) T_u
    weights: np.ndarray  # (rows,)
    joints: int
    #: How the friction coefficients move the torque; their deviations follow p's in a step
    #: (a step of p alone: the declared coefficients).
    friction: FrictionShift | None = None

    @property
    def points(self) -> int:
        """N: grid points kept per joint row block."""
        return self.error0.size // self.joints

    def error(self, step: np.ndarray) -> np.ndarray:
        """τ − τ_d (rows, B) [N·m] of the builds whose parameters moved by ``step`` (P, B; or
        (P + E, B), the friction parts' deviations after p's)."""
        step, deviation = step[:self.J.shape[1]], step[self.J.shape[1]:]
        half = step.copy()
        half[self.pairs] *= 0.5  # their products with each other, counted once
        s, rows, P = self.H.shape
        second = np.einsum("sb,srb->rb", step[self.pairs], (self.H.reshape(s * rows, P) @ half).reshape(s, rows, -1))
        out = self.error0[:, None] + self.J @ step + second
        for index, T in self.curvature.items():
            out += 0.5 * T[:, None] * step[index] ** 2
        if self.friction is not None:
            out += self.friction.shift(deviation if deviation.size else np.zeros((len(self.friction.parts),
                                                                                  step.shape[1])))
        return out

    def tangent(self, step: np.ndarray, index: int) -> np.ndarray:
        """d(τ − τ_d)/dp_index (rows, B) at the builds ``step`` (P, B, or P + E as :meth:`error`)."""
        step = step[:self.J.shape[1]]
        where = np.flatnonzero(self.pairs == index)
        if where.size:  # a σ of H: its row is its derivative's change with every step
            return self.J[:, [index]] + self.H[where[0]] @ step
        out = self.J[:, [index]] + self.H[:, :, index].T @ step[self.pairs]
        if index in self.curvature:
            out = out + self.curvature[index][:, None] * step[index]
        return out


def kept_points(grid: int, joints: int) -> np.ndarray:
    """Flat indices (C order) into the tensor grid of ``grid`` angles per joint of the points a
    build's error is taken at: all of them up to :data:`BUILD_POINTS`, else every k-th angle
    per joint, both ends kept, k the least that fits."""
    for k in range(1, grid):
        kept = sorted(set(range(0, grid, k)) | {grid - 1})
        if len(kept) ** joints <= BUILD_POINTS:
            break
    axes = np.meshgrid(*[kept] * joints, indexing="ij")
    return np.ravel_multi_index(tuple(a.ravel() for a in axes), (grid,) * joints)


def mixed_function(model: ca.Function) -> ca.Function:
    """``mixed(theta, c, k, x0, F0, q, z) -> H``: ∂ vec(dτ/dp) / ∂[k; x0; F0] ((m·P) × 3S), from
    ``model`` (:func:`cadcam.verify.model.parameter_model`) at fixed poses: exact, the poses
    not depending on the springs."""
    args = [ca.SX.sym(model.name_in(i), model.size_in(i)) for i in range(model.n_in())]
    dtau_dp = model(*args)[3]
    return ca.Function("mixed", args, [ca.jacobian(ca.vec(dtau_dp), ca.vertcat(*args[2:5]))])


def joint_scales(ev: Evaluation) -> np.ndarray:
    """Each joint's scale [N·m]: the target's peak |τ_d| over the grid, or the joint's torque
    floor where that is larger (a vanishing target); NaN for a joint without a torque goal."""
    return np.array([joint_scale(ev.problem, i, ev.tau_d[i]) for i in range(len(ev.problem.joints))])


def build_model(ev: Evaluation, sens: Sensitivity, mixed: ca.Function, slots: list[Setting]) -> tuple[BuildModel, list]:
    """The :class:`BuildModel` of the evaluated design ``ev`` with its sensitivity ``sens`` and
    ``mixed`` (:func:`mixed_function`), its curvature along each slot of ``slots`` from the
    design re-evaluated at the slot's ends (:func:`slot_curvature`); and what those ends
    violate, one sentence each (a slot's range is a limit of the design)."""
    problem, layout = ev.problem, sens.layout
    m, S = len(problem.joints), len(problem.springs)
    points = kept_points(ev.grid, m)
    N, P = points.size, layout.size
    theta, z = ev.theta[:, points], sens.z[:, points]
    H = np.asarray(mixed.map(N)(theta, *layout.split(layout.nominal), z))  # (m·P) × (N·3S)
    kept = 3 if adjusts(problem) else 1  # the rates; with an adjustment, x0 and F0 too
    H = H.reshape(P, m, N, 3 * S).transpose(3, 1, 2, 0)[:kept * S].reshape(kept * S, m * N, P)
    pairs = np.concatenate([np.arange(S) + layout.start[name] for name in ("k", "x0", "F0")[:kept]])
    scales = joint_scales(ev)
    weights = np.repeat(np.where(np.isfinite(scales), 1.0 / scales, 0.0), N)
    J = sens.jacobian[:, points, :].reshape(m * N, P)
    curvature, violated = {}, []
    for slot in slots:
        curvature[slot.index], words = slot_curvature(ev, layout, slot, J[:, slot.index], points)
        violated += words
    return (BuildModel((ev.tau - ev.tau_d)[:, points].ravel(), J, pairs, H, curvature, weights, m,
                       friction_shift(ev, points)), violated)


def slot_curvature(ev: Evaluation, layout, slot: Setting, slope: np.ndarray, points: np.ndarray) -> tuple:
    """The torque's curvature T (rows,) along ``slot`` over its range, from the design
    re-evaluated exactly at the range's ends (τ(±h) = τ ± J h + ½ T h², h its bound: central,
    or from the one end whose design holds its limits and ``slope`` J; 0 if neither does), and
    the sentences of what each end violates."""
    h, tau = slot.bound, ev.tau[:, points].ravel()
    ends, words = {}, []
    for sign in (1.0, -1.0):
        p, d = built(ev.problem, ev.design, layout, layout.step(slot.index, sign * h))
        end = evaluate(p, d, grid=ev.grid)
        new = [v for v in end.violations if _limit(v) not in {_limit(w) for w in ev.violations}]
        if new:
            words += [f"{slot.name} at {sign * 1e3 * slot.travel:+g} mm: {v}" for v in new]
        else:
            ends[sign] = end.tau[:, points].ravel()
    if len(ends) == 2:
        return (ends[1.0] + ends[-1.0] - 2 * tau) / h**2, words
    if ends:
        sign, end = next(iter(ends.items()))
        return 2 * (end - tau - sign * slope * h) / h**2, words
    return np.zeros_like(tau), words


def _limit(violation: str) -> str:
    """A violation's sentence without its margin: the limit it names."""
    return violation.split(" (margin")[0]


# -- settings per build -------------------------------------------------------------------------
def box_least_squares(M: np.ndarray, g: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """min ½ dᵀ M d + gᵀ d within low ≤ d ≤ high, for a batch: M (B, A, A) positive
    semidefinite, g, low, high (B, A); by an active set, each pass solving for the settings
    off their bounds and moving to a bound those that pass it, or off one those whose
    gradient points inside."""
    B, A = g.shape
    eye = np.broadcast_to(np.eye(A), (B, A, A))
    ridge = _ridge(M) * eye
    free = np.ones((B, A), dtype=bool)
    d = np.zeros((B, A))
    for _ in range(ACTIVE_SET_PASSES):
        both = free[:, :, None] & free[:, None, :]
        system = np.where(both, M + ridge, eye * ~free[:, :, None])
        rhs = np.where(free, -g - np.einsum("bij,bj->bi", M, np.where(free, 0.0, d)), d)
        d = np.where(free, np.linalg.solve(system, rhs[..., None])[..., 0], d)
        passed = free & ((d < low) | (d > high))
        d = np.clip(d, low, high)
        grad = np.einsum("bij,bj->bi", M, d) + g
        release = ~free & (((d <= low) & (grad < 0)) | ((d >= high) & (grad > 0)))
        if not passed.any() and not release.any():
            break
        free = (free & ~passed) | release
    return d


def _ridge(M: np.ndarray) -> np.ndarray:
    """A ridge (B, 1, 1) for the batch of normal matrices ``M`` (B, A, A), 10⁻¹² of their
    trace: a setting with no effect stays where it is instead of making the system singular."""
    return 1e-12 * np.maximum(np.trace(M, axis1=1, axis2=2), 1e-300)[:, None, None]


def best_settings(model: BuildModel, step: np.ndarray, chosen: list[Setting]) -> np.ndarray:
    """Each build's best settings (A, B) [parameter units] within their ranges: least squares of
    the weighted error over the grid, by :data:`SETTING_STEPS` Gauss–Newton steps from the
    middle of each range."""
    a = np.zeros((len(chosen), step.shape[1]))
    bound = np.array([s.bound for s in chosen])[:, None]
    for _ in range(SETTING_STEPS):
        full = with_settings(step, chosen, a)
        r = model.weights[:, None] * model.error(full)
        K = np.stack([model.weights[:, None] * model.tangent(full, s.index) for s in chosen])  # (A, rows, B)
        M = np.einsum("arb,crb->bac", K, K)
        g = np.einsum("arb,rb->ba", K, r)
        a = a + box_least_squares(M, g, (-bound - a).T, (bound - a).T).T
    return a


def with_settings(step: np.ndarray, chosen: list[Setting], a: np.ndarray) -> np.ndarray:
    """The builds' steps (P, B) with the settings ``a`` (A, B) added."""
    out = step.copy()
    for s, value in zip(chosen, a):
        out[s.index] += value
    return out


def screw_terms(model: BuildModel, step: np.ndarray, screws: list[Setting]) -> tuple[np.ndarray, np.ndarray]:
    """The builds' error (rows, B) and its derivative along each screw (S, rows, B): the error
    is affine in the screws, the torque being linear in each pre-extension."""
    return model.error(step), np.stack([model.tangent(step, s.index) for s in screws])


def held_screws(model: BuildModel, error: np.ndarray, K: np.ndarray, screws: list[Setting], pose: int) -> np.ndarray:
    """The screws' settings (S, B) that null the torque error at the grid pose ``pose`` (the arm
    holds still there) — every joint with a torque goal, in least squares, the least settings
    where the screws are more than the joints — within their ranges; ``error``, ``K`` from
    :func:`screw_terms`."""
    rows = [i * model.points + pose for i in range(model.joints) if model.weights[i * model.points] > 0]
    e, k = error[rows].T[..., None], K[:, rows].transpose(2, 1, 0)  # (B, r, 1), (B, r, S)
    kt = k.transpose(0, 2, 1)
    small = min(len(rows), len(screws))
    normal = kt @ k if len(rows) >= len(screws) else k @ kt  # (B, small, small)
    normal = normal + _ridge(normal) * np.eye(small)  # a screw with no effect there stays put
    if len(rows) >= len(screws):
        delta = -np.linalg.solve(normal, kt @ e)[..., 0]
    else:
        delta = -(kt @ np.linalg.solve(normal, e))[..., 0]
    bound = np.array([s.bound for s in screws])
    return np.clip(delta, -bound, bound).T


@dataclass
class Table:
    """The adjustment table: per spring, rows of its measured rate (the other springs at their
    catalogue rate) and each slot's setting for it, with the screws' setting the "holds still"
    step then gives a build whose only error is that rate."""

    rates: np.ndarray  # (S, rows) [N/m]
    slots: np.ndarray  # (S, U, rows) [parameter units]
    screws: np.ndarray  # (S, S', rows) [m]

    def slot_settings(self, k: np.ndarray) -> np.ndarray:
        """The slots' settings (U, B) for the measured rates ``k`` (S, B): each spring's row
        interpolated, the springs' corrections from the middle row added."""
        S, U = self.slots.shape[:2]
        middle = self.slots[0, :, self.rates.shape[1] // 2]
        out = np.repeat(middle[:, None], k.shape[1], axis=1)
        for j in range(S):
            for u in range(U):
                out[u] += np.interp(k[j], self.rates[j], self.slots[j, u]) - middle[u]
        return out


def as_set(model: BuildModel, step: np.ndarray, chosen: list[Setting], table: "Table", rates: np.ndarray,
           pose: int | None) -> np.ndarray:
    """The settings (A, B) a builder following the table gives the builds ``step`` (P, B) whose
    springs' rates are ``rates`` (S, B): the slots from the table, then the screws nulling the
    error at the grid pose ``pose``."""
    a = slots_as_set(step, chosen, table, rates)
    screws = [i for i, s in enumerate(chosen) if s.screw]
    if screws and pose is not None:
        picked = [chosen[i] for i in screws]
        a[screws] = held_screws(model, *screw_terms(model, with_settings(step, chosen, a), picked), picked, pose)
    return a


def slots_as_set(step: np.ndarray, chosen: list[Setting], table: "Table", rates: np.ndarray) -> np.ndarray:
    """The settings (A, B) with the slots set from the table for the measured ``rates`` (S, B),
    within their ranges, the screws at the middle."""
    a = np.zeros((len(chosen), step.shape[1]))
    slots = [i for i, s in enumerate(chosen) if not s.screw]
    if slots:
        bound = np.array([chosen[i].bound for i in slots])[:, None]
        a[slots] = np.clip(table.slot_settings(rates), -bound, bound)
    return a


def largest_errors(model: BuildModel, step: np.ndarray) -> np.ndarray:
    """Each build's largest |τ − τ_d| per joint (m, B) [N·m]."""
    e = model.error(step).reshape(model.joints, model.points, -1)
    return np.abs(e).max(axis=1)


# -- the simulation -----------------------------------------------------------------------------
@dataclass
class Builds:
    """What the builds give (see the module); :meth:`to_dict` is ``result.json``'s ``builds``.

    Attributes
    ----------
    options : dict
        ``[builds]``: count, seed, distribution.
    sources : list of dict
        Each drawn part that moves the torque: its ``tolerance``, ``what`` and ``plus_minus``
        (the tolerance: a share, or metres).
    scales : ndarray
        Each joint's scale [N·m] (:func:`joint_scales`; NaN without a torque goal).
    before, best, set : ndarray or None
        Each build's largest |τ − τ_d| per joint (m, B) [N·m]: as built, at its best settings,
        as set by the table (None without an adjustment).
    chosen : list of Setting
        The adjustment's settings.
    pose : ndarray or None
        The stated pose θ* [rad] where the screws are set (None without screws).
    at_end : dict
        The share of builds with a setting at an end of its range, ``best`` and ``set``.
    table : Table or None
    payloads : list of dict
        Per mass of a pendulum's mass_range (:func:`payload_settings`).
    limits : list of str
        What the adjustment's ranges violate, one sentence each (a range is a limit of the design).
    seconds : float
        Wall time of the builds [s].
    """

    options: dict
    sources: list
    scales: np.ndarray
    before: np.ndarray
    best: np.ndarray | None
    set: np.ndarray | None
    chosen: list
    pose: np.ndarray | None
    at_end: dict
    table: Table | None
    payloads: list
    limits: list
    seconds: float

    def percentiles(self, which: str) -> np.ndarray:
        """P50 and P95 (2, m) [N·m] of ``before``, ``best`` or ``set``."""
        return np.percentile(getattr(self, which), PERCENTILES, axis=1)

    def to_dict(self) -> dict:
        """``result.json``'s ``builds`` (SI)."""
        stages = ["before"] + (["best", "set"] if self.chosen else [])
        joints = []
        for i, scale in enumerate(self.scales):
            if not np.isfinite(scale):
                joints.append(None)
                continue
            joints.append({"scale": float(scale), **{
                stage: {f"p{p}": float(v) for p, v in zip(PERCENTILES, self.percentiles(stage)[:, i])}
                for stage in stages}})
        out = {**{key: self.options[key] for key in SIMULATION_KEYS}, "distribution_words": DISTRIBUTIONS[self.options["distribution"]],
               "sources": self.sources, "joints": joints, "seconds": self.seconds}
        if self.chosen:
            out["adjustment"] = {
                "settings": [{"name": s.name, "what": s.what, "parameter_index": s.index, "travel": s.travel,
                              "per_metre": s.per_metre} for s in self.chosen],
                "hold_pose": None if self.pose is None else [float(t) for t in self.pose],
                "at_range_end": self.at_end, "limits": self.limits, "table": table_rows(self)[1]}
        if self.payloads:
            out["payloads"] = self.payloads
        return out


def simulate_builds(ev: Evaluation, sens: Sensitivity) -> Builds | None:
    """The builds of the design evaluated as ``ev`` (its grid) with its band's derivatives
    ``sens``, as its problem's ``[builds]``, ``[tolerances]`` and ``[adjustment]`` say; None
    where ``[builds] count`` is 0."""
    start = time.perf_counter()
    problem, layout = ev.problem, sens.layout
    options = problem.build_options
    if options["count"] == 0:
        return None
    chosen = settings(problem, layout)
    mixed = mixed_function(sens.model)
    model, violated = build_model(ev, sens, mixed, [s for s in chosen if not s.screw])
    D = with_friction(np.concatenate(list(sens.directions.values()), axis=1), model.friction,
                      problem.tolerance["friction"])
    xi = draws(options["seed"], options["count"], D.shape[1], options["distribution"])
    table = pose = None
    if chosen:
        table = rate_table(model, problem, layout, chosen)
        pose = hold_pose(model, D @ xi[:, :HOLD_BUILDS], chosen, table, layout)
        table = replace(table, screws=_table_screws(model, problem, layout, chosen, table, pose))
    before, best, set_, ends = [], [], [], {"best": 0, "set": 0}
    rows = model.error0.size * (len(model.pairs) + len(chosen) + 4)
    block = max(1, BLOCK_NUMBERS // rows)
    for first in range(0, options["count"], block):
        step = D @ xi[:, first:first + block]
        before.append(largest_errors(model, step))
        if chosen:
            rates = rates_of(step, layout, len(problem.springs))
            for name, a, out in (("best", best_settings(model, step, chosen), best),
                                 ("set", as_set(model, step, chosen, table, rates, pose), set_)):
                out.append(largest_errors(model, with_settings(step, chosen, a)))
                ends[name] += int(_at_end(a, chosen).sum())
    at_end = {name: n / options["count"] for name, n in ends.items()}
    theta = None if pose is None else ev.theta[:, kept_points(ev.grid, len(problem.joints))[pose]]
    payloads = payload_settings(ev, sens, chosen)
    return Builds(options, _sources(problem, sens), joint_scales(ev), _joined(before), _joined(best), _joined(set_),
                  chosen, theta, at_end, table, payloads, screw_limits(ev, chosen) + violated,
                  time.perf_counter() - start)


def with_friction(D: np.ndarray, friction: FrictionShift | None, tolerance: float) -> np.ndarray:
    """The steps ``D`` (P × columns) of the parts drawn, with a column and a row per friction
    part after them (its deviation, ± ``tolerance`` a share of its coefficient): a build's step
    is then (P + E) long, as :meth:`BuildModel.error` reads it."""
    if friction is None:
        return D
    E = len(friction.parts)
    out = np.zeros((D.shape[0] + E, D.shape[1] + E))
    out[:D.shape[0], :D.shape[1]] = D
    out[D.shape[0]:, D.shape[1]:] = tolerance * np.eye(E)
    return out


def rates_of(step: np.ndarray, layout, S: int) -> np.ndarray:
    """The springs' rates (S, B) [N/m] of the builds ``step`` (P, B)."""
    k = layout.start["k"]
    return layout.nominal[k:k + S, None] + step[k:k + S]


def screw_limits(ev: Evaluation, chosen: list[Setting]) -> list[str]:
    """What the screws' range violates, one sentence each: a spring whose extension over the
    range, shifted by ± its screw's travel, leaves [0, its largest extension]."""
    problem, metrics, out = ev.problem, ev.metrics, []
    for s in chosen:
        if not s.screw:
            continue
        j = s.number - 1
        low, high = metrics.extension_min[j] - s.travel, metrics.extension_max[j] + s.travel
        if low < 0:
            out.append(f"{s.name} at {-1e3 * s.travel:g} mm: spring {j + 1} goes slack (its extension reaches "
                       f"{1e3 * low:.3g} mm)")
        if high > problem.extension_limit(j):
            out.append(f"{s.name} at +{1e3 * s.travel:g} mm: spring {j + 1} extends {1e3 * high:.4g} mm, beyond its "
                       f"{1e3 * problem.extension_limit(j):.4g} mm")
    return out


def _joined(blocks: list) -> np.ndarray | None:
    """The blocks' builds side by side (m, B), or None without blocks."""
    return np.concatenate(blocks, axis=1) if blocks else None


def _sources(problem: Problem, sens: Sensitivity) -> list[dict]:
    """Each part drawn that moves the torque: its tolerance, the part in words and ± how far
    (the tolerance's value: a share, or metres)."""
    tol = problem.tolerance
    stepped = [{"tolerance": key, "what": label, "plus_minus": float(tol[key])}
               for key, D in sens.directions.items() for label, column in zip(sens.labels[key], D.T) if column.any()]
    return stepped + [{"tolerance": "friction", "what": _friction_words(part), "plus_minus": float(tol["friction"])}
                      for part in friction_parts(problem) if tol["friction"] > 0]


def _friction_words(part) -> str:
    """A friction part in words: ``spring 1's guide's mu``, ``spring 2's idler's coefficient``."""
    kind, name = ("guide", "mu") if isinstance(part, Guide) else ("idler", "coefficient")
    return f"spring {part.spring + 1}'s {kind} on {part.port.label()}: its {name}"


def _at_end(a: np.ndarray, chosen: list[Setting]) -> np.ndarray:
    """Whether each build (B,) has a setting at an end of its range."""
    bound = np.array([s.bound for s in chosen])[:, None]
    return np.any(np.abs(a) >= bound * (1 - 1e-9), axis=0)


def rate_table(model: BuildModel, problem: Problem, layout, chosen: list[Setting]) -> Table:
    """The table's rates and each slot's best setting for them (:class:`Table`; its screws are
    filled once the pose is chosen)."""
    S, tol = len(problem.springs), problem.tolerance["rate"]
    rates = np.array([s.rate * (1 + tol * np.linspace(-1, 1, TABLE_ROWS)) for s in problem.springs])
    slots = [i for i, s in enumerate(chosen) if not s.screw]
    out = np.zeros((S, len(slots), TABLE_ROWS))
    for j, spring in enumerate(problem.springs):
        step = np.zeros((layout.size, TABLE_ROWS))
        step[layout.start["k"] + j] = rates[j] - spring.rate
        out[j] = best_settings(model, step, chosen)[slots]
    return Table(rates, out, np.zeros((S, 0, TABLE_ROWS)))


def _table_screws(model: BuildModel, problem: Problem, layout, chosen: list[Setting], table: Table,
                  pose: int | None) -> np.ndarray:
    """The screws' settings (S, S', rows) of the table's rows: what "holds still" at ``pose``
    gives a build whose only error is that row's rate."""
    screws = [i for i, s in enumerate(chosen) if s.screw]
    out = np.zeros((len(problem.springs), len(screws), TABLE_ROWS))
    for j, spring in enumerate(problem.springs):
        step = np.zeros((layout.size, TABLE_ROWS))
        step[layout.start["k"] + j] = table.rates[j] - spring.rate
        rates = np.repeat([[s.rate] for s in problem.springs], TABLE_ROWS, axis=1)
        rates[j] = table.rates[j]
        out[j] = as_set(model, step, chosen, table, rates, pose)[screws]
    return out


def hold_pose(model: BuildModel, step: np.ndarray, chosen: list[Setting], table: Table, layout) -> int | None:
    """The grid pose (an index of the points kept) where the screws are set so that the arm holds
    still: the one of at most :data:`HOLD_CANDIDATES` that gives the builds ``step`` the least
    P95 of their worst weighted error; None without screws."""
    screws = [s for s in chosen if s.screw]
    if not screws:
        return None
    slotted = with_settings(step, chosen, slots_as_set(step, chosen, table, rates_of(step, layout, len(table.rates))))
    error, K = screw_terms(model, slotted, screws)
    candidates = np.unique(np.linspace(0, model.points - 1, min(HOLD_CANDIDATES, model.points)).round().astype(int))
    scores = []
    for n in candidates:
        held = error + np.einsum("srb,sb->rb", K, held_screws(model, error, K, screws, n))
        scores.append(np.percentile(np.abs(model.weights[:, None] * held).max(axis=0), 95))
    return int(candidates[int(np.argmin(scores))])


def table_rows(builds: Builds) -> tuple[list[str], list[list[float]]]:
    """The adjustment table (``adjustment.csv``): its column names and rows — each spring's
    measured rate [N/m] (one spring's varying, the others at their catalogue rate), each slot's
    setting [mm along the slot] and each screw's [mm of pre-extension]; with a payload range, a
    first column ``mass_kg`` and a row per mass (at the catalogue rates)."""
    table, chosen = builds.table, builds.chosen
    slots = [s for s in chosen if not s.screw]
    screws = [s for s in chosen if s.screw]
    S = table.rates.shape[0]
    mass = [builds.payloads[0]["design_mass"]] if builds.payloads else []
    header = (["mass_kg"] if builds.payloads else []) + [f"rate{j + 1}_N_per_m" for j in range(S)] + \
        [f"{s.name.replace(' ', '')}_mm" for s in slots + screws]
    rows = []
    for j in range(S):
        for r in range(TABLE_ROWS):
            rates = [table.rates[jj, TABLE_ROWS // 2] if jj != j else table.rates[j, r] for jj in range(S)]
            rows.append(mass + [_shown(v) for v in rates]
                        + [_mm(table.slots[j, u, r] / s.per_metre) for u, s in enumerate(slots)]
                        + [_mm(table.screws[j, u, r]) for u in range(len(screws))])
    for p in builds.payloads:
        rows.append([_shown(p["mass"])] + [_shown(v) for v in table.rates[:, TABLE_ROWS // 2]]
                    + [_mm(p["settings"][s.name] / s.per_metre) for s in slots + screws])
    return header, rows


#: Decimals [mm] of the table's settings: a micrometre, finer than any screw is turned.
TABLE_DECIMALS = 3


def _mm(metres: float) -> float:
    """A setting [m] in millimetres as the table gives it (:data:`TABLE_DECIMALS`)."""
    return round(1e3 * float(metres), TABLE_DECIMALS) + 0.0  # + 0.0: no −0.0


def _shown(value: float) -> float:
    """A rate or a mass as the table gives it: to ten digits, without the rounding of its
    sum (919.9999999999999 is 920.0)."""
    return float(f"{float(value):.10g}")


# -- payloads -------------------------------------------------------------------------------------
def payload_settings(ev: Evaluation, sens: Sensitivity, chosen: list[Setting]) -> list[dict]:
    """Per mass of each pendulum target's ``mass_range`` (:data:`MASS_ROWS` of them), the
    settings that meet its torque best (least squares over the grid, within the ranges) and
    the errors there, the design re-evaluated exactly at each Gauss–Newton step; the masses
    from the design's outwards, each step starting from its neighbour's settings. Empty
    without a mass range or an adjustment."""
    problem = ev.problem
    out = []
    for i, joint in enumerate(problem.joints):
        span = joint.target.data.get("mass_range") if joint.target.kind == "pendulum" else None
        if span is None or not chosen:
            continue
        design_mass = joint.target.data["mass"]
        masses = np.linspace(*span, MASS_ROWS)
        found = {}
        for side in (masses[masses >= design_mass], masses[masses < design_mass][::-1]):
            a = np.zeros(len(chosen))
            for mass in side:
                a, row = _payload(ev, sens, chosen, i, float(mass), a)
                found[float(mass)] = {"joint": i + 1, "design_mass": design_mass, **row}
        out += [found[float(m)] for m in masses]
    return out


def with_mass(problem: Problem, joint: int, mass: float) -> Problem:
    """``problem`` with joint ``joint``'s pendulum carrying ``mass`` [kg]."""
    target = problem.joints[joint].target
    moved = replace(problem.joints[joint], target=replace(target, data={**target.data, "mass": mass}))
    return replace(problem, joints=tuple(moved if i == joint else j for i, j in enumerate(problem.joints)))


def _payload(ev: Evaluation, sens: Sensitivity, chosen: list[Setting], joint: int, mass: float,
             a: np.ndarray) -> tuple[np.ndarray, dict]:
    """The settings for ``mass`` from ``a`` (see :func:`payload_settings`) and its row."""
    problem, layout = with_mass(ev.problem, joint, mass), sens.layout
    bound = np.array([s.bound for s in chosen])
    scales = joint_scales(ev)
    weights = np.repeat(np.where(np.isfinite(scales), 1.0 / scales, 0.0), ev.tau.shape[1])
    for _ in range(PAYLOAD_STEPS):
        here = payload_evaluation(problem, ev, layout, chosen, a)
        J = sensitivity(here, sens.model).jacobian
        r = weights * (here.tau - here.tau_d).ravel()
        K = weights[:, None] * J[:, :, [s.index for s in chosen]].reshape(r.size, len(chosen))
        d = box_least_squares((K.T @ K)[None], (K.T @ r)[None], (-bound - a)[None], (bound - a)[None])[0]
        a = a + d
        if np.all(np.abs(d) <= PAYLOAD_TOL * bound):
            break
    here = payload_evaluation(problem, ev, layout, chosen, a, profile=True)
    metrics = here.metrics
    return a, {"mass": mass, "settings": {s.name: float(v) for s, v in zip(chosen, a)},
               "at_range_end": bool(np.any(np.abs(a) >= bound * (1 - 1e-9))),
               "rmse": float(metrics.rmse[joint]), "relative_rmse": metrics.relative_rmse[joint],
               "max_abs_error": float(metrics.max_abs_error[joint]), "violations": here.violations}


def payload_evaluation(problem: Problem, ev: Evaluation, layout, chosen: list[Setting], a: np.ndarray,
                        profile: bool = False) -> Evaluation:
    """``problem`` (a payload's) with ``ev``'s design set as ``a`` says, evaluated exactly on
    ``ev``'s grid (``profile``: with the profile's scans, whose limits it then checks)."""
    step = np.zeros(layout.size)
    for s, value in zip(chosen, a):
        step[s.index] += value
    p, d = built(problem, ev.design, layout, step)
    return evaluate(p, d, grid=ev.grid, profile=profile)
