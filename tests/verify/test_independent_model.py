"""Tests of the independent wire-cam reference model itself (tests/mechanisms/wire_cam/independent_wire_cam.py).

Nothing here imports cadcam or compares against cadcam's torque: these tests establish that the
reference model is right on its own terms (closed forms, two derivative paths, geometry).
"""
import numpy as np
import pytest

from ..mechanisms.wire_cam.independent_wire_cam import (contact, energy, energy_torque, extensions, load_design,
                                   make_design)

R_IDLER, A0 = 0.020, 0.015
RATES = [1100.0, 7350.0]
POLY = [0.025, 0.004, 0.002]               # rho = 0.025 + 0.004 phi + 0.002 phi**2 [m]
THETA = np.linspace(0.0, np.pi / 2, 19)


def _rho(c, phi):
    """rho, rho', rho'' of an increasing-power polynomial (numpy's own evaluator)."""
    p = np.polynomial.Polynomial(c)
    return p(phi), p.deriv(1)(phi), p.deriv(2)(phi)


def _result_dict(coeffs, x0, preload=None):
    """A hand-made dict shaped like cadcam's result.json (only the keys the model reads)."""
    springs = [{"name": "wire spring", "rate": RATES[0], "travel": 0.06, "ports": ["wire:1"]},
               {"name": "platform spring", "rate": RATES[1], "travel": 0.04,
                "ports": ["platform:1"]}]
    if preload is not None:
        for s, f in zip(springs, preload):
            s["preload"] = f
    return {"design": {"cams": [{"monomial_coefficients": list(coeffs),
                                 "monomial_coefficients_highest_first": list(coeffs)[::-1]}],
                       "preextension": list(x0)},
            "problem": {"cams": [{"idler": {"radius": R_IDLER, "offset": A0}}],
                        "springs": springs}}


@pytest.fixture(scope="module")
def poly_design():
    return load_design(_result_dict(POLY, [0.0, 0.01]))


def _virtual_work_torque(d, theta):
    """tau from moment arms, no finite differences and no arc-length quadrature.

    Contact kinematics: the gap along the normal stays closed, n.(v_idler - v_cam) = 0 at p,
    with v_cam = -theta' z x p (the cam turns by -theta in the world) and v_idler = qx' x, so
    qx' = -z.(p x n)/n_x.  The wire is taut over a zero-length free span at p, so its length
    grows by t.(v_idler - v_cam): x1' = z.(p x t) + t_x qx', t the cam's unit tangent towards
    increasing phi.  Then tau = sum_j (k_j x_j + F0_j) x_j'.
    """
    ct = contact(d, theta)
    px, py = ct["p"]
    rho, drho, _ = _rho(d.coefficients, ct["alpha"])
    psi = ct["alpha"] - theta
    tx = drho * np.cos(psi) - rho * np.sin(psi)
    ty = drho * np.sin(psi) + rho * np.cos(psi)
    nrm = np.hypot(tx, ty)
    tx, ty = tx / nrm, ty / nrm
    nx, ny = ct["qx"] - px, d.offset - py          # towards the idler centre
    dq = -(px * ny - py * nx) / nx
    dwire = (px * ty - py * tx) + tx * dq
    rates, f0 = np.asarray(d.rates), np.asarray(d.preloads)
    x = extensions(d, theta)
    dx = np.array([sum(s * (dwire if kind == "wire" else dq) for s, kind in ports)
                   for ports in d.ports])
    return np.sum((rates[:, None] * x + f0[:, None]) * dx, axis=0)


# ------------------------------------------------------------------ 1. circular cam, closed form

def test_circular_cam_closed_form():
    R, x0, f0 = 0.03, np.array([0.004, 0.002]), np.array([3.0, 20.0])
    d = make_design([R], R_IDLER, A0, RATES, x0, preloads=f0)
    ct = contact(d, THETA)
    # the idler does not move; the contact stays at a fixed world angle
    qx = np.sqrt((R + R_IDLER) ** 2 - A0 ** 2)
    np.testing.assert_allclose(ct["qx"], qx, rtol=1e-12)
    np.testing.assert_allclose(ct["alpha"] - THETA, np.arctan2(A0, qx), atol=1e-12)
    np.testing.assert_allclose(ct["gamma"], np.pi + np.arctan2(A0, qx), atol=1e-12)
    x = extensions(d, THETA)
    np.testing.assert_allclose(x[0], x0[0] + R * THETA, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(x[1], x0[1], rtol=1e-9)
    V = energy(d, THETA)
    np.testing.assert_allclose(V, np.sum(0.5 * np.array(RATES)[:, None] * x ** 2
                                         + f0[:, None] * x, axis=0), rtol=1e-12)
    tau = energy_torque(d, THETA)
    np.testing.assert_allclose(tau, (RATES[0] * x[0] + f0[0]) * R, rtol=1e-9)


# ------------------------------------------------------------------ 2. the derivative, two paths

def test_torque_independent_of_step(poly_design):
    """Richardson-extrapolated central differences at steps 4x apart agree to ~1e-11 N m;
    plain central differences converge as h**2 towards them."""
    t1 = energy_torque(poly_design, THETA, step=2e-3)
    t2 = energy_torque(poly_design, THETA, step=5e-4)
    np.testing.assert_allclose(t1, t2, rtol=0, atol=1e-10)
    e1 = energy_torque(poly_design, THETA, step=2e-3, richardson=False) - t2
    e2 = energy_torque(poly_design, THETA, step=1e-3, richardson=False) - t2
    big = np.abs(e1) > 1e-8                   # where the O(h**2) term stands above the noise
    assert big.sum() >= len(THETA) // 2
    np.testing.assert_allclose(e1[big] / e2[big], 4.0, rtol=0.02)


def test_torque_equals_difference_of_energy(poly_design):
    """tau against a central difference of energy() itself (a different code path: the
    extensions from theta = 0, then V), extrapolated from h = 1e-3 and 5e-4."""
    def cd(h):
        return (energy(poly_design, THETA + h) - energy(poly_design, THETA - h)) / (2 * h)
    naive = (4 * cd(5e-4) - cd(1e-3)) / 3
    np.testing.assert_allclose(energy_torque(poly_design, THETA), naive, rtol=0, atol=1e-9)


@pytest.mark.parametrize("preload", [None, [4.0, 25.0]])
def test_torque_equals_virtual_work_of_the_contact(preload):
    d = load_design(_result_dict(POLY, [0.002, 0.01], preload))
    np.testing.assert_allclose(energy_torque(d, THETA), _virtual_work_torque(d, THETA),
                               rtol=0, atol=1e-9)


# ------------------------------------------------------------------ 3. geometry of a real cam

def test_polynomial_cam_geometry(poly_design):
    d = poly_design
    phi = np.linspace(0.0, np.pi, 2001)
    rho, drho, ddrho = _rho(POLY, phi)
    assert np.all(rho ** 2 + 2 * drho ** 2 - rho * ddrho > 0)        # the cam is convex
    ct = contact(d, THETA)
    x = extensions(d, THETA)
    assert np.all(ct["qx"] > 0)
    assert np.all(x[1] > 0) and x[1, -1] > x[1, 0]                    # the idler is pushed out
    assert np.all(np.diff(x[0]) > 0)                                  # the wire winds on
    np.testing.assert_allclose(x[:, 0], [0.0, 0.01], atol=1e-15)
    px, py = ct["p"]
    # p lies on the idler circle and on the cam
    np.testing.assert_allclose(np.hypot(px - ct["qx"], py - A0), R_IDLER, rtol=0, atol=1e-12)
    rho_a, drho_a, _ = _rho(POLY, ct["alpha"])
    np.testing.assert_allclose(np.hypot(px, py), rho_a, rtol=0, atol=1e-15)
    # the cam's tangent (Eq. 3) and the idler's (Eq. 4) are antiparallel at p
    psi = ct["alpha"] - THETA
    t = np.array([drho_a * np.cos(psi) - rho_a * np.sin(psi),
                  drho_a * np.sin(psi) + rho_a * np.cos(psi)]) / np.hypot(rho_a, drho_a)
    ti = np.array([-np.sin(ct["gamma"]), np.cos(ct["gamma"])])
    np.testing.assert_allclose(t + ti, 0.0, atol=1e-9)
    # the idler touches but never cuts the cam: every profile point is at least r from q
    for k, th in enumerate(THETA):
        gap = np.hypot(rho * np.cos(phi - th) - ct["qx"][k], rho * np.sin(phi - th) - A0)
        assert gap.min() >= R_IDLER - 1e-12


def test_load_design_reads_result_keys():
    res = _result_dict(POLY, [0.001, 0.01], preload=[2.0, 30.0])
    d = load_design(res)
    assert d.coefficients == tuple(POLY) and d.radius == R_IDLER and d.offset == A0
    assert d.rates == tuple(RATES) and d.preloads == (2.0, 30.0)
    del res["design"]["cams"][0]["monomial_coefficients"]            # highest-first fallback
    for s in res["problem"]["springs"]:
        del s["preload"]                                              # preload defaults to 0
    d0 = load_design(res)
    assert d0.coefficients == tuple(POLY) and d0.preloads == (0.0, 0.0)
    # a preload adds F0 x to V and F0 dx/dtheta to tau
    x = extensions(d0, THETA)
    np.testing.assert_allclose(energy(d, THETA) - energy(d0, THETA), 2.0 * x[0] + 30.0 * x[1],
                               rtol=1e-12)
    dx = [energy_torque(make_design(POLY, R_IDLER, A0, [1e-300, 1e-300], [0.0, 0.0],
                                    preloads=f), THETA) for f in ([1.0, 0.0], [0.0, 1.0])]
    np.testing.assert_allclose(energy_torque(d, THETA) - energy_torque(d0, THETA),
                               2.0 * dx[0] + 30.0 * dx[1], rtol=0, atol=1e-11)


def test_sign_of_a_port_flips_its_displacement():
    d = make_design(POLY, R_IDLER, A0, RATES, [0.0, 0.01], ports=(["wire:1"], ["-platform:1"]))
    x = extensions(d, THETA)
    x_ref = extensions(make_design(POLY, R_IDLER, A0, RATES, [0.0, 0.01]), THETA)
    np.testing.assert_allclose(x[1] - 0.01, -(x_ref[1] - 0.01), atol=1e-15)
