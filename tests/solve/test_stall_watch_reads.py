"""The stall rule's watch (:mod:`cadcam.solve.stall`) reads a run's iterates from the solver only
from the rule's iteration on, once told the run starts (:func:`run_starts`), and stops a run of
a solver used before where a fresh solver stops it, told or not."""
import casadi as ca
import pytest

from cadcam.problem import Options
from cadcam.solve.ipopt import IPOPT_STATUS, _ipopt_solver, iteration_history
from cadcam.solve.stall import STALL_STATUS, StallRule, run_starts

#: Rosenbrock's function inside a circle from a start far outside it (as test_stall_rule's):
#: its primal infeasibility is at least 1 at some early iterations, and it converges in some 20.
X = ca.MX.sym("x", 2)
NLP = {"x": X, "p": ca.MX.sym("p", 0), "f": (1 - X[0]) ** 2 + 100 * (X[1] - X[0] ** 2) ** 2,
       "g": X[0] ** 2 + X[1] ** 2}
START = [-2.0, 3.0]


class Counting:
    """A solver's stand-in for its watch: its stats, counting the reads."""

    def __init__(self, solver):
        self.solver, self.reads = solver, 0

    def stats(self):
        self.reads += 1
        return self.solver.stats()


def solved(solver, told: bool = True):
    """A run of the toy NLP on ``solver`` (its watch told it starts where ``told``): IPOPT's
    status and its iterates."""
    if told:
        run_starts(solver)
    solver(x0=START, lbg=-ca.inf, ubg=1.0)
    stats = solver.stats()
    return stats["return_status"], iteration_history(stats)


@pytest.fixture(scope="module")
def free():
    """The toy's iterates without a rule."""
    solver, _ = _ipopt_solver(NLP, Options(functions="expanded"))
    return solved(solver)[1]


def rule_stopping(free) -> StallRule:
    """A rule that stops the toy's run at its first iteration past the start with inf_pr ≥ 1."""
    k = next(k for k, v in enumerate(free["inf_pr"]) if k > 0 and v >= 1.0)
    return StallRule(iteration=k, window=0, inf_pr=1.0)


def test_a_run_is_read_from_the_rules_iteration_on_and_stopped_there(free):
    rule = rule_stopping(free)
    solver, _ = _ipopt_solver(NLP, Options(functions="expanded"), stall=rule)
    counting = solver.stall_watch.solver = Counting(solver)
    status, history = solved(solver)
    assert IPOPT_STATUS[status] == STALL_STATUS and history["iteration"][-1] == rule.iteration
    assert counting.reads == 1  # the rule's iteration alone, where read at every one it were k + 1


def test_a_run_that_converges_is_read_only_past_the_rules_iteration(free):
    rule = StallRule(iteration=5, window=0, inf_pr=1e9)
    solver, _ = _ipopt_solver(NLP, Options(functions="expanded"), stall=rule)
    counting = solver.stall_watch.solver = Counting(solver)
    status, history = solved(solver)
    assert status == "Solve_Succeeded" and history["inf_pr"] == free["inf_pr"]
    assert counting.reads == len(free["inf_pr"]) - rule.iteration


@pytest.mark.parametrize("told", [True, False])
def test_a_second_run_of_one_solver_stops_where_a_fresh_solver_does(free, told):
    rule = rule_stopping(free)
    solver, _ = _ipopt_solver(NLP, Options(functions="expanded"), stall=rule)
    first = solved(solver)
    second = solved(solver, told)
    assert IPOPT_STATUS[second[0]] == STALL_STATUS
    assert second[1]["inf_pr"] == first[1]["inf_pr"] == free["inf_pr"][:rule.iteration + 1]
