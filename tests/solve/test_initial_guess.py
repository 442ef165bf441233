"""The NLP's start from a design made in other bases than the spec's: Johnston2023's Table 3
cams (monomial) as the start of the RR-arm spec (Chebyshev profiles)."""
import dataclasses

import numpy as np

from cadcam.physics.profile import profile_function
from cadcam.solve.builds import built_for
from cadcam.verify.evaluate import start_samples


def _rho(design, k, phi):
    return np.asarray(profile_function(design.bases[k]).map(phi.size)(phi[None, :], design.coefficients[k])[0]).ravel()


def test_a_start_in_the_papers_monomials_starts_the_nlp_on_the_same_cams(rr_problem, table3):
    problem = dataclasses.replace(rr_problem, options=dataclasses.replace(rr_problem.options, functions="mapped"))
    assert table3.bases != [p.basis for p in problem.profiles]  # the case: monomial against Chebyshev
    tr = built_for(problem)[0]
    w0 = tr.initial_guess(problem, table3, start_samples(problem, table3, tr.n, tr.start_order()))
    started = tr.design_of(w0)
    phi = np.linspace(0.0, np.pi, 50)
    for k in range(len(problem.profiles)):
        np.testing.assert_allclose(_rho(started, k, phi), _rho(table3, k, phi), rtol=0, atol=1e-12)
