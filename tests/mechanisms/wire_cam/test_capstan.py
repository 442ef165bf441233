"""Capstan friction (Johnston2023, Sec. 4.1) and the correction of its Eq. 33."""
import numpy as np
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from cadcam.mechanisms.wire_cam.capstan import anchor_load, curve, loads_function, wire_torque_function
from cadcam.mechanisms.wire_cam.departure import departure_moments
from cadcam.physics.profile import Basis, profile_function
from cadcam.physics.quadrature import gauss_legendre

BASIS = Basis("monomial", 3, (0.0, 3.5))
PROFILE = profile_function(BASIS)
EXACT = wire_torque_function(BASIS, "corrected", 40)
PRINTED = wire_torque_function(BASIS, "as-printed", 40)


def _convex_cam(c, alpha):
    phi = np.linspace(0, alpha, 200)
    rho, _, _, conv = (np.asarray(v).ravel() for v in PROFILE.map(200)(phi, c))
    return rho.min() > 0.005 and conv.min() > 1e-6


def _departure_arm(c, alpha):
    rho, drho, _, _ = PROFILE(alpha, c)
    # invariant to the rotation θ: evaluate in the cam frame (θ = 0)
    return float(departure_moments(0.0, alpha, rho, drho)[0])


cams = st.tuples(st.floats(0.01, 0.05), st.floats(-0.01, 0.02), st.floats(-0.006, 0.006),
                 st.floats(-0.002, 0.002))


@settings(max_examples=60, deadline=None)
@given(c=cams, alpha=st.floats(0.2, 2.5), mu=st.floats(0.0, 1.0))
def test_exact_friction_torque_is_the_departure_moment(c, alpha, mu):
    """Eq. 35 with the correct t̂′ integrates to ẑ·(r_p × t̂) for every μ (docs/physics.md)."""
    c = np.array(c)
    assume(_convex_cam(c, alpha))
    assert abs(float(EXACT(alpha, c, mu)) - _departure_arm(c, alpha)) <= 1e-10 * abs(_departure_arm(c, alpha))


noncircular = st.tuples(st.floats(0.01, 0.05), st.floats(0.004, 0.02), st.floats(-0.004, 0.004),
                        st.floats(-0.001, 0.001))


@settings(max_examples=40, deadline=None)
@given(c=noncircular, alpha=st.floats(0.5, 2.5), mu=st.floats(0.1, 1.0))
@example(c=(0.01171875, 0.006, -0.001749459278590677, -6.184663643443787e-05), alpha=2.34375, mu=0.875)
def test_as_printed_friction_integrand_is_not(c, alpha, mu):
    """Eq. 33 as printed changes the moment density of Eq. 35 wherever r′ᵀr″ = ρ′(ρ + ρ″) ≠ 0:
    printed − correct = η ẑ·(r × r′)(r′ᵀr″)(1/|r′|² − |r′|⁶)/|r′|, with ẑ·(r × r′) = ρ² (on a
    circle the two coincide). Its integral
    over the wrap can still cancel by chance: the @example is a convex cam where the printed and
    the correct wire torque agree to 0.1 %, found by this property's earlier, integral form."""
    c = np.array(c)
    assume(_convex_cam(c, alpha))
    phi = alpha * np.linspace(0.05, 0.95, 19)
    rho, drho, ddrho, _ = (np.asarray(v).ravel() for v in PROFILE.map(phi.size)(phi, c))
    r1r2 = drho * (rho + ddrho)  # r′ᵀr″ of the polar curve
    speed = np.hypot(rho, drho)
    expected = np.exp(mu * (phi - alpha)) * rho**2 * r1r2 * (1 / speed**2 - speed**6) / speed
    moment = {model: np.asarray(loads_function(BASIS, model).map(phi.size)(phi, alpha, c, mu)[3]).ravel()
              for model in ("corrected", "as-printed")}
    # the printed t̂′ minus the correct one is the term above; it vanishes nowhere it is large
    np.testing.assert_allclose(moment["as-printed"] - moment["corrected"], expected,
                               rtol=1e-9, atol=1e-12 * np.abs(moment["corrected"]).max())
    big = np.abs(r1r2) > 1e-3 * np.abs(r1r2).max()
    assert np.all(np.abs(moment["corrected"] - moment["as-printed"])[big]
                  > 1e-3 * np.abs(moment["corrected"]).max() * np.abs(r1r2[big]) / np.abs(r1r2).max())


def test_force_balance_of_the_wire_along_the_wrap():
    """ψ(α) − ψ(0) = ∫₀^α ψ′ (Eq. 22, 24): the distributed loads and the anchor load balance
    the departure tension; tension decays as e^{μ(φ−α)} (Eq. 31)."""
    c, alpha, mu = np.array([0.025, 0.0046, 0.0133, -0.0052]), 1.6, 0.3273
    loads = loads_function(BASIS, "corrected")
    s, w = gauss_legendre(40)
    phi = alpha * s
    ten, normal, friction, _ = (np.asarray(v).ravel() for v in loads.map(40)(phi, alpha, c, mu))
    np.testing.assert_allclose(ten, np.exp(mu * (phi - alpha)), rtol=1e-14)
    r1 = np.column_stack([np.asarray(curve(p, *PROFILE(p, c)[:3])[1], dtype=float).ravel()
                          for p in phi])
    t = r1 / np.linalg.norm(r1, axis=0)
    n = np.vstack([-t[1], t[0]])
    f = normal * n + friction * t  # distributed load on the wire, f = −ψ′
    integral = -(f * w).sum(axis=1) * alpha
    t_end = np.asarray(curve(alpha, *PROFILE(alpha, c)[:3])[1], dtype=float).ravel()
    t_0 = np.asarray(curve(0.0, *PROFILE(0.0, c)[:3])[1], dtype=float).ravel()
    psi_end = t_end / np.linalg.norm(t_end)
    psi_0 = np.asarray(anchor_load(alpha, mu, t_0 / np.linalg.norm(t_0)), dtype=float).ravel()
    np.testing.assert_allclose(psi_end - psi_0, integral, atol=1e-12)
    # friction on the wire opposes the pull (acts toward the anchor), normal load pushes outward
    assert np.all(friction < 0) and np.all(normal < 0)
