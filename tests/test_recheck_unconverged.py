"""A design whose solve did not converge is re-checked on the fine grid unless
:data:`cadcam.optimize.RECHECK_UNCONVERGED` says otherwise (a catalogue search's solves): then
its status is its solver's as before, its result holds its design-grid evaluation and its
message says it was not re-checked; a converged design is re-checked either way."""
import pytest

from cadcam.optimize import RECHECK_UNCONVERGED, UNCHECKED, optimize


def optimized(problem, max_iter: int, recheck_unconverged: bool):
    """``problem`` designed from its default start within ``max_iter`` IPOPT iterations, its
    unconverged designs re-checked as ``recheck_unconverged`` says."""
    token = RECHECK_UNCONVERGED.set(recheck_unconverged)
    try:
        return optimize(problem.with_options(max_iter=max_iter))
    finally:
        RECHECK_UNCONVERGED.reset(token)


@pytest.fixture(scope="module")
def cut_short(problem_1dof):
    """The 1-DOF design stopped after 3 iterations, re-checked and not."""
    return optimized(problem_1dof, 3, True), optimized(problem_1dof, 3, False)


def test_an_unconverged_design_keeps_its_status_without_the_fine_recheck(cut_short, problem_1dof):
    checked, unchecked = cut_short
    assert checked.status == unchecked.status == "max_iterations"
    fine = problem_1dof.options.recheck_grid
    assert checked.recheck.grid == fine and checked.recheck_time_s > 0
    assert unchecked.recheck is unchecked.evaluation and unchecked.recheck.grid == problem_1dof.options.grid
    assert unchecked.recheck_time_s == 0.0 and unchecked.message.endswith(f"({UNCHECKED})")
    assert UNCHECKED not in checked.message
    assert list(unchecked.design.coefficients[0]) == list(checked.design.coefficients[0])


def test_a_converged_design_is_rechecked_on_the_fine_grid_all_the_same(problem_1dof):
    result = optimized(problem_1dof, problem_1dof.options.max_iter, False)
    assert result.solve.status == "converged"
    assert result.recheck.grid == problem_1dof.options.recheck_grid and result.recheck_time_s > 0
    assert UNCHECKED not in result.message
