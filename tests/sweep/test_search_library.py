"""A catalogue search compiles the libraries of its designs' solves (the NLP, and the NLP with
its deferred outline rows) before its workers start (:func:`cadcam.sweep.springs.prepare_functions`);
a library in the cache is named by the NLP's graph alone, so each must be generated from the
same graph as a search's design generates it (:meth:`Transcription.whole_library`), or what the
cache holds would depend on which of them compiled first."""
from __future__ import annotations

import pytest

from cadcam import load_problem
from cadcam.solve import compiled
from cadcam.solve.transcription import Transcription
from cadcam.sweep.springs import prepare_functions, search_solves, with_part

from ..conftest import ROOT

SPEC = ROOT / "docs" / "first_balancer.toml"
PART = "5108N708"


@pytest.fixture
def recorded(monkeypatch, tmp_path):
    """The serialized graphs each library asked for would be generated from; none is compiled
    (the solvers are built with expanded functions instead)."""
    graphs = []

    def record(nlp, source=None, key=None, claimed=False):
        graphs.append(compiled._nlp_function(source() if source is not None else nlp).serialize())
        return None, False

    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(compiled, "library", record)
    return graphs


@pytest.mark.skipif(not compiled.available(), reason="no C compiler to name a library by")
def test_a_search_generates_its_designs_libraries_as_a_design_does(recorded):
    problem = load_problem(SPEC)
    prepare_functions(problem, 0, PART, None)  # both at once: in either order
    with search_solves():  # as a search's design builds its NLP
        design = Transcription(with_part(problem, 0, PART, None).with_options(functions="compiled"))
        design._imposing_solver()  # a design's own second solve
    assert len(recorded) == 4 and sorted(recorded[:2]) == sorted(recorded[2:]) and recorded[2] != recorded[3]
