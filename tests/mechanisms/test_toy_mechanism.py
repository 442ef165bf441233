"""The mechanism interface carries a mechanism defined outside cadcam: ``tests/plugin/cadcam_toy_pulley.py``
(a pulley turning with its joint, its cable running to a fixed point A through a spring) plugs
in by registration alone, and is evaluated, checked against closed forms and independent
geometry, designed and written out by the CLI with no other file changed
(tests/mechanisms/test_entry_point.py installs it as a package instead)."""
import json

import numpy as np
import pytest
from numpy.polynomial import Polynomial

import cadcam
import cadcam.cli
from cadcam.verify.model import torque_function
from cadcam.mechanisms.base import departure_solver

from ..conftest import check_output_file, toy_pulley

toy_pulley()  # registers "toy_pulley", as the entry point of its installed package does

ANCHOR = (0.0, 0.10)   # m: A straight above the joint
RATE, PRELOAD, TRAVEL = 1000.0, 2.0, 0.08  # N/m, N, m
RHO_MIN, RHO_MAX = 0.010, 0.040  # m
R = 0.020  # m: the circular pulley
LINEAR = [0.020, 0.006, 0.0, 0.0]  # m, m/rad: ρ = 20 mm + 6 mm/rad · φ, convex (Eq. 40 > 0)
X0 = 0.010  # m


def write_spec(path, expression="0.5 + 0.3*theta", theta_range=(-10.0, 90.0), grid=46):
    path.write_text(f"""
name = "toy pulley"
source = "tests/plugin/cadcam_toy_pulley.py: anchored-spring pulley (Ludovico2021, Endo2010) to a point"
torque_model = "energy"

[solver]
grid = {grid}

[[joints]]
name = "joint"
theta_range_deg = [{theta_range[0]!r}, {theta_range[1]!r}]
tracking_weight = 1.0

[joints.target]
kind = "expression"
expression = "{expression}"

[[mechanisms]]
kind = "toy_pulley"
name = "pulley"
joint = 1
basis = "chebyshev"
order = 3
rho_min = {RHO_MIN!r}
rho_max = {RHO_MAX!r}
anchor = [{ANCHOR[0]!r}, {ANCHOR[1]!r}]

[[springs]]
name = "cable spring"
ports = ["cable:1"]
rate = {RATE!r}
travel = {TRAVEL!r}
preload = {PRELOAD!r}
""")
    return path


def design_of(problem, monomial, x0=X0):
    b = problem.profiles[0].basis
    return cadcam.Design([b], [b.from_monomial(np.asarray(monomial, dtype=float))], np.array([x0]))


def geometry(monomial, theta, alpha):
    """Independent numpy geometry: departure point p, unit profile tangent, unit cable
    direction û = (A − p)/|A − p| (world frame, profile point φ at world angle φ − θ)."""
    rho = Polynomial(monomial)
    r, dr = rho(alpha), rho.deriv()(alpha)
    w = alpha - theta
    p = np.array([r * np.cos(w), r * np.sin(w)])
    t = np.array([dr * np.cos(w) - r * np.sin(w), dr * np.sin(w) + r * np.cos(w)])
    u = np.asarray(ANCHOR)[:, None] - p
    return p, t / np.hypot(*t), u / np.hypot(*u)


@pytest.fixture
def problem(tmp_path):
    return cadcam.load_spec(write_spec(tmp_path / "toy.toml"))


def test_spec_reads_the_mechanism(problem, tmp_path):
    (mech,) = problem.mechanisms
    assert mech.kind == "toy_pulley" and mech.parameter_values() == ANCHOR
    assert problem.to_dict()["mechanisms"][0]["anchor"] == list(ANCHOR)
    bad = write_spec(tmp_path / "bad.toml")
    bad.write_text(bad.read_text().replace("anchor = [0.0, 0.1]", "anchor = [0.0, 0.03]"))
    with pytest.raises(cadcam.SpecError, match="anchor"):
        cadcam.load_spec(bad)


def test_circular_pulley_closed_form(problem):
    """A circle of radius R: the free span |A − p| is constant, so the cable lengthens by
    exactly Rθ, x = x₀ + Rθ and τ = (kx + F0) R; the cable leaves at the world angle
    ψ_A − acos(R/|A|) of the tangent from A (CCW winding), so α − θ is that constant."""
    design = design_of(problem, [R, 0, 0, 0])
    ev = cadcam.evaluate(problem, design, grid=21)
    theta = ev.theta[0]
    assert theta.min() < 0 < theta.max()  # the reference pose θ = 0 lies inside the range
    x = X0 + R * theta
    np.testing.assert_allclose(ev.x[0], x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ev.tau[0], (RATE * x + PRELOAD) * R, rtol=1e-11, atol=0)
    depart = np.arctan2(ANCHOR[1], ANCHOR[0]) - np.arccos(R / np.hypot(*ANCHOR))
    np.testing.assert_allclose(ev.units[0].z[0] - theta, depart, rtol=0, atol=1e-12)
    assert ev.violations == [] and ev.units[0].branch.max() < 1e-12
    # the mechanism's closed-form guess is already the solution for a circle
    solver = departure_solver(problem.mechanisms[0].structure())
    guess = solver.guess(theta, np.concatenate(design.coefficients), ANCHOR)
    np.testing.assert_allclose(guess, ev.units[0].z, rtol=0, atol=1e-12)


def test_noncircular_energy_torque(problem):
    """ρ = 20 mm + 6 mm/rad·φ: the energy torque equals a central difference of
    V = ½kx² + F0·x, and Ludovico2021's τ = (kx + F0)·r_m with r_m the signed distance from the
    joint to the free cable line (independent numpy geometry) agrees with it."""
    design = design_of(problem, LINEAR)
    ev = cadcam.evaluate(problem, design, grid=15)
    assert ev.violations == []
    theta, alpha, x = ev.theta[0], ev.units[0].z[0], ev.x[0]
    assert np.all(np.diff(alpha) > 0)  # the cable winds on as θ grows
    assert np.all(np.diff(x) > 0)      # so the spring extends: τ = ∂V/∂θ > 0
    # the departure cadcam found is a tangent point, on the winding branch
    p, t_hat, u_hat = geometry(LINEAR, theta, alpha)
    np.testing.assert_allclose(t_hat[0] * u_hat[1] - t_hat[1] * u_hat[0], 0, atol=1e-12)
    np.testing.assert_allclose(np.sum(t_hat * u_hat, axis=0), 1, atol=1e-12)
    # moment arm of the free cable about the joint: the CHECK of the energy model
    r_m = p[0] * u_hat[1] - p[1] * u_hat[0]
    ax, ay = ANCHOR  # distance from O to the line through p and A
    np.testing.assert_allclose(np.abs(r_m), np.abs(p[0] * ay - p[1] * ax)
                               / np.hypot(ax - p[0], ay - p[1]), rtol=1e-12)
    np.testing.assert_allclose(ev.tau[0], (RATE * x + PRELOAD) * r_m, rtol=1e-8, atol=0)
    assert np.all(r_m > R)  # the growing radius lengthens the arm beyond the circle's

    # energy: τ = dV/dθ by a central difference of V through the torque model's extensions
    f = torque_function(problem, design.bases)
    c = np.concatenate(design.coefficients)

    def V(th):
        xx = float(f(th, c, RATE, X0, PRELOAD)[1])
        return 0.5 * RATE * xx**2 + PRELOAD * xx

    h = 1e-4
    for th in (-0.1, 0.4, 0.9, 1.5):
        tau = float(f(th, c, RATE, X0, PRELOAD)[0])
        np.testing.assert_allclose(tau, (V(th + h) - V(th - h)) / (2 * h), rtol=1e-7)
    # the same torque model as the evaluator's on its grid
    np.testing.assert_allclose(np.asarray(f.map(theta.size)(theta, c, RATE, X0, PRELOAD)[0]).ravel(),
                               ev.tau[0], rtol=1e-12)


def reachable_target(tmp_path):
    """A smooth law close to what a known convex pulley (ρ = 20 mm + 6 mm/rad·φ, x₀ = 10 mm)
    produces with the spec's spring over [0°, 90°]: a cubic in θ fitted to its torque."""
    problem = cadcam.load_spec(write_spec(tmp_path / "probe.toml", theta_range=(0.0, 90.0)))
    ev = cadcam.evaluate(problem, design_of(problem, LINEAR), grid=46)
    assert ev.violations == []
    a = [float(v) for v in np.polynomial.polynomial.polyfit(ev.theta[0], ev.tau[0], 3)]
    return " + ".join(f"{v!r}*theta**{k}" for k, v in enumerate(a))


@pytest.fixture
def design_spec(tmp_path):
    return write_spec(tmp_path / "design.toml", reachable_target(tmp_path), theta_range=(0.0, 90.0))


def test_design_and_evaluate(design_spec):
    """Design from cadcam's default circular start for a law close to a known pulley's torque;
    the re-checked optimum tracks it at least as well as that pulley and evaluates to the
    metrics it reports."""
    problem = cadcam.load_spec(design_spec)
    known = cadcam.evaluate(problem, design_of(problem, LINEAR))
    assert known.violations == []
    result = cadcam.optimize(problem)
    assert result.status == "success", (result.message, result.recheck.violations)
    rmse = result.evaluation.metrics.rmse[0]
    # The known pulley is a feasible point of this NLP (its limits hold, the sensitivity
    # weights are 0) and misses the fitted law by its fit residual only. The objective is the
    # trapezoidal ∫(τ − τ_d)² over the design grid, which lies between n/(2(n − 1)) and
    # n/(n − 1) times the span × the plain mean square that RMSE reports; so an optimum at
    # least as good as that feasible point has RMSE ≤ √2 × the known pulley's.
    assert 0 < known.metrics.rmse[0] < 1e-5  # the law is close to the known pulley's
    assert rmse <= np.sqrt(2) * known.metrics.rmse[0]
    # cadcam.evaluate of the design reproduces the reported metrics (rootfinder from its own
    # guess instead of the NLP's angles) on the design grid and on the re-check grid. The RMSE
    # is ~1e-8 of torques ~1 N·m, so errors are compared to 1e-12 N·m, not relatively.
    reported = result.to_dict()
    atol = {"rmse": 1e-12, "max_abs_error": 1e-12, "extension_min": 1e-12,  # N·m, m
            "extension_max": 1e-12, "rho_min": 1e-12, "rho_max": 1e-12,      # m
            "alpha_max": 1e-12, "convexity_min": 1e-16, "objective": 1e-20}  # rad, m², N²m²rad
    for ev, metrics in ((cadcam.evaluate(problem, result.design), reported["metrics"]),
                        (cadcam.evaluate(problem, result.design, grid=result.recheck.grid),
                         reported["recheck"])):
        assert ev.violations == [] and ev.grid == metrics["grid"]
        for key, tol in atol.items():
            np.testing.assert_allclose(ev.metrics[key], metrics[key], rtol=1e-9, atol=tol,
                                       err_msg=key)
    assert reported["solver"]["tangency_nlp_vs_rootfinder_max"] < 1e-8


@pytest.mark.slow  # a whole cadcam design with every file: make test-slow
def test_cli_design(design_spec, tmp_path):
    """`cadcam design` on the spec: exit 0, result.json, the workshop files of the profile."""
    out = tmp_path / "out"
    assert cadcam.cli.main(["design", str(design_spec), "-o", str(out)]) == 0
    data = json.loads((out / "result.json").read_text())
    assert data["status"] == "success"
    assert data["problem"]["mechanisms"][0]["kind"] == "toy_pulley"
    for name in ("torque.csv", "profile.png", "cam1.dxf", "cam1.svg", "cam1_points.csv",
                 "cam1_sheet.pdf"):
        check_output_file(out / name)
    # it has no file model (Mechanism.port_length_from_file): the report says so, judging nothing
    report = json.loads((out / "verification.json").read_text())
    assert report["passed"] is None and report["checks"]
    assert [c["note"] for c in report["checks"]] == ["not recomputed from the files: no file model of toy_pulley"]
    # the written result is a spec again, and its design evaluates to its metrics
    again = cadcam.load_spec(out / "result.json")
    assert again.mechanisms[0].parameter_values() == ANCHOR
    ev = cadcam.evaluate(again, cadcam.Design.from_dict(data, again))
    np.testing.assert_allclose(ev.metrics.rmse, data["metrics"]["rmse"], rtol=1e-9, atol=1e-12)
    assert ev.metrics.rmse[0] < 1e-6  # N·m: the same problem as test_design_and_evaluate
