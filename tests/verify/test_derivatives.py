"""Automatic derivatives of the torque model against central finite differences."""
import numpy as np
import pytest

from cadcam.verify.model import torque_function


@pytest.mark.parametrize("model", ["energy", "force", "force-as-printed"])
def test_ad_jacobians_match_central_differences(rr_problem, table3, model):
    problem = rr_problem.with_torque_model(model)
    f = torque_function(problem, table3.bases, order=32)
    jac = f.factory("dtau", ["theta", "c", "k", "x0", "F0"],
                    ["jac:tau:theta", "jac:tau:c", "jac:tau:k", "jac:tau:x0", "jac:tau:F0"])
    rng = np.random.default_rng(1)
    theta = rng.uniform(0.1, 1.4, 2)
    c = np.concatenate(table3.coefficients)
    k = np.array([s.rate for s in problem.springs])
    x0 = table3.preextension + 1e-3
    F0 = np.array([2.0, 23.22, 1.0])  # preloads [N] (Johnston2023 Sec. 11: spring 2's pretension)
    args = [theta, c, k, x0, F0]
    J = [np.asarray(v) for v in jac(*args)]
    for which, step in ((0, 1e-6), (1, 1e-7), (2, 1e-3), (3, 1e-7), (4, 1e-3)):
        for j in range(args[which].size):
            up = [a.copy() for a in args]
            dn = [a.copy() for a in args]
            up[which][j] += step
            dn[which][j] -= step
            fd = (np.asarray(f(*up)[0]) - np.asarray(f(*dn)[0])).ravel() / (2 * step)
            ad = J[which][:, j]
            scale = max(np.abs(ad).max(), 1e-12)
            assert np.abs(ad - fd).max() <= 1e-6 * scale, (which, j, ad, fd)


def test_the_model_agrees_with_the_evaluator(rr_problem, table3):
    from cadcam.verify.evaluate import evaluate
    f = torque_function(rr_problem, table3.bases)
    ev = evaluate(rr_problem, table3, grid=5)
    k = np.array([s.rate for s in rr_problem.springs])
    for p in (0, 7, 24):
        tau, x, _ = f(ev.theta[:, p], np.concatenate(table3.coefficients), k, table3.preextension,
                      np.zeros(3))
        np.testing.assert_allclose(np.asarray(tau).ravel(), ev.tau[:, p], rtol=1e-10)
        np.testing.assert_allclose(np.asarray(x).ravel(), ev.x[:, p], rtol=1e-10, atol=1e-15)
