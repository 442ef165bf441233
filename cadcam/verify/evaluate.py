"""Evaluate a fixed design on any grid by an independent path (rootfinder and quadrature).

This is how every optimum is re-checked and how designs typed in from a paper are scored.
It shares the symbolic model with the NLP but not the NLP's solution: the departure unknowns
come from a Newton rootfinder, the wrapped lengths from a Gauss–Legendre rule of high order
(and, under Johnston2023's force models, the wire torque from the quadrature of its Eq. 35),
and convexity and ρ are sampled densely over each profile's wrapped range and minimised.

Several joints: the grid is the tensor grid of every joint's n angles, n^m points (451³ ≈
9·10⁷ for three joints at the default fine grid), and it is never stored. Every mechanism sits
on one joint, so its departure, wrap and moment arms are solved at its own joint's n angles
only; spring j's extension is x_j = x₀_j + Σ_c e_jc(θ_c) and joint i's torque
τ_i = U_i(θ_i) + Σ V_ij(θ_i) e_jc(θ_c) (:class:`TensorGrid`). From these one-angle shares the
metrics follow exactly: a spring's extremes are sums of its shares' extremes, ∫|∂τ_i/∂k_j|
needs spring j's joints only, and the sums and the maximum of (τ_i − τ_d,i)² are taken over the
joints the error depends on, streamed in blocks of :data:`BLOCK_POINTS` points. A target may
depend on every angle (an arm's gravity torques): it is replayed from its CasADi graph by
numpy broadcasting (:class:`TensorFunction`), which keeps it a sum of products of arrays over
fewer joints where it can, so the stream costs a few array operations per point. The
numbers equal a point-by-point evaluation of the tensor grid to rounding (tested).
"""
from __future__ import annotations

import itertools
from collections.abc import Mapping
from contextvars import ContextVar
from dataclasses import dataclass, field, replace
from functools import cached_property

import casadi as ca
import numpy as np

from ..designs import Design
from ..mechanisms.base import departure_solver, margin_function, pose_function, room_function, split_coefficients
from ..physics.mapped import BINARY_OPS, LINEAR_OPS, UNARY_OPS, on_points, replayed
from ..physics.profile import Basis, profile_function
from ..physics.quadrature import trapezoid_weights
from ..physics.wrap import whole_wrap_order, wound_length
from ..problem import Problem, cap
from ..variation import Layout, settings
from ..units import MM

#: Tolerances of the feasibility check: lengths [m], departure residual [-, m], branch [-].
LENGTH_TOL = 1e-6
#: Tolerance of a mechanism's own limit on the re-check, by its unit [m or rad].
LIMIT_TOL = {"m": LENGTH_TOL, "rad": 1e-6}
RESIDUAL_TOL = 1e-9
BRANCH_TOL = 1e-6
#: Points of one block of the tensor grid: a metric that needs every point of the grid streams
#: it in blocks of at most this many (each array of a block is then at most 2 MB).
BLOCK_POINTS = 1 << 18
#: Nested sampling that refines a sampled minimum (:func:`_refine_min`): points per level, and
#: levels; each level narrows the bracket 50-fold (2000 samples of 2π: to 4·10⁻¹³ rad).
REFINE_POINTS = 101
REFINE_LEVELS = 6


@dataclass(frozen=True)
class Scan:
    """How a profile's dense scan (:func:`_profile_extremes`) samples it: at least ``points``
    angles (20 per grid angle where there are more), its minima refined ``levels`` times
    (:func:`_refine_min`)."""

    points: int
    levels: int


#: The profile scan of an evaluation: every evaluation's but a provisional design's.
FULL_SCAN = Scan(2000, REFINE_LEVELS)
#: The profile scan of a provisional design's evaluation while a slider moves
#: (:meth:`cadcam.Session.design` with ``recheck=False``; the design is evaluated again when it
#: stops): at least 600 angles, as many as a profile's curve is drawn from without a scan
#: (:func:`cadcam.outputs.plots._curve`), refined 3 times (to 10⁻⁷ of the bracket): enough for
#: the live view's curves and limits, and the design the slider stops at is scanned in full.
MOVING_SCAN = Scan(600, 3)
#: The profile scan of the evaluations in the running context.
SCAN: ContextVar[Scan] = ContextVar("scan", default=FULL_SCAN)
#: Largest factor [points] kept of a target or torque over the whole grid of a block's joints
#: (32 MB), from which every block is cut; beyond it, each block is evaluated on its own.
FACTOR_POINTS = 1 << 22


@dataclass
class UnitSamples:
    """Per-angle quantities of one mechanism on its joint's grid (angles [rad], lengths [m]).

    ``z`` (unknowns × n) are the departure unknowns, ``z_ref`` those at the reference pose,
    ``d`` and ``arm`` (ports × n) the port displacements [m] and moment arms [m] of the
    problem's torque model, ``margins`` (the mechanism's limits × n) its per-pose limits
    [m], ≥ 0 when met; ``rooms`` maps each mounted port to its spring's room [m] at the grid
    angles and at the reference pose (n + 1,: the reference last), and ``wound_ref`` is
    each profile's wound length at the reference pose [m] (empty without mounted ports).
    """

    theta: np.ndarray
    z: np.ndarray
    z_ref: np.ndarray
    residual: np.ndarray
    branch: np.ndarray
    d: np.ndarray
    arm: np.ndarray
    margins: np.ndarray
    rooms: dict = field(default_factory=dict)
    wound_ref: np.ndarray = field(default_factory=lambda: np.zeros(0))


@dataclass
class ProfileSamples:
    """One profile: its departure angle α on the joint's grid and a dense scan of ρ and the
    convexity margin over its wrapped range [0, max α] (angles [rad], lengths [m])."""

    theta: np.ndarray
    alpha: np.ndarray
    alpha_ref: float
    phi: np.ndarray
    rho: np.ndarray
    convexity: np.ndarray  # Johnston2023 Eq. 40 margin at phi [m²]
    convexity_min: float
    rho_lo: float
    rho_hi: float
    curvature_radius_min: float  # smallest radius of curvature over the scan [m]


class TensorFunction:
    """A scalar CasADi function of all joint angles, ``f(theta[m])``, evaluated on a block of
    the tensor grid by numpy broadcasting (a target τ_d [N·m]).

    The function's SX instructions are replayed on arrays that each span only the joints they
    depend on, so a term of one angle costs n operations, not n^m. Sums and products of such
    arrays are kept as sums of products (:class:`Terms`) until a nonlinear operation needs
    their values, and a sine or cosine of a sum over different joints (the arm's
    sin(θ₁ + θ₂ + θ₃)) is expanded by the angle-addition formulas,
    sin(a + b) = sin a cos b + cos a sin b: on the block, a target then costs a few products
    and sums per point instead of a transcendental function; the values equal the pointwise
    ones to rounding. A function with an instruction numpy cannot replay (a ``table``
    target's interpolant) is evaluated point by point by CasADi, on the joints it depends on
    only (:attr:`support`).
    """

    def __init__(self, fn: ca.Function):
        self.fn = fn
        #: The joints the function depends on.
        self.support = tuple(int(c) for c in
                             np.flatnonzero(fn.which_depends("i0", [fn.name_out(0)], 1, False)))
        ops = [fn.instruction_id(k) for k in range(fn.n_instructions())]
        known = set(UNARY_OPS) | set(BINARY_OPS) | set(LINEAR_OPS) | {ca.OP_CONST, ca.OP_INPUT, ca.OP_OUTPUT}
        self.replayable = all(op in known for op in ops)
        self._program = [(op, fn.instruction_input(k), fn.instruction_output(k),
                          fn.instruction_constant(k) if op == ca.OP_CONST else None)
                         for k, op in enumerate(ops)]

    def __call__(self, thetas: list, limit: int | None = None) -> "Terms":
        """The values at the angles ``thetas`` (one array per joint [rad], all broadcastable
        against each other), as :class:`Terms` (``.value()`` gives the array). With ``limit``,
        :class:`TooLarge` is raised rather than evaluating an array of more points."""
        if not self.replayable:
            if limit is not None and _size(*(thetas[c] for c in self.support)) > limit:
                raise TooLarge
            return Terms.of(self._pointwise(thetas), limit)
        work, out = {}, None
        for op, ins, outs, const in self._program:
            if op == ca.OP_CONST:
                work[outs[0]] = Terms.of(const, limit)
            elif op == ca.OP_INPUT:
                work[outs[0]] = Terms.of(thetas[ins[1]], limit)
            elif op == ca.OP_OUTPUT:
                out = work[ins[0]].compact()
            elif op in LINEAR_OPS:
                args = ins[:1] if op in (ca.OP_NEG, ca.OP_TWICE) else ins[:2]
                work[outs[0]] = LINEAR_OPS[op](*(work[r] for r in args))
            elif op in (ca.OP_SIN, ca.OP_COS):
                work[outs[0]] = work[ins[0]].trig(op == ca.OP_SIN)
            elif op in UNARY_OPS:
                work[outs[0]] = Terms.of(UNARY_OPS[op](work[ins[0]].value()), limit)
            else:
                work[outs[0]] = Terms.of(BINARY_OPS[op](work[ins[0]].value(), work[ins[1]].value()),
                                         limit)
        return out

    def _pointwise(self, thetas: list) -> np.ndarray:
        """CasADi's own evaluation at every point of the broadcast of the supporting angles."""
        shape = np.broadcast_shapes(*[np.shape(thetas[c]) for c in self.support])
        points = np.vstack([np.broadcast_to(np.asarray(t if c in self.support else np.ravel(t)[0],
                                                       dtype=float), shape).ravel()
                            for c, t in enumerate(thetas)])
        return np.asarray(self.fn.map(points.shape[1])(points)).reshape(shape)


def _size(*arrays) -> int:
    """Points of the broadcast of ``arrays``."""
    return int(np.prod(np.broadcast_shapes(*[np.shape(a) for a in arrays])))


class TooLarge(Exception):
    """A :class:`Terms` would evaluate an array beyond its limit."""


class Terms:
    """Σ_k Π_f a_kf: a sum of products of arrays that each span some of the joints (broadcastable
    against each other), kept unevaluated while its value would be larger than its factors.

    A term's factors are merged where one spans the other's joints (that costs no more than
    the larger); a sum whose value is no larger than its largest factor is evaluated at once.
    ``limit``: :meth:`value` raises :class:`TooLarge` rather than make an array of more
    points (None: no limit).
    """

    MAX_TERMS = 16  # a product of longer sums is evaluated

    def __init__(self, terms: list[tuple], limit: int | None = None):
        self.terms, self.limit = terms, limit

    @classmethod
    def of(cls, value, limit: int | None = None) -> "Terms":
        """One array or number."""
        return cls([(value,)], limit)

    def _new(self, terms: list[tuple]) -> "Terms":
        """Other terms under the same limit."""
        return Terms(terms, self.limit)

    def size(self) -> int:
        """Points of the value."""
        return _size(*(f for t in self.terms for f in t))

    def value(self):
        """The array (or number) the terms sum to, small terms first."""
        if self.limit is not None and (len(self.terms) > 1 or len(self.terms[0]) > 1) \
                and self.size() > self.limit:
            raise TooLarge
        products = sorted((_product(t) for t in self.terms), key=np.size)
        out = products[0]
        for k, p in enumerate(products[1:]):
            if k and np.shape(out) == np.broadcast_shapes(np.shape(out), np.shape(p)):
                out += p  # a sum made here: safe to add into
            else:
                out = out + p
        return out

    def on(self, block: "Block") -> "Terms":
        """The terms on a block of the grid they span (their axes are the block's)."""
        return Terms([tuple(block.cut(f) for f in t) for t in self.terms])

    def compact(self) -> "Terms":
        """The same sum with the terms smaller than the whole added into one array (unless
        that is beyond the limit)."""
        whole = self.size()
        small = self._new([t for t in self.terms if _size(*t) < whole])
        if len(small.terms) < 2 or (self.limit is not None and small.size() > self.limit):
            return self
        return self._new([(small.value(),)] + [t for t in self.terms if _size(*t) == whole])

    def _settle(self) -> "Terms":
        """Evaluated at once if the value is no larger than the largest factor."""
        big = max(np.size(f) for t in self.terms for f in t)
        if len(self.terms) > 1 and self.size() <= big:
            return self._new([(self.value(),)])
        return self

    def __add__(self, other: "Terms") -> "Terms":
        return self._new(self.terms + other.terms)._settle()

    def __neg__(self) -> "Terms":
        return self._new([_scaled(t, -1.0) for t in self.terms])

    def __sub__(self, other: "Terms") -> "Terms":
        return self + (-other)

    def __mul__(self, other) -> "Terms":
        if not isinstance(other, Terms):
            return self._new([_scaled(t, other) for t in self.terms])
        if len(self.terms) * len(other.terms) > self.MAX_TERMS:
            return self._new([(self.value() * other.value(),)])
        return self._new([_merged(p + q) for p in self.terms for q in other.terms])._settle()

    def trig(self, sine: bool) -> "Terms":
        """sin or cos of the sum. Where it spans joints that no single term spans all of, it is
        split into b, the terms on the last of its joints, and a, the others, and expanded:
        sin(a + b) = sin a cos b + cos a sin b, cos(a + b) = cos a cos b − sin a sin b."""
        spans = [np.broadcast_shapes(*map(np.shape, t)) for t in self.terms]
        full = np.broadcast_shapes(*spans)
        wide = [k for k, n in enumerate(full) if n > 1]
        on_last = [k for k, s in enumerate(spans) if wide and len(s) == len(full) and s[wide[-1]] > 1]
        a = self._new([t for k, t in enumerate(self.terms) if k not in on_last])
        b = self._new([self.terms[k] for k in on_last])
        if not a.terms or not b.terms or max(a.size(), b.size()) >= np.prod(full):
            v = self.value()
            return self._new([(np.sin(v) if sine else np.cos(v),)])
        va, vb = a.value(), b.value()
        sin_a, cos_a, sin_b, cos_b = np.sin(va), np.cos(va), np.sin(vb), np.cos(vb)
        if sine:
            return self._new([(sin_a, cos_b), (cos_a, sin_b)])
        return self._new([(cos_a, cos_b), (-sin_a, sin_b)])


def _product(term: tuple):
    """The product of a term's factors."""
    out = term[0]
    for f in term[1:]:
        out = out * f
    return out


def _scaled(term: tuple, factor) -> tuple:
    """The term times a number."""
    return _merged(term + (factor,))


def _merged(term: tuple) -> tuple:
    """The term's factors, each multiplied into the smallest larger one that spans its joints
    (a number into the smallest factor)."""
    out = []
    for f in sorted(term, key=np.size, reverse=True):
        fits = [k for k, g in enumerate(out) if _size(g, f) == np.size(g)]
        if fits:
            k = min(fits, key=lambda k: np.size(out[k]))
            out[k] = out[k] * f
        else:
            out.append(f)
    return tuple(out)


@dataclass(frozen=True)
class Block:
    """A sub-grid of the tensor grid of joint angles: joint ``axes[k]`` takes the grid indices
    ``index[k]``; the arrays on it have one dimension per axis, in that order."""

    axes: tuple[int, ...]
    index: tuple[np.ndarray, ...]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(i) for i in self.index)

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    @cached_property
    def _slices(self) -> tuple:
        """``index`` with runs of consecutive indices as slices (views, not copies)."""
        return tuple(slice(ix[0], ix[-1] + 1) if np.all(np.diff(ix) == 1) else ix for ix in self.index)

    def cut(self, values):
        """This block of an array over the whole grid of its axes (or a number), which may
        have size 1 along some of them."""
        if not np.ndim(values):
            return values
        return values[tuple(ix if k > 1 else slice(None) for ix, k in zip(self._slices, np.shape(values)))]

    def view(self, values: np.ndarray, joint: int) -> np.ndarray:
        """Per-angle ``values`` of ``joint`` on this block, broadcastable along its axes."""
        k = self.axes.index(joint)
        shape = [1] * len(self.axes)
        shape[k] = len(self.index[k])
        return np.asarray(values)[self._slices[k]].reshape(shape)

    def weights(self, weights: list[np.ndarray]) -> list[np.ndarray]:
        """The block's part of per-joint quadrature ``weights`` (one vector per joint)."""
        return [weights[c][ix] for c, ix in zip(self.axes, self._slices)]


def blocks(axes: tuple[int, ...], n: int, limit: int | None = None):
    """The blocks of at most ``limit`` points (default :data:`BLOCK_POINTS`) that tile the
    tensor grid of the joints ``axes`` with ``n`` angles each: whole trailing axes, slabs of
    one axis, single indices of the leading ones."""
    limit = limit or BLOCK_POINTS
    sizes = [n] * len(axes)
    k, rest = 0, int(np.prod(sizes))
    while k < len(sizes) and rest > limit:
        rest //= sizes[k]
        k += 1
    whole = [np.arange(s) for s in sizes[k:]]
    if k == 0:
        yield Block(axes, tuple(whole))
        return
    step = max(limit // rest, 1)
    for lead in itertools.product(*(range(s) for s in sizes[:k - 1])):
        for start in range(0, sizes[k - 1], step):
            yield Block(axes, tuple([np.array([i]) for i in lead]
                                    + [np.arange(start, min(start + step, sizes[k - 1]))] + whole))


class TensorGrid:
    """A design's joint torques, targets and spring extensions on the tensor grid of all
    joints' angles, held as one-angle samples: nothing of size n^m is stored, only (cached)
    the factors of each target and torque over the joints it depends on, each of at most
    :data:`FACTOR_POINTS` points, from which any block is cut.

    Every port depends on its own joint's angle, so spring j's extension is
    x_j = x₀_j + Σ_c e_jc(θ_c) and joint i's torque τ_i = U_i(θ_i) + Σ V_ij(θ_i) e_jc(θ_c)
    (Johnston2023 Eq. 14, 16, 17, 36; :meth:`cadcam.physics.springs.Network.torque_terms`),
    with ∂τ_i/∂k_j = x_j a_ij(θ_i) (Eq. 43). Angles [rad], lengths [m], torques [N·m].

    Parameters
    ----------
    problem : Problem
    x0 : array
        Pre-extensions [m].
    axes : list of array
        Each joint's grid angles [rad].
    units : list of UnitSamples
        Each mechanism's port displacements and arms on its joint's grid.
    """

    def __init__(self, problem: Problem, x0: np.ndarray, axes: list[np.ndarray], units: list):
        m = len(problem.joints)
        self.problem, self.axes, self.x0, self.m = problem, axes, np.asarray(x0, dtype=float), m
        self.n = axes[0].size
        self.network = net = problem.network()
        d, arm = [[] for _ in range(m)], [[] for _ in range(m)]
        for mech, unit in zip(problem.mechanisms, units):  # global port order within a joint
            d[mech.joint] += list(unit.d)
            arm[mech.joint] += list(unit.arm)
        springs = problem.spring_parameters()
        k, F0 = springs.rate, springs.preload
        #: (j, c) → e_jc, joint c's share of spring j's extension [m] on joint c's grid.
        self.shares = net.shares(d)
        #: Per joint (U_i [N·m], {(j, c): V_ij [N/m·m]}) on its own grid.
        self.terms = [net.torque_terms(i, k, F0, self.x0, arm[i], self.shares) for i in range(m)]
        #: (i, j) → a_ij [m], the arm of spring j's force on joint i, for the springs on joint i.
        self.arms = {(i, j): np.asarray(net.arm_term(j, i, arm[i]), dtype=float)
                     for j in range(net.S) for i in net.joints_of(j)}
        self.targets = [TensorFunction(joint.target.function(m, i))
                        for i, joint in enumerate(problem.joints)]
        self._whole: dict = {}

    @property
    def points(self) -> int:
        """Points of the tensor grid, n^m."""
        return self.n**self.m

    def torque_joints(self, i: int) -> tuple[int, ...]:
        """The joints joint i's torque depends on: its own and those its springs also join."""
        return tuple(sorted({i} | {c for _, c in self.terms[i][1]}))

    def error_joints(self, i: int) -> tuple[int, ...]:
        """The joints τ_i − τ_d,i depends on."""
        return tuple(sorted(set(self.torque_joints(i)) | set(self.targets[i].support)))

    def torque(self, i: int, block: Block) -> Terms:
        """τ_i = U_i + Σ V_ij e_jc [N·m] on ``block`` (its ``value()`` broadcastable)."""
        def build(b, limit):
            U, V = self.terms[i]
            return Terms([(b.view(U, i) if np.ndim(U) else U,)]
                         + [(b.view(v, i), b.view(self.shares[jc], jc[1])) for jc, v in V.items()], limit)
        return self._on(("torque", i), block, build)

    def target(self, i: int, block: Block) -> Terms:
        """τ_d,i [N·m] on ``block`` (its ``value()`` broadcastable)."""
        return self._on(("target", i), block,
                        lambda b, limit: self.targets[i](self._angles(b), limit))

    def _on(self, key: tuple, block: Block, build) -> Terms:
        """``build(block, limit)`` (:class:`Terms`), cut from the terms over the whole grid of
        the block's joints (built once) if those need no array of more than
        :data:`FACTOR_POINTS` points, else built on the block."""
        key = key + (block.axes,)
        if key not in self._whole:
            whole = Block(block.axes, tuple(np.arange(self.n) for _ in block.axes))
            try:
                self._whole[key] = build(whole, FACTOR_POINTS).compact()
            except TooLarge:
                self._whole[key] = None
        whole = self._whole[key]
        return build(block, None) if whole is None else whole.on(block)

    def _angles(self, block: Block) -> list:
        """Each joint's angles on ``block`` (the first one for a joint it does not span)."""
        return [block.view(self.axes[c], c) if c in block.axes else self.axes[c][0] for c in range(self.m)]

    def extension(self, j: int, block: Block) -> np.ndarray:
        """x_j = x₀_j + Σ_c e_jc [m] on ``block`` (broadcastable)."""
        return self.x0[j] + sum(block.view(self.shares[j, c], c) for c in self.network.joints_of(j))

    def extension_range(self, j: int) -> tuple[float, float]:
        """(min, max) of x_j over the tensor grid [m], exactly: the shares depend on different
        angles, so the extremes of their sum are the sums of their extremes."""
        shares = [self.shares[j, c] for c in self.network.joints_of(j)]
        return (float(self.x0[j] + sum(e.min() for e in shares)),
                float(self.x0[j] + sum(e.max() for e in shares)))

    def rate_sensitivity(self, i: int, j: int, block: Block) -> np.ndarray:
        """∂τ_i/∂k_j = x_j a_ij [m²] on ``block`` (Johnston2023 Eq. 43; 0 for a spring that
        does not act on joint i)."""
        if (i, j) not in self.arms:
            return np.zeros(())
        return self.extension(j, block) * block.view(self.arms[i, j], i)

    def whole(self) -> Block:
        """The whole grid as one block."""
        return Block(tuple(range(self.m)), tuple(np.arange(self.n) for _ in range(self.m)))

    def line(self, point, axis: int) -> Block:
        """The grid line along joint ``axis``'s angle through the grid point ``point`` (one
        index per joint)."""
        return Block(tuple(range(self.m)), tuple(np.arange(self.n) if c == axis else np.array([point[c]])
                                                 for c in range(self.m)))

    def sample(self, block: Block) -> dict:
        """θ (m, P) [rad], τ and τ_d (m, P) [N·m], x (S, P) [m] and ∂τ/∂k (m, P, S) [m²] at the
        P points of ``block`` (a block over every joint), in C order of its axes."""
        P, m, S = block.size, self.m, len(self.problem.springs)
        full = lambda a: np.broadcast_to(a, block.shape).ravel()  # noqa: E731
        sens = [[full(self.rate_sensitivity(i, j, block)) for j in range(S)] for i in range(m)]
        return {"theta": np.vstack([full(block.view(self.axes[i], i)) for i in range(m)]),
                "tau": np.vstack([full(self.torque(i, block).value()) for i in range(m)]),
                "tau_d": np.vstack([full(self.target(i, block).value()) for i in range(m)]),
                "x": np.array([full(self.extension(j, block)) for j in range(S)]).reshape(S, P),
                "dtau_dk": np.array(sens).reshape(m, S, P).transpose(0, 2, 1)}


def _sums(values, weights: list[np.ndarray]) -> tuple[float, float]:
    """(Σ v, Σ W v) over a block: plain and with the product weights W = w₀ ⊗ w₁ ⊗ … (one
    vector per axis of the block); ``values`` may have size 1 along axes where the block has
    more (it is then constant along them)."""
    v = np.asarray(values, dtype=float)
    v = v.reshape((1,) * (len(weights) - v.ndim) + v.shape)
    plain = float(v.sum()) * np.prod([w.size for w, k in zip(weights, v.shape) if k == 1])
    for w in reversed(weights):
        v = v @ w if v.shape[-1] > 1 else v[..., 0] * w.sum()
    return float(plain), float(v)


@dataclass
class Evaluation:
    """A design evaluated on the tensor grid of all joints' angles.

    The grid is held per joint (:class:`TensorGrid`); ``metrics`` (see :func:`evaluate`) are
    computed from it exactly, streaming the tensor grid in blocks where a metric needs every
    point. ``theta`` (m, N) [rad], ``tau``/``tau_d`` (m, N) [N·m], ``x`` (S, N) [m],
    ``dtau_dk`` (m, N, S) [m²] and ``energy`` (N,) [J] are the tensor grid's values,
    materialised on first use (refused beyond :func:`cadcam.problem.cap` ``grid_points``);
    ``worst`` holds per joint the grid indices of its largest |τ − τ_d|.
    """

    problem: Problem
    design: Design
    grid: int
    units: list[UnitSamples]
    profiles: list[ProfileSamples]
    tensor: TensorGrid
    #: Set by :func:`evaluate`.
    metrics: Metrics = field(init=False)
    worst: list = field(init=False)

    @property
    def violations(self) -> list[str]:
        """Human-readable constraint violations beyond the check tolerances."""
        return self.metrics.violations

    @cached_property
    def _sample(self) -> dict:
        if self.tensor.points > cap("grid_points"):
            raise ValueError(f"the tensor grid of {self.tensor.points:.3g} points exceeds the cap "
                             f"{cap('grid_points'):.3g} on materialised points (CADCAM_CAP_GRID_POINTS); "
                             "use the metrics, streamed exactly, or TensorGrid.sample on a block")
        return self.tensor.sample(self.tensor.whole())

    theta = property(lambda self: self._sample["theta"], doc="Grid points θ (m, N) [rad].")
    tau = property(lambda self: self._sample["tau"], doc="Joint torques τ (m, N) [N·m].")
    tau_d = property(lambda self: self._sample["tau_d"], doc="Targets τ_d (m, N) [N·m].")
    x = property(lambda self: self._sample["x"], doc="Spring extensions x (S, N) [m].")
    dtau_dk = property(lambda self: self._sample["dtau_dk"], doc="Rate sensitivities ∂τ/∂k (m, N, S) [m²].")

    @property
    def energy(self) -> np.ndarray:
        """Spring energy V = Σ ½k x² + F0 x [J] at every grid point (N,)."""
        return sum(s.energy(self.x[j]) for j, s in enumerate(self.problem.springs))


def _profile_extremes(basis: Basis, c: np.ndarray, phi_hi: float, n: int):
    """Dense samples of ρ and the convexity margin on [0, phi_hi], with refined minima."""
    prof = replayed(profile_function(basis))  # CasADi's values to the bit, every angle at once
    phi = np.linspace(0.0, phi_hi, n)
    rho, drho, _, conv = (v.ravel() for v in prof(phi, c))
    # the three refined in step, each level's angles of all three in one call of the profile
    conv_min, rho_lo, rho_hi = _refine_mins(prof, c, phi, [(conv, 3, 1.0), (rho, 0, 1.0), (-rho, 0, -1.0)])
    rho_hi = -rho_hi
    with np.errstate(divide="ignore", invalid="ignore"):  # 0 where not convex
        curvature = np.where(conv > 0, (rho**2 + drho**2) ** 1.5 / conv, 0.0)
    return phi, rho, conv, conv_min, rho_lo, rho_hi, float(np.min(curvature))


def _refine_min(local, c, phi, values, out_index, sign=1.0):
    """Minimum of ``values`` (= sign·output ``out_index`` of the profile at ``phi``) refined
    between samples by nested sampling: the two intervals around the least value so far are
    sampled at :data:`REFINE_POINTS` angles by ``local`` (the profile function mapped over as
    many angles as it is given), as many times as the running context's scan says
    (:data:`SCAN`). Every value it returns is the profile's at some angle, so it never
    undershoots the true minimum, and a kink (a piecewise basis) or a flat stretch does not
    mislead it (NaN where the profile itself is not finite)."""
    return _refine_mins(local, c, phi, [(values, out_index, sign)])[0]


def _refine_mins(local, c, phi, wanted) -> list[float]:
    """:func:`_refine_min` of each of ``wanted`` = [(values, out_index, sign), …], in step: each
    level's angles of them all in one call of ``local``, where a call each costs more than the
    profile's values at a hundred angles (the fine re-check of a catalogue search's design
    refined three minima per profile); the same angles and values as one at a time."""
    state = []  # per minimum: [least so far, bracket's ends], None where not finite
    for values, _, _ in wanted:
        k = int(np.argmin(values)) if np.all(np.isfinite(values)) else None
        state.append(None if k is None else [float(values[k]), phi[max(k - 1, 0)], phi[min(k + 1, phi.size - 1)]])
    live = [i for i, s in enumerate(state) if s is not None]
    for _ in range(SCAN.get().levels if live else 0):
        angles = [np.linspace(state[i][1], state[i][2], REFINE_POINTS) for i in live]
        out = local(np.concatenate(angles), c)
        for block, (i, p) in enumerate(zip(live, angles)):
            _, out_index, sign = wanted[i]
            v = sign * np.asarray(out[out_index]).ravel()[block * REFINE_POINTS:(block + 1) * REFINE_POINTS]
            v[~np.isfinite(v)] = np.inf  # a non-finite sample is never the least
            j = int(np.argmin(v))
            state[i] = [min(state[i][0], float(v[j])), p[max(j - 1, 0)], p[min(j + 1, p.size - 1)]]
    return [float("nan") if s is None else s[0] for s in state]


def mechanism_samples(problem: Problem, design: Design, u: int, theta: np.ndarray,
                      order: int | None = None, integrals: str = "quadrature",
                      profile: bool = True, seed=None) -> tuple[UnitSamples, list[ProfileSamples]]:
    """Solve mechanism ``u``'s departure with the rootfinder at ``theta`` and evaluate its port
    quantities (and, with ``profile``, scan ρ and the convexity margin of its profiles), the
    wrap integrals on ``order`` points (default the re-check's,
    :func:`cadcam.physics.wrap.whole_wrap_order` of the design's profiles).

    ``seed`` = (θ, z) samples (z: unknowns × n), e.g. an NLP's solution, interpolated as
    Newton's start.
    """
    mech = problem.mechanisms[u]
    sl = problem.profile_slices()[u]
    bases = tuple(design.bases[sl])
    structure = (type(mech), bases)
    c = np.concatenate([np.asarray(v, dtype=float) for v in design.coefficients[sl]])
    q = np.asarray(mech.parameter_values(), dtype=float)
    th = np.concatenate([[mech.reference_angle], theta])
    start = None if seed is None else np.vstack([np.interp(th, seed[0], row) for row in seed[1]])
    z, residual = departure_solver(structure).solve(th, c, q, start)
    n = theta.size
    order = whole_wrap_order(design.bases) if order is None else order
    pose = on_points(pose_function(structure, problem.torque_model, order, integrals), n)
    d, arm, _, branch = (np.asarray(v) for v in pose(theta, z[:, 1:], z[:, 0], c, q))
    margins = np.asarray(on_points(margin_function(structure), n)(theta, z[:, 1:], c, q, arm))
    pieces = split_coefficients(bases, c)
    rooms, wound = _mounted_rooms(structure, th, z, c, q)
    unit = UnitSamples(theta, z[:, 1:], z[:, 0], np.maximum(residual[1:], residual[0]),
                       branch.ravel(), d.reshape(-1, n), arm.reshape(-1, n),
                       margins.reshape(-1, n), rooms, wound)
    profiles = []
    for k, (b, ck) in enumerate(zip(bases, pieces)):
        # the wrapped range; where the departure failed (NaN), the whole design interval
        phi_hi = float(np.max(z[k])) if np.all(np.isfinite(z[k])) else b.domain[1]
        scan = (_profile_extremes(b, ck, phi_hi, max(20 * n, SCAN.get().points)) if profile
                else (np.array([]), np.array([]), np.array([]), np.nan, np.nan, np.nan, np.nan))
        profiles.append(ProfileSamples(theta, z[k, 1:], float(z[k, 0]), *scan))
    return unit, profiles


def _mounted_rooms(structure, th: np.ndarray, z: np.ndarray, c: np.ndarray, q: np.ndarray) -> tuple[dict, np.ndarray]:
    """Each mounted port's room [m] (:meth:`cadcam.mechanisms.base.Mechanism.spring_room`) at the
    angles ``th[1:]`` then at the reference pose ``th[0]`` (z: unknowns × angles, the reference
    first), and each profile's wound length [m] at the reference pose; empty without mounted ports."""
    cls, bases = structure
    if not cls.mounted_ports:
        return {}, np.zeros(0)
    at = np.r_[th[1:], th[0]], np.c_[z[:, 1:], z[:, :1]]
    rooms = {port: np.asarray(on_points(room_function(structure, port), th.size)(*at, c, q)).ravel()
             for port in cls.mounted_ports}
    wound = [float(wound_length(b, z[k, 0], ck)) for k, (b, ck) in enumerate(zip(bases, split_coefficients(bases, c)))]
    return rooms, np.array(wound)


def poses_of(problem: Problem, units: list[UnitSamples]) -> list:
    """Each mechanism's solved unknowns in ``units`` at its reference angle and grid angles, as
    :attr:`cadcam.designs.Design.poses` holds them: (θ increasing [rad], z (unknowns × angles))."""
    out = []
    for mech, unit in zip(problem.mechanisms, units):
        theta, first = np.unique(np.r_[mech.reference_angle, unit.theta], return_index=True)
        out.append((theta, np.column_stack([unit.z_ref, unit.z])[:, first]))
    return out


def start_samples(problem: Problem, design: Design, grid: int, order: int) -> list:
    """Per-mechanism samples of ``design`` on a ``grid``-angle grid with quadrature ``order``, for
    :meth:`cadcam.solve.transcription.Transcription.initial_guess`: departure by the rootfinder,
    port quantities in closed form. For the robust objective, each slot's ends follow, the
    samples of its mechanism with the slot at either end of its range
    (:func:`cadcam.solve.robust.slot_ends`'s order)."""
    samples = evaluate(problem, design, grid=grid, order=order, integrals="closed-form", profile=False).units
    if problem.options.objective != "robust":
        return samples
    for setting in settings(problem, Layout(problem, design)):
        if setting.screw:
            continue
        u = setting.number - 1
        mech = problem.mechanisms[u]
        value = dict(zip(mech.parameter_names, mech.parameter_values()))[setting.parameter]
        for sign in (1.0, -1.0):  # the robust objective's ENDS
            moved = tuple(m.placed({setting.parameter: value + sign * setting.bound}) if k == u else m
                          for k, m in enumerate(problem.mechanisms))
            samples.append(evaluate(replace(problem, mechanisms=moved), design, grid=grid, order=order,
                                    integrals="closed-form", profile=False).units[u])
    return samples


def evaluate(problem: Problem, design: Design, grid: int | None = None,
             order: int | None = None, integrals: str = "quadrature",
             profile: bool = True, seeds=None) -> Evaluation:
    """Evaluate ``design`` on a uniform grid of ``grid`` angles per joint (default: the
    problem's), under the problem's torque model.

    Returns an :class:`Evaluation` whose ``metrics`` hold, in SI units: ``rmse`` and
    ``max_abs_error`` [N·m] per joint over the grid points; ``output_rmse`` and
    ``output_max_abs_error`` [m] per mechanism with an output law (None for the others); ``extension_min``/``extension_max``
    [m] per spring; ``convexity_min`` [m²], ``rho_min``/``rho_max`` [m], ``alpha_max`` [rad]
    per profile over its wrapped range [0, max α]; ``tangency_residual_max``;
    ``sensitivity_integral`` ∫|∂τ_i/∂k_j| [m²·rad^m] per joint and spring (trapezoidal);
    ``objective`` (Johnston2023 Eq. 46/47: the least-squares tracking and rate-sensitivity
    terms, whichever ``solver.objective`` and ``band_weight`` the solve minimised; the solve's
    own objective is :attr:`cadcam.result.Result.fun`); ``margins`` (positive = satisfied) and
    ``violations``. ``profile = False`` skips the profile scans (their metrics are then NaN);
    ``seeds`` (per mechanism, see :func:`mechanism_samples`) start the rootfinder from known
    unknowns, by default the design's :attr:`~cadcam.designs.Design.poses` where it has them.
    """
    n = grid or problem.options.grid
    seeds = design.poses if seeds is None else seeds
    units, profiles = [], []
    for u, mech in enumerate(problem.mechanisms):
        unit, profs = mechanism_samples(problem, design, u, problem.joints[mech.joint].grid(n),
                                        order, integrals, profile, None if seeds is None else seeds[u])
        units.append(unit)
        profiles += profs
    tensor = TensorGrid(problem, design.preextension, [j.grid(n) for j in problem.joints], units)
    ev = Evaluation(problem, design, n, units, profiles, tensor)
    ev.metrics, ev.worst = _metrics(ev)
    return ev


def rate_deviation(problem: Problem, design: Design, factor: float, springs=None,
                   grid: int | None = None) -> np.ndarray:
    """RMSE per joint [N·m] between the torques of ``design`` with nominal spring rates and with
    the rates of ``springs`` (default all, as Johnston2023's Table 5) multiplied by ``factor``.

    τ is linear in the rates, so with every rate scaled this is |factor − 1| × the RMS torque
    for any design; one spring at a time is what measures robustness.
    """
    nominal = evaluate(problem, design, grid=grid, profile=False)
    changed = evaluate(problem.with_spring_rates(factor, springs), design, grid=grid, profile=False)
    return np.sqrt(np.mean((changed.tau - nominal.tau) ** 2, axis=1))


def _relative(errors, sizes) -> list:
    """errors / sizes per joint (the RMSE against the target's RMS), None where the target is
    zero everywhere."""
    return [float(e / s) if s > 0 else None for e, s in zip(errors, sizes)]


def output_law(mech, theta: np.ndarray) -> np.ndarray:
    """The mechanism's output target x_d [m] at the joint angles ``theta`` [rad]."""
    return np.asarray(mech.output_target.function(1, 0).map(theta.size)(theta)).ravel()


def output_error(mech, unit: UnitSamples):
    """x − x_d [m] of a mechanism's output over its samples, or None without an output law."""
    if mech.output_target is None:
        return None
    return unit.z[mech.unknowns.index(mech.output)] - output_law(mech, unit.theta)


#: The names of an evaluation's metrics (the keys of :attr:`Evaluation.metrics`), which a
#: study may ``record``.
@dataclass(frozen=True)
class Metric:
    """One number (or list) of an evaluation's metrics, declared once: labels, units and the
    study tables read it.

    ``per`` says what its index counts (``"joint"``, ``("joint", "spring")``, None for one
    number); ``unit`` is SI (``"ratio"`` for a fraction, ``""`` for a count).
    """

    label: str
    per: str | tuple[str, ...] | None
    unit: str


#: The evaluation's numeric metrics, in the order :func:`evaluate` reports them.
METRICS = {
    "grid": Metric("grid angles per joint", None, ""),
    "output_rmse": Metric("output RMSE", "mechanism", "m"),
    "output_max_abs_error": Metric("output max |x − x_d|", "mechanism", "m"),
    "rmse": Metric("RMSE", "joint", "N·m"),
    "relative_rmse": Metric("RMSE / RMS target", "joint", "ratio"),
    "max_abs_error": Metric("max |τ − τ_d|", "joint", "N·m"),
    "extension_min": Metric("least extension", "spring", "m"),
    "extension_max": Metric("largest extension", "spring", "m"),
    "convexity_min": Metric("least convexity margin", "profile", "m²"),
    "rho_min": Metric("least ρ", "profile", "m"),
    "rho_max": Metric("largest ρ", "profile", "m"),
    "curvature_radius_min": Metric("least radius of curvature", "profile", "m"),
    "alpha_max": Metric("largest wrap α", "profile", "rad"),
    "tangency_residual_max": Metric("largest departure residual", None, "-"),
    "sensitivity_integral": Metric("∫|∂τ/∂k|", ("joint", "spring"), "m²·rad^m"),
    "objective": Metric("objective (Eq. 46/47)", None, "-"),
}
#: Every key of an evaluation's metrics: the numbers, then the margins and the violations.
METRIC_NAMES = (*METRICS, "margins", "violations")


@dataclass(frozen=True, eq=False)
class Metrics(Mapping):
    """An evaluation's metrics, typed: each number of :data:`METRICS` (per joint, spring,
    profile or mechanism as it declares; SI units), the ``margins`` (each ≥ 0 when met: the
    generic ones of :data:`MARGINS` and each mechanism's own limits) and the ``violations``
    (one sentence each). Read by attribute; as a mapping too, in the form of ``result.json``'s
    ``metrics`` (:meth:`to_dict`)."""

    grid: int
    output_rmse: list
    output_max_abs_error: list
    rmse: list
    relative_rmse: list
    max_abs_error: list
    extension_min: list
    extension_max: list
    convexity_min: list
    rho_min: list
    rho_max: list
    curvature_radius_min: list
    alpha_max: list
    tangency_residual_max: float
    sensitivity_integral: list
    objective: float
    margins: dict
    violations: list

    def __getitem__(self, name: str):
        if name not in METRIC_NAMES:
            raise KeyError(name)
        return getattr(self, name)

    def __iter__(self):
        return iter(METRIC_NAMES)

    def __len__(self) -> int:
        return len(METRIC_NAMES)

    def to_dict(self) -> dict:
        """The metrics as plain data (``result.json``'s ``metrics`` and ``recheck``)."""
        return {name: getattr(self, name) for name in METRIC_NAMES}


def _streamed(tensor: TensorGrid) -> dict:
    """The metrics that need every point of the tensor grid, exactly and in bounded memory.

    Joint i's error τ_i − τ_d,i depends on the joints of :meth:`TensorGrid.error_joints`
    only; its sums over the whole grid are its sums over their sub-grid times the points (or,
    trapezoidal, the angle ranges) of the others. The sub-grid is streamed in blocks of
    :data:`BLOCK_POINTS`, accumulating Σ(τ − τ_d)², Σ W (τ − τ_d)², max (τ − τ_d)² with its
    place and Σ τ_d². ∫|∂τ_i/∂k_j| = ∫|x_j a_ij| needs spring j's joints only.
    """
    axes, n, m = tensor.axes, tensor.n, tensor.m
    w = [trapezoid_weights(a) for a in axes]
    span = [float(wi.sum()) for wi in w]
    out = {"sq": [], "wsq": [], "max": [], "td2": [], "worst": []}
    for i in range(m):
        own = tensor.error_joints(i)
        sq = wsq = td2 = 0.0
        worst, place = -np.inf, [0] * m
        for block in blocks(own, n):
            td = tensor.target(i, block).value()
            td2 += float(np.einsum("i,i->", np.ravel(td), np.ravel(td))) * block.size / np.size(td)
            err2 = np.asarray(td - tensor.torque(i, block).value(), dtype=float)
            err2 = np.square(err2, out=err2).reshape((1,) * (len(own) - err2.ndim) + err2.shape)
            plain, weighted = _sums(err2, block.weights(w))
            sq, wsq = sq + plain, wsq + weighted
            top = float(err2.max())
            if not (top <= worst or np.isnan(worst)):  # a larger error, or the first NaN
                worst = top
                k = np.unravel_index(int(np.argmax(err2)), err2.shape)
                for axis, (c, ix) in enumerate(zip(block.axes, block.index)):
                    place[c] = int(ix[k[axis]])
        rest = [c for c in range(m) if c not in own]
        points = n ** len(own)
        out["sq"].append(sq / points)
        out["wsq"].append(wsq * float(np.prod([span[c] for c in rest])))
        out["max"].append(float(np.sqrt(worst)))
        out["td2"].append(td2 / points)
        out["worst"].append(tuple(place))
    S = len(tensor.problem.springs)
    sens = np.zeros((m, S))
    for i, j in tensor.arms:
        own = tuple(tensor.network.joints_of(j))
        total = sum(_sums(np.abs(tensor.rate_sensitivity(i, j, b)), b.weights(w))[1] for b in blocks(own, n))
        sens[i, j] = total * float(np.prod([span[c] for c in range(m) if c not in own]))
    out["sens"] = sens
    return out


#: The re-check's generic margins (each ≥ 0 when met), declared once: what each belongs to
#: (``springs``, ``mechanisms`` or ``profiles``), the tolerance a violation must pass [SI] and
#: the words that name it. A mechanism's own margins are its :attr:`Mechanism.limits`.
MARGINS = {
    "travel": ("springs", LENGTH_TOL, "spring above its travel"),
    "extension_lower": ("springs", LENGTH_TOL, "spring in compression"),
    "convexity": ("profiles", 0.0, "profile not convex"),
    "rho_min": ("profiles", LENGTH_TOL, "radius below rho_min"),
    "rho_max": ("profiles", LENGTH_TOL, "radius above rho_max"),
    "tangency": ("mechanisms", 0.0, "departure not solved"),
    "branch": ("mechanisms", 0.0, "cable on the wrong departure branch"),
    "preextension": ("springs", LENGTH_TOL, "negative pre-extension"),
    "curvature_radius": ("profiles", LENGTH_TOL, "radius of curvature below its minimum"),
}


def _margins(ev: Evaluation, ext: np.ndarray) -> dict:
    """Every margin of :data:`MARGINS` (per spring, profile or mechanism) and each mechanism's
    own (its limits' smallest margins over the grid), given the springs' extension ranges
    ``ext`` [m]."""
    p = ev.problem
    travel = p.spring_parameters().travel
    return {
        "travel": (travel - ext[:, 1]).tolist(),
        "extension_lower": ext[:, 0].tolist(),
        "convexity": [c.convexity_min for c in ev.profiles],
        "rho_min": [c.rho_lo - pc.rho_min for c, pc in zip(ev.profiles, p.profiles)],
        "rho_max": [pc.rho_max - c.rho_hi for c, pc in zip(ev.profiles, p.profiles)],
        "tangency": [float(RESIDUAL_TOL - u.residual.max()) for u in ev.units],
        "branch": [float(BRANCH_TOL - u.branch.max()) for u in ev.units],
        "preextension": ev.design.preextension.tolist(),
        "curvature_radius": [c.curvature_radius_min - p.curvature_limit(k)
                             for k, c in enumerate(ev.profiles)],
        "mechanism": [{name: float(row.min()) for name, row in zip(mech.margin_names, u.margins)}
                      for mech, u in zip(p.mechanisms, ev.units)],
    }


#: A catalogue spring's body limits (:meth:`cadcam.physics.springs.SpringBody.extension_limits`)
#: as the re-check names them: the words and the quantity, its unit and its largest value.
BODY_CHECKS = {
    "length": ("spring longer than its largest length", "length", "m", "length_max"),
    "load": ("spring force above its largest load", "force", "N", "load_max"),
    "stress": ("wire stress above its allowance", "stress", "Pa", "allowed_stress"),
}


def _body_violations(p: Problem, extension_max) -> list[str]:
    """One line per catalogue spring whose largest extension passes one of its body's limits by
    more than the travel's tolerance."""
    out = []
    for s, x in zip(p.springs, extension_max):
        if s.body is None:
            continue
        for name, limit in s.body.extension_limits().items():
            words, quantity, unit, largest = BODY_CHECKS[name]
            if not x <= limit + LENGTH_TOL:
                out.append(f"{words}: {s.name} ({getattr(s.body, quantity)(x):.4g} {unit} of "
                           f"{getattr(s.body, largest):.4g} {unit})")
    return out


def free_cable(ev: "Evaluation", j: int, u: int, port: str, joint: int) -> np.ndarray:
    """The free cable [m] between the profile and the hook of spring ``j``, mounted on ``port``
    of mechanism ``u`` on ``joint`` (:meth:`cadcam.problem.Problem.mounted_springs`), over the
    joint's grid: its room less its length L0 + x; negative where the spring does not fit."""
    tensor = ev.tensor
    x = np.ravel(tensor.extension(j, tensor.line([0] * tensor.m, joint))) * np.ones(tensor.n)
    return ev.units[u].rooms[port][:-1] - ev.problem.springs[j].free_length - x


def _fit_violations(ev: "Evaluation") -> list[str]:
    """One line per mounted spring that does not fit between its mount and the profile
    somewhere on the grid by more than the travel's tolerance."""
    out = []
    for j, u, port, joint in ev.problem.mounted_springs():
        least = float(np.min(free_cable(ev, j, u, port, joint)))
        if not least >= -LENGTH_TOL:
            out.append(f"spring longer than its room: {ev.problem.springs[j].name} reaches "
                       f"{-MM * least:.3g} mm past where the cable leaves {ev.problem.mechanisms[u].name}")
    return out


def _cable_violations(p: Problem, extension_max) -> list[str]:
    """One line per spring whose force at its largest extension ``extension_max`` puts more
    than the working load on the problem's cable, beyond the travel's tolerance."""
    if p.cable is None:
        return []
    return [f"cable tension above its working load: {s.name} pulls {s.rate * x + s.preload:.4g} N on "
            f"{p.cable.label()} (working load {p.cable.working_load:.4g} N, its breaking load over "
            f"{p.cable.safety_factor:g})"
            for s, x in zip(p.springs, extension_max)
            if not x <= p.cable.extension_limit(s.rate, s.preload) + LENGTH_TOL]


def cable_report(problem: Problem, metrics: Metrics) -> dict | None:
    """The problem's cable and its checks on an evaluation's ``metrics``
    (:meth:`cadcam.physics.cables.Cable.report`): each spring's largest force F0 + k·x, the
    tension it puts on the cable, and each profile's least radius of curvature; None without
    a ``[cable]``."""
    if problem.cable is None:
        return None
    tensions = [s.preload + s.rate * x for s, x in zip(problem.springs, metrics.extension_max)]
    return problem.cable.report(tensions, metrics.curvature_radius_min)


def _violations(p: Problem, margins: dict, extension_max=()) -> list[str]:
    """One line per margin below minus its tolerance (a NaN, not computable, counts as one),
    then each catalogue spring's body limit passed at its largest extension ``extension_max``
    and each spring's pull beyond its cable's working load."""
    violations = _body_violations(p, extension_max) + _cable_violations(p, extension_max)
    for mech, own in zip(p.mechanisms, margins["mechanism"]):
        violations += [f"{lim.name.replace('_', ' ')} below its limit: {mech.name} (margin {own[lim.name]:.3g})"
                       for lim in mech.limits if not own[lim.name] >= -LIMIT_TOL[lim.unit]]
    for key, (owners, tol, words) in MARGINS.items():
        for item, v in zip(getattr(p, owners), margins[key]):
            if not v >= -tol:
                violations.append(f"{words}: {item.name} (margin {v:.3g})")
    return violations


def _metrics(ev: Evaluation) -> tuple[Metrics, list]:
    """The metrics of :func:`evaluate` and, per joint, the grid indices of its worst point."""
    p = ev.problem
    grid = _streamed(ev.tensor)
    sens = grid["sens"]
    objective = float(sum(c.tracking_weight * grid["wsq"][i] + np.dot(c.sensitivity_weights, sens[i])
                          for i, c in enumerate(p.joints)))
    ext = np.array([ev.tensor.extension_range(j) for j in range(len(p.springs))]).reshape(-1, 2)
    margins = _margins(ev, ext)
    violations = _violations(p, margins, ext[:, 1]) + _fit_violations(ev)
    out_err = [output_error(mech, u) for mech, u in zip(p.mechanisms, ev.units)]
    return Metrics(
        grid=ev.grid,
        output_rmse=[None if e is None else float(np.sqrt(np.mean(e**2))) for e in out_err],
        output_max_abs_error=[None if e is None else float(np.abs(e).max()) for e in out_err],
        rmse=np.sqrt(grid["sq"]).tolist(),
        relative_rmse=_relative(np.sqrt(grid["sq"]), np.sqrt(grid["td2"])),
        max_abs_error=grid["max"],
        extension_min=ext[:, 0].tolist(),
        extension_max=ext[:, 1].tolist(),
        convexity_min=margins["convexity"],
        rho_min=[c.rho_lo for c in ev.profiles],
        rho_max=[c.rho_hi for c in ev.profiles],
        curvature_radius_min=[c.curvature_radius_min for c in ev.profiles],
        alpha_max=[float(c.alpha.max()) for c in ev.profiles],
        tangency_residual_max=float(max(u.residual.max() for u in ev.units)),
        sensitivity_integral=sens.tolist(),
        objective=objective,
        margins=margins,
        violations=violations,
    ), grid["worst"]
