"""The NLP's Lagrangian Hessian built from mapped functions has the sparsity CasADi derives exactly
from the expanded (SX) functions (issue 30, item 1: builds that do not grow)."""
from dataclasses import replace

import pytest
import numpy as np

from cadcam import load_spec
from cadcam.solve.transcription import Transcription

from ..conftest import ROOT

BALANCER = ROOT / "models" / "fedorov2018_balancer.toml"


def hessian_pattern(problem, functions: str) -> np.ndarray:
    """The (row, column) pairs of the NLP's Lagrangian Hessian with ``functions``."""
    tr = Transcription(replace(problem, options=replace(problem.options, functions=functions)))
    rows, cols = tr.solver.get_function("nlp_hess_l").sparsity_out(0).get_triplet()
    return np.array(sorted(zip(rows, cols)))


@pytest.mark.slow  # seconds of designs: make test-slow
def test_the_mapped_hessian_has_the_expanded_ones_sparsity():
    """A differential pair, whose per-angle functions have several outputs and see both
    profiles' coefficients: called whole, each pose's unknowns were coupled to every
    coefficient in the mapped Hessian (about 4× the nonzeros), though no row couples them."""
    problem = load_spec(BALANCER, overrides=[("solver.grid", 11)])
    expanded, mapped = (hessian_pattern(problem, f) for f in ("expanded", "mapped"))
    assert len(expanded) > 0
    np.testing.assert_array_equal(mapped, expanded)
