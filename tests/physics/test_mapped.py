"""A map of a function over n points is built once and evaluates as CasADi's own map."""
import casadi as ca
import numpy as np
import pytest

from cadcam.physics.mapped import REPLAY_POINTS, Direct, Replay, direct, mapped, on_points, replayed


def test_a_map_is_built_once_per_function_and_count_and_evaluates_as_casadis():
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [ca.sin(x) * x])
    twin = ca.Function("f", [x], [ca.sin(x) * x])  # equal, but another function: another key
    assert mapped(f, 7) is mapped(f, 7)
    assert mapped(f, 7) is not mapped(f, 8) and mapped(twin, 7) is not mapped(f, 7)
    points = np.linspace(-1, 2, 7)
    np.testing.assert_array_equal(np.asarray(mapped(f, 7)(points)), np.asarray(f.map(7)(points)))


def test_a_replay_of_plain_arithmetic_gives_the_maps_values_to_the_bit():
    from cadcam.physics.profile import Basis, profile_function

    prof = profile_function(Basis("chebyshev", 5, (0.0, 6.0)))
    replay = replayed(prof)
    assert replay.exact and replayed(prof) is replay
    rng = np.random.default_rng(3)
    for n in (1, 7, 2000):
        c = np.r_[0.03, rng.normal(0.0, 0.004, 5)]
        phi = np.sort(rng.uniform(0.0, 6.0, n))
        for got, want in zip(replay(phi, c), mapped(prof, n)(phi, c)):
            assert got.shape == (1, n)
            np.testing.assert_array_equal(got, np.asarray(want))


def test_a_replay_broadcasts_outputs_that_do_not_vary_and_keeps_nan():
    x, c = ca.SX.sym("x"), ca.SX.sym("c", 2)
    f = ca.Function("f", [x, c], [x / c[0] - c[1], c[1] * 2, ca.SX(1, 1)])
    points = np.array([0.0, 1.0, np.nan, 3.0])
    got = replayed(f)(points, [0.0, 4.0])
    np.testing.assert_array_equal(got[0], [[np.nan, np.inf, np.nan, np.inf]])
    np.testing.assert_array_equal(got[1], [[8.0] * 4])
    np.testing.assert_array_equal(got[2], np.zeros((1, 4)))


def test_a_function_beyond_plain_arithmetic_is_evaluated_by_its_map():
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [ca.sin(x) * x, ca.vertcat(x, x * x)])
    mx = ca.MX.sym("x")
    g = ca.Function("g", [mx], [mx * 3])
    points = np.linspace(-1.0, 2.0, 9)
    assert not replayed(f).exact and not replayed(g).exact
    for got, want in zip(replayed(f)(points), mapped(f, 9)(points)):
        np.testing.assert_array_equal(got, np.asarray(want))
    np.testing.assert_array_equal(replayed(g)(points), np.asarray(mapped(g, 9)(points)))


def test_with_rounding_other_functions_are_replayed_to_the_maps_rounding():
    x, c = ca.SX.sym("x"), ca.SX.sym("c", 2)
    f = ca.Function("f", [x, c], [ca.atan2(ca.sin(x) * c[0], ca.cos(x) + c[1]), ca.sqrt(ca.fmax(x, c[1]))])
    assert not replayed(f).replays and replayed(f, rounding=True).replays
    assert not replayed(f, rounding=True).exact
    points = np.linspace(-3.0, 3.0, 2 * REPLAY_POINTS)
    for got, want in zip(replayed(f, rounding=True)(points, [1.5, 0.25]), mapped(f, points.size)(points, [1.5, 0.25])):
        np.testing.assert_array_max_ulp(got, np.asarray(want), maxulp=4)
    assert isinstance(on_points(f, REPLAY_POINTS), Replay) and on_points(f, REPLAY_POINTS - 1).f is mapped(f, REPLAY_POINTS - 1)


def test_a_replay_takes_an_empty_input():
    x, none = ca.SX.sym("x"), ca.SX.sym("none", 0)
    f = ca.Function("f", [x, none], [x * 2, ca.sin(x)])
    points = np.linspace(0.0, 1.0, 5)
    for got, want in zip(replayed(f, rounding=True)(points, np.zeros(0)), mapped(f, 5)(points, np.zeros(0))):
        np.testing.assert_array_max_ulp(got, np.asarray(want), maxulp=4)


def test_a_direct_call_gives_the_calls_values_for_each_form_the_call_takes():
    x, c = ca.SX.sym("x"), ca.SX.sym("c", 3)
    f = ca.Function("f", [x, c], [ca.sin(x) * c[0] + c[1], ca.vertcat(x, c[2] * x), ca.SX(2, 1)])
    m = mapped(f, 5)
    points = np.linspace(-1.0, 2.0, 5)
    coefficients = np.array([[1.5], [-0.25], [3.0]])
    for args in [(points, [1.5, -0.25, 3.0]), (points[None, :], coefficients),
                 (points[:, None], np.tile(coefficients, (1, 5)))]:
        got, want = direct(m)(*args), m(*args)
        assert len(got) == len(want)
        for g, w in zip(got, want):
            assert g.shape == np.asarray(w).shape
            np.testing.assert_array_equal(g, np.asarray(w))
    assert isinstance(on_points(f, 5), Direct) and on_points(f, 5).f is m
    np.testing.assert_array_equal(direct(f)(0.5, coefficients)[1], np.asarray(f(0.5, coefficients)[1]))


def test_a_direct_call_of_an_argument_it_cannot_take_as_is_is_the_call():
    x = ca.SX.sym("x", 2, 2)
    f = ca.Function("f", [x], [ca.trace(x)])
    np.testing.assert_array_equal(direct(f)(np.eye(2)), [[2.0]])
    np.testing.assert_array_equal(direct(f)([[1.0, 2.0], [3.0, 4.0]]), [[5.0]])
    with pytest.raises(RuntimeError):  # a 3 × 3 for a 2 × 2: the call's own error
        direct(f)(np.eye(3))
