"""Cam profile ρ(φ) in a polynomial basis (Johnston2023, Sec. 6).

A profile is the polar function ρ(φ) [m] of the cam-attached angle φ [rad], with the wire
anchored at φ = 0. Two bases are offered:

* ``monomial`` — the papers' basis, ρ(φ) = Σ β_k φ^k (Johnston2023 Eq. 38). Coefficients are stored
  in increasing powers; the papers print them highest power first (MATLAB ``polyval`` order),
  and :func:`monomial_from_highest_first` converts.
* ``chebyshev`` — Chebyshev polynomials of the first kind on the design interval
  ``domain = (0, φ_max)``; the same polynomials, far better conditioned at high order.

Both are exact polynomials of the same degree, so :meth:`Basis.to_monomial` and
:meth:`Basis.from_monomial` are exact linear maps.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import casadi as ca
import numpy as np
from numpy.polynomial import Chebyshev, Polynomial

BASES = ("monomial", "chebyshev")


@dataclass(frozen=True)
class Basis:
    """A polynomial basis of degree ``order`` for ρ(φ).

    Parameters
    ----------
    name : {"monomial", "chebyshev"}
    order : int
        Polynomial degree n; there are n + 1 coefficients [m].
    domain : tuple of float
        Design interval (φ_lo, φ_hi) [rad] on which the Chebyshev basis is orthogonal;
        ignored by the monomial basis except for plotting.
    """

    name: str
    order: int
    domain: tuple[float, float]

    def __post_init__(self):
        if self.name not in BASES:
            raise ValueError(f"unknown basis {self.name!r}; expected one of {BASES}")

    @property
    def size(self) -> int:
        """Number of coefficients, n + 1."""
        return self.order + 1

    def rho(self, phi, c):
        """ρ(φ) [m] as a CasADi expression of ``phi`` [rad] and coefficients ``c`` [m].

        Monomial: Horner's rule for Eq. 38 of Johnston2023. Chebyshev: three-term recurrence
        T_{k+1} = 2uT_k − T_{k−1} with u the affine image of φ on [−1, 1].
        """
        if self.name == "monomial":
            out = c[self.order]
            for k in range(self.order - 1, -1, -1):
                out = out * phi + c[k]
            return out
        lo, hi = self.domain
        u = (2 * phi - (lo + hi)) / (hi - lo)
        t_prev, t_cur = 1, u
        out = c[0] + (c[1] * u if self.order >= 1 else 0)
        for k in range(2, self.order + 1):
            t_prev, t_cur = t_cur, 2 * u * t_cur - t_prev
            out = out + c[k] * t_cur
        return out

    def _numpy_poly(self, c):
        c = np.asarray(c, dtype=float)
        if self.name == "monomial":
            return Polynomial(c)
        return Chebyshev(c, domain=list(self.domain))

    def to_monomial(self, c) -> np.ndarray:
        """Coefficients in increasing powers of φ [m·rad^-k] of the same polynomial."""
        return Basis("monomial", self.order, self.domain).converted(c, self)

    def from_monomial(self, m) -> np.ndarray:
        """Coefficients in this basis of ρ(φ) = Σ m_k φ^k (``m`` in increasing powers)."""
        m = np.asarray(m, dtype=float)
        if m.size != self.size:
            raise ValueError(f"expected {self.size} monomial coefficients, got {m.size}")
        return self.converted(m, Basis("monomial", self.order, self.domain))

    def converted(self, c, source: "Basis", samples: int = 400) -> np.ndarray:
        """Coefficients in this basis of the profile ``c`` in ``source``: exact (up to rounding)
        where ``source``'s degree is at most this one's, else its least-squares fit on
        ``samples`` equally spaced angles of this basis's domain (a lower degree cannot hold
        the profile exactly)."""
        if source == self:
            return np.asarray(c, dtype=float).copy()
        if source.order > self.order:
            phi = np.linspace(*self.domain, max(samples, self.size))
            return fit_profile(self, phi, np.asarray(profile_function(source).map(phi.size)(phi[None, :], c)[0]).ravel())
        return _exactly_converted(self, source, tuple(np.asarray(c, dtype=float).ravel())).copy()

    def offset(self, delta: float) -> np.ndarray:
        """Coefficients in this basis of the constant ρ(φ) = ``delta`` [m]: added to a profile's,
        they offset it uniformly (a cut outline ``delta`` larger)."""
        return self.from_monomial(np.eye(self.size)[0] * delta)


def monomial_from_highest_first(beta) -> np.ndarray:
    """Papers' β (highest power first, Johnston2023 Tables 3–4) → increasing powers."""
    return np.asarray(beta, dtype=float)[::-1].copy()


def convexity_margin(rho, drho, ddrho):
    """Convexity margin ρ² + 2ρ′² − ρρ″ [m²] (Johnston2023 Eq. 40); the profile is convex where > 0.

    It is x′y″ − y′x″ of the polar curve (Eq. 37, 39).
    """
    return rho**2 + 2 * drho**2 - rho * ddrho  # Johnston2023 Eq. 40


def curvature(rho, drho, margin):
    """Curvature κ [1/m] of the polar curve ρ(φ) from its Eq. 40 ``margin`` [m²]: the margin
    over the speed |dp/dφ| = √(ρ² + ρ′²) cubed (Johnston2023 Eq. 37, 40)."""
    return margin / (rho**2 + drho**2) ** 1.5


def support_distance(rho, drho):
    """Distance [m] from the rotation axis to the profile's tangent line at φ: ρ²/√(ρ² + ρ′²).

    The tangent t = (ρ′cos φ − ρ sin φ, ρ′sin φ + ρ cos φ) (Johnston2023 Eq. 3) turned by −90°
    is the outward normal n, and n·p = ρ² with |n| = √(ρ² + ρ′²). A convex outline holds a disk
    of radius R about the axis wherever this is ≥ R at every point.
    """
    return rho**2 / ca.sqrt(rho**2 + drho**2)


def inside_tangent(rho, drho, rho_e, delta):
    """How far the point (ρ_e, φ − δ) lies inside the profile's tangent line at (ρ, φ), over
    δ²/2: [ρ² − ρ_e(ρ cos δ + ρ′ sin δ)] / (δ²/2) [m²]; ≥ 0 when it is on the axis's side.

    The numerator is n·(p − p_e) with n the unnormalised outward normal of
    :func:`support_distance`; dividing by δ²/2 keeps the row of order ρ² for points near φ (on
    a circle it is ρ²(1 − cos δ)/(δ²/2)). A locally convex arc whose tangent turns by less than
    a turn lies inside the tangent line at each of its points if both its ends do: along the
    arc, n·(p − p_e) changes sign at most once, where the tangent has turned by half a turn.
    """
    return (rho**2 - rho_e * (rho * ca.cos(delta) + drho * ca.sin(delta))) / (delta**2 / 2)


#: Exact conversions of profiles between bases kept (:func:`_exactly_converted`): a design
#: session converts the same start circles at every step.
KEPT_CONVERSIONS = 256


@lru_cache(maxsize=KEPT_CONVERSIONS)
def _exactly_converted(basis: Basis, source: Basis, c: tuple) -> np.ndarray:
    """Coefficients in ``basis`` of the profile ``c`` in ``source``, whose degree is at most
    ``basis``'s (:meth:`Basis.converted`), made once per profile: NumPy's conversion takes
    milliseconds. Not to be changed in place (the caller copies it)."""
    target = basis._numpy_poly(np.zeros(1))  # its kind and domain (monomial: φ itself)
    out = source._numpy_poly(np.asarray(c)).convert(kind=type(target), domain=target.domain).coef
    return np.pad(out, (0, basis.size - out.size))


@lru_cache(maxsize=64)
def profile_function(basis: Basis) -> ca.Function:
    """CasADi Function ``profile(phi, c) -> (rho, drho, ddrho, convexity)``.

    ``rho`` [m] (Eq. 38), its first and second derivatives with respect to φ [m/rad, m/rad²]
    by automatic differentiation, and the convexity margin of Eq. 40 [m²].
    """
    phi = ca.SX.sym("phi")
    c = ca.SX.sym("c", basis.size)
    rho = basis.rho(phi, c)
    drho = ca.jacobian(rho, phi)
    ddrho = ca.jacobian(drho, phi)
    return ca.Function(
        "profile", [phi, c], [rho, drho, ddrho, convexity_margin(rho, drho, ddrho)],
        ["phi", "c"], ["rho", "drho", "ddrho", "convexity"],
    )


@lru_cache(maxsize=64)
def basis_row_function(basis: Basis) -> ca.Function:
    """CasADi Function ``row(phi) -> b``: the basis's polynomials at φ [rad] as a row, so that
    ρ(φ) = b · c (Johnston2023 Eq. 38 is linear in the coefficients c)."""
    phi = ca.SX.sym("phi")
    c = ca.SX.sym("c", basis.size)
    return ca.Function("basis_row", [phi], [ca.jacobian(basis.rho(phi, c), c)], ["phi"], ["b"])


def fit_profile(basis: Basis, phi, rho) -> np.ndarray:
    """Least-squares coefficients of ``basis`` for polar samples ρ(φ) of a profile.

    The design matrix is the basis's own rows (:func:`basis_row_function`) at ``phi``, so any
    basis works.

    Parameters
    ----------
    basis : Basis
    phi : array_like
        Polar angles [rad] measured as the basis expects (from the anchor).
    rho : array_like
        Polar radii [m].

    Returns
    -------
    ndarray
        Coefficients [m] in the basis's order.

    Raises
    ------
    ValueError
        For mismatched samples or fewer samples than coefficients.
    """
    phi = np.asarray(phi, dtype=float)
    if phi.ndim != 1 or phi.size == 0 or not np.all(np.isfinite(phi)):
        raise ValueError("phi must be a non-empty 1-D array of finite angles [rad]")
    rho = np.asarray(rho, dtype=float)
    if rho.shape != phi.shape:
        raise ValueError("phi and rho must have the same shape")
    if phi.size < basis.size:
        raise ValueError(f"need at least {basis.size} samples to fit {basis.size} coefficients")
    rows = np.asarray(basis_row_function(basis).map(phi.size)(phi[None, :]))  # 1 × (size·samples)
    matrix = rows.reshape(basis.size, phi.size, order="F").T
    return np.linalg.lstsq(matrix, rho, rcond=None)[0]
