"""A catalogue search compiles the library of its designs' second solve (the NLP with its
deferred outline rows) before its workers start (:func:`cadcam.sweep.springs.prepare_functions`);
a library in the cache is named by the NLP's graph alone, so it must be generated from the same
graph as a design's own solve generates it (:meth:`Transcription.whole_library`), or what the
cache holds would depend on which of them compiled first."""
from __future__ import annotations

import pytest

from cadcam import load_problem
from cadcam.solve import compiled
from cadcam.solve.transcription import Transcription
from cadcam.sweep.springs import prepare_functions, with_part

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
def test_a_search_generates_the_second_solves_library_as_a_design_does(recorded):
    problem = load_problem(SPEC)
    prepare_functions(problem, 0, PART, None)
    first, searched = recorded  # the NLP's, then the one with the deferred rows
    design = Transcription(with_part(problem, 0, PART, None).with_options(functions="compiled"))
    design._imposing_solver()  # a design's own second solve
    assert recorded[2:] == [first, searched]
