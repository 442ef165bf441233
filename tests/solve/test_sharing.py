"""The warm solver and the solver that imposes the deferred rows share the first solver's
derivatives (cadcam/solve/sharing.py): they are the derivatives CasADi would generate for their
NLPs, with every function the first solver was built with (expanded, mapped or compiled)."""
import casadi as ca
import numpy as np
import pytest

from cadcam import load_spec
from cadcam.optimize import start_design
from cadcam.solve import compiled
from cadcam.solve.transcription import Transcription, WARM_IPOPT, _ipopt_options
from cadcam.verify.evaluate import start_samples

from ..conftest import SPEC_1DOF, needs_cc

DERIVED = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")


def _outputs(solver: ca.Function, name: str, args: list) -> list[ca.DM]:
    f = solver.get_function(name)
    out = f(*args[:f.n_in()])
    return [ca.DM(v) for v in (out if isinstance(out, tuple) else [out])]


def _same_functions(shared: ca.Function, generated: ca.Function, point: list):
    """Every function IPOPT calls gives, to rounding, ``generated``'s values (a mapped or
    compiled graph may keep a few structural zeros the expanded one drops)."""
    for name in DERIVED:
        for a, b in zip(_outputs(shared, name, point), _outputs(generated, name, point), strict=True):
            a, b = np.asarray(ca.densify(a)), np.asarray(ca.densify(b))
            assert a.shape == b.shape and np.abs(a - b).max() <= 1e-13 * np.abs(b).max(), name


@pytest.fixture(scope="module")
def small():
    """The 1-DOF cam at grid 12, its start point and parameters: an NLP with outline rows."""
    problem, start = start_design(load_spec(SPEC_1DOF).with_options(grid=12, convexity_points=16))
    tr = Transcription(problem)
    w0, pv = tr.start_point(problem, start, start_samples(problem, start, tr.n, tr.start_order()))
    return problem, w0, pv


@pytest.mark.parametrize("functions", ["expanded", "mapped", pytest.param("compiled", marks=needs_cc)])
def test_shared_derivatives_are_those_of_the_warm_and_the_whole_nlp(small, functions, tmp_path, monkeypatch):
    problem, w0, pv = small
    if functions == "compiled":
        monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path))
    tr = Transcription(problem.with_options(functions=functions))
    assert tr._deferred.size1_out(0) > 0
    lam = np.random.default_rng(3).standard_normal(tr.whole_nlp["g"].shape[0])
    options = {**_ipopt_options(problem.options, WARM_IPOPT), "expand": True}
    whole = ca.nlpsol("whole", "ipopt", tr.whole_nlp, options)
    _same_functions(tr._imposing_solver(), whole, [w0, pv, 0.7, lam])
    warm = ca.nlpsol("warm", "ipopt", tr.nlp, options)
    _same_functions(tr._warm_solver(), warm, [w0, pv, 0.7, lam[:tr.nlp["g"].shape[0]]])
    if functions == "compiled":
        assert compiled.cached_libraries() and len(compiled.cached_libraries()) == 1  # the NLP's only
