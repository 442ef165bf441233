"""The radial cam with a translating roller follower (``roller_follower``): a mechanism with its
own equations (a roller's contact, not a wrapped cable) in one folder plus a spec.

Checked here: the shipped pendulum balancer designs and passes its re-check; an independent
numpy model (``independent_roller_follower``: the roller resting on a dense point cloud of the
cam, the torque by central differences of the spring energy) reproduces the follower's travel,
the torque and the pressure angle on the fine re-check grid; the closed-form guess is exact on
circles; the energy torque equals the hand-derived force model F ds/dθ; the pressure-angle
limit holds while it binds; a bad spec key is one SpecError line naming it.
"""
import math

import numpy as np
import pytest

import cadcam
from cadcam import SpecError
from cadcam.mechanisms.base import departure_solver, guess_function, mechanism_class, residual_function
from cadcam.physics.profile import Basis

from ...conftest import ROOT
from .independent_roller_follower import RollerCam, chebyshev_values

SPEC = ROOT / "models" / "roller_follower_pendulum.toml"
MASS, LENGTH, G = 0.5, 0.1, 9.81  # the spec's pendulum: tau_d = m g l sin(theta)


@pytest.fixture(scope="module")
def result(roller_result):
    return roller_result


@pytest.fixture(scope="module")
def cam(result):
    return RollerCam.from_result(result.to_dict())


def test_pendulum_balancer_is_designed_and_passes_its_recheck(result):
    assert result.success, result.summary()
    fine = result.recheck.metrics
    assert fine["relative_rmse"][0] < 1e-3  # 0.03 % of the target's RMS
    margins = fine["margins"]["mechanism"][0]
    assert margins["pressure_angle_max"] > 0 and margins["pressure_angle_min"] > 0
    assert margins["pitch_curvature_radius"] > 0
    # the contact runs over the designed arc, from just after the cam's polar axis
    alpha = result.recheck.units[0].z[0]
    assert 0 < alpha.min() < 0.5 and np.all(np.diff(alpha) > 0)
    assert "pressure angle up to" in result.summary()


def test_independent_envelope_reproduces_travel_and_torque(result, cam):
    """The roller resting on the cam's point cloud, not cadcam's contact equations: s(θ) to
    0.01 nm and τ = dV/dθ to 1e-5 N·mm on the 451 angles of the fine re-check (measured:
    6e-13 m and 4e-11 N·m; the contact angle, where the envelope is flat, to 1e-8 rad)."""
    fine = result.recheck
    theta = fine.theta[0]
    s, phi = cam.follower(theta)
    s_ref = cam.follower(cam.reference_angle)[0][0]
    unit = fine.units[0]
    np.testing.assert_allclose(s - s_ref, unit.d[0], rtol=0, atol=1e-11)
    np.testing.assert_allclose(s, unit.z[1], rtol=0, atol=1e-11)
    np.testing.assert_allclose(phi, unit.z[0], rtol=0, atol=1e-6)
    assert phi.max() <= fine.metrics.alpha_max[0] + 1e-9  # on the arc the workshop files keep
    np.testing.assert_allclose(cam.torque(theta), fine.tau[0], rtol=0, atol=1e-8)
    # and the torque is the pendulum's to the design's own accuracy
    np.testing.assert_allclose(cam.torque(theta), MASS * G * LENGTH * np.sin(theta), rtol=0,
                               atol=2 * fine.metrics.max_abs_error[0] + 1e-6)


def test_independent_pressure_angle_matches_the_declared_margins(result, cam):
    """φ_p from the independent contact normal equals φ_max − (margin of φ_p ≤ φ_max) and
    (margin of φ_p ≥ −φ_max) − φ_max."""
    fine, mech = result.recheck, result.problem.mechanisms[0]
    phi_p = cam.pressure_angle(fine.theta[0])
    margins = dict(zip(mech.margin_names, fine.units[0].margins))
    upper, lower = margins["pressure_angle_max"], margins["pressure_angle_min"]
    np.testing.assert_allclose(mech.max_pressure_angle - upper, phi_p, rtol=0, atol=1e-6)
    np.testing.assert_allclose(lower - mech.max_pressure_angle, phi_p, rtol=0, atol=1e-6)
    assert np.all(phi_p < 0)  # a rising follower: the normal leans back against the cam's turn


def test_independent_pitch_curvature_matches_the_declared_margin(result, cam):
    """The pitch curve traced by the independent roller centre in the cam's frame has the
    radius of curvature ρ_c + r that the margin ρ_p − λr reports (docs/roller_follower.md Eq. G6)."""
    fine, mech = result.recheck, result.problem.mechanisms[0]
    theta = fine.theta[0][5:-5:10]  # inside the range: central differences
    margin = dict(zip(mech.margin_names, fine.units[0].margins))["pitch_curvature_radius"][5:-5:10]
    np.testing.assert_allclose(cam.pitch_curvature_radius(theta), margin + mech.min_pitch_curvature_radius,
                               rtol=1e-5)


def test_drawing_hooks_put_the_roller_on_the_cam(result, cam):
    """circles(): the roller, centred at the independent roller centre and touching the cam
    where world_points puts the contact; segments(): the stem, along the follower's line."""
    mech, unit = result.problem.mechanisms[0], result.evaluation.units[0]
    c = np.concatenate(result.design.coefficients)
    u = np.array([np.cos(mech.follower_angle), np.sin(mech.follower_angle)])
    for k in (0, unit.theta.size // 2, unit.theta.size - 1):
        theta, z = unit.theta[k], unit.z[:, k]
        (centre, radius), = mech.circles(theta, z, c)
        assert radius == mech.roller_radius
        s = cam.follower(theta)[0][0]
        np.testing.assert_allclose(centre, s * u + mech.offset * np.array([-u[1], u[0]]), atol=1e-11)
        contact = np.array(mech.world_points(theta, z[0], float(cam.rho(z[0]))))
        assert abs(np.hypot(*(centre - contact)) - radius) < 1e-11
        (start, end), = mech.segments(theta, z, c)
        np.testing.assert_allclose(start, centre)
        np.testing.assert_allclose((end - start) / np.hypot(*(end - start)), u, atol=1e-14)


def test_independent_chebyshev_evaluation(cam):
    """The test's own Clenshaw recurrence against numpy's Chebyshev series."""
    phi = np.linspace(*cam.domain, 7)
    series = np.polynomial.Chebyshev(cam.coefficients, domain=list(cam.domain))
    np.testing.assert_allclose(chebyshev_values(cam.coefficients, cam.domain, phi), series(phi), atol=1e-15)


def _structure(order=4):
    return mechanism_class("roller_follower"), (Basis("chebyshev", order, (0.0, 3.5)),)


@pytest.mark.parametrize("beta, offset, axis", [(np.pi / 2, 0.0, 1.2), (np.pi / 2, 0.008, 1.0),
                                                (0.3, -0.006, -0.4), (2.5, 0.004, 1.9)])
def test_guess_is_exact_on_a_circle(beta, offset, axis):
    """A circle ρ about the axis: the roller centre on the circle ρ + r, so s = √((ρ + r)² − e²),
    at world angle β + atan2(e, s), i.e. α = θ + β − γ₀ + atan2(e, s)."""
    structure = _structure()
    cls, (basis,) = structure
    rho, r = 0.03, 0.006
    c = basis.from_monomial([rho, 0, 0, 0, 0])
    q = dict(roller_radius=r, follower_angle=beta, offset=offset, axis_angle=axis,
             max_pressure_angle=0.5, reference_angle=0.0, min_pitch_curvature_radius=0.012)
    q = np.array([q[n] for n in cls.parameter_names])
    theta = np.linspace(-0.3, 1.2, 9)
    z = np.asarray(guess_function(structure).map(theta.size)(theta, c, q))
    s = math.sqrt((rho + r) ** 2 - offset**2)
    np.testing.assert_allclose(z[1], s, rtol=0, atol=1e-15)
    np.testing.assert_allclose(z[0], theta + beta - axis + math.atan2(offset, s), rtol=0, atol=1e-14)
    R = np.asarray(residual_function(structure).map(theta.size)(theta, z, c, q)[0])
    assert np.abs(R).max() < 1e-15


def test_guess_starts_newton_on_a_non_circular_cam():
    """A non-circular profile: the guess's sweeps land within 1e-6 rad of the root Newton
    reaches, on the physical branch (s > 0, the normal towards the follower)."""
    structure = _structure()
    cls, (basis,) = structure
    c = basis.from_monomial([0.025, 0.004, 0.002, -0.0004, 0.0])
    q = np.array([0.005, np.pi / 2, 0.003, 1.2, 0.5, 0.0, 0.01])
    theta = np.linspace(0.0, np.pi / 2, 12)
    start = np.asarray(guess_function(structure).map(theta.size)(theta, c, q))
    z, res = departure_solver(structure).solve(theta, c, q)
    assert res.max() < 1e-12 and np.abs(z - start).max() < 1e-6 and np.all(z[1] > 0)
    branch = np.asarray(residual_function(structure).map(theta.size)(theta, z, c, q)[1])
    assert np.all(branch == 0)


def test_energy_torque_equals_the_force_model(result):
    """τ = dV/dθ by the implicit function theorem equals F ds/dθ with ds/dθ = e − s tan φ_p
    (virtual work; docs/roller_follower.md Eq. G5), on the fine grid."""
    energy = cadcam.evaluate(SPEC, result.design, grid=451, profile=False)
    force = cadcam.evaluate(SPEC, result.design, grid=451, profile=False, torque_model="force")
    np.testing.assert_allclose(force.units[0].arm, energy.units[0].arm, rtol=0, atol=1e-12)
    np.testing.assert_allclose(force.tau, energy.tau, rtol=0, atol=1e-10)


def test_energy_torque_with_an_offset_follower_equals_the_force_model():
    """Same on a problem with an offset, tilted follower (e ≠ 0: ds/dθ = e − s tan φ_p) and
    a non-circular cam."""
    problem = cadcam.load_problem(SPEC, overrides={"mechanisms.1.offset": 0.004,
                                                   "mechanisms.1.follower_angle": 1.2})
    basis = problem.profiles[0].basis
    design = cadcam.Design([basis], [basis.from_monomial([0.02, 0.003, 0.001, -0.0002, 0, 0, 0])],
                           np.array([0.008]))
    energy = cadcam.evaluate(problem, design, grid=61, profile=False)
    force = cadcam.evaluate(problem, design, grid=61, profile=False, torque_model="force")
    assert np.abs(energy.units[0].arm).min() > 1e-3  # a cam that moves its follower
    np.testing.assert_allclose(force.tau, energy.tau, rtol=0, atol=1e-10)


def test_pressure_angle_limit_binds_and_holds():
    """With φ_max = 0.15 rad (8.6°), below the 13° the free design reaches, the limit binds:
    the lower one, φ_p ≥ −φ_max, that of a rising follower. It holds on the NLP's own grid
    (rootfinder, not the NLP's iterate) and on the fine re-check up to the overshoot between
    grid angles (a few 1e-5 rad: see docs/roller_follower.md, 'Limits')."""
    result = cadcam.design(SPEC, overrides={"mechanisms.1.max_pressure_angle": 0.15})
    assert result.solve.status == "converged"
    names = result.problem.mechanisms[0].margin_names
    on_grid = dict(zip(names, result.evaluation.units[0].margins))
    fine = dict(zip(names, result.recheck.units[0].margins))
    assert -1e-8 <= on_grid["pressure_angle_min"].min() <= 1e-6  # binds, and holds
    assert on_grid["pressure_angle_max"].min() > 0.1             # the other side is slack
    assert -1e-4 <= fine["pressure_angle_min"].min() <= 1e-6
    assert any("pressure angle" in b and "lower limit" in b for b in result.binding)
    assert result.recheck.metrics.relative_rmse[0] < 1e-2     # the target still met to 1 %


def test_pitch_curvature_limit_binds_and_holds():
    """With λ = 7 (ρ_p ≥ 35 mm, above the free design's 28 mm) the pitch curve's radius of
    curvature limit binds; it holds on the fine re-check within its 1 µm tolerance."""
    result = cadcam.design(SPEC, overrides={"mechanisms.1.min_pitch_curvature_ratio": 7.0})
    assert result.success, result.summary()
    names = result.problem.mechanisms[0].margin_names
    fine = dict(zip(names, result.recheck.units[0].margins))["pitch_curvature_radius"]
    assert -1e-6 <= fine.min() <= 1e-6
    assert any("pitch-curve radius of curvature at its lower limit: 35.00 mm" in b for b in result.binding)


def test_spec_round_trip_keeps_the_placement():
    problem = cadcam.load_problem(SPEC)
    mech = problem.mechanisms[0]
    again = cadcam.load_problem(problem.to_dict()).mechanisms[0]
    assert again == mech
    assert mech.axis_angle == pytest.approx(np.pi / 2 - math.asin(0.005 * 0.5 / 0.012) - 0.1)


@pytest.mark.parametrize("key, value, expected", [
    ("roller_radius", -0.005, "mechanisms[1].roller_radius = -0.005: expected the roller's radius r: a number > 0 [m]"),
    ("follower_angle", "up", "mechanisms[1].follower_angle = 'up': expected the world direction"),
    ("max_pressure_angle", 2.0, "mechanisms[1].max_pressure_angle = 2.0: expected the largest pressure"),
    ("min_pitch_curvature_ratio", 0.5, "mechanisms[1].min_pitch_curvature_ratio = 0.5: expected the pitch curve's least radius of curvature in roller radii (1: convexity only; 2–3 usual): a number ≥ 1"),
    ("offset", 0.02, "mechanisms[1].offset = 0.02: expected an offset with |offset|"),
    ("axis_angle", 2.5, "mechanisms[1].axis_angle = 2.5: expected a placement whose contact angles"),
    ("initial_radius", 0.05, "mechanisms[1].initial_radius = 0.05: expected the radius of the NLP's circular start, inside (rho_min, rho_max): a number in ("),
    ("roller_radious", 0.005, "unknown key 'mechanisms[1].roller_radious'"),
])
def test_bad_spec_key_is_one_line_naming_it(key, value, expected):
    with pytest.raises(SpecError) as info:
        cadcam.load_problem(SPEC, overrides={f"mechanisms.1.{key}": value})
    message = str(info.value)
    assert "\n" not in message and str(SPEC) in message and expected in message, message


def test_missing_roller_radius_is_named():
    data = cadcam.load_problem(SPEC).to_dict()
    del data["mechanisms"][0]["roller_radius"]
    with pytest.raises(SpecError, match=r"missing key 'mechanisms\[1\]\.roller_radius'"):
        cadcam.load_problem(data)
