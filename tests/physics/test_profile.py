import numpy as np
import pytest

from cadcam.physics.profile import Basis, monomial_from_highest_first, profile_function


@pytest.mark.parametrize("order", [1, 3, 5, 9])
def test_chebyshev_and_monomial_describe_the_same_polynomial(order):
    rng = np.random.default_rng(order)
    m = rng.normal(size=order + 1) * 1e-2
    cheb = Basis("chebyshev", order, (0.0, 3.0))
    mono = Basis("monomial", order, (0.0, 3.0))
    c = cheb.from_monomial(m)
    np.testing.assert_allclose(cheb.to_monomial(c), m, rtol=1e-9, atol=1e-14)
    phi = np.linspace(0, 3, 7)
    a = np.asarray(profile_function(cheb).map(7)(phi, c))
    b = np.asarray(profile_function(mono).map(7)(phi, m))
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("target", [Basis("chebyshev", 5, (0.2, 4.0)), Basis("monomial", 4, (0.0, 1.0)),
                                    Basis("chebyshev", 3, (0.0, 3.0))])
def test_a_profile_converted_to_a_basis_of_its_degree_or_higher_is_the_same_curve(target):
    """Basis.converted across kinds, domains and degrees, where the target holds the profile."""
    source = Basis("chebyshev", 3, (0.0, 3.0))
    c = np.array([0.03, 0.01, -0.002, 0.0005])
    phi = np.linspace(0, 3, 9)
    a = np.asarray(profile_function(source).map(9)(phi, c))
    b = np.asarray(profile_function(target).map(9)(phi, target.converted(c, source)))
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-13)


def test_a_profile_converted_to_a_lower_degree_is_its_least_squares_fit():
    """A cubic in a quadratic basis: the residual of the fit is orthogonal to the quadratics."""
    source, target = Basis("monomial", 3, (0.0, 2.0)), Basis("chebyshev", 2, (0.0, 2.0))
    c = np.array([0.02, 0.0, 0.0, 0.001])  # ρ = 0.02 + 0.001 φ³
    phi = np.linspace(0.0, 2.0, 400)
    residual = 0.02 + 0.001 * phi**3 - np.asarray(profile_function(target).map(400)(phi, target.converted(c, source))[0]).ravel()
    assert np.max(np.abs(residual)) > 1e-4  # a cubic is not a quadratic ...
    np.testing.assert_allclose([residual @ phi**k for k in range(3)], 0, atol=1e-12)  # ... but its best one


def test_derivatives_and_convexity_margin_of_a_known_polynomial():
    # ρ = 0.02 + 0.01 φ − 0.003 φ²: ρ′ = 0.01 − 0.006 φ, ρ″ = −0.006
    f = profile_function(Basis("monomial", 2, (0, 2)))
    phi = 0.7
    rho, d1, d2, conv = (float(v) for v in f(phi, [0.02, 0.01, -0.003]))
    assert rho == pytest.approx(0.02 + 0.007 - 0.003 * 0.49)
    assert d1 == pytest.approx(0.01 - 0.0042)
    assert d2 == pytest.approx(-0.006)
    assert conv == pytest.approx(rho**2 + 2 * d1**2 - rho * d2)  # Johnston2023 Eq. 40


def test_papers_highest_first_order_reads_rho0_at_the_constant():
    m = monomial_from_highest_first([-0.0052, 0.0133, 0.0046, 0.0250])
    rho0 = float(profile_function(Basis("monomial", 3, (0, 3)))(0.0, m)[0])
    assert rho0 == pytest.approx(0.025)


def test_the_recheck_refines_extremes_between_samples_to_the_exact_value():
    # ρ = 0.02 + 0.01 φ − 0.003 φ² on [0, 2]: largest 0.02 + 0.01²/(4·0.003) at φ = 5/3, which
    # falls between the six samples; smallest 0.02 at φ = 0, a sample
    from cadcam.verify.evaluate import _profile_extremes

    basis = Basis("monomial", 2, (0, 2))
    _, rho, _, _, rho_lo, rho_hi, _ = _profile_extremes(basis, np.array([0.02, 0.01, -0.003]), 2.0, 6)
    exact = 0.02 + 0.01**2 / (4 * 0.003)
    assert exact - rho.max() > 1e-5  # the samples alone miss it
    assert rho_hi == pytest.approx(exact, rel=1e-14)
    assert rho_lo == pytest.approx(0.02, rel=1e-14)


def test_refining_a_minimum_at_a_kink_lands_on_it_and_never_below():
    # |φ − a| has no derivative at its minimum (as a piecewise profile may have)
    from cadcam.verify.evaluate import _refine_min

    a = 0.123456789
    phi = np.linspace(0.0, 1.0, 11)
    local = lambda p, c: [np.abs(p - a)]  # noqa: E731 — the profile function, mapped
    m = _refine_min(local, None, phi, np.abs(phi - a), 0)
    # the last level samples every 0.2 rad / 50⁵ / 100 = 6.4e-12 rad
    assert 0.0 <= m < 1e-11 and np.abs(phi - a).min() > 0.02


def test_refining_steps_around_angles_where_the_profile_is_not_finite():
    # finite at the samples, NaN left of the minimum at a: the refinement keeps to the right
    from cadcam.verify.evaluate import _refine_min

    a = 0.123456789
    phi = np.linspace(0.0, 1.0, 11)
    local = lambda p, c: [np.where(p < a, np.nan, p - a)]  # noqa: E731 — the profile function, mapped
    assert 0.0 <= _refine_min(local, None, phi, np.abs(phi - a), 0) < 1e-11


def _tangent_geometry(basis, c, phi):
    """Points, outward unit normals and tangent distances from the axis of a profile, by plane
    geometry on finite differences of its points (not the profile's own derivatives)."""
    rho = np.asarray(profile_function(basis).map(phi.size)(phi, c)[0]).ravel()
    p = np.column_stack((rho * np.cos(phi), rho * np.sin(phi)))
    t = np.gradient(p, phi, axis=0, edge_order=2)
    n = np.column_stack((t[:, 1], -t[:, 0])) / np.hypot(*t.T)[:, None]
    return p, n, np.sum(n * p, axis=1)


def test_support_distance_is_the_tangent_lines_distance_from_the_axis():
    from cadcam.physics.profile import support_distance
    basis, c = Basis("monomial", 2, (0.0, 3.0)), np.array([0.01, 0.004, -0.0006])
    phi = np.linspace(0.0, 3.0, 4001)
    _, _, distance = _tangent_geometry(basis, c, phi)
    rho, drho = (np.asarray(v).ravel() for v in profile_function(basis).map(phi.size)(phi, c)[:2])
    np.testing.assert_allclose(np.asarray(support_distance(rho, drho)).ravel()[5:-5], distance[5:-5], rtol=1e-6)


def test_inside_tangent_has_the_sign_of_the_ends_side_of_each_tangent():
    """A spiral of nearly a turn whose end overhangs its start: the end lies outside the
    tangents near the start and inside the others; the row's sign says which everywhere."""
    from cadcam.physics.profile import inside_tangent
    basis, c, end = Basis("monomial", 1, (0.0, 6.0)), np.array([0.01, 0.002]), 6.0
    phi = np.linspace(0.0, 5.9, 600)
    p, n, _ = _tangent_geometry(basis, c, phi)
    rho, drho = (np.asarray(v).ravel() for v in profile_function(basis).map(phi.size)(phi, c)[:2])
    rho_e = c[0] + c[1] * end
    side = np.sum(n * (rho_e * np.array([np.cos(end), np.sin(end)]) - p), axis=1)  # ≤ 0: inside
    row = np.asarray(inside_tangent(rho, drho, rho_e, phi - end)).ravel()
    assert (side > 1e-7).any() and (side < -1e-7).any()
    clear = np.abs(side) > 1e-7
    np.testing.assert_array_equal(row[clear] >= 0, side[clear] < 0)
