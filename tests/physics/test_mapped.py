"""A map of a function over n points is built once and evaluates as CasADi's own map."""
import casadi as ca
import numpy as np

from cadcam.physics.mapped import mapped


def test_a_map_is_built_once_per_function_and_count_and_evaluates_as_casadis():
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [ca.sin(x) * x])
    twin = ca.Function("f", [x], [ca.sin(x) * x])  # equal, but another function: another key
    assert mapped(f, 7) is mapped(f, 7)
    assert mapped(f, 7) is not mapped(f, 8) and mapped(twin, 7) is not mapped(f, 7)
    points = np.linspace(-1, 2, 7)
    np.testing.assert_array_equal(np.asarray(mapped(f, 7)(points)), np.asarray(f.map(7)(points)))
