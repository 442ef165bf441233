import math

import casadi as ca
import numpy as np
import pytest

from cadcam.targets import ExpressionError, Target, parse_expression, read_table

THETA = ca.SX.sym("theta")


def value(expr, theta):
    return float(ca.Function("f", [THETA], [expr])(theta))


def test_expressions_become_casadi_expressions():
    e = parse_expression("0.08*theta**2 + sin(pi/6) - atan2(1, 1) + -2", {"theta": THETA})
    assert value(e, 1.5) == pytest.approx(0.08 * 2.25 + 0.5 - math.pi / 4 - 2)


@pytest.mark.parametrize("text", [
    "__import__('os')", "__import__('os').system('true')", "theta.real", "().__class__",
    "theta[0]", "open('x')", "lambda: 1", "'text'", "[1, 2]", "theta if theta else 1",
    "eval('1')", "sin(theta, 2)", "True", "unknown_name * 2", "theta; 1", "",
])
def test_anything_outside_the_whitelist_is_refused(text):
    with pytest.raises(ExpressionError):
        parse_expression(text, {"theta": THETA})


def test_pendulum_and_table_targets(tmp_path):
    pend = Target("pendulum", {"mass": 0.5, "length": 0.25, "g": 9.81, "phase": 0.0})
    assert float(pend.function(1, 0)(0.3)) == pytest.approx(0.5 * 9.81 * 0.25 * math.sin(0.3))
    f = tmp_path / "t.csv"
    th = np.linspace(0, 90, 31)
    f.write_text("theta_deg,torque_Nm\n" + "\n".join(f"{a},{0.08 * math.radians(a) ** 2}" for a in th))
    table = Target("table", {"samples": read_table(f)})
    # a cubic B-spline through samples of a quadratic reproduces it between the samples
    assert float(table.function(1, 0)(0.777)) == pytest.approx(0.08 * 0.777**2, rel=1e-6)
