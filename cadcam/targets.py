"""Target torque laws τ_d [N·m] of the cam angles [rad].

A spec is data: target expressions are parsed with :mod:`ast` into a tree that is walked
against a whitelist of names, functions and operators and turned into a CasADi expression.
Nothing is ever passed to ``eval`` or ``exec``, so a spec from someone else cannot run code.
"""
from __future__ import annotations

import ast
import csv
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

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


class ExpressionError(ValueError):
    """An expression uses something outside the whitelist, or is not an expression."""


def parse_expression(text: str, names: dict[str, object]):
    """Turn ``text`` into a CasADi expression using only whitelisted constructs.

    Parameters
    ----------
    text : str
        Arithmetic in Python syntax: numbers, ``+ - * / **``, unary minus, parentheses, calls
        of :data:`FUNCTIONS`, the constants ``pi`` and ``e`` and the given ``names``.
    names : dict
        Variable name → CasADi symbol or number.

    Raises
    ------
    ExpressionError
        For anything else: attribute access, subscripts, other calls, strings, keywords…
    """
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError("an expression must be a non-empty string")
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_EXPRESSION_LENGTH} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"not a valid expression ({exc.msg})") from None
    scope = {**CONSTANTS, **names}

    def walk(node):
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return float(node.value)
        if isinstance(node, ast.Name):
            if node.id in scope:
                return scope[node.id]
            raise ExpressionError(f"unknown name {node.id!r}; allowed: {sorted(scope)}")
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](ca.SX(walk(node.left)), walk(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](ca.SX(walk(node.operand)))
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                raise ExpressionError(f"call of {ast.unparse(node.func)!r} is not allowed; "
                                      f"allowed functions: {sorted(FUNCTIONS)}")
            arity = 2 if node.func.id == "atan2" else 1
            if node.keywords or len(node.args) != arity:
                raise ExpressionError(f"{node.func.id}() takes {arity} positional argument(s)")
            return FUNCTIONS[node.func.id](*[ca.SX(walk(a)) for a in node.args])
        raise ExpressionError(f"{type(node).__name__} {ast.unparse(node)!r} is not allowed")

    return ca.SX(walk(tree))


def angle_names(thetas, cam: int) -> dict:
    """Names an expression may use for the angles: ``theta`` (own cam) and ``theta1…thetaM``."""
    out = {f"theta{i + 1}": t for i, t in enumerate(thetas)}
    out["theta"] = thetas[cam]
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


@dataclass
class Target:
    """A target torque τ_d [N·m] for one cam.

    ``kind`` is ``expression`` (``expression`` with optional numeric ``parameters``),
    ``pendulum`` (τ = m g l sin(θ + phase): ``mass`` [kg], ``length`` [m] to the centre of
    mass, ``g`` [m/s²], ``phase`` [rad]) or ``table`` (``samples`` of (θ [rad], τ [N·m]),
    interpolated by a cubic B-spline in the cam's own angle) or ``arm`` (joint ``joint``'s
    gravity torque of a planar serial arm with ``masses`` [kg], ``lengths`` [m], ``com`` [m]
    and ``g``, the cam angles being the joint angles; see :func:`serial_arm_torques`).
    """

    kind: str
    data: dict = field(default_factory=dict)

    def expression(self, thetas, cam: int):
        """τ_d as a CasADi expression of the cam angles ``thetas`` (a list of SX)."""
        if self.kind == "expression":
            names = {**{k: float(v) for k, v in self.data.get("parameters", {}).items()},
                     **angle_names(thetas, cam)}
            return parse_expression(self.data["expression"], names)
        if self.kind == "pendulum":
            d = self.data
            return d["mass"] * d["g"] * d["length"] * ca.sin(thetas[cam] + d["phase"])
        if self.kind == "arm":
            d = self.data
            joints = serial_arm_torques(thetas[:len(d["masses"])], d["masses"], d["lengths"],
                                        d["com"], d["g"])
            return joints[d["joint"] - 1]
        if self.kind == "table":
            s = np.asarray(self.data["samples"], dtype=float)
            interp = ca.interpolant("target_table", "bspline", [s[:, 0]], s[:, 1])
            return interp(thetas[cam])
        raise ValueError(f"unknown target kind {self.kind!r}")

    def function(self, n_cams: int, cam: int) -> ca.Function:
        """``target(theta[n_cams]) -> tau_d`` [N·m]."""
        th = ca.SX.sym("theta", n_cams)
        return ca.Function("target", [th], [self.expression([th[i] for i in range(n_cams)], cam)])

    def to_dict(self) -> dict:
        """Resolved form (tables inlined as samples) in the spec's format."""
        return {"kind": self.kind, **self.data}


def read_table(path: Path) -> list[list[float]]:
    """Read a CSV of target samples with header ``theta_rad,torque_Nm`` or ``theta_deg,torque_Nm``.

    Returns sorted [θ [rad], τ [N·m]] pairs. Raises ValueError with a reason.
    """
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise ValueError("the table is empty")
    head = [h.strip() for h in rows[0]]
    if head not in (["theta_rad", "torque_Nm"], ["theta_deg", "torque_Nm"]):
        raise ValueError("the header must be 'theta_rad,torque_Nm' or 'theta_deg,torque_Nm'")
    try:
        data = np.array([[float(v) for v in r] for r in rows[1:] if r], dtype=float)
    except ValueError:
        raise ValueError("every row must hold two numbers") from None
    if data.ndim != 2 or data.shape[1] != 2 or data.shape[0] < 4:
        raise ValueError("need at least 4 rows of two numbers")
    if head[0] == "theta_deg":
        data[:, 0] = np.radians(data[:, 0])
    data = data[np.argsort(data[:, 0])]
    if np.any(np.diff(data[:, 0]) <= 0):
        raise ValueError("angles must be distinct")
    return data.tolist()
