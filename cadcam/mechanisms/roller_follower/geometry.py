"""Contact geometry of a radial cam and a translating roller follower (classic cam design:
Norton2009, the radial cam with an offset translating roller follower), written once in CasADi.

Frames and symbols (SI: metres, radians). The joint axis is the origin of the world frame.

* The cam turns with the joint: its profile point at polar angle φ sits at world angle
  ψ = φ + γ₀ − θ, γ₀ the world angle of the cam's polar axis φ = 0 at θ = 0 (its mounting
  angle on the shaft; γ₀ = 0 is the base class's ``profile_rotation``), so, with
  e_r = (cos ψ, sin ψ) and e_t = (−sin ψ, cos ψ),

  (G1)  p(φ) = ρ(φ) e_r,    dp/dφ = ρ′ e_r + ρ e_t,    ℓ = |dp/dφ| = √(ρ² + ρ′²).

* The profile is traversed counter-clockwise as φ grows, so its outward unit normal is the
  tangent turned by −90°:

  (G2)  n̂ = (ρ e_r − ρ′ e_t) / ℓ            (n̂ = e_r on a circle about the axis).

* The follower translates along the fixed line C(s) = e v̂ + s û, with û = (cos β, sin β) its
  direction of travel (``follower_angle`` β), v̂ = (−sin β, cos β), e the ``offset`` of the
  line from the axis and s the position of the roller centre along it, measured from the foot
  of the perpendicular from the axis.

* A roller of radius r touching the profile at p(α) has its centre on the outward normal:

  (G3)  C = p(α) + r n̂(α)                   (the pitch point; the pitch curve as α varies).

Pressure angle (the angle between the contact normal, along which the cam pushes the roller
without friction, and the follower's line of motion):

  (G4)  φ_p = atan2(n̂·v̂, n̂·û).

Velocity ratio. The cam's material point at p moves with angular velocity −θ̇ about the axis,
v = −θ̇ ẑ × p; the roller centre moves with ṡ û. No penetration: their normal components
agree, ṡ (û·n̂) = −θ̇ (ẑ × p)·n̂ = −θ̇ (p × n̂). With p × n̂ = C × n̂ (G3) and
C × n̂ = s (n̂·v̂) − e (n̂·û):

  (G5)  ds/dθ = e − s tan φ_p               (the follower's velocity ratio [m/rad]),

the classic relation between pressure angle, offset and follower velocity (Norton2009's
tan φ = (ṡ − e)/(s + √(R_p² − e²)) with s measured from the base circle and the opposite sense
of rotation). By virtual work a follower force F along û needs the torque τ = F ds/dθ: the
hand-derived force model the energy torque is checked against.

Curvature. The profile's radius of curvature is ρ_c = ℓ³/κ_m with κ_m = ρ² + 2ρ′² − ρρ″ the
convexity margin (Johnston2023 Eq. 40); the pitch curve (G3) is the parallel curve at
distance r outside a convex profile and shares its centres of curvature:

  (G6)  ρ_p = ρ_c + r = ℓ³/κ_m + r.
"""
from __future__ import annotations

import casadi as ca


def follower_axes(beta):
    """û = (cos β, sin β), the follower's direction of travel, and v̂ = (−sin β, cos β) [-]."""
    return (ca.cos(beta), ca.sin(beta)), (-ca.sin(beta), ca.cos(beta))


def contact_point(theta, alpha, rho, drho, axis=0.0):
    """World profile point p(α) [m], outward unit normal n̂(α) [-] and ℓ = |dp/dφ| [m/rad]
    at joint angle θ from ρ, ρ′ at α, the polar axis at world angle ``axis`` γ₀ at θ = 0
    (Eq. G1, G2)."""
    psi = alpha + axis - theta  # the profile turns with the joint: world angle φ + γ₀ − θ
    c, s = ca.cos(psi), ca.sin(psi)
    ell = ca.sqrt(rho**2 + drho**2)  # (G1)
    p = (rho * c, rho * s)
    n = ((rho * c + drho * s) / ell, (rho * s - drho * c) / ell)  # (G2): (ρ e_r − ρ′ e_t)/ℓ
    return p, n, ell


def pitch_point(p, n, r):
    """Roller centre C = p + r n̂ [m] (Eq. G3)."""
    return (p[0] + r * n[0], p[1] + r * n[1])


def line_coordinates(point, beta, offset):
    """(a, b) [m]: a point's coordinates along û and, less the offset e, along v̂; on the
    follower's line b = 0 and a = s."""
    (ux, uy), (vx, vy) = follower_axes(beta)
    return point[0] * ux + point[1] * uy, point[0] * vx + point[1] * vy - offset


def pressure_angle(n, beta):
    """φ_p = atan2(n̂·v̂, n̂·û) [rad] (Eq. G4): positive when the normal leans towards +v̂."""
    (ux, uy), (vx, vy) = follower_axes(beta)
    return ca.atan2(n[0] * vx + n[1] * vy, n[0] * ux + n[1] * uy)


def velocity_ratio(n, s, beta, offset):
    """ds/dθ = e − s (n̂·v̂)/(n̂·û) [m/rad] (Eq. G5), the follower's travel per radian of the
    joint: the moment arm of a follower force."""
    (ux, uy), (vx, vy) = follower_axes(beta)
    return offset - s * (n[0] * vx + n[1] * vy) / (n[0] * ux + n[1] * uy)


def pitch_curvature_radius(rho, drho, convexity, r):
    """ρ_p = (ρ² + ρ′²)^{3/2} / (ρ² + 2ρ′² − ρρ″) + r [m] (Eq. G6): the pitch curve's radius
    of curvature at a convex point of the profile (``convexity`` the Johnston2023 Eq. 40
    margin [m²], kept positive over the designed range by the engine's convexity rows)."""
    return (rho**2 + drho**2) ** 1.5 / convexity + r
