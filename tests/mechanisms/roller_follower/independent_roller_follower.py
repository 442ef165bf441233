"""An independent reference model of the radial cam with a translating roller follower (numpy
only; no cadcam, no casadi).

Classic cam design (Norton2009): a cam turns with the joint; a roller of radius r on a follower
that slides along a fixed straight line rests on it, pressed by a spring. This module
recomputes the follower's travel, the spring's energy and the joint torque of a design from
the plain data of a cadcam result (``result.json``, or ``Result.to_dict()``). It shares no
code with cadcam: not its contact residuals, not its guess, not its energy torque.

Inputs (SI units)
-----------------
* ``problem.mechanisms[0]``: ``roller_radius`` r, ``follower_angle`` β (the world direction of
  the follower's travel), ``offset`` e (the line is {e v̂ + s û}, û = (cos β, sin β),
  v̂ = (−sin β, cos β)), ``axis_angle`` γ₀ (the profile point at polar angle φ sits at world
  angle φ + γ₀ − θ), ``reference_angle`` θ_ref;
* ``design.cams[0]``: ``basis`` ("chebyshev" on ``domain`` or "monomial") and
  ``coefficients`` of ρ(φ) [m]; ``design.preextension`` x₀ [m];
* ``problem.springs``: ``rate`` k, ``preload`` F₀, ``ports`` ("follower:1", optional "-").

Algorithm (a roller resting on a point cloud, not a tangency equation)
----------------------------------------------------------------------
The cam is sampled densely, ρ(φ) by Clenshaw's recurrence written here. At joint angle θ a cam
point P sits at ρ (cos ψ, sin ψ), ψ = φ + γ₀ − θ. A roller whose centre e v̂ + s û lies on the
line passes through P where (P·v̂ − e)² + (s − P·û)² = r², so the roller clears P for
s ≥ P·û + √(r² − (P·v̂ − e)²) (points farther than r from the line never meet it). Pressed
onto the cam, the follower rests at the least s that clears every point:

    s(θ) = max over cam points P with |P·v̂ − e| ≤ r of  P·û + √(r² − (P·v̂ − e)²),

the envelope of the roller's positions. The maximum over the samples is refined by nested
sampling of ρ(φ) around it, so s(θ) is that of the smooth cam to rounding. The spring's
deflection is x = x₀ + Σ sign·(s(θ) − s(θ_ref)), its energy V = ½kx² + F₀x, and the torque
τ = dV/dθ by a central difference (k x̄ + F₀)(x(θ + h) − x(θ − h))/(2h). The contact point P*
gives the normal n̂ = (C − P*)/r and the pressure angle atan2(n̂·v̂, n̂·û); the roller centre,
carried into the cam's frame, traces the pitch curve, whose radius of curvature follows from
central differences along θ.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Samples of the first scan over the design interval, points and levels of each refinement
#: (each level narrows the bracket REFINE_POINTS/2-fold).
SCAN_POINTS = 8001
REFINE_POINTS = 41
REFINE_LEVELS = 9
#: Joint angles scanned together: each angle's scan is its own, and a block keeps the scan's
#: arrays (angles × SCAN_POINTS) small enough to stay in the processor's cache.
BLOCK_ANGLES = 16
#: Central-difference step of the torque [rad].
STEP = 1e-5


def chebyshev_values(coefficients, domain, phi) -> np.ndarray:
    """Σ c_k T_k(u) at u = (2φ − (lo + hi))/(hi − lo), by Clenshaw's recurrence."""
    lo, hi = domain
    u = (2 * np.asarray(phi, dtype=float) - (lo + hi)) / (hi - lo)
    b1 = b2 = np.zeros_like(u)
    for c in coefficients[:0:-1]:
        b1, b2 = 2 * u * b1 - b2 + c, b1
    return u * b1 - b2 + coefficients[0]


@dataclass(frozen=True)
class RollerCam:
    """One designed cam with its follower and its springs, as plain numbers (SI)."""

    basis: str
    domain: tuple
    coefficients: np.ndarray
    roller_radius: float
    follower_angle: float
    offset: float
    axis_angle: float
    reference_angle: float
    springs: tuple  # (rate, preload, pre-extension, sign) per spring on the follower port

    @classmethod
    def from_result(cls, data: dict) -> "RollerCam":
        """The cam of a result's plain data (``result.json``)."""
        mech, cam = data["problem"]["mechanisms"][0], data["design"]["cams"][0]
        springs = []
        for spring, x0 in zip(data["problem"]["springs"], data["design"]["preextension"]):
            for port in spring["ports"]:
                if port.lstrip("-") == "follower:1":
                    springs.append((spring["rate"], spring.get("preload", 0.0), x0,
                                    -1.0 if port.startswith("-") else 1.0))
        return cls(cam["basis"], tuple(cam["domain"]), np.asarray(cam["coefficients"], dtype=float),
                   mech["roller_radius"], mech["follower_angle"], mech["offset"], mech["axis_angle"],
                   mech["reference_angle"], tuple(springs))

    def rho(self, phi) -> np.ndarray:
        """ρ(φ) [m]."""
        if self.basis == "chebyshev":
            return chebyshev_values(self.coefficients, self.domain, phi)
        return np.polyval(self.coefficients[::-1], phi)

    def _clearance(self, theta, phi):
        """The least roller position s [m] that clears each cam point (−inf off the roller's
        strip), at joint angles ``theta`` (column) and polar angles ``phi``."""
        rho, psi = self.rho(phi), phi + self.axis_angle - theta
        b = self.follower_angle
        along = rho * np.cos(psi - b)               # P·û
        across = rho * np.sin(psi - b) - self.offset  # P·v̂ − e
        gap = self.roller_radius**2 - across**2
        return np.where(gap >= 0, along + np.sqrt(np.maximum(gap, 0.0)), -np.inf)

    def follower(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """The roller centre's position s(θ) [m] and the contact's polar angle φ* [rad]."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        blocks = [self._follower(theta[k:k + BLOCK_ANGLES, None]) for k in range(0, theta.size, BLOCK_ANGLES)]
        return np.concatenate([s for s, _ in blocks]), np.concatenate([phi for _, phi in blocks])

    def _follower(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`follower` at the joint angles ``theta`` (column)."""
        phi = np.linspace(*self.domain, SCAN_POINTS)
        width = phi[1] - phi[0]
        values = self._clearance(theta, phi[None, :])
        best = phi[np.argmax(values, axis=1)][:, None]
        for _ in range(REFINE_LEVELS):
            local = best + width * np.linspace(-1.0, 1.0, REFINE_POINTS)[None, :]
            values = self._clearance(theta, local)
            best = np.take_along_axis(local, np.argmax(values, axis=1)[:, None], axis=1)
            width *= 2.0 / (REFINE_POINTS - 1)
        return values.max(axis=1), best[:, 0]

    def pressure_angle(self, theta) -> np.ndarray:
        """The angle [rad] from the follower's direction û to the contact normal n̂ = (C − P*)/r,
        positive towards v̂."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        s, phi = self.follower(theta)
        rho, psi, b = self.rho(phi), phi + self.axis_angle - theta, self.follower_angle
        u, v = np.array([np.cos(b), np.sin(b)]), np.array([-np.sin(b), np.cos(b)])
        centre = s[:, None] * u + self.offset * v
        normal = centre - np.column_stack([rho * np.cos(psi), rho * np.sin(psi)])
        return np.arctan2(normal @ v, normal @ u)

    def pitch_point(self, theta) -> np.ndarray:
        """The roller centre in the cam's own frame [m], shape (angles, 2): the world point
        s û + e v̂ turned by θ − γ₀ (the pitch curve as θ runs)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        s = self.follower(theta)[0]
        b, turn = self.follower_angle, theta - self.axis_angle
        x = s * np.cos(b) - self.offset * np.sin(b)
        y = s * np.sin(b) + self.offset * np.cos(b)
        return np.column_stack([x * np.cos(turn) - y * np.sin(turn), x * np.sin(turn) + y * np.cos(turn)])

    def pitch_curvature_radius(self, theta, step: float = 1e-3) -> np.ndarray:
        """The pitch curve's radius of curvature [m], (x′² + y′²)^{3/2}/(x′y″ − y′x″) by central
        differences along θ."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        minus, mid, plus = (self.pitch_point(theta + k * step) for k in (-1, 0, 1))
        d1, d2 = (plus - minus) / (2 * step), (plus - 2 * mid + minus) / step**2
        return np.hypot(*d1.T) ** 3 / np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])

    def deflections(self, theta) -> np.ndarray:
        """Each spring's deflection x = x₀ + sign·(s(θ) − s(θ_ref)) [m], (springs, angles)."""
        s = self.follower(theta)[0] - self.follower(self.reference_angle)[0][0]
        return np.array([x0 + sign * s for _, _, x0, sign in self.springs])

    def energy(self, theta) -> np.ndarray:
        """V = Σ ½kx² + F₀x [J]."""
        x = self.deflections(theta)
        return sum(0.5 * k * xj**2 + f0 * xj for (k, f0, _, _), xj in zip(self.springs, x))

    def torque(self, theta, step: float = STEP) -> np.ndarray:
        """τ = dV/dθ [N·m] by a central difference, as (k x̄ + F₀)(x₊ − x₋)/(2h) summed over
        the springs (no cancellation of large energies)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        up, down = self.deflections(theta + step), self.deflections(theta - step)
        return sum((k * 0.5 * (a + b) + f0) * (a - b) / (2 * step)
                   for (k, f0, _, _), a, b in zip(self.springs, up, down))
