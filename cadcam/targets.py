"""Target torque laws τ_d [N·m] of the joint angles [rad].

A spec is data: target expressions are parsed with :mod:`ast` into a tree that is walked
against a whitelist of names, functions and operators and turned into a CasADi expression.
Nothing is ever passed to ``eval`` or ``exec``, so a spec from someone else cannot run code.
"""
from __future__ import annotations

import ast
import csv
import io
import pickle
import re
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Callable

import casadi as ca
import numpy as np

from .files import read_input
from .keys import GRAVITY, MASS, REACH, Key, KeyTable, is_real

FUNCTIONS = {
    "sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "asin": ca.asin, "acos": ca.acos,
    "atan": ca.atan, "atan2": ca.atan2, "sinh": ca.sinh, "cosh": ca.cosh, "tanh": ca.tanh,
    "exp": ca.exp, "log": ca.log, "sqrt": ca.sqrt,
}
CONSTANTS = {"pi": np.pi, "e": np.e}
_BINARY = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b,
           ast.Mult: lambda a, b: a * b, ast.Div: lambda a, b: a / b,
           ast.Pow: lambda a, b: a**b}
_UNARY = {ast.USub: lambda a: -a, ast.UAdd: lambda a: a}
MAX_EXPRESSION_LENGTH = 2000
#: Deepest nesting of an expression's syntax tree (a long chain of unary minus signs is deep).
MAX_EXPRESSION_DEPTH = 100


class ExpressionError(ValueError):
    """An expression uses something outside the whitelist, or is not an expression."""


#: What each guard of :func:`parse_expression` asks of its sub-expression(s) over the range.
GUARDS = {
    "denominator": "a divisor that is zero or changes sign (a pole)",
    "log": "log of a number ≤ 0",
    "sqrt": "sqrt of a negative number",
    "asin": "asin or acos outside [-1, 1]",
    "power": "a negative number to a fractional power, or zero to a negative one",
    "atan2": "atan2(y, x) crossing its branch cut (y changes sign where x < 0: a jump of 2π)",
}


def parse_expression(text: str, names: dict[str, object], guards: list | None = None):
    """Turn ``text`` into a CasADi expression using only whitelisted constructs.

    Parameters
    ----------
    text : str
        Arithmetic in Python syntax: numbers, ``+ - * / **``, unary minus, parentheses, calls
        of :data:`FUNCTIONS`, the constants ``pi`` and ``e`` and the given ``names``.
    names : dict
        Variable name → CasADi symbol or number.
    guards : list, optional
        If given, receives a ``(kind, operands)`` pair for every operation that is undefined,
        infinite or discontinuous somewhere (:data:`GUARDS`): each divisor (``tan`` counts as
        division by ``cos``), each argument of ``log``, ``sqrt``, ``asin`` and ``acos``, each
        power's base and exponent and each ``atan2``'s (y, x). :func:`check_guards` checks them
        over a range: a target with a pole or a jump is refused before any work.

    Raises
    ------
    ExpressionError
        For anything else: attribute access, subscripts, other calls, strings, keywords…
    """
    tree = _syntax_tree(text)
    guard = guards.append if guards is not None else (lambda item: None)
    return ca.SX(_Builder({**CONSTANTS, **names}, guard).build(tree.body))


def _syntax_tree(text: str) -> ast.Expression:
    """The :mod:`ast` tree of the expression ``text``, refused when empty, too long or too deep."""
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError("an expression must be a non-empty string")
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_EXPRESSION_LENGTH} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, RecursionError, MemoryError, ValueError) as exc:
        raise ExpressionError(f"not a valid expression ({getattr(exc, 'msg', 'too deeply nested')})") from None
    if _depth(tree) > MAX_EXPRESSION_DEPTH:
        raise ExpressionError(f"expression nested deeper than {MAX_EXPRESSION_DEPTH} levels")
    return tree


#: The guard (:data:`GUARDS`) of each function whose argument(s) it checks; ``tan``'s divisor
#: is the cosine of its argument.
_CALL_GUARDS = {"tan": "denominator", "log": "log", "sqrt": "sqrt", "asin": "asin", "acos": "asin",
                "atan2": "atan2"}


class _Builder:
    """Builds the CasADi expression of a syntax tree over the names of ``scope``, passing each
    guard of :func:`parse_expression` to ``guard``."""

    def __init__(self, scope: dict, guard: Callable):
        self.scope, self.guard = scope, guard

    def build(self, node):
        """The value of ``node``: a float, a name's value or an SX."""
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return _finite_number(node)
        if isinstance(node, ast.Name):
            if node.id in self.scope:
                return self.scope[node.id]
            raise ExpressionError(f"unknown name {node.id!r}; allowed: {sorted(self.scope)}")
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            left, right = ca.SX(self.build(node.left)), self.build(node.right)
            if isinstance(node.op, ast.Div):
                self.guard(("denominator", (right,)))
            if isinstance(node.op, ast.Pow):
                self.guard(("power", (left, right)))
            return _BINARY[type(node.op)](left, right)
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](ca.SX(self.build(node.operand)))
        if isinstance(node, ast.Call):
            return self.call(node)
        raise ExpressionError(f"{type(node).__name__} {ast.unparse(node)!r} is not allowed")

    def call(self, node: ast.Call):
        """A call of one of :data:`FUNCTIONS` with its positional arguments, and its guard."""
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            raise ExpressionError(f"call of {ast.unparse(node.func)!r} is not allowed; "
                                  f"allowed functions: {sorted(FUNCTIONS)}")
        arity = 2 if node.func.id == "atan2" else 1
        if node.keywords or len(node.args) != arity:
            raise ExpressionError(f"{node.func.id}() takes {arity} positional argument(s)")
        args = [ca.SX(self.build(a)) for a in node.args]
        kind = _CALL_GUARDS.get(node.func.id)
        if kind:
            self.guard((kind, (ca.cos(args[0]),) if node.func.id == "tan" else tuple(args)))
        return FUNCTIONS[node.func.id](*args)


def _finite_number(node: ast.Constant) -> float:
    """A numeric literal as a float, refused when too large for one."""
    try:
        value = float(node.value)
    except OverflowError:
        value = np.inf
    if not np.isfinite(value):
        raise ExpressionError(f"the number {ast.unparse(node)[:20]}… is too large for a float")
    return value


def _depth(tree) -> int:
    """The depth of an :mod:`ast` tree, without recursion."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, d = stack.pop()
        deepest = max(deepest, d)
        stack.extend((child, d + 1) for child in ast.iter_child_nodes(node))
    return deepest


def check_guards(guards, symbols, axes) -> str | None:
    """The first guard of :func:`parse_expression` that fails on the tensor grid of the angle
    ``axes`` (one increasing array per symbol in ``symbols``): its description and where, or
    None if all hold.

    A divisor fails where it is zero or changes sign between neighbouring samples along any
    angle (a pole lies between them); ``atan2`` where y changes sign between neighbours with
    x < 0 at both.
    """
    mesh = np.meshgrid(*axes, indexing="ij")
    points = np.array([m.ravel() for m in mesh])
    shape = mesh[0].shape

    def crossing(v, also=None):
        """Sign changes between neighbours along any axis, flagged at the first of the pair."""
        out = np.zeros(shape, dtype=bool)
        for a in range(len(shape)):
            lo = [slice(None)] * len(shape)
            hi = [slice(None)] * len(shape)
            lo[a], hi[a] = slice(None, -1), slice(1, None)
            flip = np.sign(v[tuple(lo)]) * np.sign(v[tuple(hi)]) < 0
            if also is not None:
                flip &= also[tuple(lo)] & also[tuple(hi)]
            out[tuple(lo)] |= flip
        return out

    for kind, operands in guards:
        f = ca.Function("guard", [ca.vertcat(*symbols)], list(operands))
        vals = [np.asarray(v).reshape(shape) for v in f.map(points.shape[1]).call([points])]
        v = vals[0]
        if kind == "denominator":
            bad = (v == 0) | crossing(v)
        elif kind == "log":
            bad = v <= 0
        elif kind == "sqrt":
            bad = v < 0
        elif kind == "asin":
            bad = np.abs(v) > 1
        elif kind == "power":
            base, exponent = vals
            bad = ((base < 0) & (exponent != np.round(exponent))) | ((base == 0) & (exponent < 0))
        else:  # atan2(y, x)
            bad = crossing(v, vals[1] < 0)
        if np.any(bad):
            where = np.degrees(points[:, int(np.argmax(bad.ravel()))])
            return f"{GUARDS[kind]} near theta = {np.round(where, 3).tolist()} deg"
    return None


def reserved_name(name: str) -> bool:
    """Whether an expression parameter may not take ``name``: a function of
    :data:`FUNCTIONS`, a constant or an angle name of :func:`angle_names`."""
    return name in FUNCTIONS or name in CONSTANTS or re.fullmatch(r"theta\d*", name) is not None


def angle_names(thetas, joint: int) -> dict:
    """Names an expression may use for the angles: ``theta`` (own joint) and ``theta1…thetaM``."""
    out = {f"theta{i + 1}": t for i, t in enumerate(thetas)}
    out["theta"] = thetas[joint]
    return out


def serial_arm_torques(thetas, masses, lengths, com, g):
    """Gravity-balancing torques [N·m] of a planar serial arm by the transposed Jacobian.

    Joint angles ``thetas`` [rad] are measured from the upward vertical, each relative to the
    previous link; link i has mass ``masses[i]`` [kg] at ``com[i]`` [m] from its joint and
    length ``lengths[i]`` [m]. With p_i the centre of mass of link i and F_i = (0, −m_i g) its
    weight, τ = Σ_i J_i(θ)ᵀ F_i (Endo2010 Eq. 3–8) is the torque a balancer must supply; for
    the RR arm it is Johnston2023's Eq. 49.
    """
    q = ca.vertcat(*thetas)
    tau = ca.SX.zeros(q.shape[0])
    base = ca.SX.zeros(2)
    phi = 0
    for i, m in enumerate(masses):
        phi = phi + q[i]
        direction = ca.vertcat(ca.sin(phi), ca.cos(phi))
        p_i = base + com[i] * direction  # Endo2010 Eq. 4: position of the point mass
        J_i = ca.jacobian(p_i, q)  # Endo2010 Eq. 5
        tau = tau + ca.mtimes(J_i.T, ca.vertcat(0, -m * g))  # Endo2010 Eq. 3, 6–8
        base = base + lengths[i] * direction
    return [tau[i] for i in range(q.shape[0])]


FIVE_BAR_LENGTHS = ("upper", "crank", "fore", "com")


def _five_bar_points(q, lengths) -> list:
    """Positions [m] of the six point masses of Endo2010's five-bar arm (Fig. 7, the
    "six-point-mass system") at the angles ``q`` = (θ1, θ2) [rad].

    Geometry (x forwards, y up; angles from the upward vertical, positive towards +x, both
    measured at the base O as in Endo2010 Eq. 4), with u(θ) = (sin θ, cos θ):

    * link 1 (upper arm, length l_u) from O at θ1 to the elbow E = l_u u(θ1);
    * the crank (link 2, length l_c) from O at θ2 to C = l_c u(θ2);
    * the coupler from C parallel to link 1 to D = C + l_u u(θ1);
    * the forearm, rigid through D and E and so parallel to the crank, carries the tip
      T = E − l_a u(θ2) beyond the elbow (Endo2010 Eq. 4:
      p6 = (l_u sin θ1 − l_a sin θ2, l_u cos θ1 − l_a cos θ2)).

    The masses: p1 = l1 u(θ1) on link 1; p2 = l2 u(θ2) on the crank; p3 = C + l3 u(θ1) on the
    coupler; p4 = E at the elbow; p5 = E + l5 u(θ2) on the forearm's rear part (from E towards
    D); p6 = T at the tip. ``lengths`` as for :func:`five_bar_torques`.
    """
    l_u, l_c, l_a = (float(lengths[k]) for k in ("upper", "crank", "fore"))
    l1, l2, l3, l5 = (float(v) for v in lengths["com"])

    def u(t):
        return ca.vertcat(ca.sin(t), ca.cos(t))

    elbow, crank_end = l_u * u(q[0]), l_c * u(q[1])
    return [l1 * u(q[0]),                 # m1 on link 1
            l2 * u(q[1]),                 # m2 on the crank
            crank_end + l3 * u(q[0]),     # m3 on the coupler
            elbow,                        # m4 at the elbow
            elbow + l5 * u(q[1]),         # m5 on the forearm's rear part
            elbow - l_a * u(q[1])]        # m6 at the tip, Endo2010 Eq. 4


def five_bar_torques(theta1, theta2, masses, lengths, g):
    """Gravity-balancing torques [N·m] of Endo2010's parallel five-bar arm (Sec. III, Fig. 7).

    Angles [rad] are measured at the base from the upward vertical, positive forwards
    (Endo2010 Eq. 4): θ1 of link 1 (the upper arm), θ2 of the crank, which the forearm stays
    parallel to; six point masses p_k model the links (Endo2010 Fig. 7; the geometry and
    their positions: :func:`_five_bar_points`). With F_k = (0, −m_k g) and J_k = ∂p_k/∂(θ1, θ2)
    (Endo2010 Eq. 5), τ = Σ_k J_kᵀ F_k (Endo2010 Eq. 3, 6–7) is the generalised force of
    gravity, i.e. −∂V/∂θ with V = g Σ m_k y_k, the torque a balancer must supply (the
    convention of :func:`serial_arm_torques`). Summed, it takes the form of Endo2010 Eq. 8,
    each joint's torque depending on its own angle only::

        τ1 = g (m1 l1 + m3 l3 + (m4 + m5 + m6) l_u) sin θ1
        τ2 = g (m2 l2 + m3 l_c + m5 l5 − m6 l_a) sin θ2

    (positive coefficient: an inverted pendulum; negative: an ordinary one).

    Parameters
    ----------
    theta1, theta2 : float or casadi.SX or casadi.MX
        Angles of link 1 and of the crank [rad].
    masses : sequence of 6 float
        m1 … m6 [kg].
    lengths : mapping
        ``upper`` l_u, ``crank`` l_c, ``fore`` l_a [m] and ``com`` = [l1, l2, l3, l5] [m].
    g : float
        Gravity [m/s²].

    Returns
    -------
    list
        [τ1, τ2] [N·m], of the angles' CasADi type (DM for numbers).
    """
    m = [float(v) for v in masses]
    if len(m) != 6:
        raise ValueError(f"five_bar_torques needs 6 masses, got {len(m)}")
    q = ca.SX.sym("q", 2)
    tau = ca.SX.zeros(2)
    for m_k, p_k in zip(m, _five_bar_points(q, lengths)):
        J_k = ca.jacobian(p_k, q)  # Endo2010 Eq. 5
        tau = tau + ca.mtimes(J_k.T, ca.vertcat(0, -m_k * g))  # Endo2010 Eq. 3, 6–7
    out = ca.Function("five_bar_torques", [q], [tau])(ca.vertcat(theta1, theta2))
    return [out[0], out[1]]  # Endo2010 Eq. 8


@dataclass(frozen=True)
class TargetKind:
    """A kind of target law, declared once: its law, where it may be used, and (for a kind a
    mechanism brings) how its keys are read from a spec.

    Attributes
    ----------
    name : str
        The spec's ``kind``.
    law : callable
        ``law(data, thetas, joint)``: the law as a CasADi expression of the joint angles
        ``thetas`` (a list of SX) for the joint numbered ``joint`` (0-based), from the kind's ``data``.
    torque, output : bool
        Whether it may be a joint's torque law [N·m], a mechanism's output law [m].
    read : callable or None
        ``read(reader, theta_range) -> data``: the kind's keys from its spec table (the reader
        of :mod:`cadcam.spec`), for a kind the spec reader does not know itself.
    check : callable or None
        ``check(datas) -> str or None``: given the data of every output law of this kind in
        one problem, ``"key: what is wrong"`` where they contradict each other.
    keys : KeyTable or None
        Its keys (beside ``kind``): what the spec reader reads, the reference lists and the
        result's schema describes.
    """

    name: str
    law: Callable
    torque: bool = True
    output: bool = False
    read: Callable | None = None
    check: Callable | None = None
    keys: KeyTable | None = None


_KINDS: dict[str, TargetKind] = {}


def register_target_kind(kind: TargetKind) -> TargetKind:
    """Make ``kind`` available to specs and :class:`Target` (a mechanism's folder registers
    the laws it brings)."""
    if kind.name in _KINDS and _KINDS[kind.name] != kind:
        raise ValueError(f"a target kind named {kind.name!r} is already registered")
    _KINDS[kind.name] = kind
    return kind


def target_kind(name: str) -> TargetKind:
    """The registered target kind ``name``; ValueError if there is none."""
    try:
        return _KINDS[name]
    except KeyError:
        raise ValueError(f"unknown target kind {name!r}") from None


def target_kinds(output: bool = False) -> tuple[str, ...]:
    """Names of the kinds that may be a torque law (or, with ``output``, an output law)."""
    return tuple(k.name for k in _KINDS.values() if (k.output if output else k.torque))


def _expression_names(data: dict, thetas, joint: int) -> dict:
    """An ``expression``'s names: its numeric ``parameters`` and the angles."""
    return {**{k: float(v) for k, v in data.get("parameters", {}).items()}, **angle_names(thetas, joint)}


def _expression_law(data, thetas, joint):
    return parse_expression(data["expression"], _expression_names(data, thetas, joint))


def _pendulum_law(d, thetas, joint):
    return d["mass"] * d["g"] * d["length"] * ca.sin(thetas[joint] + d["phase"])


def _arm_law(d, thetas, joint):
    joints = serial_arm_torques(thetas[:len(d["masses"])], d["masses"], d["lengths"], d["com"], d["g"])
    return joints[d["joint"] - 1]


def _five_bar_law(d, thetas, joint):
    joints = five_bar_torques(thetas[0], thetas[1], d["masses"], {k: d[k] for k in FIVE_BAR_LENGTHS}, d["g"])
    return joints[d["joint"] - 1]


def _table_law(d, thetas, joint):
    s = np.asarray(d["samples"], dtype=float)
    return ca.interpolant("target_table", "bspline", [s[:, 0]], s[:, 1])(thetas[joint])


#: The units a table's angles may be written in, with their factor to radians.
ANGLE_UNITS = {"rad": 1.0, "deg": np.pi / 180}

#: Every target table's ``kind``: the law it is (one of :func:`target_kinds`).
KIND = Key("kind", "", "the kind of law", "string", min_length=1)
G = Key("g", "m/s²", "the gravity", low=0, open_low=True, default=9.81, plausible=GRAVITY)
EXPRESSION_KEYS = KeyTable('kind = "expression"', "A law written as an expression of theta (theta1, theta2… "
                           "on several joints), parsed, never evaluated as code.", (
    Key("expression", "", "an expression of theta such as '0.08*theta**2', in N·m for a torque, m for an output",
        "string", min_length=1),
    Key("parameters", "", "named numbers the expression uses", "table", default={}, check=lambda v: all(
            isinstance(k, str) and k.isidentifier() and not reserved_name(k) and is_real(x) for k, x in v.items()),
        words="each name = a number, the name not a function's, pi, e, theta, theta1, theta2…"),
))
PENDULUM_KEYS = KeyTable('kind = "pendulum"', "A pendulum's gravity torque m g l sin(θ + phase).", (
    Key("mass", "kg", "the pendulum's mass m", low=0, open_low=True, plausible=MASS),
    Key("length", "m", "the distance l from the joint to the centre of mass", low=0, open_low=True, plausible=REACH),
    G,
    Key("phase", "rad", "the phase added to the joint angle", default=0.0),
    Key("mass_range", "kg", "the least and greatest mass m the pendulum has in use (an arm whose payload changes)",
        "numbers", length=2, low=0, open_low=True, default=None, default_text="none: mass alone",
        check=lambda v: v[0] < v[1], words="least < greatest", plausible=MASS,
        details="the design is for `mass`, within the range; the adjustment ([adjustment]) is set for each mass, "
                "and its table (adjustment.csv) maps the mass to the setting"),
))
TABLE_KEYS = KeyTable('kind = "table"', "A law sampled in a table, interpolated by a cubic B-spline: inline "
                      "samples, or a CSV file with header theta_rad,<value> or theta_deg,<value> (torque_Nm "
                      "for a torque, x_m for an output).", (
    Key("samples", "", "[angle, value] rows, angles increasing, in angle_unit (the value in N·m for a torque, "
        "m for an output); give samples or file", "rows", length=2, min_length=4, default=None,
        default_text="none: file", check=lambda v: all(b[0] > a[0] for a, b in zip(v, v[1:])),
        words="angles increasing"),
    Key("angle_unit", "", "the unit of the samples' angles", "choice", choices=tuple(ANGLE_UNITS), default="rad"),
    Key("file", "", "a CSV file, relative to the spec, whose header names its angles' unit: theta_rad,<value> or "
        "theta_deg,<value>", "string", min_length=1, default=None, default_text="none: samples"),
))
ARM_KEYS = KeyTable('[arm] (or kind = "arm")', "A planar serial arm whose joints are the problem's joints: "
                    "its gravity torques (an arm target gives these keys itself or reads the spec's [arm]).", (
    Key("masses", "kg", "each link's mass, one per joint", "numbers", low=0, open_low=True, min_length=1,
        plausible=MASS),
    Key("lengths", "m", "each link's length, one per mass", "numbers", low=0, plausible=REACH),
    Key("com", "m", "each link's centre-of-mass distance from its joint, one per mass", "numbers", plausible=REACH),
    G,
))
ARM_JOINT = Key("joint", "", "the arm's joint whose torque this is (1-based)", "integer", low=1)
FIVE_BAR_KEYS = KeyTable('kind = "five_bar"', "A joint's gravity torque of Endo2010's parallel five-bar arm "
                         "(2 joints: theta1 = link 1, theta2 = the crank).", (
    Key("joint", "", "1 (link 1, theta1) or 2 (the crank, theta2)", "integer", low=1, high=2),
    Key("masses", "kg", "the point masses m1…m6", "numbers", length=6, low=0, open_low=True, plausible=MASS),
    Key("upper", "m", "the upper arm's length l_u", low=0, open_low=True, plausible=REACH),
    Key("crank", "m", "the crank's length l_c", low=0, open_low=True, plausible=REACH),
    Key("fore", "m", "the forearm's length l_a, elbow to tip", low=0, plausible=REACH),
    Key("com", "m", "the distances [l1, l2, l3, l5]", "numbers", length=4, low=0, plausible=REACH),
    G,
))

for _kind in (TargetKind("expression", _expression_law, output=True, keys=EXPRESSION_KEYS),
              TargetKind("pendulum", _pendulum_law, keys=PENDULUM_KEYS),
              TargetKind("table", _table_law, output=True, keys=TABLE_KEYS),
              TargetKind("arm", _arm_law, keys=KeyTable('kind = "arm"', "Joint's gravity torque of a planar "
                                                        "serial arm ([arm]'s keys, given here or in [arm]).",
                                                        (ARM_JOINT, *ARM_KEYS.keys))),
              TargetKind("five_bar", _five_bar_law, keys=FIVE_BAR_KEYS),
              TargetKind("none", lambda d, thetas, joint: ca.SX(0),
                         keys=KeyTable('kind = "none"', "No torque goal: the joint's torque is not weighed.", ()))):
    register_target_kind(_kind)


#: How many targets' functions are kept (:meth:`Target.function`, by their kind and data).
KEPT_FUNCTIONS = 64


@lru_cache(maxsize=KEPT_FUNCTIONS)
def _kept_function(kind: str, data: bytes, n_joints: int, joint: int) -> ca.Function:
    """:func:`_function` of the law of ``kind`` with the pickled ``data``, built once: a design
    page parses its spec again, targets and all, at every step of a slider, and builds the
    target's function several times a step (the parse, the NLP's parameters, the evaluation)."""
    return _function(kind, pickle.loads(data), n_joints, joint)


def _function(kind: str, data: dict, n_joints: int, joint: int) -> ca.Function:
    """``target(theta[n_joints]) -> tau_d`` [N·m] of the law of ``kind`` with ``data``."""
    th = ca.SX.sym("theta", n_joints)
    return ca.Function("target", [th], [Target(kind, data).expression([th[i] for i in range(n_joints)], joint)])


@dataclass
class Target:
    """A target torque τ_d [N·m] for one joint.

    ``kind`` is ``expression`` (``expression`` with optional numeric ``parameters``),
    ``pendulum`` (τ = m g l sin(θ + phase): ``mass`` [kg], ``length`` [m] to the centre of
    mass, ``g`` [m/s²], ``phase`` [rad]) or ``table`` (``samples`` of (θ [rad], τ [N·m]),
    interpolated by a cubic B-spline in the joint's own angle) or ``arm`` (joint ``joint``'s
    gravity torque of a planar serial arm with ``masses`` [kg], ``lengths`` [m], ``com`` [m]
    and ``g``, its joints being the problem's joints; see :func:`serial_arm_torques`) or
    ``five_bar`` (joint ``joint``'s gravity torque of Endo2010's parallel five-bar arm with
    six ``masses`` [kg], lengths ``upper``, ``crank``, ``fore`` and ``com`` = [l1, l2, l3, l5]
    [m] and ``g``; joint angles θ1 (link 1) and θ2 (crank); see :func:`five_bar_torques`) or
    ``none`` (no torque goal: τ_d = 0 with no weight in the objective).

    A mechanism's output law x(θ) [m] (:attr:`cadcam.mechanisms.base.Mechanism.output_target`)
    is a Target too: ``expression`` or ``table`` of metres, or a kind the mechanism's folder
    registers (:func:`register_target_kind`).
    """

    kind: str
    data: dict = field(default_factory=dict)

    def expression(self, thetas, joint: int):
        """τ_d as a CasADi expression of the joint angles ``thetas`` (a list of SX)."""
        return target_kind(self.kind).law(self.data, thetas, joint)

    def guard_failure(self, axes, joint: int) -> str | None:
        """For an ``expression``: where it has a pole, leaves its functions' domains or jumps
        on the tensor grid of the angle ``axes`` [rad] (:func:`check_guards`); else None."""
        if self.kind != "expression":
            return None
        th = ca.SX.sym("theta", len(axes))
        thetas = [th[i] for i in range(len(axes))]
        guards = []
        parse_expression(self.data["expression"], _expression_names(self.data, thetas, joint), guards)
        return check_guards(guards, thetas, axes)

    def function(self, n_joints: int, joint: int) -> ca.Function:
        """``target(theta[n_joints]) -> tau_d`` [N·m], built once per law (:func:`_kept_function`)."""
        try:
            data = pickle.dumps(self.data)
        except (pickle.PicklingError, TypeError, AttributeError):  # not plain data: built each time
            return _function(self.kind, self.data, n_joints, joint)
        return _kept_function(self.kind, data, n_joints, joint)

    def coupled_joints(self, n_joints: int, joint: int) -> list[int]:
        """The other joints (0-based) whose angles τ_d of ``joint`` depends on, read from its
        expression graph: empty where the target is a function of its own angle only."""
        th = ca.SX.sym("theta", n_joints)
        law = self.expression([th[i] for i in range(n_joints)], joint)
        return [i for i in range(n_joints) if i != joint and ca.depends_on(law, th[i])]

    def to_dict(self) -> dict:
        """Resolved form (tables inlined as samples) in the spec's format."""
        return {"kind": self.kind, **self.data}


def read_table(path: Path, value: str = "torque_Nm") -> list[list[float]]:
    """Read a CSV of target samples with header ``theta_rad,<value>`` or ``theta_deg,<value>``
    (``torque_Nm`` for a torque law, ``x_m`` for a displacement law).

    Returns sorted [θ [rad], value] pairs. Raises ValueError with a reason.
    """
    unit, rows = read_table_rows(path, value)
    data = np.array(rows, dtype=float)
    data[:, 0] *= ANGLE_UNITS[unit]
    return data.tolist()


def read_table_rows(path: Path, value: str = "torque_Nm") -> tuple[str, list[list[float]]]:
    """The CSV of target samples at ``path`` as written: the unit its header names for the
    angles (a key of :data:`ANGLE_UNITS`) and its [angle, value] rows sorted by angle
    (:func:`read_table` gives them in radians). Raises ValueError with a reason."""
    try:  # a byte order mark (spreadsheets write one) is not part of the header; strict: an
        # unclosed quote would otherwise swallow the rest of the file as one cell
        rows = list(csv.reader(io.StringIO(read_input(path).removeprefix("\ufeff"), newline=""), strict=True))
    except csv.Error as exc:
        raise ValueError(f"not a readable CSV ({exc}): close every quote, or remove it") from None
    if not rows:
        raise ValueError("the table is empty")
    head = [h.strip() for h in rows[0]]
    if head not in (["theta_rad", value], ["theta_deg", value]):
        raise ValueError(f"the header must be 'theta_rad,{value}' or 'theta_deg,{value}'")
    try:
        data = np.array([[float(v) for v in r] for r in rows[1:] if r], dtype=float)
    except ValueError:
        raise ValueError("every row must hold two numbers") from None
    if data.ndim != 2 or data.shape[1] != 2 or data.shape[0] < 4:
        raise ValueError("need at least 4 rows of two numbers")
    if not np.all(np.isfinite(data)):
        raise ValueError(f"data row {1 + int(np.argmin(np.all(np.isfinite(data), axis=1)))} holds nan or inf; "
                         "every number must be finite")
    unit = head[0].removeprefix("theta_")
    data = data[np.argsort(data[:, 0])]
    if np.any(np.diff(data[:, 0] * ANGLE_UNITS[unit]) <= 0):  # distinct in radians too (no two round to one)
        raise ValueError("angles must be distinct")
    return unit, data.tolist()
