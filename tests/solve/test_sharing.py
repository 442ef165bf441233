"""The warm solver shares the first solver's derivatives (cadcam/solve/sharing.py): they are
the functions CasADi would generate for its NLP, whether the first solver's were expanded or
mapped (a compiled build's warm solver loads its library)."""
import casadi as ca
import numpy as np
import pytest

from cadcam import load_spec
from cadcam.optimize import start_design
from cadcam.solve.ipopt import WARM_IPOPT, _ipopt_options
from cadcam.solve.transcription import Transcription
from cadcam.verify.evaluate import start_samples

from ..conftest import SPEC_1DOF

DERIVED = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")


def _outputs(solver: ca.Function, name: str, args: list) -> list[ca.DM]:
    f = solver.get_function(name)
    out = f(*args[:f.n_in()])
    return [ca.DM(v) for v in (out if isinstance(out, tuple) else [out])]


def _same_functions(shared: ca.Function, generated: ca.Function, point: list):
    """Every function IPOPT calls gives, to rounding, ``generated``'s values (a mapped
    graph may keep a few structural zeros the expanded one drops)."""
    for name in DERIVED:
        for a, b in zip(_outputs(shared, name, point), _outputs(generated, name, point), strict=True):
            a, b = np.asarray(ca.densify(a)), np.asarray(ca.densify(b))
            assert a.shape == b.shape and np.abs(a - b).max() <= 1e-13 * np.abs(b).max(), name


@pytest.fixture(scope="module")
def small():
    """The 1-DOF cam at grid 12, its start point and parameters."""
    problem, start = start_design(load_spec(SPEC_1DOF).with_options(grid=12, convexity_points=16))
    tr = Transcription(problem)
    w0, pv = tr.start_point(problem, start, start_samples(problem, start, tr.n, tr.start_order()))
    return problem, w0, pv


@pytest.mark.parametrize("functions", ["expanded", "mapped"])
def test_the_warm_solver_evaluates_the_derivatives_of_its_nlp(small, functions):
    problem, w0, pv = small
    tr = Transcription(problem.with_options(functions=functions))
    lam = np.random.default_rng(3).standard_normal(tr.nlp["g"].shape[0])
    options = {**_ipopt_options(problem.options, WARM_IPOPT), "expand": True}
    _same_functions(tr._warm_solver(), ca.nlpsol("warm", "ipopt", tr.nlp, options), [w0, pv, 0.7, lam])
