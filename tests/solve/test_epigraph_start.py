"""A minimax epigraph started on its rows (:meth:`Transcription.epigraphs_met`): at a start,
each epigraph variable is the largest error its rows bound, so that they all hold and one
binds."""
import casadi as ca
import numpy as np
import pytest

import cadcam
from cadcam.optimize import start_design
from cadcam.solve.builds import built_for
from cadcam.solve.transcription import EPIGRAPH_START
from cadcam.verify.evaluate import start_samples

SPEC = "models/ludovico2021_pendulum.toml"  # minimax on the joint's torque: one epigraph variable


def test_a_met_epigraph_holds_its_rows_and_one_binds():
    problem, start = start_design(cadcam.load_problem(SPEC, functions="mapped"))
    tr = built_for(problem)[0]
    w0, pv = tr.start_point(problem, start, start_samples(problem, start, tr.n, tr.start_order()))
    lbg = tr.bounds(problem)[0]
    g = ca.Function("g", [tr.nlp["x"], tr.nlp["p"]], [tr.nlp["g"]])
    (name,) = tr.epigraph_names
    met = tr.epigraphs_met(w0, pv, above=1.0)
    assert tr.v.part(w0, name)[0] == 0.0 and tr.v.part(met, name)[0] > 0.0
    lower = met.copy()
    tr.v.put(lower, name, tr.v.part(met, name) * (1 - 1e-6))
    at, below = (np.asarray(g(w, pv)).ravel() - lbg for w in (met, lower))
    rows = np.flatnonzero(at != below)  # the epigraph's rows: those its variable moves
    assert rows.size == 2 * problem.options.grid  # t − err ≥ 0 and t + err ≥ 0 at each angle
    assert at[rows].min() >= 0.0 and at[rows].min() < 1e-12 * tr.v.part(met, name)[0] + 1e-15  # all hold, one binds
    assert below[rows].min() < 0.0  # any lower and one breaks
    start_rows = np.asarray(g(w0, pv)).ravel() - lbg
    assert start_rows[rows].min() < 0.0  # as initial_guess leaves it, the start breaks them


def test_an_epigraph_starts_above_its_errors_by_default():
    problem, start = start_design(cadcam.load_problem(SPEC, functions="mapped"))
    tr = built_for(problem)[0]
    w0, pv = tr.start_point(problem, start, start_samples(problem, start, tr.n, tr.start_order()))
    (name,) = tr.epigraph_names
    on = tr.v.part(tr.epigraphs_met(w0, pv, above=1.0), name)[0]
    assert tr.v.part(tr.epigraphs_met(w0, pv), name)[0] == pytest.approx(EPIGRAPH_START * on, rel=1e-12)
