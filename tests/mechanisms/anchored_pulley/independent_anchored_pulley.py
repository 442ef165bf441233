"""An independent reference model of the anchored-spring pulley (numpy only; no cadcam, no casadi).

Ludovico, Guardiani, Lasagni, Lee, Cannella, Caldwell 2021, RA-L 6(2) (Ludovico2021), Sec. II
(Kim & Deshpande's pulley), and Endo, Yamada, Yajima, Ogata, Hirose 2010, ICRA (Endo2010),
Sec. II: a cable is anchored on a convex pulley, wound on it and leaves it tangentially,
straight to the end of a spring acting along it.  This module recomputes the torque of a
design that ``cadcam design`` wrote, from what a third party receives: the outline
``cam{i}_points.csv`` and the fields of ``result.json``.  It shares no code with cadcam.

Inputs (SI units inside; the CSV is in millimetres)
----------------------------------------------------
* ``cam{i}_points.csv`` (``x_mm,y_mm``): the closed outline of pulley i as a convex polygon,
  counter-clockwise, in the pulley's frame (the joint at the origin) with the cable anchored at
  the vertex on the +x axis (polar angle 0, the first vertex) and wound counter-clockwise from
  it.  For ``winding = "cw"`` the real pulley is this polygon mirrored, (x, y) -> (x, -y).
* ``result.json``: ``problem.mechanisms[i]`` -- ``spring_end`` (the spring end's world position
  at theta = 0 [m]), ``turning`` ("pulley" or "spring_end": the body that turns with the joint,
  by ``sense``*theta, counter-clockwise positive), ``winding``, ``anchor_angle`` (the world angle
  of the anchor direction at theta = 0 [rad]), ``reference_angle`` (where the extension is the
  pre-extension [rad]); ``problem.springs[j]`` -- ``rate`` [N/m], ``preload`` [N], ``ports``
  (``"cable:i"``, 1-based, optional leading ``-``); ``design.preextension[j]`` [m].

Algorithm (world geometry, not cadcam's tangency residual)
-----------------------------------------------------------
At joint angle theta the turning body is rotated by sense*theta about the origin.  The spring
end S is carried into the polygon's frame: rotate the world by -(anchor_angle + the pulley's
turn), which puts the anchor direction on +x, then mirror y for a clockwise winding (the real
profile point at polar angle phi lies at w*phi there, w = +1 ccw, -1 cw).  In that frame the
cable is wound counter-clockwise, so the pulley lies on the left of the free cable running from
the departure point D to S: D is the vertex all others lie clockwise of, seen from S (the
largest angle of V - S measured counter-clockwise from the direction S -> O).  The cable path
is the polygon's arc from the anchor (vertex 0) to D plus the free span |S - D|; the spring
extension is x_j = x0_j + sum over its ports of sign * (L(theta) - L(reference_angle)), the
energy V = sum_j (k_j x_j**2 / 2 + F0_j x_j), and the torque tau = dV/dtheta by a central
difference, evaluated as sum_j (k_j xbar_j + F0_j)(x_j(theta + h) - x_j(theta - h)) / (2h) with
xbar_j the mean of the two extensions (no cancellation of large energies).

The polygon's L(theta) is continuous and continuously differentiable (where the departure moves
to the next vertex, S and both vertices are collinear), so the central difference converges;
its error against the smooth pulley is set by the polygon's chordal tolerance (see the test).
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["Pulley", "PulleySystem", "read_points", "load_system", "spring_end_in_frame",
           "departure", "cable_length", "extensions", "energy", "torque"]

_PORT = re.compile(r"^(-?)cable:([1-9][0-9]*)$")
_WINDING = {"ccw": 1.0, "cw": -1.0}
MM = 1e-3  # m per mm


@dataclass(frozen=True)
class Pulley:
    """One pulley: its outline polygon and where it and its spring end sit.

    Attributes
    ----------
    outline : ndarray, shape (N, 2)
        Polygon vertices [m], counter-clockwise, vertex 0 the anchor on the +x axis.
    spring_end : ndarray, shape (2,)
        World position of the spring end at theta = 0 [m].
    turning : {"pulley", "spring_end"}
    sense : float
        +1 or -1.
    winding : {"ccw", "cw"}
    anchor_angle : float
        World angle of the anchor direction at theta = 0 [rad].
    reference_angle : float
        Joint angle at which the port displacement is zero [rad].
    """

    outline: np.ndarray
    spring_end: np.ndarray
    turning: str
    sense: float
    winding: str
    anchor_angle: float
    reference_angle: float

    def __post_init__(self):
        if self.turning not in ("pulley", "spring_end"):
            raise ValueError(f"turning = {self.turning!r}: expected 'pulley' or 'spring_end'")
        if self.winding not in _WINDING:
            raise ValueError(f"winding = {self.winding!r}: expected 'ccw' or 'cw'")
        if self.sense not in (1.0, -1.0):
            raise ValueError(f"sense = {self.sense!r}: expected 1 or -1")
        p = np.asarray(self.outline, dtype=float)
        if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3:
            raise ValueError("outline must be an (N >= 3, 2) array of vertices")
        if abs(p[0, 1]) > 1e-12 * abs(p[0, 0]) or not p[0, 0] > 0:
            raise ValueError("outline: the first vertex (the anchor) must lie on the +x axis")
        edges = np.roll(p, -1, axis=0) - p
        after = np.roll(edges, -1, axis=0)
        turn = edges[:, 0] * after[:, 1] - edges[:, 1] * after[:, 0]  # left turn at each vertex
        if not np.all(turn > 0):
            raise ValueError("outline must be a strictly convex counter-clockwise polygon")
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*edges[:-1].T))])
        object.__setattr__(self, "outline", p)
        object.__setattr__(self, "spring_end", np.asarray(self.spring_end, dtype=float))
        object.__setattr__(self, "_arc", arc)


@dataclass(frozen=True)
class PulleySystem:
    """Pulleys on one joint and the springs on their cables.

    Attributes
    ----------
    pulleys : tuple of Pulley
    rates, preloads, preextension : tuple of float
        Per spring: k [N/m], F0 [N], x0 [m] (the extension with every port at its reference).
    ports : tuple of tuple of (float, int)
        Per spring: (sign, pulley index 0-based) of each cable port.
    """

    pulleys: tuple
    rates: tuple
    preloads: tuple
    preextension: tuple
    ports: tuple


def read_points(path) -> np.ndarray:
    """The vertices of a ``cam{i}_points.csv`` (header ``x_mm,y_mm``) in metres, shape (N, 2)."""
    path = Path(path)
    header = path.read_text().splitlines()[0].strip()
    if header != "x_mm,y_mm":
        raise ValueError(f"{path}: header {header!r}, expected 'x_mm,y_mm'")
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2) * MM


def load_system(folder) -> PulleySystem:
    """Read ``result.json`` and ``cam{i}_points.csv`` of a ``cadcam design`` output folder.

    Only 1-DOF problems of anchored pulleys (every mechanism on joint 1) are covered.
    """
    folder = Path(folder)
    result = json.loads((folder / "result.json").read_text())
    problem = result["problem"]
    mechs = problem["mechanisms"]
    if any(m["kind"] != "anchored_pulley" for m in mechs):
        raise NotImplementedError("this reference model covers anchored pulleys only")
    if any(m["joint"] != 1 for m in mechs):
        raise NotImplementedError("this reference model covers one joint only")
    pulleys = tuple(Pulley(read_points(folder / f"cam{i + 1}_points.csv"), m["spring_end"],
                           m["turning"], float(m["sense"]), m["winding"],
                           float(m["anchor_angle"]), float(m["reference_angle"]))
                    for i, m in enumerate(mechs))
    ports = []
    for s in problem["springs"]:
        ps = []
        for p in s["ports"]:
            mt = _PORT.match(p)
            if not mt or int(mt.group(2)) > len(pulleys):
                raise ValueError(f"port {p!r}: expected 'cable:i' with 1 <= i <= {len(pulleys)}")
            ps.append((-1.0 if mt.group(1) else 1.0, int(mt.group(2)) - 1))
        ports.append(tuple(ps))
    springs = problem["springs"]
    return PulleySystem(pulleys, tuple(float(s["rate"]) for s in springs),
                        tuple(float(s.get("preload", 0.0)) for s in springs),
                        tuple(float(x) for x in result["design"]["preextension"]), tuple(ports))


def _rotate(angle, v):
    """Rotate the points ``v`` (n, 2) by ``angle`` (n,) [rad] counter-clockwise."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)


def spring_end_in_frame(pulley: Pulley, theta) -> np.ndarray:
    """The spring end at joint angles ``theta`` [rad] in the outline's frame [m], shape (n, 2)."""
    th = np.atleast_1d(np.asarray(theta, dtype=float))
    turn = pulley.sense * th
    zero = np.zeros_like(th)
    world = _rotate(turn if pulley.turning == "spring_end" else zero,
                    np.tile(pulley.spring_end, (th.size, 1)))
    own = _rotate(-(pulley.anchor_angle + (turn if pulley.turning == "pulley" else zero)), world)
    own[:, 1] *= _WINDING[pulley.winding]  # the outline is the cw pulley mirrored
    return own


def departure(pulley: Pulley, theta):
    """Departure vertex index j (n,), the vertex D (n, 2) and the spring end S (n, 2) [m]."""
    S = spring_end_in_frame(pulley, theta)
    P = pulley.outline
    inward = -S / np.linalg.norm(S, axis=1, keepdims=True)  # S -> O: O lies inside the pulley
    w = P[None, :, :] - S[:, None, :]                        # (n, N, 2): S -> every vertex
    ang = np.arctan2(inward[:, None, 0] * w[..., 1] - inward[:, None, 1] * w[..., 0],
                     inward[:, None, 0] * w[..., 0] + inward[:, None, 1] * w[..., 1])
    j = np.argmax(ang, axis=1)  # the most counter-clockwise vertex seen from S
    if np.any(j == 0):
        raise ValueError("the cable leaves at its anchor: the pulley is not wound")
    return j, P[j], S


def cable_length(pulley: Pulley, theta) -> np.ndarray:
    """Path length anchor -> departure vertex (along the polygon) -> spring end [m], (n,)."""
    j, D, S = departure(pulley, theta)
    return pulley._arc[j] + np.linalg.norm(S - D, axis=1)


def _port_sums(system: PulleySystem, lengths) -> np.ndarray:
    """Per spring, sum of sign * lengths[pulley] (lengths: per pulley, (n,)) -> (S, n)."""
    return np.array([sum(sign * lengths[u] for sign, u in ps) for ps in system.ports])


def extensions(system: PulleySystem, theta) -> np.ndarray:
    """Spring extensions x_j(theta) [m], shape (springs, n)."""
    th = np.atleast_1d(np.asarray(theta, dtype=float))
    delta = [cable_length(p, th) - cable_length(p, p.reference_angle)[0] for p in system.pulleys]
    return np.asarray(system.preextension)[:, None] + _port_sums(system, delta)


def energy(system: PulleySystem, theta) -> np.ndarray:
    """Spring energy V = sum_j (k_j x_j**2 / 2 + F0_j x_j) [J], shape (n,)."""
    x = extensions(system, theta)
    k, f0 = np.asarray(system.rates)[:, None], np.asarray(system.preloads)[:, None]
    return np.sum(0.5 * k * x**2 + f0 * x, axis=0)


def torque(system: PulleySystem, theta, step: float = 1e-6) -> np.ndarray:
    """Joint torque tau = dV/dtheta [N m] by a central difference of step ``step`` [rad], (n,).

    Positive where the springs' energy grows with theta (the torque they resist).
    """
    th = np.atleast_1d(np.asarray(theta, dtype=float))
    xm, xp = extensions(system, th - step), extensions(system, th + step)
    dx = _port_sums(system, [cable_length(p, th + step) - cable_length(p, th - step)
                             for p in system.pulleys])
    k, f0 = np.asarray(system.rates)[:, None], np.asarray(system.preloads)[:, None]
    return np.sum((k * 0.5 * (xm + xp) + f0) * dx, axis=0) / (2 * step)
