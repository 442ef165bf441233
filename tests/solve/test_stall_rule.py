"""The stall rule (:mod:`cadcam.solve.stall`): it stops an IPOPT run that is still as far from
feasible as it says at its iteration, leaves one that is closer by then to converge as it
would without it, keeps the builds made under it apart, and a spring it stops is undecided."""
from types import SimpleNamespace

import casadi as ca
import pytest

from cadcam.optimize import verdict as design_verdict
from cadcam.problem import Options
from cadcam.solve.builds import structure_key
from cadcam.solve.ipopt import IPOPT_STATUS, Solve, _ipopt_solver, iteration_history
from cadcam.solve.stall import STALL_RULE, STALL_STATUS, StallRule, stall_rule
from cadcam.sweep.springs import SEARCH_STALL, verdict

from ..conftest import SPEC_1DOF

#: Rosenbrock's function inside a circle, from a start far outside it: IPOPT's primal
#: infeasibility falls below 1 within a few iterations and it converges in some 20.
X = ca.MX.sym("x", 2)
NLP = {"x": X, "p": ca.MX.sym("p", 0), "f": (1 - X[0]) ** 2 + 100 * (X[1] - X[0] ** 2) ** 2,
       "g": X[0] ** 2 + X[1] ** 2}
BOUND = 1.0


def run(stall: StallRule | None):
    """The toy NLP solved from its start under ``stall``: x, IPOPT's status and its iterates."""
    solver, _ = _ipopt_solver(NLP, Options(functions="expanded"), stall=stall)
    x = solver(x0=[-2.0, 3.0], lbg=-ca.inf, ubg=BOUND)["x"]
    stats = solver.stats()
    return x.full().ravel(), stats["return_status"], iteration_history(stats)


@pytest.fixture(scope="module")
def free():
    """The toy NLP solved without a rule."""
    return run(None)


def test_the_toy_converges_after_iterates_both_above_and_below_the_threshold(free):
    _, status, history = free
    assert status == "Solve_Succeeded"
    assert max(history["inf_pr"][1:]) >= 1.0 > history["inf_pr"][-1]


def test_a_run_still_infeasible_at_the_rules_iteration_is_stopped_there(free):
    k = next(k for k, v in enumerate(free[2]["inf_pr"]) if k > 0 and v >= 1.0)
    _, status, history = run(StallRule(iteration=k, window=0, inf_pr=1.0))
    assert IPOPT_STATUS[status] == STALL_STATUS
    assert history["iteration"][-1] == k
    assert history["inf_pr"] == free[2]["inf_pr"][:k + 1]


def test_a_run_feasible_enough_at_the_rules_iteration_converges_as_without_it(free):
    k = next(k for k, v in enumerate(free[2]["inf_pr"]) if v < 1.0)
    x, status, history = run(StallRule(iteration=k, window=0, inf_pr=1.0))
    assert status == "Solve_Succeeded"
    assert history["inf_pr"] == free[2]["inf_pr"]
    assert list(x) == list(free[0])


def test_a_run_that_ends_before_the_rules_iteration_is_not_stopped(free):
    x, status, history = run(StallRule(iteration=len(free[2]["inf_pr"]) + 5, window=0, inf_pr=0.0))
    assert status == "Solve_Succeeded" and list(x) == list(free[0])


@pytest.mark.parametrize("inf_pr, iteration, window, stops", [
    ([5.0] * 3, 2, 0, True), ([5.0] * 3, 1, 0, False), ([5.0, 5.0, 0.5], 2, 0, False), ([5.0, 5.0, 1.0], 2, 0, True),
    ([5.0, 0.5, 5.0, 5.0], 3, 1, True), ([5.0, 0.5, 5.0, 5.0], 3, 2, False), ([0.5, 5.0, 5.0, 5.0], 3, 2, True)])
def test_the_rule_judges_the_window_up_to_its_iteration_alone(inf_pr, iteration, window, stops):
    assert StallRule(iteration=iteration, window=window, inf_pr=1.0).stops(inf_pr) is stops


def test_builds_under_a_rule_are_kept_apart_from_others():
    from cadcam import load_spec

    problem = load_spec(SPEC_1DOF)
    plain = structure_key(problem)
    with stall_rule(SEARCH_STALL):
        assert STALL_RULE.get() == SEARCH_STALL
        ruled = structure_key(problem)
    assert STALL_RULE.get() is None and ruled != plain == structure_key(problem)


def test_a_stopped_design_says_so_and_its_spring_is_undecided():
    stopped = Solve(design=None, status=STALL_STATUS, return_status="User_Requested_Stop", iterations=40,
                    solve_time_s=0.1, objective=1.0, z=[],
                    history={**iteration_history({}), "inf_pr": [30.0, 4.25]})
    status, message = design_verdict(None, stopped, SimpleNamespace(metrics=None), "converged")
    assert status == STALL_STATUS and "stall rule" in message and "4.25" in message
    word, reason = verdict({"status": STALL_STATUS, "message": message, "inf_pr": 4.25})
    assert word == "undecided" and "stall rule" in reason and "4.25" in reason
    assert SEARCH_STALL.words() in reason
