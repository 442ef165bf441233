"""Linear springs joined into a network by the named ports of mechanisms (Johnston2023, Sec. 3
and 5).

A mechanism offers named **ports**: displacements d_p(θ) [m] of its geometry, such as the
length change of a cable or the travel of a slider. A spring joins ports, each with a sign; its
extension is its pre-extension plus the signed displacements of its ports,
x_j = x₀_j + Σ_p P_jp d_p (Johnston2023 Eq. 14, 16, 17). Its energy is ½k_j x_j² + F0_j x_j
(F0: the preload or initial tension), and the torque on joint i is

    τ_i = ∂V/∂θ_i = Σ_j (k_j x_j + F0_j) a_ij,    a_ij = Σ_(p on joint i) P_jp a_p,

with a_p the port's moment arm: dd_p/dθ in the energy model, or a paper's force-model arm
(Johnston2023 Eq. 19–21, 36). Every port belongs to one joint and depends on that joint's angle
only, which is what makes multi-joint grids separable.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..keys import PART_SIZE, Key, KeyTable, Plausible


@dataclass(frozen=True)
class Port:
    """Port ``name`` of mechanism ``mechanism`` (0-based), with ``sign`` ±1."""

    mechanism: int
    name: str
    sign: float = 1.0

    def label(self) -> str:
        """The spec form, ``"wire:1"`` or ``"-platform:2"``."""
        return f"{'-' if self.sign < 0 else ''}{self.name}:{self.mechanism + 1}"


def wahl_factor(index):
    """The stress correction k = (w + 0.5)/(w − 0.75) [-] of a coil of spring index ``index``
    w = D/d (Bergsträsser's factor, EN 13906-2 Eq. for extension springs); numbers or arrays."""
    return (index + 0.5) / (index - 0.75)


@dataclass(frozen=True)
class SpringBody:
    """A real spring's body: its sizes and the limits of its length, load and wire stress.

    Every field may be a number or an array (one entry per catalogue spring), so that one
    formula serves a spec's spring and the whole catalogue's screen
    (:mod:`cadcam.physics.catalogue`).

    Attributes
    ----------
    rate : float
        Rate k [N/m].
    preload : float
        Initial tension F0 [N]: the force at the free length.
    free_length : float
        Free length L0 [m] (inside the hooks).
    length_max : float
        Longest allowed length [m].
    load_max : float
        Largest allowed load [N].
    wire_diameter : float
        Wire diameter d [m].
    coil_diameter : float
        Mean coil diameter D = outside diameter − d [m].
    allowed_stress : float
        Static allowance of the wire's corrected shear stress [Pa]
        (:data:`cadcam.physics.catalogue.MATERIALS`).
    """

    rate: float
    preload: float
    free_length: float
    length_max: float
    load_max: float
    wire_diameter: float
    coil_diameter: float
    allowed_stress: float

    def force(self, x):
        """The force F0 + kx [N] at extension ``x`` [m]."""
        return self.preload + self.rate * x

    def length(self, x):
        """The length L0 + x [m] at extension ``x`` [m]."""
        return self.free_length + x

    def stress(self, x):
        """The corrected shear stress τ = 8·D·F·k/(π·d³) [Pa] of the wire at extension ``x`` [m]
        (EN 13906-2; k the :func:`wahl_factor` of w = D/d)."""
        d, D = self.wire_diameter, self.coil_diameter
        return 8 * D * self.force(x) * wahl_factor(D / d) / (math.pi * d**3)

    def extension_limits(self) -> dict:
        """The largest extension [m] each limit allows, by name: ``length`` (L ≤ L_max),
        ``load`` (F ≤ F_max) and ``stress`` (τ ≤ the allowance). Each is an upper bound on x
        because force, length and stress all grow with it."""
        d, D = self.wire_diameter, self.coil_diameter
        stress_force = self.allowed_stress * math.pi * d**3 / (8 * D * wahl_factor(D / d))
        return {"length": self.length_max - self.free_length,
                "load": (self.load_max - self.preload) / self.rate,
                "stress": (stress_force - self.preload) / self.rate}


#: The names of :meth:`SpringBody.extension_limits`, in the order a tie is named.
BODY_LIMITS = ("length", "load", "stress")


@dataclass(frozen=True)
class Spring:
    """A linear extension spring.

    Parameters
    ----------
    name : str
    rate : float
        Stiffness k [N/m].
    travel : float
        Maximum allowed extension x_max [m]; 0 ≤ x ≤ x_max is required (Johnston2023 Eq. 46).
    ports : tuple of Port
    preload : float
        Initial tension F0 [N]: the force is F0 + kx for x > 0 (Endo2010; a catalogue's
        pretension).
    free_length : float or None
        Length of the unloaded spring [m]; the installed length is free_length + x.
    preextension : float or None
        Fixed pre-extension x₀ [m] (Ludovico2021's u₀); None makes it a design variable.
    part : str or None
        The catalogue part number the rate, preload, free length and travel were filled from.
    catalogue : str or None
        The catalogue file the part is read from; None: the shipped one.
    body : SpringBody or None
        The part's body (sizes and limits); its travel is the least extension the body's
        limits allow.
    """

    name: str
    rate: float
    travel: float
    ports: tuple[Port, ...]
    preload: float = 0.0
    free_length: float | None = None
    preextension: float | None = None
    part: str | None = None
    catalogue: str | None = None
    body: SpringBody | None = None

    def energy(self, x):
        """Stored energy ½kx² + F0·x [J] at extension ``x`` [m]."""
        return 0.5 * self.rate * x**2 + self.preload * x

    def to_dict(self) -> dict:
        """The spec form."""
        out = {"name": self.name, "rate": self.rate, "travel": self.travel,
               "ports": [p.label() for p in self.ports], "preload": self.preload}
        if self.free_length is not None:
            out["free_length"] = self.free_length
        if self.preextension is not None:
            out["preextension"] = self.preextension
        if self.part is not None:
            out["part"] = self.part
        if self.catalogue is not None:
            out["catalogue"] = self.catalogue
        return out

    def body_report(self, extension_max: float) -> dict | None:
        """The body's numbers at the largest extension ``extension_max`` [m] a design reaches,
        against their limits (SI units), or None for a spring without a body."""
        b = self.body
        if b is None:
            return None
        limits = b.extension_limits()
        return {"name": self.name, "part": self.part,
                "peak_force": float(b.force(extension_max)), "load_max": float(b.load_max),
                "max_length": float(b.length(extension_max)), "length_max": float(b.length_max),
                "peak_stress": float(b.stress(extension_max)), "allowed_stress": float(b.allowed_stress),
                "wire_diameter": float(b.wire_diameter), "coil_diameter": float(b.coil_diameter),
                "free_length": float(b.free_length), "initial_tension": float(b.preload),
                "extension_limits": {k: float(v) for k, v in limits.items()},
                "travel_binding": min(BODY_LIMITS, key=lambda k: limits[k])}


@dataclass(frozen=True)
class SpringParameters:
    """The numbers of a problem's springs as vectors, one entry per spring in spring order
    (:meth:`cadcam.problem.Problem.spring_parameters`).

    Attributes
    ----------
    rate : ndarray
        Stiffnesses k [N/m].
    preload : ndarray
        Initial tensions F0 [N].
    travel : ndarray
        Maximum allowed extensions x_max [m].
    """

    rate: np.ndarray
    preload: np.ndarray
    travel: np.ndarray


def shipped_range(column: str, what: str, low: bool = True) -> Plausible:
    """The shipped catalogue's range of its springs' ``column`` (a :class:`SpringBody` field:
    ``rate``, ``preload``), named ``what``; without its least value where ``low`` is False."""
    from .catalogue import shipped  # that module reads its springs' bodies from this one

    values = getattr(shipped().body, column)
    return Plausible(float(np.min(values)) if low else None, float(np.max(values)),
                     f"the shipped catalogue's {what}")


#: Where a spring's rate [N/m] is plausible: within the shipped catalogue's rates (a rate beyond
#: is no stock spring's, and one below reads as N/mm typed as N/m).
CATALOGUE_RATES = functools.partial(shipped_range, "rate", "rates")
#: Where a spring's initial tension [N] is plausible: up to the shipped catalogue's largest (a
#: small one, or none, is any spring's).
CATALOGUE_PRELOADS = functools.partial(shipped_range, "preload", "initial tensions", low=False)

#: A ``[[springs]]`` table's keys (:mod:`cadcam.spec` reads them, the reference lists them).
SPRING_KEYS = KeyTable("[[springs]]", "A linear extension spring joining ports of the mechanisms.", (
    Key("name", "", "the spring's name", "string", default_text="'spring N'", default=None),
    Key("ports", "", "the ports the spring joins, each 'port:mechanism' with an optional '-' for the "
        "opposite sign, such as 'wire:1' or '-platform:2'", "strings", min_length=1),
    Key("part", "", "a catalogue part number: fills rate, preload, free_length and travel (the least "
        "extension its largest length, largest load and wire stress allow) from its row, so the spec "
        "gives none of them", "string", min_length=1, default=None, default_text="none (the spec gives the rate)"),
    Key("catalogue", "", "the catalogue CSV the part is read from, relative to the spec "
        "(columns as cadcam.physics.catalogue.COLUMNS)", "string", min_length=1, default=None,
        default_text="none (the shipped McMaster-Carr catalogue)"),
    Key("rate", "N/m", "the spring's rate k", low=0, open_low=True, plausible=CATALOGUE_RATES),
    Key("travel", "m", "the spring's largest extension x_max (0 ≤ x ≤ x_max, Johnston2023 Eq. 46)", low=0, open_low=True,
        plausible=PART_SIZE),
    Key("preload", "N", "the spring's initial tension F0 (force F0 + kx for x > 0)", low=0, default=0.0,
        plausible=CATALOGUE_PRELOADS),
    Key("free_length", "m", "the unloaded spring's length (its installed length is free_length + x)",
        low=0, open_low=True, default=None, default_text="none (not drawn to length)", plausible=PART_SIZE),
    Key("preextension", "m", "a fixed pre-extension x0 in [0, travel]", low=0, default=None,
        default_text="none (a design variable)", plausible=PART_SIZE),
))


class Network:
    """The signed spring–port incidence of a problem and which joint each port turns with.

    Parameters
    ----------
    springs : list of Spring
    port_joint : list of int
        Joint of each port, in the problem's global port order.
    port_index : dict
        (mechanism, port name) → global port index.
    n_joints : int
    arm_scales : dict, optional
        (spring, mechanism, port name) → a weight of that path's arm in the torques (not in the
        extensions): the friction band's centre (:meth:`cadcam.physics.friction.Friction.arm_scales`).
    """

    def __init__(self, springs, port_joint, port_index: dict, n_joints: int, arm_scales: dict | None = None):
        self.S, self.m = len(springs), n_joints
        self.port_joint = np.asarray(port_joint, dtype=int)
        self.P = np.zeros((self.S, len(port_joint)))
        for j, s in enumerate(springs):
            for p in s.ports:
                self.P[j, port_index[p.mechanism, p.name]] += p.sign
        #: The incidence the torques read: P with each weighted path's entry scaled.
        self.W = self.P.copy()
        for (j, u, name), scale in (arm_scales or {}).items():
            self.W[j, port_index[u, name]] *= scale
        self.joint_ports = [np.flatnonzero(self.port_joint == i) for i in range(n_joints)]

    def joints_of(self, j: int) -> list[int]:
        """The joints spring ``j`` is attached to."""
        return [c for c in range(self.m) if np.any(self.P[j, self.joint_ports[c]])]

    def term(self, j: int, c: int, values):
        """Σ over joint ``c``'s ports of P_jp · values_p (``values`` in joint c's port order).

        With port displacements it is joint c's share of spring j's extension, e_jc(θ_c), so
        that x_j = x₀_j + Σ_c e_jc(θ_c) (Johnston2023 Eq. 14, 16, 17); the torques' arms are
        :meth:`arm_term`'s. Either way it depends on joint c's angle only.
        """
        return self._sum(self.P, j, c, values)

    def arm_term(self, j: int, c: int, arms):
        """The arm a_cj(θ_c) [m] of spring j's force on joint c from joint c's port ``arms``, so
        that τ_c = Σ_j (k_j x_j + F0_j) a_cj and ∂τ_c/∂k_j = x_j a_cj (Johnston2023 Eq. 36, 43):
        :meth:`term` with each path weighted as the torques weigh it (:attr:`W`, which is P
        unless friction's band centre is tracked)."""
        return self._sum(self.W, j, c, arms)

    def _sum(self, incidence, j: int, c: int, values):
        out = 0
        for k, p in enumerate(self.joint_ports[c]):
            if incidence[j, p]:
                out = out + incidence[j, p] * values[k]
        return out

    def torque_terms(self, i: int, k, preload, x0, arm_i, shares: dict):
        """Joint ``i``'s torque split by angle: τ_i = U_i(θ_i) + Σ_(j,c) V_ij(θ_i) e_jc(θ_c).

        τ_i = Σ_j (k_j x_j + F0_j) a_ij(θ_i) with x_j = x₀_j + Σ_c e_jc(θ_c). ``arm_i`` are
        joint i's port arms, ``shares`` maps (j, c) to e_jc. Returns U_i and a dict
        (j, c) → V_ij = k_j a_ij for every other joint c that spring j also touches.
        """
        U, V = 0, {}
        for j in range(self.S):
            if i not in self.joints_of(j):
                continue
            a = self.arm_term(j, i, arm_i)
            U = U + (k[j] * (x0[j] + shares[j, i]) + preload[j]) * a
            V.update({(j, c): k[j] * a for c in self.joints_of(j) if c != i})
        return U, V

    def shares(self, d_of_joint) -> dict:
        """(j, c) → e_jc for every spring j and joint c it touches; ``d_of_joint[c]`` holds
        joint c's port displacements in its port order."""
        return {(j, c): self.term(j, c, d_of_joint[c])
                for j in range(self.S) for c in self.joints_of(j)}

    def function(self) -> ca.Function:
        """Extensions, torques and rate sensitivities as a CasADi Function.

        ``network(d, arm, k, x0, F0) -> (x, tau, dtau_dk)`` with port displacements ``d`` [m]
        and arms ``arm`` [m] in global port order, rates ``k`` [N/m], pre-extensions ``x0`` [m]
        and preloads ``F0`` [N]. ``x`` [m] are the extensions, ``tau`` [N·m] the joint torques
        and ``dtau_dk`` [m²] the m × S Jacobian ∂τ_i/∂k_j by automatic differentiation
        (Johnston2023 Eq. 41–43).
        """
        G = self.P.shape[1]
        d, arm = ca.SX.sym("d", G), ca.SX.sym("arm", G)
        k, x0, F0 = ca.SX.sym("k", self.S), ca.SX.sym("x0", self.S), ca.SX.sym("F0", self.S)
        per_joint = lambda v: [v[idx.tolist()] if idx.size else [] for idx in self.joint_ports]  # noqa: E731
        dj, aj = per_joint(d), per_joint(arm)
        e = self.shares(dj)
        x = ca.vertcat(*[x0[j] + sum(e[j, c] for c in self.joints_of(j)) for j in range(self.S)])
        tau = []
        for i in range(self.m):
            U, V = self.torque_terms(i, k, F0, x0, aj[i], e)
            tau.append(U + sum(v * e[jc] for jc, v in V.items()))
        tau = ca.vertcat(*tau)
        return ca.Function("network", [d, arm, k, x0, F0], [x, tau, ca.jacobian(tau, k)],
                           ["d", "arm", "k", "x0", "F0"], ["x", "tau", "dtau_dk"])
