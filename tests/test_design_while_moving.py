"""What a design page saves while a slider moves: a provisional design without the fine re-check
(:meth:`cadcam.Session.design` with ``recheck=False``), re-checked when the slider stops, and the
target's check not made again for a target that passed it."""
import numpy as np
import pytest

import cadcam
from cadcam import spec as spec_module
from cadcam.optimize import PROVISIONAL
from cadcam.solve.ipopt import MOVING_TOL_FACTOR, RESOLVE_IPOPT, RESOLVE_OPTIONS, SESSION_IPOPT, moving_options
from cadcam.solve.predictor import PREDICTED_IPOPT
from cadcam.solve.transcription import Transcription

from .conftest import SPEC_1DOF


@pytest.fixture(scope="module")
def session():
    """A design session of the 1-DOF spec on a coarse grid, its first design made."""
    session = cadcam.Session()
    assert session.design(SPEC_1DOF, grid=12).success
    return session


def test_a_provisional_design_is_judged_on_the_design_grid_then_rechecked_in_full(session):
    edit = {"springs.1.rate": 1.02 * cadcam.load_spec(SPEC_1DOF).springs[0].rate}
    moving = session.design(SPEC_1DOF, grid=12, overrides=edit, recheck=False)
    assert moving.provisional and moving.recheck is moving.evaluation and moving.recheck_time_s == 0.0
    assert moving.success and f"met on the design grid ({PROVISIONAL})" in moving.message
    let_go = session.design(SPEC_1DOF, grid=12, overrides=edit)
    assert not let_go.provisional and let_go.success and "met on the fine re-check grid" in let_go.message
    assert let_go.recheck.grid > let_go.evaluation.grid and let_go.recheck_time_s > 0
    assert let_go.message.endswith("(warm start from the last design)")
    np.testing.assert_allclose(let_go.x, moving.x, rtol=1e-6)  # the same design, now re-checked


def test_a_sessions_warm_solve_starts_pushed_little_off_its_last_answer(session, monkeypatch):
    """Within a session's design its warm re-solves take :data:`SESSION_IPOPT`, within its
    provisional design :func:`moving_options` (its barrier capped low, its tolerance the
    spec's loosened), from the predicted start
    with its iterations capped (:data:`PREDICTED_IPOPT`); elsewhere (a sweep, a catalogue
    search) :data:`RESOLVE_IPOPT` stands."""
    used = []
    warm_solver = Transcription._warm_solver

    def recorded(self, extra=None):
        used.append({**RESOLVE_OPTIONS.get(), **(extra or {})})
        return warm_solver(self, extra)

    monkeypatch.setattr(Transcription, "_warm_solver", recorded)
    edit = {"springs.1.rate": 1.01 * cadcam.load_spec(SPEC_1DOF).springs[0].rate}
    assert session.design(SPEC_1DOF, grid=12, overrides=edit, recheck=False).message.endswith(
        "(warm start from the last design)")
    assert session.design(SPEC_1DOF, grid=12, overrides=edit).message.endswith("(warm start from the last design)")
    tol = cadcam.load_spec(SPEC_1DOF).options.tol
    assert used == [{**moving_options(tol), **PREDICTED_IPOPT}, SESSION_IPOPT] and RESOLVE_OPTIONS.get() is RESOLVE_IPOPT
    assert used[0]["ipopt.tol"] == MOVING_TOL_FACTOR * tol > tol


def test_a_target_that_passed_its_check_is_not_checked_again(monkeypatch):
    """The memory starts empty here: another test on this worker may have checked these targets."""
    monkeypatch.setattr(spec_module, "_passed_targets", type(spec_module._passed_targets)())
    cadcam.load_problem(SPEC_1DOF)  # its target passed: remembered

    def refuse(*args):
        raise AssertionError("checked again")

    monkeypatch.setattr(spec_module, "_checked_target", refuse)
    cadcam.load_problem(SPEC_1DOF, overrides=[("springs.1.rate", 1234.0)])  # the same target
    with pytest.raises(AssertionError, match="checked again"):  # another target is checked
        cadcam.load_problem(SPEC_1DOF, overrides=[("cams.1.target.expression", "0.07*theta**2")])
    with pytest.raises(AssertionError, match="checked again"):  # the same target over another range
        cadcam.load_problem(SPEC_1DOF, overrides=[("cams.1.theta_range_deg", [0.0, 80.0])])
