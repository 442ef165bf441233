"""An independent reference model of Johnston2023's 1-DOF wire-wrapped cam (numpy and scipy only).

Johnston, Orekhov, Simaan 2023, *Design considerations and robustness to parameter uncertainty
in wire-wrapped cam mechanisms*, JMR 15(3): Fig. 1, Eq. 10-16.  This module shares no code with
cadcam (it imports neither cadcam nor casadi) and exists so that tests can check cadcam's torque
against tau = dV/dtheta, V = sum_j (k_j x_j**2 / 2 + F0_j x_j), computed another way.

Geometry (angles in rad, lengths in m)
--------------------------------------
* The cam profile is rho(phi) = sum_i c_i phi**i, the wire anchored at phi = 0.  The cam is
  turned by theta: the profile point at polar angle phi sits at world angle psi = phi - theta,
  i.e. at rho(phi) (cos psi, sin psi).
* The idler is a circle of radius r whose centre q = (qx, a0) slides horizontally at height a0 on
  the +x side of the cam, pressed against it by the platform spring.

Algorithm (not the paper's tangency equations, Eq. 6-8)
--------------------------------------------------------
* Contact.  A disc of radius r centred at (qx, a0) clears the cam point at polar angle phi iff
  qx >= f(phi) = rho cos psi + sqrt(r**2 - (a0 - rho sin psi)**2) (where the root is real).  The
  idler pushed against the cam therefore sits at qx(theta) = max_phi f(phi, theta): a dense scan
  over the window phi in [max(0, theta - pi/2), theta + pi/2], then Brent's root finder on the
  analytic df/dphi inside the bracket around the best sample (a derivative root is located to
  ~1e-16 rad, a function-value search only to ~1e-8).  The maximiser is the contact angle alpha
  and gamma is the polar angle of p - q about q, in [0, 2 pi).
* Extensions (Eq. 14, 16).  wire:    Delta = int_{alpha(0)}^{alpha(theta)} sqrt(rho**2 + rho'**2)
  dphi + r (gamma(theta) - gamma(0)) by adaptive quadrature (scipy.integrate.quad);
  platform: Delta = qx(theta) - qx(0).  x_j = x_j0 + sum over spring j's ports of sign * Delta.
* Torque.  tau = dV/dtheta by central differences with Richardson extrapolation.  The central
  difference of V is evaluated in the algebraically identical form
  sum_j (k_j xbar_j + F0_j) (x_j(theta + h) - x_j(theta - h)) / (2 h), xbar_j the mean of the two
  extensions, with the wire's difference integrated directly from alpha(theta - h) to
  alpha(theta + h): no cancellation of large energies, so roundoff stays near 1e-12 N m.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

__all__ = ["WireCamDesign", "make_design", "load_design", "contact", "extensions", "energy",
           "energy_torque"]

_PORT = re.compile(r"^(-?)(wire|platform):([1-9][0-9]*)$")
_N_SCAN = 721            # samples of the contact window (pi wide): spacing 4.4e-3 rad
_QUAD = dict(epsabs=1e-16, epsrel=1e-13, limit=200)


@dataclass(frozen=True)
class WireCamDesign:
    """A 1-DOF wire-cam design with its springs.

    Attributes
    ----------
    coefficients : tuple of float
        Profile rho(phi) = sum_i coefficients[i] * phi**i, increasing powers [m / rad**i].
    radius : float
        Idler radius r [m].
    offset : float
        Height a0 of the idler centre above the cam axis [m].
    rates : tuple of float
        Spring rates k_j [N/m].
    preloads : tuple of float
        Spring preloads F0_j [N] (force at zero extension).
    preextension : tuple of float
        Extensions x_j0 at theta = 0 [m].
    ports : tuple of tuple of (float, str)
        For each spring, its (sign, kind) ports; kind is ``"wire"`` (the wire's length change) or
        ``"platform"`` (the idler centre's displacement qx(theta) - qx(0)).
    phi_min : float
        Lower end of the profile's valid range [rad] (the wire anchor, 0).
    """

    coefficients: tuple
    radius: float
    offset: float
    rates: tuple
    preloads: tuple
    preextension: tuple
    ports: tuple
    phi_min: float = 0.0
    _ref: dict = field(default=None, compare=False, repr=False)

    @property
    def n_springs(self) -> int:
        """Number of springs."""
        return len(self.rates)


def make_design(coefficients, radius, offset, rates, preextension, preloads=None, ports=None):
    """Build a design by hand.

    Parameters
    ----------
    coefficients : array_like
        Monomial coefficients of rho(phi), increasing powers [m / rad**i].
    radius : float
        Idler radius r [m].
    offset : float
        Idler height a0 [m].
    rates : array_like, shape (m,)
        Spring rates k_j [N/m].
    preextension : array_like, shape (m,)
        Extensions at theta = 0 [m].
    preloads : array_like, shape (m,), optional
        Preloads F0_j [N]; default 0.
    ports : sequence of sequence of str, optional
        cadcam-style ports per spring (``"wire:1"``, ``"-platform:1"``); default: spring 1 on
        the wire, spring 2 on the platform.

    Returns
    -------
    WireCamDesign
    """
    rates = tuple(float(k) for k in rates)
    m = len(rates)
    if ports is None:
        if m != 2:
            raise ValueError("give ports unless there are exactly two springs (wire, platform)")
        ports = (["wire:1"], ["platform:1"])
    parsed = []
    for j, plist in enumerate(ports):
        ps = []
        for p in plist:
            mt = _PORT.match(p)
            if not mt:
                raise ValueError(f"spring {j + 1}: port {p!r} is not like 'wire:1' or '-platform:1'")
            if int(mt.group(3)) != 1:
                raise NotImplementedError("this reference model covers one cam only")
            ps.append((-1.0 if mt.group(1) else 1.0, mt.group(2)))
        parsed.append(tuple(ps))
    preloads = (0.0,) * m if preloads is None else tuple(float(f) for f in preloads)
    x0 = tuple(float(x) for x in preextension)
    if not (len(parsed) == len(preloads) == len(x0) == m):
        raise ValueError("rates, preextension, preloads and ports need one entry per spring")
    c = tuple(float(v) for v in coefficients)
    d = WireCamDesign(c, float(radius), float(offset), rates, preloads, x0, tuple(parsed))
    object.__setattr__(d, "_ref", _contact_one(d, 0.0))
    return d


def load_design(result):
    """Read a design from a cadcam ``result.json``.

    Parameters
    ----------
    result : dict or str or pathlib.Path
        The parsed ``result.json`` (or its path).  Used keys: ``design.cams[0].
        monomial_coefficients`` (increasing powers, [m / rad**i]; or ``..._highest_first``),
        ``design.preextension`` [m], ``problem.mechanisms[0].idler.radius`` and ``.offset``
        [m] (``problem.cams[0]`` in the older shorthand),
        ``problem.springs[j].rate`` [N/m], optional ``.preload`` [N] (default 0) and ``.ports``.

    Returns
    -------
    WireCamDesign
    """
    if isinstance(result, (str, Path)):
        result = json.loads(Path(result).read_text())
    design, problem = result["design"], result["problem"]
    holders = problem.get("mechanisms", problem.get("cams"))
    if len(design["cams"]) != 1 or len(holders) != 1:
        raise NotImplementedError("this reference model covers 1-DOF (one cam) designs only")
    cam = design["cams"][0]
    if "monomial_coefficients" in cam:
        coeffs = cam["monomial_coefficients"]
    else:
        coeffs = list(reversed(cam["monomial_coefficients_highest_first"]))
    idler = holders[0]["idler"]
    springs = problem["springs"]
    ports = None
    if all("ports" in s for s in springs):
        ports = [s["ports"] for s in springs]
    return make_design(coeffs, idler["radius"], idler["offset"],
                       [s["rate"] for s in springs], design["preextension"],
                       preloads=[s.get("preload", 0.0) for s in springs], ports=ports)


# ----------------------------------------------------------------------------- geometry

def _horner(c, phi):
    """rho(phi) and rho'(phi) for increasing-power coefficients ``c`` (scalar or array phi)."""
    rho = 0.0 * phi + c[-1]
    drho = 0.0 * phi
    for a in c[-2::-1]:
        drho = drho * phi + rho
        rho = rho * phi + a
    return rho, drho


def _speed(c, phi):
    """|dr/dphi| = sqrt(rho**2 + rho'**2) [m/rad] at a scalar phi."""
    rho, drho = _horner(c, phi)
    return math.sqrt(rho * rho + drho * drho)


def _contact_one(d, theta):
    """Contact of the idler and the cam at one cam angle ``theta`` [rad] (see :func:`contact`)."""
    c, r, a0 = d.coefficients, d.radius, d.offset
    lo, hi = max(d.phi_min, theta - math.pi / 2), theta + math.pi / 2
    phi = np.linspace(lo, hi, _N_SCAN)
    rho, _ = _horner(c, phi)
    psi = phi - theta
    u = a0 - rho * np.sin(psi)
    disc = r * r - u * u
    f = np.where(disc >= 0.0, rho * np.cos(psi) + np.sqrt(np.maximum(disc, 0.0)), -np.inf)
    i = int(np.argmax(f))
    if not np.isfinite(f[i]):
        raise ValueError(f"theta = {theta}: the idler cannot reach the cam at height a0 = {a0}")
    if i == 0 or i == _N_SCAN - 1:
        raise ValueError(f"theta = {theta}: the idler's contact lies at the end of the window "
                         f"[{lo:.6g}, {hi:.6g}] rad of the profile (wire anchor reached?)")

    def disc_at(x):
        rh, _ = _horner(c, x)
        uu = a0 - rh * math.sin(x - theta)
        return r * r - uu * uu

    def dfdphi(x):
        rh, drh = _horner(c, x)
        sp, cp = math.sin(x - theta), math.cos(x - theta)
        uu = a0 - rh * sp
        s = math.sqrt(max(r * r - uu * uu, 0.0))
        if s == 0.0:
            return math.copysign(math.inf, uu * (drh * sp + rh * cp))
        return drh * cp - rh * sp + uu * (drh * sp + rh * cp) / s

    a, b = float(phi[i - 1]), float(phi[i + 1])
    # a neighbour outside the root's domain: move it to the domain's edge (df/dphi is infinite
    # there, pointing inward, so the maximum is interior)
    if disc[i - 1] < 0.0:
        a = brentq(disc_at, a, float(phi[i]), xtol=1e-15)
        a = math.nextafter(a, math.inf) if disc_at(a) < 0 else a
    if disc[i + 1] < 0.0:
        b = brentq(disc_at, float(phi[i]), b, xtol=1e-15)
        b = math.nextafter(b, -math.inf) if disc_at(b) < 0 else b
    fa, fb = dfdphi(a), dfdphi(b)
    if not (fa > 0.0 > fb):
        raise ValueError(f"theta = {theta}: no isolated maximum of the idler position near "
                         f"phi = {phi[i]:.6g} rad (df/dphi = {fa:.3g}, {fb:.3g})")
    alpha = brentq(dfdphi, a, b, xtol=1e-16, rtol=8.9e-16, maxiter=200)
    rho_a, _ = _horner(c, alpha)
    psi_a = alpha - theta
    u_a = a0 - rho_a * math.sin(psi_a)
    s_a = math.sqrt(max(r * r - u_a * u_a, 0.0))
    qx = rho_a * math.cos(psi_a) + s_a
    # p - q = (-s, -u): the polar angle of the contact about the idler centre, in [0, 2 pi)
    gamma = math.atan2(-u_a, -s_a) % (2.0 * math.pi)
    return dict(alpha=alpha, gamma=gamma, qx=qx,
                p=(rho_a * math.cos(psi_a), rho_a * math.sin(psi_a)))


def contact(design, theta):
    """Idler-cam contact.

    Parameters
    ----------
    design : WireCamDesign
    theta : float or array_like, shape (n,)
        Cam angles [rad].

    Returns
    -------
    dict of ndarray
        ``alpha`` (n,) cam polar angle of the contact point [rad]; ``gamma`` (n,) its polar
        angle about the idler centre [rad]; ``qx`` (n,) the idler centre's x [m]; ``p`` (2, n)
        the contact point in world coordinates [m].
    """
    th = np.atleast_1d(np.asarray(theta, dtype=float))
    cs = [_contact_one(design, float(t)) for t in th]
    return dict(alpha=np.array([k["alpha"] for k in cs]), gamma=np.array([k["gamma"] for k in cs]),
                qx=np.array([k["qx"] for k in cs]), p=np.array([k["p"] for k in cs]).T.reshape(2, -1))


def _wire_length_change(d, ca, cb):
    """Wire taken up between contacts ``ca`` and ``cb``: arc on the cam + wrap on the idler [m]."""
    arc = quad(lambda x: _speed(d.coefficients, x), ca["alpha"], cb["alpha"], **_QUAD)[0]
    return arc + d.radius * (cb["gamma"] - ca["gamma"])


def _combine(d, wire, platform):
    """Per-spring sums of signed port displacements [m], shape (m,)."""
    out = np.zeros(d.n_springs)
    for j, ps in enumerate(d.ports):
        for sign, kind in ps:
            out[j] += sign * (wire if kind == "wire" else platform)
    return out


def _x_from_contact(d, ct):
    ref = d._ref
    return np.asarray(d.preextension) + _combine(d, _wire_length_change(d, ref, ct),
                                                 ct["qx"] - ref["qx"])


def extensions(design, theta):
    """Spring extensions (Eq. 14 and 16).

    Parameters
    ----------
    design : WireCamDesign
    theta : float or array_like, shape (n,)
        Cam angles [rad].

    Returns
    -------
    ndarray, shape (m, n)
        Extension x_j of each spring at each angle [m], in the design's spring order.
    """
    th = np.atleast_1d(np.asarray(theta, dtype=float))
    return np.array([_x_from_contact(design, _contact_one(design, float(t))) for t in th]).T


def energy(design, theta):
    """Spring energy V = sum_j (k_j x_j**2 / 2 + F0_j x_j).

    Parameters
    ----------
    design : WireCamDesign
    theta : float or array_like, shape (n,)
        Cam angles [rad].

    Returns
    -------
    ndarray, shape (n,)
        V [J].
    """
    x = extensions(design, theta)
    k = np.asarray(design.rates)[:, None]
    f0 = np.asarray(design.preloads)[:, None]
    return np.sum(0.5 * k * x * x + f0 * x, axis=0)


def _central(d, theta, h, mid):
    """Central difference of V at ``theta`` with step ``h`` [N m], evaluated without cancellation."""
    cm, cp = _contact_one(d, theta - h), _contact_one(d, theta + h)
    # the two extensions from the middle one: x(theta -/+ h) = x(theta) + [theta .. theta -/+ h]
    xm = mid["x"] + _combine(d, _wire_length_change(d, mid["c"], cm), cm["qx"] - mid["c"]["qx"])
    xp = mid["x"] + _combine(d, _wire_length_change(d, mid["c"], cp), cp["qx"] - mid["c"]["qx"])
    dx = _combine(d, _wire_length_change(d, cm, cp), cp["qx"] - cm["qx"])
    xbar = 0.5 * (xm + xp)
    return float(np.sum((np.asarray(d.rates) * xbar + np.asarray(d.preloads)) * dx)) / (2.0 * h)


def energy_torque(design, theta, step=2e-3, richardson=True):
    """Static torque tau = dV/dtheta of the springs on the cam axis.

    Parameters
    ----------
    design : WireCamDesign
    theta : float or array_like, shape (n,)
        Cam angles [rad].
    step : float, optional
        Central-difference step h [rad].
    richardson : bool, optional
        Extrapolate the steps h and h/2 to O(h**4) (default); else the plain central difference
        with step h (error O(h**2)).

    Returns
    -------
    ndarray, shape (n,)
        tau [N m]; positive when the springs' energy grows with theta (the torque an actuator
        supplies to turn the cam forward quasi-statically).
    """
    th = np.atleast_1d(np.asarray(theta, dtype=float))
    out = np.empty(th.size)
    for n, t in enumerate(th):
        c0 = _contact_one(design, float(t))
        mid = dict(c=c0, x=_x_from_contact(design, c0))
        d1 = _central(design, float(t), step, mid)
        if richardson:
            d2 = _central(design, float(t), 0.5 * step, mid)
            out[n] = (4.0 * d2 - d1) / 3.0
        else:
            out[n] = d1
    return out
