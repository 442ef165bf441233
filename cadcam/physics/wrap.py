"""Wrapped wire length by Gauss–Legendre quadrature (Johnston2023, Sec. 3.1), and how many
points each integral over a wrap takes, chosen here once (:func:`whole_wrap_order`,
:func:`friction_order`, :func:`wound_length`)."""
from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np

from .profile import Basis, profile_function
from .quadrature import gauss_legendre


def arc_length_density(rho, drho):
    """‖r′(φ)‖ = √(ρ² + ρ′²) [m/rad], the integrand of Eq. 10 (Johnston2023)."""
    return ca.sqrt(rho**2 + drho**2)  # Johnston2023 Eq. 10


@lru_cache(maxsize=64)
def length_function(basis: Basis, order: int) -> ca.Function:
    """``length(a, b, c) -> ∫_a^b √(ρ² + ρ′²) dφ`` [m] by ``order``-point Gauss–Legendre.

    This is l_cam of Eq. 10 between two cam angles; Eq. 14's wrapped-length change is
    ``length(α₀, α, c)``.
    """
    a, b = ca.SX.sym("a"), ca.SX.sym("b")
    c = ca.SX.sym("c", basis.size)
    s, w = gauss_legendre(order)
    phi = a + (b - a) * ca.DM(s).T
    prof = profile_function(basis).map(order)
    rho, drho, _, _ = prof(phi, c)
    integral = (b - a) * ca.mtimes(arc_length_density(rho, drho), ca.DM(w))
    return ca.Function("length", [a, b, c], [integral], ["a", "b", "c"], ["length"])


@lru_cache(maxsize=64)
def length_change_function(basis: Basis, order: int) -> ca.Function:
    """``length_change(a, b, c, dc) -> dl``: the change [m] of :func:`length_function`'s
    length between the fixed angles a and b when the coefficients change by ``dc`` [m]."""
    a, b = ca.SX.sym("a"), ca.SX.sym("b")
    c, dc = ca.SX.sym("c", basis.size), ca.SX.sym("dc", basis.size)
    change = ca.jtimes(length_function(basis, order)(a, b, c), c, dc)
    return ca.Function("length_change", [a, b, c, dc], [change], ["a", "b", "c", "dc"], ["dl"])


def segment_lengths(basis: Basis, order: int, first_order: int, alpha_ref, alpha, c, dc=None):
    """Profile lengths of the segments [α_ref, α₀], [α₀, α₁], … [m] (Eq. 10, Johnston2023), or
    with ``dc`` their changes [m] when the coefficients change by ``dc`` (the ends held).

    ``order`` Gauss–Legendre points per segment, ``first_order`` for the first (long when the
    angle range does not start at θ = 0). Segments between neighbouring grid contacts are
    short, so a low-order rule there is as accurate as a high-order one over the whole wrap;
    the wrapped length at α_i is the running sum (Eq. 14).
    """
    n = alpha.shape[0]
    function, args = (length_function, (c,)) if dc is None else (length_change_function, (c, dc))
    first = function(basis, first_order)(alpha_ref, alpha[0], *args)
    rest = function(basis, order).map(n - 1)(alpha[:n - 1].T, alpha[1:].T, *args).T
    return ca.vertcat(first, rest)


#: Least Gauss–Legendre points of a wrapped length (and of a force model's friction) over the
#: whole wrap where a design is checked: the re-check, its torque model and its tolerance band,
#: the reference the tests hold the NLP's and the export's integrals to.
CHECK_ORDER = 48
#: Least points of the same integrals in the exported model, whose generated code grows with
#: them: tests check the exported torque against the re-check to 1e-12.
EXPORT_ORDER = 24
#: Points of the NLP's force-model friction integral per point of its wrapped-length segments:
#: the friction integral spans the whole wrap.
FRICTION_ORDER = 8


def whole_wrap_order(bases, least: int = CHECK_ORDER) -> int:
    """Gauss–Legendre points of the wrapped length (and of a force model's friction) over a
    whole wrap on profiles in ``bases``: at least ``least`` (:data:`CHECK_ORDER` where a design
    is checked, :data:`EXPORT_ORDER` in the exported model), and 4/3 of the highest profile's
    coefficients, as the arc-length integrand √(ρ² + ρ′²) of a profile of high degree needs (an
    order-35 pulley of the moment-arm method agrees with its re-check's torque to rounding on 48
    points, not on 24)."""
    return max(least, -(-4 * max(b.size for b in bases) // 3))


def friction_order(quadrature_order: int) -> int:
    """Gauss–Legendre points of the NLP's force-model friction integral over the whole wrap:
    :data:`FRICTION_ORDER` times the ``quadrature_order`` of each of its wrapped-length
    segments (``[solver] quadrature_order``)."""
    return FRICTION_ORDER * quadrature_order


#: Gauss–Legendre points per radian of a basis's design interval for :func:`wound_length`.
WOUND_POINTS_PER_RAD = 8


def wound_length(basis: Basis, alpha, c):
    """W(α) = ∫₀^α √(ρ² + ρ′²) dφ [m]: the cable wound from the anchor φ = 0 to α
    (Johnston2023 Eq. 10; Fedorov2018 Eq. 6a), by one Gauss–Legendre rule whose order grows
    with the design interval (at least 32 points; tests check it against adaptive quadrature)."""
    order = max(32, int(np.ceil(WOUND_POINTS_PER_RAD * basis.domain[1])))
    return length_function(basis, order)(0, alpha, c)
