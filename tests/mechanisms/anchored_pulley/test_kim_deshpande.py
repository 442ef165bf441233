"""Kim & Deshpande's closed-form pulley and Ludovico2021's convex QCQP (Sec. II–IV)."""
import sys

import numpy as np
import pytest
from scipy.integrate import quad

from cadcam.physics.profile import Basis, fit_profile, profile_function
from cadcam.mechanisms.anchored_pulley.kim_deshpande import closed_form, envelope, spring_state
from cadcam.mechanisms.anchored_pulley.ludovico_qcqp import design_matrices, solve_qcqp

THETA_I, THETA_F = np.pi / 6, 5 * np.pi / 6
K, U0, L = 30e3, 0.015, 0.25  # Ludovico2021 Tables I and III
THETA = np.linspace(THETA_I, THETA_F, 2001)


def pendulum(t):
    return 147.1 * np.cos(t)  # Ludovico2021 Eq. 37, Table I


def generic(t):
    return 147.1 * (np.cos(t) - np.sin(t)) + 84.4  # Ludovico2021 Eq. 39, Table III


def split(target, d_off, lam=0.5):
    """Antagonistic sub-torques: pulley 1 (u0 at θ_f) and pulley 2 (u0 at θ_i)."""
    return (lambda t: lam * target(t) + d_off), (lambda t: -(1 - lam) * target(t) + d_off)


def geometric_extension(cf, ell):
    """Extension of the spring of a pulley built from its envelope points, by geometry alone.

    The points are a polygon in winding order from the anchor (the θ0 end); for each spring end
    S the departure vertex is the extreme one seen from S (the rest of the pulley lies clockwise
    of the ray S → departure point), the cable length is the polygon's arc length to it plus the
    free span, and the extension is u0 plus the change of that length.
    """
    sigma = cf.state.sigma
    order = np.argsort(sigma * cf.state.theta)
    points = cf.envelope.points[order]
    arc = np.r_[0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    chi = sigma * cf.state.theta[order]
    lengths = []
    for s in ell * np.c_[np.cos(chi), np.sin(chi)]:
        inward, w = -s / np.linalg.norm(s), points - s
        angle = np.arctan2(inward[0] * w[:, 1] - inward[1] * w[:, 0], w @ inward)
        j = np.argmax(angle)
        lengths.append(arc[j] + np.linalg.norm(s - points[j]))
    lengths = np.asarray(lengths)
    return order, cf.state.u[order][0] + lengths - lengths[0]


# --- spring state and closed form -----------------------------------------------------------

@pytest.mark.parametrize("theta0, F0", [(THETA_I, 0.0), (THETA_F, 40.0)])
def test_spring_state_balances_energy_against_adaptive_quadrature(theta0, F0):
    tau = split(pendulum, 79.6)[0 if theta0 == THETA_F else 1]
    theta = np.linspace(THETA_I, THETA_F, 23)
    state = spring_state(tau, theta, theta0, K, U0, F0)
    work = np.array([abs(quad(tau, theta0, t, epsabs=0, epsrel=1e-13)[0]) for t in theta])
    stored = 0.5 * K * state.u**2 + F0 * state.u - (0.5 * K * U0**2 + F0 * U0)
    np.testing.assert_allclose(stored, work, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(state.force, K * state.u + F0, rtol=1e-14)
    np.testing.assert_allclose(state.r_m * state.force, tau(theta), rtol=1e-13)
    assert state.sigma == (1 if theta0 == THETA_I else -1)


@pytest.mark.parametrize("theta0, F0", [(THETA_I, 0.0), (THETA_F, 0.0), (THETA_I, 60.0)])
def test_a_constant_moment_arm_gives_a_circle(theta0, F0):
    r, side = 0.04, (1 if theta0 == THETA_I else -1)
    # F·r with u = u0 + r|θ − θ0|, continued linearly past θ0 for the differences of τ
    def tau(t):
        return (K * (U0 + side * r * (t - theta0)) + F0) * r
    cf = closed_form(tau, THETA, theta0, K, U0, L, F0=F0, chi0=0.3)
    env, sigma = cf.envelope, cf.state.sigma
    np.testing.assert_allclose(cf.state.r_m, r, rtol=1e-12)
    np.testing.assert_allclose(cf.dr_m, 0, atol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(env.points, axis=1), r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(env.radius_of_curvature, r, rtol=1e-7)
    np.testing.assert_allclose(env.dnu, sigma, atol=1e-9)
    np.testing.assert_allclose(env.span, np.sqrt(L**2 - r**2), rtol=1e-9)
    # the departure point sits a quarter turn behind the cable line's normal…
    np.testing.assert_allclose(env.phi_polar - env.nu, 0, atol=1e-7)
    # …and the normal a quarter turn minus asin(r/ℓ) behind the spring end
    np.testing.assert_allclose(0.3 + sigma * THETA - env.nu, np.arccos(r / L), atol=1e-12)
    assert cf.feasible and cf.curvature_zeros.size == 0 and cf.nonregular_points.size == 0


def test_moment_arm_derivatives_match_differences_of_the_spring_state():
    tau1 = split(generic, 86.4)[0]
    theta = np.linspace(0.6, 2.4, 9)
    h = 1e-4
    r = [spring_state(tau1, theta + d, THETA_F, K, U0).r_m for d in (-h, 0, h)]
    cf = closed_form(tau1, theta, THETA_F, K, U0, L)
    np.testing.assert_allclose(cf.dr_m, (r[2] - r[0]) / (2 * h), rtol=1e-6)
    np.testing.assert_allclose(cf.d2r_m, (r[2] - 2 * r[1] + r[0]) / h**2, rtol=1e-4)
    exact = closed_form(tau1, theta, THETA_F, K, U0, L,
                        dtau=lambda t: -73.55 * (np.sin(t) + np.cos(t)),
                        d2tau=lambda t: -73.55 * (np.cos(t) - np.sin(t)))
    np.testing.assert_allclose(cf.dr_m, exact.dr_m, rtol=1e-9)
    np.testing.assert_allclose(cf.d2r_m, exact.d2r_m, rtol=1e-7)


def test_radius_of_curvature_matches_the_points():
    cf = closed_form(split(generic, 86.4)[1], np.linspace(1.2, 2.4, 4001), THETA_I, K, U0, L)
    env = cf.envelope
    # |dX/dθ| = |R ν′| for the envelope (dX/dν = R t)
    speed = np.linalg.norm(np.gradient(env.points, env.theta, axis=0, edge_order=2), axis=1)
    np.testing.assert_allclose(speed[1:-1], np.abs(env.radius_of_curvature * env.dnu)[1:-1],
                               rtol=1e-5)


@pytest.fixture(scope="module")
def pendulum_pulleys():
    tau1, tau2 = split(pendulum, 79.6)
    return (closed_form(tau1, THETA, THETA_F, K, U0, L),
            closed_form(tau2, THETA, THETA_I, K, U0, L), tau1, tau2)


def test_pendulum_closed_form_reproduces_the_papers_spring_and_moment_arms(pendulum_pulleys):
    cf1, cf2, _, _ = pendulum_pulleys
    for cf in (cf1, cf2):
        s = cf.state
        print(f"sigma {s.sigma:+d}: u {s.u.min() * 1e3:.3f}-{s.u.max() * 1e3:.3f} mm, F max "
              f"{s.force.max():.1f} N, r_m {s.r_m.min() * 1e3:.3f}-{s.r_m.max() * 1e3:.3f} mm")
        assert s.u.min() == pytest.approx(0.015, abs=1e-12)
        assert s.u.max() == pytest.approx(0.1065, abs=2e-4)  # appendix: 107 mm deflection
        assert s.force.max() == pytest.approx(3190, rel=2e-3)  # appendix: 3133 N with k_s = 29 277
        assert s.r_m.min() == pytest.approx(0.0353, abs=1e-4)
        assert s.r_m.max() == pytest.approx(0.0472, abs=1e-4)
        assert cf.feasible
        assert cf.curvature_zeros.size == 0 and cf.nonregular_points.size == 0
    assert (cf1.state.sigma, cf2.state.sigma) == (-1, 1)
    # λ = 0.5 and τ_d(π − θ) = −τ_d(θ): the two pulleys are mirror images (Ludovico2021 Sec. IV-A)
    np.testing.assert_allclose(cf1.state.r_m, cf2.state.r_m[::-1], rtol=1e-9)


def test_pendulum_pulley_built_from_its_envelope_gives_the_target(pendulum_pulleys):
    cf1, cf2, tau1, tau2 = pendulum_pulleys
    for cf, tau in ((cf1, tau1), (cf2, tau2)):
        order, u = geometric_extension(cf, L)
        np.testing.assert_allclose(u, cf.state.u[order], rtol=0, atol=1e-8)
        theta = cf.state.theta[order]
        torque = K * u * np.gradient(u, cf.state.sigma * theta, edge_order=2)  # F du/d(σθ)
        np.testing.assert_allclose(torque, tau(theta), rtol=0, atol=1e-3)


def test_generic_torque_closed_form_is_infeasible_where_the_paper_says():
    tau1, tau2 = split(generic, 86.4)
    cf1 = closed_form(tau1, THETA, THETA_F, K, U0, L)
    cf2 = closed_form(tau2, THETA, THETA_I, K, U0, L)
    print("pulley 1 curvature zeros", cf1.curvature_zeros, "non-regular", cf1.nonregular_points)
    print("pulley 2 curvature zeros", cf2.curvature_zeros, "non-regular", cf2.nonregular_points)
    # pulley 2: a non-regular point (Eq. 30 = 0) at 0.91 rad in the paper
    assert cf2.curvature_zeros.size == 0
    assert cf2.nonregular_points.size == 1
    assert cf2.nonregular_points[0] == pytest.approx(0.916, abs=0.01)
    radius = cf2.envelope.radius_of_curvature
    below = THETA < cf2.nonregular_points[0]
    assert np.all(radius[below] < 0) and np.all(radius[~below] > 0)
    # pulley 1: a curvature zero (1 + φ′ = 0) at 0.54 rad in the paper, its mirrored angle π − θ
    assert cf1.nonregular_points.size == 0
    assert cf1.curvature_zeros.size == 1
    assert np.pi - cf1.curvature_zeros[0] == pytest.approx(0.546, abs=0.01)
    assert abs(closed_form(tau1, cf1.curvature_zeros, THETA_F, K, U0, L).envelope.dnu[0]) < 1e-9
    assert abs(closed_form(tau2, cf2.nonregular_points, THETA_I, K, U0, L).envelope.regularity[0]
               ) < 1e-9
    assert not cf1.feasible and not cf2.feasible


# --- profile fit ----------------------------------------------------------------------------

@pytest.mark.parametrize("name, order", [("monomial", 5), ("chebyshev", 7)])
def test_fit_profile_recovers_a_polynomial(name, order):
    basis = Basis(name, order, (0.0, 2.0))
    rng = np.random.default_rng(order)
    c = basis.from_monomial(np.r_[0.04, rng.normal(size=order) * 1e-3])
    phi = np.linspace(0, 2.0, 57)
    rho = np.asarray(profile_function(basis).map(phi.size)(phi[None, :], c)[0]).ravel()
    np.testing.assert_allclose(fit_profile(basis, phi, rho), c, rtol=1e-8, atol=1e-12)


def test_fit_profile_of_the_pendulum_pulley(pendulum_pulleys):
    env = pendulum_pulleys[1].envelope  # σ = +1: φ increases from the anchor at θ_i
    phi = env.phi_polar - env.phi_polar[0]
    basis = Basis("chebyshev", 7, (0.0, float(phi[-1])))
    c = fit_profile(basis, phi, env.rho)
    rho = np.asarray(profile_function(basis).map(phi.size)(phi[None, :], c)[0]).ravel()
    assert np.abs(rho - env.rho).max() < 2e-4  # measured 9.8e-5 m on a 35–47 mm profile


# --- bad input ------------------------------------------------------------------------------

@pytest.mark.parametrize("call, match", [
    (lambda: spring_state(np.cos, [0.1, 0.5], 0.3, K, U0), "one side of theta0"),
    (lambda: spring_state(lambda t: -np.ones_like(t), [0.1, 0.5], 0.0, K, U0), "tau must be"),
    (lambda: spring_state(np.cos, [0.1, 0.5], 0.0, -1.0, U0), "spring rate"),
    (lambda: spring_state(np.cos, [0.1, 0.5], 0.0, K, 0.0), "force at theta0"),
    (lambda: envelope([0.1], [0.3], [0.0], [0.0], L, 0.0, 1), "below ell"),
    (lambda: envelope([0.1], [0.03], [0.0], [0.0], L, 0.0, 0), "sigma"),
    (lambda: envelope([0.1, 0.2], [0.03], [0.0], [0.0], L, 0.0, 1), "same shape"),
    (lambda: fit_profile(Basis("monomial", 5, (0, 1)), [0.0, 1.0], [0.1, 0.1]), "at least 6"),
    (lambda: solve_qcqp(np.cos, 0.2, 1.0, 0.5, K, U0, L), "theta_i or theta_f"),
])
def test_bad_input_is_a_one_line_value_error(call, match):
    with pytest.raises(ValueError, match=match) as info:
        call()
    assert "\n" not in str(info.value)


# --- Ludovico2021's convex QCQP -------------------------------------------------------------

def test_design_matrices_differentiate_the_polynomial():
    theta = np.linspace(THETA_I, THETA_F, 11)
    beta = np.array([0.04, 0.01, -0.003, 2e-4, 3e-5, -1e-6])
    H, Hd, Hdd = design_matrices(theta, 5)
    p = np.polynomial.Polynomial(beta)
    np.testing.assert_allclose(H @ beta, p(theta), rtol=1e-14)
    np.testing.assert_allclose(Hd @ beta, p.deriv()(theta), rtol=1e-13)
    np.testing.assert_allclose(Hdd @ beta, p.deriv(2)(theta), rtol=1e-13)


def test_qcqp_without_cvxpy_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "cvxpy", None)
    with pytest.raises(ImportError, match=r"pip install 'cadcam\[convex\]'"):
        solve_qcqp(np.cos, 0.2, 1.0, 0.2, K, U0, L)


@pytest.mark.parametrize("target, d_off, bound", [
    (pendulum, 79.6, 1.2),  # measured 1.00 N·m (the paper: 2.2)
    (generic, 86.4, 7.0),  # measured 5.86 N·m (the paper: 6.4)
])
def test_qcqp_solves_the_papers_examples(target, d_off, bound):
    pytest.importorskip("cvxpy")
    tau1, tau2 = split(target, d_off)
    results = []
    for tau, theta0, sigma in ((tau1, THETA_F, -1), (tau2, THETA_I, 1)):
        res = solve_qcqp(tau, THETA_I, THETA_F, theta0, K, U0, L)
        assert res.status == "optimal"
        assert res.theta.size == 250 and np.diff(res.theta)[0] == pytest.approx(8.41e-3, abs=1e-5)
        tol = 1e-7
        assert np.all(res.r_m >= -tol) and np.all(res.r_m <= L + tol)  # Eq. 11–12
        assert np.all(res.r_m**2 + res.dr_m**2 <= L**2 + tol)  # Eq. 15, 17
        assert np.all(res.d2r_m + res.r_m / 4 >= -tol)  # Eq. 35
        # the rectangle sum of Eq. 8 runs from the end where the spring is at u0: its work is
        # within two rectangles of the exact work of the target (the other way round it would
        # be off by up to the whole work, about 4e6 N² in v²)
        exact = spring_state(tau, res.theta, theta0, K, U0).force
        d_alpha = (THETA_F - THETA_I) / 250
        np.testing.assert_allclose(res.v**2, exact**2, rtol=0,
                                   atol=2 * K * 2 * tau(res.theta).max() * d_alpha)
        # the convex subset guarantees an exactly feasible pulley
        env = envelope(res.theta, res.r_m, res.dr_m, res.d2r_m, L, 0.0, sigma)
        assert np.all(sigma * env.dnu > 0) and np.all(env.radius_of_curvature > 0)
        assert np.all(env.span > 0)
        results.append(res)
    paper = results[0].error_paper - results[1].error_paper  # net τ1 − τ2 − τ_d
    actual = results[0].torque - results[1].torque - target(results[0].theta)
    print(f"max |paper-style error| {np.abs(paper).max():.3f} N·m, max |actual| "
          f"{np.abs(actual).max():.3f} N·m, {results[0].solver} "
          f"{results[0].solve_time + results[1].solve_time:.3f} s")
    assert np.abs(paper).max() < bound
