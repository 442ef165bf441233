"""How a catalogue search's solves are judged (:func:`cadcam.sweep.springs.search_solves`'s
switches of :mod:`cadcam.optimize`): a design whose solve did not converge is re-checked on the
fine grid unless :data:`RECHECK_UNCONVERGED` says otherwise, and then keeps its solver's status,
its result holding its design-grid evaluation and its message saying it was not re-checked; a
converged design is re-checked either way; without :data:`SCAN_DESIGN_GRID` its design-grid
evaluation does not scan its profiles, and its verdict, rmse and re-check are the same."""
import math

import pytest

from cadcam.optimize import RECHECK_UNCONVERGED, SCAN_DESIGN_GRID, UNCHECKED, optimize

#: The design grid of these designs (the spec's own is 46): quick, and as good a test.
GRID = 12


def optimized(problem, max_iter: int | None = None, recheck_unconverged: bool = True, scan: bool = True):
    """``problem`` designed from its default start on :data:`GRID` angles (within ``max_iter``
    IPOPT iterations if given) with the two switches set as given."""
    problem = problem.with_options(grid=GRID, **({} if max_iter is None else {"max_iter": max_iter}))
    tokens = RECHECK_UNCONVERGED.set(recheck_unconverged), SCAN_DESIGN_GRID.set(scan)
    try:
        return optimize(problem)
    finally:
        SCAN_DESIGN_GRID.reset(tokens[1])
        RECHECK_UNCONVERGED.reset(tokens[0])


@pytest.fixture(scope="module")
def cut_short(problem_1dof):
    """The 1-DOF design stopped after 3 iterations, re-checked and not."""
    return optimized(problem_1dof, 3), optimized(problem_1dof, 3, recheck_unconverged=False)


@pytest.fixture(scope="module")
def converged(problem_1dof):
    """The 1-DOF design as ``cadcam design`` judges it and as a search does."""
    return optimized(problem_1dof), optimized(problem_1dof, recheck_unconverged=False, scan=False)


def test_an_unconverged_design_keeps_its_status_without_the_fine_recheck(cut_short):
    checked, unchecked = cut_short
    assert checked.status == unchecked.status == "max_iterations"
    fine = checked.problem.options.recheck_grid
    assert checked.recheck.grid == fine and checked.recheck_time_s > 0
    assert unchecked.recheck is unchecked.evaluation and unchecked.recheck.grid == GRID
    assert unchecked.recheck_time_s == 0.0 and unchecked.message.endswith(f"({UNCHECKED})")
    assert UNCHECKED not in checked.message
    assert list(unchecked.design.coefficients[0]) == list(checked.design.coefficients[0])


def test_a_converged_design_is_rechecked_and_judged_alike_without_the_design_grids_scan(converged):
    plain, searched = converged
    assert plain.status == searched.status == "success" and searched.message == plain.message
    assert searched.recheck.grid == plain.problem.options.recheck_grid and searched.recheck_time_s > 0
    assert searched.recheck.metrics.rho_min == plain.recheck.metrics.rho_min
    assert searched.recheck.metrics.convexity_min == plain.recheck.metrics.convexity_min
    assert searched.evaluation.metrics.rmse == plain.evaluation.metrics.rmse
    assert math.isnan(searched.evaluation.metrics.rho_min[0]) and not math.isnan(plain.evaluation.metrics.rho_min[0])
