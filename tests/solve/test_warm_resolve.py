"""A warm re-solve after a small edit (the design page's loop) starts at the last answer's own
NLP point with its multipliers, without sampling its design again, and reaches the optimum the
default start reaches."""
import importlib

import numpy as np
import pytest

from cadcam import load_spec
from cadcam.optimize import solve, start_design
from cadcam.solve.transcription import Transcription

from ..conftest import SPEC_1DOF


@pytest.fixture(scope="module")
def answered():
    """The 1-DOF cam at grid 12, its NLP and its answer from the default start."""
    problem, start = start_design(load_spec(SPEC_1DOF).with_options(grid=12, convexity_points=16))
    tr = Transcription(problem)
    return problem, tr, solve(tr, problem, start)


def test_an_answer_keeps_its_nlp_point_beside_its_multipliers(answered):
    problem, tr, first = answered
    w = first.multipliers.x
    assert w.shape == (tr.v.size,)
    np.testing.assert_array_equal(first.design.coefficients[0], tr.design_of(w).coefficients[0])
    # the departure unknowns the answer reports are the point's own
    np.testing.assert_array_equal(first.z[0][0], tr.v.part(w, f"z0_{problem.mechanisms[0].unknowns[0]}"))


def test_a_warm_resolve_starts_at_the_answers_point_without_sampling_its_design(answered, monkeypatch):
    problem, tr, first = answered
    edited = problem.with_spring_rates(1.01, [0])
    cold = solve(tr, edited, start_design(edited)[1])

    def sampled(*args, **kwargs):
        raise AssertionError("the warm start sampled the design again")

    monkeypatch.setattr(importlib.import_module("cadcam.optimize"), "start_samples", sampled)
    warm = solve(tr, edited, first.design, first.multipliers)
    assert warm.status == cold.status == "converged"
    assert warm.iterations < cold.iterations
    assert warm.objective <= cold.objective * (1 + 1e-6)


def test_the_warm_point_is_the_answers_with_the_edited_problems_parameters(answered):
    problem, tr, first = answered
    edited = problem.with_spring_rates(1.01, [0])
    w0, pv = tr.warm_point(edited, first.multipliers.x)
    np.testing.assert_array_equal(w0, first.multipliers.x)
    np.testing.assert_array_equal(tr.p.part(pv, "k"), edited.spring_parameters().rate)
    np.testing.assert_array_equal(pv, tr.parameters(edited))  # no check ranges in this structure
