"""Linear springs joined into a network by ports (seed 003, Sec. 3 and 5).

Every cam offers two ports: its **wire** (the wire's length change pulls a spring riding on the
idler platform, Eq. 14) and its **platform** (the horizontal motion of the idler centre, Eq. 16
and 18). A spring joins ports, or a port and ground, each with a sign; its extension is its
pre-extension plus the signed displacements of its ports (Eq. 14, 16, 17). The force k·x it
carries acts on each of its ports: along the wire's unit tangent at a wire port (Eq. 19) and
along the unit inward normal at a platform port (Eq. 20); the torque on a cam is the sum over
its ports (Eq. 21, 36).

The 1-DOF mechanism of seed 003 Fig. 1 is spring 1 on ``wire:1`` and spring 2 on
``platform:1``; the 2-DOF one of Fig. 2 is springs 1 and 3 on the wires and spring 2 on
``platform:1`` and ``platform:2``.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

PORT_KINDS = ("wire", "platform")


@dataclass(frozen=True)
class Port:
    """A connection of a spring to cam ``cam`` (0-based) through ``kind``, with ``sign`` ±1."""

    cam: int
    kind: str
    sign: float = 1.0

    @property
    def index(self) -> int:
        """Position of this port in the per-network port vector [wire₀, platform₀, wire₁, …]."""
        return 2 * self.cam + PORT_KINDS.index(self.kind)


@dataclass(frozen=True)
class Spring:
    """A linear extension spring.

    Parameters
    ----------
    name : str
    rate : float
        Stiffness k [N/m].
    travel : float
        Maximum allowed extension x_max [m]; 0 ≤ x ≤ x_max is required (seed 003, Eq. 46).
    ports : tuple of Port
    """

    name: str
    rate: float
    travel: float
    ports: tuple[Port, ...]


def wire_displacement(length, r, gamma, gamma_ref):
    """Change of the wire port [m]: Δl_cam + r(γ − γ₀) (seed 003, Eq. 14 without x₁₀)."""
    return length + r * (gamma - gamma_ref)  # seed 003, Eq. 14


def platform_displacement(qx, qx_ref):
    """Change of the platform port [m]: Δq_x (seed 003, Eq. 16 and 18 without x₂₀)."""
    return qx - qx_ref  # seed 003, Eq. 16, 18


def incidence(springs: list[Spring], n_cams: int) -> np.ndarray:
    """Signed spring–port incidence matrix P [S × 2m], ports ordered [wire₀, platform₀, …]."""
    P = np.zeros((len(springs), 2 * n_cams))
    for j, s in enumerate(springs):
        for p in s.ports:
            P[j, p.index] += p.sign
    return P


def cams_of(P: np.ndarray, j: int) -> list[int]:
    """The cams spring ``j`` is attached to."""
    return [c for c in range(P.shape[1] // 2) if P[j, 2 * c] or P[j, 2 * c + 1]]


def cam_term(P: np.ndarray, j: int, c: int, ports):
    """Σ over cam ``c``'s ports of P_jp · ports_p, for ``ports`` = [wire, platform] of cam c.

    With port displacements it is cam c's share of spring j's extension, e_jc(θ_c), so that
    x_j = x₀_j + Σ_c e_jc(θ_c) (seed 003, Eq. 14, 16, 17). With moment arms it is the arm
    a_cj(θ_c) of spring j's force on cam c, so that τ_c = Σ_j k_j x_j a_cj (Eq. 19–21, 36) and
    ∂τ_c/∂k_j = x_j a_cj (Eq. 43). Either way it depends on cam c's own angle only, which is
    what makes multi-cam grids separable.
    """
    return P[j, 2 * c] * ports[0] + P[j, 2 * c + 1] * ports[1]


def torque_terms(P: np.ndarray, i: int, k, x0, arm_i, shares: dict):
    """Cam ``i``'s torque split by angle: τ_i = U_i(θ_i) + Σ_(j,c) V_ij(θ_i) e_jc(θ_c).

    Seed 003, Eq. 19–21 and 36: τ_i = Σ_j k_j x_j a_ij(θ_i) with x_j = x₀_j + Σ_c e_jc(θ_c)
    (Eq. 14, 16, 17). ``arm_i`` = [wire, normal] arms of cam i, ``shares`` maps (j, c) to
    e_jc. Returns U_i and a dict (j, c) → V_ij = k_j a_ij for every other cam c that spring j
    also touches (the 2-DOF network's spring 2 couples the cams this way only).
    """
    U, V = 0, {}
    for j in range(P.shape[0]):
        if i not in cams_of(P, j):
            continue
        a = cam_term(P, j, i, arm_i)
        U = U + k[j] * a * (x0[j] + shares[j, i])
        V.update({(j, c): k[j] * a for c in cams_of(P, j) if c != i})
    return U, V


def network_function(springs: list[Spring], n_cams: int) -> ca.Function:
    """Extensions, torques and rate sensitivities of a spring network as a CasADi Function.

    ``network(d, arm, k, x0) -> (x, tau, dtau_dk)`` with port displacements ``d`` [m] and
    moment arms ``arm`` [m] ordered [wire₀, platform₀, wire₁, …], rates ``k`` [N/m] and
    pre-extensions ``x0`` [m]. ``x`` [m] are the spring extensions (Eq. 14, 16, 17), ``tau``
    [N·m] the cam torques (Eq. 21, 36) and ``dtau_dk`` [N·m/(N/m) = m²] the m × S Jacobian
    ∂τ_i/∂k_j by automatic differentiation (Eq. 41–43).
    """
    P = incidence(springs, n_cams)
    S = len(springs)
    d, arm = ca.SX.sym("d", 2 * n_cams), ca.SX.sym("arm", 2 * n_cams)
    k, x0 = ca.SX.sym("k", S), ca.SX.sym("x0", S)
    shares = {(j, c): cam_term(P, j, c, d[2 * c:2 * c + 2]) for j in range(S) for c in cams_of(P, j)}
    x = ca.vertcat(*[x0[j] + sum(shares[j, c] for c in cams_of(P, j))
                     for j in range(S)])  # seed 003, Eq. 14, 16, 17
    tau = []
    for i in range(n_cams):
        U, V = torque_terms(P, i, k, x0, arm[2 * i:2 * i + 2], shares)
        tau.append(U + sum(v * shares[jc] for jc, v in V.items()))  # seed 003, Eq. 21, 36
    tau = ca.vertcat(*tau)
    return ca.Function("network", [d, arm, k, x0], [x, tau, ca.jacobian(tau, k)],
                       ["d", "arm", "k", "x0"], ["x", "tau", "dtau_dk"])
