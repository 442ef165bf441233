"""Tangency (Johnston2023 Eq. 1–8), spring extensions (Eq. 14–16) and torque (Eq. 19–21, and
the energy model)."""
import numpy as np
import pytest

from cadcam.verify.evaluate import evaluate

from ...conftest import circle_design


@pytest.mark.parametrize("model", ["energy", "force", "force-as-printed"])
def test_circular_cam_closed_forms(problem_1dof, model):
    """On a circular cam every torque model gives τ = k₁x₁ρ: the models agree."""
    problem = problem_1dof.with_torque_model(model)
    rho, x0 = 0.03, np.array([0.004, 0.002])
    cam = problem.mechanisms[0]
    ev = evaluate(problem, circle_design(problem, rho, x0), grid=31)
    unit = ev.units[0]
    theta = unit.theta
    alpha, gamma = unit.z
    # contact at a constant world angle: (ρ + r) sin(α − θ) = a0
    np.testing.assert_allclose(alpha - theta,
                               np.arcsin(cam.idler_offset / (rho + cam.idler_radius)), atol=1e-12)
    np.testing.assert_allclose(gamma, np.pi + alpha - theta, atol=1e-12)
    # the wire grows by ρθ; the platform does not move
    np.testing.assert_allclose(ev.x[0], x0[0] + rho * theta, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(ev.x[1], x0[1], atol=1e-14)
    # torque k1 x1 ρ, the normal term's moment arm vanishes
    np.testing.assert_allclose(unit.arm[1], 0.0, atol=1e-15)
    k1 = problem.springs[0].rate
    np.testing.assert_allclose(ev.tau[0], k1 * ev.x[0] * rho, rtol=1e-10)


def test_tangency_residuals_vanish_on_the_published_designs(rr_problem, table3):
    ev = evaluate(rr_problem, table3, grid=91)
    for unit in ev.units:
        assert unit.residual.max() <= 1e-10
        np.testing.assert_allclose(unit.branch, 0.0, atol=1e-12)  # 1 + t̂(α)·t̂(γ): t̂(α) = −t̂(γ)


def test_eq43_sensitivities_equal_the_automatic_derivative(rr_problem, table3):
    """∂τ₁/∂k₁ = ẑ·(r_p × x₁t̂), ∂τ₁/∂k₂ = ẑ·(r_p × x₂n̂) (Eq. 43, force model with the
    corrected capstan)."""
    ev = evaluate(rr_problem.with_torque_model("force"), table3, grid=12)
    n = ev.grid
    i1, i2 = np.indices((n, n)).reshape(2, -1)
    c1, c2 = ev.units
    np.testing.assert_allclose(ev.dtau_dk[0, :, 0], ev.x[0] * c1.arm[0, i1], rtol=1e-9)
    np.testing.assert_allclose(ev.dtau_dk[0, :, 1], ev.x[1] * c1.arm[1, i1], rtol=1e-9)
    np.testing.assert_allclose(ev.dtau_dk[0, :, 2], 0.0, atol=0)
    np.testing.assert_allclose(ev.dtau_dk[1, :, 2], ev.x[2] * c2.arm[0, i2], rtol=1e-9)
    # the wire arm by quadrature of Eq. 35 equals the departure moment ρ²/√(ρ²+ρ′²)
    from cadcam.mechanisms.wire_cam.departure import departure_moments
    from cadcam.physics.profile import profile_function
    rho, drho, _, _ = (np.asarray(v).ravel() for v in profile_function(table3.bases[0]).map(n)(
        c1.z[0], table3.coefficients[0]))
    arm_t = np.asarray(departure_moments(c1.theta, c1.z[0], rho, drho)[0], dtype=float).ravel()
    np.testing.assert_allclose(c1.arm[0], arm_t, rtol=1e-10)


@pytest.mark.parametrize("model,expected", [
    # docs/physics.md (independent values): Table 3 on the uniform 46 × 46 grid [N·mm]
    ("force-as-printed", {"rmse": (270, 128), "max": (862, 389)}),
    ("force", {"rmse": (597, 137), "max": (1645, 387)}),
])
def test_table3_design_reproduces_reference_values(rr_problem, table3, model, expected):
    ev = evaluate(rr_problem.with_torque_model(model), table3, grid=46)
    np.testing.assert_allclose(np.array(ev.metrics.rmse) * 1e3, expected["rmse"], rtol=0.01)
    np.testing.assert_allclose(np.array(ev.metrics.max_abs_error) * 1e3, expected["max"], rtol=0.01)
    # docs/physics.md (independent): spring 1 reaches 57.9 mm, spring 2 stays in [9.3, 30.1] mm
    assert ev.metrics.extension_max[0] * 1e3 == pytest.approx(57.9, abs=0.05)
    assert ev.metrics.extension_min[1] * 1e3 == pytest.approx(9.33, abs=0.01)
    assert ev.metrics.extension_max[1] * 1e3 == pytest.approx(30.1, abs=0.05)
    assert ev.metrics.convexity_min[0] == pytest.approx(2.3e-6, rel=0.05)


def test_a_cam_the_idler_cannot_reach_gives_violations_not_an_exception(problem_1dof):
    """(ρ + r) < a₀: no tangency exists; the evaluator reports it instead of raising."""
    import dataclasses
    cam = dataclasses.replace(problem_1dof.mechanisms[0], idler_offset=0.045, idler_radius=0.005)
    problem = dataclasses.replace(problem_1dof, mechanisms=(cam,))
    ev = evaluate(problem, circle_design(problem, 0.010, [0.0, 0.0]), grid=12)
    assert any(v.startswith("departure not solved") for v in ev.violations)
    assert not np.isfinite(ev.metrics.rmse[0])
