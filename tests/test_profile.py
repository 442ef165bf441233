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
