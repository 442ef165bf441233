"""Fedorov2018's balancer re-designed by a design session after an edit of its law (the
pendulum's mass, both its keys): the edit moves the pair's cable length, so the last answer
does not start it; provisional (while a slider moves), the envelope pulleys of the edited law
judged on the design grid; in full, the NLP from them, which converges (from the start as a
first design takes it, it can end at the iteration limit)."""
import numpy as np
import pytest

import cadcam
import cadcam.api
from cadcam.optimize import start_design

BALANCER = "models/fedorov2018_balancer.toml"
MASS_KEYS = ("joints.1.target.mass", "mechanisms.1.output_target.mass")
MASS = 0.17 * 1.01  # the spec's 0.17 kg, 1 % heavier
GRAVITY = 9.81  # [m/s²]
LENGTH = 0.10  # the pendulum's length [m], the spec's


@pytest.fixture(scope="module")
def edits():
    """The session's first design of the spec, then its provisional and full designs after the
    mass edit, in the order the design page asks for them."""
    session = cadcam.Session()
    first = session.design(BALANCER)
    overrides = {key: MASS for key in MASS_KEYS}
    return first, session.design(BALANCER, overrides=overrides, recheck=False), \
        session.design(BALANCER, overrides=overrides)


@pytest.mark.slow  # two balancer designs: minutes on two cores
def test_a_provisional_law_edit_is_the_envelope_of_the_edited_law(edits):
    first, moving, _ = edits
    completed, start = start_design(cadcam.load_problem(BALANCER, overrides={k: MASS for k in MASS_KEYS}))
    assert first.success and moving.success and moving.provisional
    assert moving.nit == 0 and moving.solve.multipliers is None  # no NLP solved
    assert moving.build_time_s == 0.0  # through the NLP the session kept: nothing built
    assert moving.problem.mechanisms[0].cable_length == completed.mechanisms[0].cable_length \
        != first.problem.mechanisms[0].cable_length
    for got, want in zip(moving.design.coefficients, start.coefficients):
        np.testing.assert_array_equal(got, want)
    assert "the default start" in moving.message


@pytest.mark.slow  # two balancer designs: minutes on two cores
def test_a_full_law_edit_converges_from_the_envelope_and_meets_fedorovs_goals(edits):
    _, moving, full = edits
    assert full.success and full.solve.status == "converged" and full.nit > 0  # the NLP's optimum, not the start
    assert "its epigraphs above its errors" in full.message
    fine = full.recheck.metrics
    assert fine["output_max_abs_error"][0] < 1e-5  # x(θ) within 0.01 mm, as the first design
    assert fine["max_abs_error"][0] < 0.01 * MASS * GRAVITY * LENGTH  # the torque within 1 % of m g l_p
    assert full.fun < moving.fun  # polished below the envelope's error


#: The iterations the first NLP of test_a_failed_first_design_of_the_edited_law_is_solved_again is
#: stopped at: far from its optimum, so that it ends at the limit.
FIRST_CAP = 5


@pytest.mark.slow  # two balancer solves: minutes on two cores
def test_a_failed_first_design_of_the_edited_law_is_solved_again(monkeypatch):
    """The session's first design of the spec with the heavier pendulum (a page opening it),
    whose NLP from the default start ends at its iteration limit (on some machines it does at
    the spec's own limit, on others it converges; here that NLP is stopped at FIRST_CAP
    iterations): solved again from that start with its epigraph above its errors and every row
    at once, it converges, and both runs are in its trials."""
    real, calls = cadcam.api.optimize, []

    def first_capped(problem, **kw):
        calls.append(problem)
        if len(calls) > 1:
            return real(problem, **kw)
        kw.pop("transcription")  # the capped NLP is built apart: its iteration limit is in its build
        return real(problem.with_options(max_iter=FIRST_CAP), **kw)

    monkeypatch.setattr(cadcam.api, "optimize", first_capped)
    result = cadcam.Session().design(BALANCER, overrides={key: MASS for key in MASS_KEYS})
    assert len(calls) == 2  # the first design's NLP, then the one solved again
    assert result.success and result.solve.status == "converged"
    assert "from the default start again" in result.message
    assert [t["status"] for t in result.solve.trials] == ["max_iterations", "converged"]
    assert result.recheck.metrics["output_max_abs_error"][0] < 1e-5
