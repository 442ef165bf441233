"""Friction's physics (cadcam.physics.friction): the capstan and the idler's bearing against
their laws solved independently, the band's edges against the closed forms, and the band's
centre as the spring network weighs the arms."""
import math

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq

from cadcam.physics.friction import (Friction, Guide, Idler, JointBearing, band_edges, capstan_log_ratio,
                                     idler_log_ratio)
from cadcam.physics.springs import Network, Port, Spring

RNG = np.random.default_rng(52)


def test_a_guide_alone_splits_a_positive_term_by_e_to_the_2_mu_beta():
    mu, wrap = 0.16, math.radians(135.0)
    terms = RNG.uniform(0.1, 2.0, size=(1, 50))
    plus, minus = band_edges(terms, [capstan_log_ratio(mu, wrap)])
    np.testing.assert_allclose(plus / minus, math.exp(2 * mu * wrap), rtol=1e-14)
    np.testing.assert_allclose(plus, terms[0] * math.exp(mu * wrap), rtol=1e-14)


def test_where_the_turn_lets_the_spring_shorten_the_profile_side_is_the_slack_one():
    """A negative term (the spring shortens as the joint turns towards +θ): turning towards +θ
    the spring's side is the taut one, so τ⁺ = t e^{−μβ}, still the upper edge."""
    L = capstan_log_ratio(0.2, math.pi)
    plus, minus = band_edges(np.array([[-1.0]]), [L])
    assert plus[0] == pytest.approx(-math.exp(-L)) and minus[0] == pytest.approx(-math.exp(L))
    assert plus[0] > minus[0]


def test_the_idlers_ratio_balances_its_bearing_on_the_resultant():
    """T_h − T_l = c (T_h + T_l) sin(β/2), solved for T_h by a root finder at T_l = 1."""
    for c, wrap in ((0.058, math.pi), (0.2, math.radians(70.0)), (0.0, 1.0)):
        high = brentq(lambda t: t - 1 - c * (t + 1) * math.sin(wrap / 2), 1.0, 10.0, xtol=1e-15)
        assert idler_log_ratio(c, wrap) == pytest.approx(math.log(high), rel=1e-12, abs=1e-15)
    # the rigging measurement the key's words cite: 89 % of the tension through 180°
    assert math.exp(-idler_log_ratio((1 - 0.89) / 1.89, math.pi)) == pytest.approx(0.89)


def test_without_friction_the_band_is_the_sum_of_its_terms_and_a_bearing_shifts_it():
    terms = RNG.normal(size=(3, 40))
    plus, minus = band_edges(terms, np.zeros(3))
    np.testing.assert_array_equal(plus, terms.sum(axis=0))
    np.testing.assert_array_equal(minus, terms.sum(axis=0))
    plus, minus = band_edges(terms, np.zeros(3), 0.007)
    np.testing.assert_allclose(plus - terms.sum(axis=0), 0.007, rtol=1e-12)
    np.testing.assert_allclose(terms.sum(axis=0) - minus, 0.007, rtol=1e-12)


def test_edges_are_vectorised_over_builds():
    """One μ per build (the Monte Carlo's draws) broadcast against the paths' terms."""
    terms = RNG.uniform(0.5, 1.0, size=(1, 1, 30))  # one path, one build axis, 30 angles
    mu = np.array([0.0, 0.1, 0.3]).reshape(1, 3, 1)
    plus, minus = band_edges(np.broadcast_to(terms, (1, 3, 30)), capstan_log_ratio(mu, math.pi))
    assert plus.shape == (3, 30)
    np.testing.assert_allclose(plus / minus, np.exp(2 * mu[0] * math.pi) * np.ones((3, 30)), rtol=1e-14)


def test_a_joint_bearing_adds_its_torque_and_its_share_of_the_load():
    bearing = JointBearing(0, torque=0.01, coefficient=0.3, radius=0.003)
    assert bearing.friction_torque(20.0) == pytest.approx(0.01 + 0.3 * 0.003 * 20.0)


def _network(scales=None):
    """Two springs: spring 1 on port a (joint 1) and port b (joint 2), spring 2 on port b."""
    springs = [Spring("s1", 1000.0, 0.1, (Port(0, "a"), Port(1, "b", -1.0))), Spring("s2", 500.0, 0.1, (Port(1, "b"),))]
    return Network(springs, [0, 1], {(0, "a"): 0, (1, "b"): 1}, 2, scales)


def test_the_band_centre_weights_each_paths_arm_not_the_extensions():
    d, arm = ca.DM([0.01, 0.02]), ca.DM([0.03, -0.04])
    k, x0, F0 = ca.DM([1000.0, 500.0]), ca.DM([0.005, 0.002]), ca.DM([2.0, 1.0])
    x, tau, _ = _network().function()(d, arm, k, x0, F0)
    xs, taus, _ = _network({(0, 1, "b"): 1.5}).function()(d, arm, k, x0, F0)
    np.testing.assert_array_equal(np.asarray(xs), np.asarray(x))
    T = np.asarray(k * x + F0).ravel()
    assert float(taus[0]) == pytest.approx(float(tau[0]))  # spring 1's path on joint 1 is not weighted
    # joint 2: spring 1's path through b weighted 1.5 (sign −1), spring 2's not
    assert float(taus[1]) == pytest.approx(-1.5 * T[0] * -0.04 + T[1] * -0.04)


def test_only_a_tracked_centre_weights_the_arms():
    port = Port(0, "cable")
    friction = Friction(guides=(Guide(0, port, 0.16, math.pi), Guide(0, port, 0.1, 1.0)),
                        idlers=(Idler(0, port, 0.058, math.pi),))
    L = 0.16 * math.pi + 0.1 + idler_log_ratio(0.058, math.pi)
    assert friction.path_log_ratios() == {(0, 0, "cable"): pytest.approx(L)}
    assert friction.arm_scales() == {}
    centred = Friction(friction.guides, friction.idlers, centre=True)
    assert centred.arm_scales() == {(0, 0, "cable"): pytest.approx(math.cosh(L))}
    assert friction.scaled(0.0).path_log_ratios() == {(0, 0, "cable"): 0.0}


def test_a_parts_log_ratio_takes_a_build_s_factor_on_its_coefficient():
    """A build's coefficients, one factor per build: the guide's μβ and the idler's ratio with
    its coefficient times each factor; one number stays a float."""
    port = Port(0, "cable")
    guide, idler = Guide(0, port, 0.16, math.pi / 6), Idler(0, port, 0.058, math.pi)
    factors = np.array([0.7, 1.0, 1.3])
    np.testing.assert_allclose(guide.log_ratio(factors), 0.16 * factors * math.pi / 6, rtol=1e-15)
    np.testing.assert_allclose(idler.log_ratio(factors), [idler_log_ratio(0.058 * f, math.pi) for f in factors],
                               rtol=1e-15)
    assert isinstance(guide.log_ratio(), float) and guide.log_ratio() == pytest.approx(0.16 * math.pi / 6)
