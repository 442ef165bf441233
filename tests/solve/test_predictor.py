"""The predicted warm start of a provisional re-solve (:mod:`cadcam.solve.predictor`): exact on
a problem whose KKT conditions are linear, and on a design session's slider step the same
optimum as the plain warm start in fewer iterations."""
import casadi as ca
import numpy as np
import pytest

import cadcam
from cadcam.solve import transcription
from cadcam.solve.ipopt import Multipliers, moving_options
from cadcam.solve.predictor import NEARLY_CONVERGED, nearly_converged, predicted

from ..conftest import SPEC_1DOF


@pytest.fixture(scope="module")
def quadratic():
    """min x₁² + x₂² + (x₃ − 1)² subject to x₁ + x₂ − p ≥ 0 (active), x₁ − x₂ ≤ 10 (not), x₃
    fixed at 0: an IPOPT solver and its answer at p = 1."""
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p")
    nlp = {"x": x, "p": p, "f": x[0] ** 2 + x[1] ** 2 + (x[2] - 1) ** 2, "g": ca.vertcat(x[0] + x[1] - p, x[0] - x[1])}
    solver = ca.nlpsol("quadratic", "ipopt", nlp, {"print_time": False, "ipopt.print_level": 0, "ipopt.tol": 1e-12})
    bounds = (np.array([0.0, -np.inf]), np.array([np.inf, 10.0]))
    variable_bounds = (np.array([-np.inf, -np.inf, 0.0]), np.array([np.inf, np.inf, 0.0]))
    sol = solver(x0=[3.0, 1.0, 0.0], p=1.0, lbg=bounds[0], ubg=bounds[1], lbx=variable_bounds[0],
                 ubx=variable_bounds[1])
    warm = Multipliers(np.asarray(sol["lam_x"]).ravel(), np.asarray(sol["lam_g"]).ravel(), False,
                       np.asarray(sol["x"]).ravel())
    return solver, warm, bounds, variable_bounds


def test_the_prediction_of_a_quadratic_is_its_new_optimum(quadratic):
    """Linear KKT conditions on an unchanged active set: one step lands on the optimum at p = 1.3,
    x = (0.65, 0.65, 0) with the active row's multiplier −1.3; the fixed variable stays put."""
    solver, warm, bounds, variable_bounds = quadratic
    np.testing.assert_allclose(warm.x, [0.5, 0.5, 0.0], atol=1e-8)
    guess = predicted(solver, warm, np.array([1.3]), bounds, variable_bounds)
    np.testing.assert_allclose(guess.x, [0.65, 0.65, 0.0], atol=1e-7)
    np.testing.assert_allclose(guess.lam_g[0], -1.3, rtol=1e-6)
    assert abs(guess.lam_g[1]) < 1e-6  # the inactive row's multiplier stays (near) zero


def test_a_singular_linearization_leaves_the_start_at_the_last_answer(quadratic):
    """Without the fixed variable's bounds and with a Hessian of zero there is no step: the row
    alone cannot fix two free variables, and the last answer is the start."""
    _, warm, bounds, _ = quadratic
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p")
    flat = ca.nlpsol("flat", "ipopt", {"x": x, "p": p, "f": 0 * x[0], "g": ca.vertcat(x[0] + x[1] - p, x[0] - x[1])},
                     {"print_time": False, "ipopt.print_level": 0})
    free = (np.full(3, -np.inf), np.full(3, np.inf))
    assert predicted(flat, warm, np.array([1.3]), bounds, free) is warm


def test_slider_steps_reach_the_plain_warm_starts_optimum_in_fewer_iterations(monkeypatch):
    """The 1-DOF wire cam, spring 1's rate stepped 2 % four times while a slider moves: each
    provisional design from the predicted start ends at the optimum the plain warm start
    reaches (within the tolerance both provisional solves stop at, :func:`moving_options`),
    and the steps after the first, each from the last provisional answer, in fewer
    iterations."""
    spec = cadcam.load_spec(SPEC_1DOF)
    rate, tol = spec.springs[0].rate, moving_options(spec.options.tol)["ipopt.tol"]

    def steps():
        session = cadcam.Session()
        assert session.design(SPEC_1DOF).success
        out = [session.design(SPEC_1DOF, overrides={"springs.1.rate": rate * 1.02 ** k}, recheck=False)
               for k in (1, 2, 3, 4)]
        assert all(r.success for r in out)
        return [r.fun for r in out], sum(r.nit for r in out[1:])

    objectives, iterations = steps()
    monkeypatch.setattr(transcription, "predicted", lambda solver, warm, *args: warm)
    plain_objectives, plain_iterations = steps()
    np.testing.assert_allclose(objectives, plain_objectives, rtol=tol)
    assert iterations < plain_iterations


def test_a_row_the_step_would_break_joins_the_active_set():
    """min (x₁ − p)² + (x₂ − 2)² subject to x₁ ≤ 1.1, free at p = 1, and x₂ ≤ 1, binding: at
    p = 1.3 the step on the binding row alone would break the first, so it binds too,
    x = (1.1, 1) with the multipliers (0.4, 2)."""
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p")
    solver = ca.nlpsol("capped", "ipopt", {"x": x, "p": p, "f": (x[0] - p) ** 2 + (x[1] - 2) ** 2, "g": x},
                       {"print_time": False, "ipopt.print_level": 0, "ipopt.tol": 1e-12})
    bounds, free = (np.full(2, -np.inf), np.array([1.1, 1.0])), (np.full(2, -np.inf), np.full(2, np.inf))
    sol = solver(x0=[0.0, 0.0], p=1.0, lbg=bounds[0], ubg=bounds[1])
    warm = Multipliers(np.asarray(sol["lam_x"]).ravel(), np.asarray(sol["lam_g"]).ravel(), False,
                       np.asarray(sol["x"]).ravel())
    assert abs(warm.lam_g[0]) < 1e-6 and warm.lam_g[1] > 1  # the first row free, the second binding
    guess = predicted(solver, warm, np.array([1.3]), bounds, free)
    np.testing.assert_allclose(guess.x, [1.1, 1.0], atol=1e-7)
    np.testing.assert_allclose(guess.lam_g, [0.4, 2.0], rtol=1e-6)


@pytest.mark.parametrize("inf_pr, inf_du, near", [(1e-12, 0.1 * NEARLY_CONVERGED, True),
                                                  (1e-12, 10 * NEARLY_CONVERGED, False),
                                                  (10 * NEARLY_CONVERGED, 1e-12, False)])
def test_a_run_cut_short_goes_on_only_near_its_end(inf_pr, inf_du, near):
    """Judged on its last iterate's primal and dual infeasibility, both within the limit."""
    stats = {"iterations": {"inf_pr": [1.0, inf_pr], "inf_du": [1.0, inf_du]}}
    assert nearly_converged(stats) is near
    assert not nearly_converged({})  # a run without iterations


def test_a_design_imports_no_sparse_linear_algebra_for_the_predictor():
    """Every design imports the predictor (the transcription's solve asks it); SciPy's sparse
    modules, a noticeable share of a command's start, are imported only where it predicts."""
    import subprocess
    import sys

    code = ("import sys; import cadcam.api, cadcam.cli, cadcam.solve.predictor; "
            "print(sorted(m for m in sys.modules if m.startswith('scipy.sparse')))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout.strip() == "[]"
