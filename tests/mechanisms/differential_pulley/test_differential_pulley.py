"""The differential pair of noncircular pulleys (Fedorov2018): closed forms for circles, an
independent model of eccentric discs, Eq. 11 against the energy model's arm, the envelope
synthesis, the 360° balancer (and the design page's warm re-design of it) and the spec's errors."""
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from cadcam.mechanisms.base import Profile, departure_solver, port_function, wound_lengths
from cadcam.mechanisms.differential_pulley.model import DifferentialPulley
from cadcam.optimize import optimize, start_design
from cadcam.physics.profile import Basis, profile_function
from cadcam.physics.wrap import wound_length
from cadcam.solve.builds import built_for
from cadcam.spec import SpecError, load_spec, parse_spec, read_spec_data
from cadcam.mechanisms.differential_pulley.fedorov_envelope import cable_lengths, envelope, fit_pulley

RANGE = (-np.radians(170), np.radians(170))
BALANCER = "models/fedorov2018_balancer.toml"


def _pair(q=0.0, order=12, winding="ccw", sense=1.0):
    basis = Basis("chebyshev", order, DifferentialPulley.profile_domain(RANGE))
    profiles = (Profile("p 1", basis, 0.005, 0.09), Profile("p 2", basis, 0.005, 0.09))
    return DifferentialPulley(name="p", joint=0, profiles=profiles, idler_radius=q, winding=winding,
                              sense=sense, slider_range=(0.1, 0.4), reference_angle=RANGE[0])


def _circle(basis, r):
    return basis.from_monomial(np.r_[r, np.zeros(basis.order)])


def _anchored(mech, radii, x):
    """The pair with anchors 0.1 rad before each circle's least-wound departure point at x."""
    chi0 = [0.1 + np.arccos((r - mech.idler_radius) / x) - s * (RANGE[0] if s > 0 else RANGE[1])
            for r, s in zip(radii, mech.sigmas)]
    return replace(mech, anchor_angles=tuple(mech.slider_angle - w * c for w, c in zip(mech.windings, chi0)))


def _solve(mech, coefs, theta, x_ref, alpha0=None):
    """x(θ) by cadcam's rootfinder, with the cable length set at the reference angle (Newton
    from ``alpha0`` there, by default the closed-form guess)."""
    if alpha0 is None:
        alpha0 = departure_solver(mech.structure()).guess(mech.reference_angle, np.concatenate(coefs),
                                                          mech.parameter_values())[:2, 0]
    length = cable_lengths(mech, coefs, mech.reference_angle, x_ref, alpha0)[0]
    mech = replace(mech, cable_length=length)
    z, res = departure_solver(mech.structure()).solve(theta, np.concatenate(coefs), mech.parameter_values())
    assert res.max() < 1e-10
    return mech, z


def test_wound_length_matches_adaptive_quadrature():
    basis = Basis("chebyshev", 9, (0.0, 7.0))
    c = basis.from_monomial([0.04, 0.004, -0.001, 2e-4, 0, 0, 0, 0, 0, 0])
    f = profile_function(basis)
    density = lambda p: float(np.hypot(*[float(v) for v in f(p, c)[:2]]))  # noqa: E731
    for alpha in (0.3, 3.0, 6.9):
        assert float(wound_length(basis, alpha, c)) == pytest.approx(quad(density, 0, alpha, epsabs=1e-14)[0],
                                                                     rel=1e-12)


def test_identical_circles_wound_oppositely_leave_the_idler_still():
    mech = _pair(q=0.01)
    coefs = [_circle(p.basis, 0.04) for p in mech.profiles]
    mech = _anchored(mech, (0.04, 0.04), 0.2)
    _, z = _solve(mech, coefs, np.linspace(*RANGE, 60), 0.2)
    assert np.ptp(z[2]) < 1e-12
    assert z[2, 0] == pytest.approx(0.2, abs=1e-12)


def test_unequal_circles_and_a_point_idler_follow_their_closed_form():
    """Circles r1 ≠ r2, q = 0: L = Σ r_k(χ_k − acos(r_k/x)) + √(x² − r_k²) with χ₁ + χ₂ fixed
    and σ₂ = −σ₁, so (r₂ − r₁)σ₂θ is a closed-form function of x."""
    r = (0.03, 0.045)
    mech = _pair()
    coefs = [_circle(p.basis, rk) for p, rk in zip(mech.profiles, r)]
    mech = _anchored(mech, r, 0.2)
    theta = np.linspace(*RANGE, 40)
    mech, z = _solve(mech, coefs, theta, 0.2)
    chi0, sig = mech.chi0(), mech.sigmas

    def length(x, th):
        return sum(rk * (c0 + s * th - np.arccos(rk / x)) + np.sqrt(x**2 - rk**2)
                   for rk, c0, s in zip(r, chi0, sig))

    x = [brentq(lambda xx: length(xx, th) - mech.cable_length, 0.046, 5.0, xtol=1e-15) for th in theta]
    assert np.abs(z[2] - x).max() < 1e-11
    assert np.ptp(z[2]) > 0.02  # the idler does move (by 46 mm)


def _disc_x(mech, discs, theta):
    """Independent model of two eccentric discs (radius a, centre at e·(cos φe, sin φe) in
    each pulley's frame, anchor on the ray φ = 0) and a point idler: tangent points and wrapped
    arcs about each disc's own centre, x by bracketing the constant length."""
    def half(k, x, th):
        a, e, pe = discs[k]
        C = e * np.array([np.cos(pe), np.sin(pe)])
        chi = mech.chi0()[k] + mech.sigmas[k] * th
        P = x * np.array([np.cos(chi), np.sin(chi)])
        d = P - C
        dist = np.hypot(*d)
        # departure about C (ccw winding), on the turn of χ (unwrapped: the anchor fixes it)
        psi = chi + np.angle(np.exp(1j * (np.arctan2(d[1], d[0]) - chi))) - np.arccos(a / dist)
        # the anchor: where the ray φ = 0 meets the disc
        s = e * np.cos(pe) + np.sqrt(a**2 - (e * np.sin(pe))**2)
        psi0 = np.arctan2(-C[1], s - C[0])
        return a * (psi - psi0) + np.sqrt(dist**2 - a**2)

    out = []
    for th in theta:
        out.append(brentq(lambda x: half(0, x, th) + half(1, x, th) - mech.cable_length, 0.1, 0.4,
                          xtol=1e-15))
    return np.array(out)


def test_eccentric_discs_move_the_idler_as_an_independent_model_says():
    discs = [(0.04, 0.006, 0.7), (0.035, 0.004, -1.2)]
    mech = _pair(order=15)
    basis = mech.profiles[0].basis
    phi = np.linspace(*basis.domain, 800)
    coefs = []
    for a, e, pe in discs:  # ρ(φ) of the disc about the shaft, fitted in the basis
        rho = e * np.cos(phi - pe) + np.sqrt(a**2 - (e * np.sin(phi - pe))**2)
        coefs.append(np.polynomial.chebyshev.chebfit(2 * phi / basis.domain[1] - 1, rho, basis.order))
    mech = _anchored(mech, [a + e for a, e, _ in discs], 0.2)
    theta = np.linspace(*RANGE, 25)
    mech, z = _solve(mech, coefs, theta, 0.2)
    x = _disc_x(mech, discs, theta)
    assert np.ptp(x) > 5e-3
    assert np.abs(z[2] - x).max() < 1e-7  # the polynomial fit of the discs


def test_slider_arm_is_fedorov_eq_11_summed_over_both_halves():
    """dx/dθ by the implicit function theorem (the energy model's arm of port ``slider``)
    equals −Σ σ_k r_k sin α_k / Σ cos β_k (Fedorov2018 Eq. 8, 10, 11 for both halves)."""
    mech = _pair(q=0.012, order=15)
    problem = load_spec(BALANCER)
    theta = np.linspace(*RANGE, 400)
    law = problem.mechanisms[0].output_target
    t = ca.SX.sym("t")
    x, dx = (np.asarray(v).ravel() for v in ca.Function(
        "law", [t], [law.expression([t], 0), ca.jacobian(law.expression([t], 0), t)]).map(theta.size)(theta))
    from cadcam.mechanisms.differential_pulley.fedorov_envelope import differential_envelopes
    mech, envs = differential_envelopes(mech, theta, x, dx, 0.055)
    coefs = [fit_pulley(p.basis, env) for p, env in zip(mech.profiles, envs)]
    mech, z = _solve(mech, coefs, theta, x[0], [env.phi_polar[0] for env in envs])
    c, q = np.concatenate(coefs), np.asarray(mech.parameter_values())
    bases = mech.bases
    th, zz, cc, qq = ca.SX.sym("th"), ca.SX.sym("z", 7), ca.SX.sym("c", c.size), ca.SX.sym("q", q.size)
    wound = np.asarray(ca.Function("W", [zz, cc], [wound_lengths(bases, zz, cc)]).map(theta.size)(z, c))
    ports = port_function(mech.structure(), "energy", 16).map(theta.size)
    _, arm, _, _ = ports(theta, z, z[:, 0], 0 * wound, wound, c, q)
    hand = ca.Function("eq11", [th, zz, cc, qq], [
        -sum(DifferentialPulley.moment_arms(bases, th, zz, cc, qq))
        / sum(DifferentialPulley.slider_cosines(bases, th, zz, cc, qq))]).map(theta.size)
    eq11 = np.asarray(hand(theta, z, c, q)).ravel()
    assert np.abs(np.asarray(arm).ravel() - eq11).max() < 1e-9
    assert np.abs(eq11).max() > 0.01  # a moving idler: the check is not trivially 0 = 0


@pytest.mark.parametrize("q", [0.0, 0.01])
def test_envelope_of_a_steady_transfer_is_a_circle(q):
    """Fedorov's envelope method (q = 0 and q ≠ 0): a fixed idler and cable transferred at
    σ(R − q) per radian give the circle of radius R."""
    theta = np.linspace(0, 4, 200)
    for sigma in (1.0, -1.0):
        env = envelope(theta, np.full_like(theta, 0.2), np.zeros_like(theta),
                       np.full_like(theta, sigma * (0.05 - q)), 0.3, sigma, q)
        assert np.abs(env.rho - 0.05).max() < 1e-12
        assert np.abs(env.curvature_radius - 0.05).max() < 1e-9
        assert env.convex


@pytest.fixture(scope="module")
def balancer():
    """The spec's design from the default start, through the NLP kept for its structure
    (:func:`cadcam.solve.builds.built_for`), as the design page's session designs it: the
    page's warm re-design below reuses that build instead of building it again."""
    completed, start = start_design(load_spec(BALANCER))
    return optimize(completed, built_for(completed)[0], start=start)


@pytest.mark.slow  # the balancer's design takes minutes on two cores
def test_balancer_meets_fedorovs_goals(balancer):
    r = balancer
    fine = r.recheck.metrics
    assert r.status == "success", r.recheck.violations
    assert fine["output_max_abs_error"][0] < 1e-5  # x(θ) within 0.01 mm over [−179°, 179°]
    mgl = 0.17 * 9.81 * 0.10
    assert fine["max_abs_error"][0] < 0.01 * mgl  # the energy torque within 1 % of m g l_p
    assert min(fine["curvature_radius_min"]) >= 0.005
    assert max(fine["alpha_max"]) < 2 * np.pi  # each wrap under one turn (a flat groove)
    assert min(fine["margins"]["mechanism"][0].values()) >= 0


@pytest.mark.slow  # the balancer's design takes minutes on two cores
def test_balancer_energy_is_constant_over_the_turn(balancer):
    ev = balancer.recheck
    mgl = 0.17 * 9.81 * 0.10
    theta = ev.theta[0]
    total = ev.energy + mgl * (1 - np.cos(theta))  # Fedorov2018 Eq. 16
    assert np.ptp(total) < 2e-4 * 2 * mgl
    assert np.ptp(ev.energy) == pytest.approx(2 * mgl, rel=1e-2)  # the springs do store it


@pytest.mark.slow  # the balancer's design takes minutes on two cores
def test_balancer_result_recomputes_from_its_json(balancer, tmp_path):
    """Saved and loaded, the result's problem (anchors, cable length, slider) and design (with
    the poses it was checked at) re-evaluate to the run's x(θ) and torques, on the design grid
    and on the fine one; so does the design against its spec, whose pair's cable length and
    anchors are completed as the run completed them (left at zero, no cable reaches: α
    beyond 7 rad)."""
    import cadcam

    balancer.save(tmp_path, workshop=None, figures=False)
    path = tmp_path / "result.json"
    assert cadcam.load_problem(path).mechanisms[0].cable_length == balancer.problem.mechanisms[0].cable_length
    for spec, run, grid in ((path, balancer.evaluation, None), (BALANCER, balancer.evaluation, None),
                            (path, balancer.recheck, balancer.problem.options.recheck_grid)):
        again = cadcam.evaluate(spec, path, grid=grid)
        np.testing.assert_allclose(again.units[0].z, run.units[0].z, rtol=0, atol=1e-9)  # α₁, α₂, x, …
        assert np.abs(again.tau - run.tau).max() <= 1e-9 * np.abs(run.tau).max()
        assert max(again.metrics.alpha_max) < 2 * np.pi and again.violations == run.violations


@pytest.mark.parametrize("key, value, message", [
    ("mechanisms.1.slider_range", [0.05, 0.2], "x_min > rho_max + idler_radius"),
    ("mechanisms.1.output_target.kind", "pendulum", "the kind of law: one of 'expression', 'table', 'spring_balance', 'cable_robot'"),
    ("mechanisms.1.groove", "spiral", "(planar per turn): one of 'flat', 'helical'"),
    ("mechanisms.1.output_target.expression", "1/(theta-theta)", "mechanisms[1].output_target"),
])
def test_malformed_differential_specs_get_one_line_errors(key, value, message):
    from cadcam.spec import apply_override
    data = read_spec_data(BALANCER)
    if key.endswith("expression"):
        apply_override(data, "mechanisms.1.output_target", {"kind": "expression", "expression": value})
    else:
        apply_override(data, key, value)
    with pytest.raises(SpecError) as err:
        parse_spec(data, "balancer.toml")
    assert message in str(err.value)
    assert "\n" not in str(err.value)


@pytest.mark.slow  # the balancer's design takes minutes on two cores
def test_balancer_outlines_close_round_the_hub_as_the_nlp_designed_them(balancer):
    """Wraps of nearly a turn leave no room for a rounded closure: the outline closes by the
    convex hull of the designed arc and the hub, which the NLP's outline rows keep the whole
    arc on, and the holes fit a 6 mm bore."""
    from cadcam.make.workshop import closed_outline, cut_outline, holes, polyline
    hub = balancer.problem.workshop.hub_radius
    for basis, c, prof in zip(balancer.design.bases, balancer.design.coefficients, balancer.recheck.profiles):
        end = float(prof.alpha.max())
        with pytest.raises(ValueError):
            closed_outline(basis, c, end)
        outline = cut_outline(basis, c, end, hub)
        pts = polyline(outline, 1e-5)
        edge = np.roll(pts, -1, axis=0) - pts
        nxt = np.roll(edge, -1, axis=0)
        assert (edge[:, 0] * nxt[:, 1] - edge[:, 1] * nxt[:, 0]).min() > -1e-12  # convex: every corner turns left
        rho0 = float(profile_function(basis)(0.0, c)[0])
        assert np.hypot(*outline.points[0]) == pytest.approx(rho0, rel=1e-9)
        assert outline.rho_range[0] >= hub - 1e-9
        holes(outline, balancer.problem.workshop.bore_diameter, 0.0025)  # raises if a wall is short


@pytest.mark.slow  # the balancer's design takes minutes on two cores
def test_balancer_files_give_its_torque_and_x(balancer, tmp_path):
    """Read back from the written DXFs, about the 0.5 mm cable's centre line (its anchor too,
    where pulley 2's cable is tied at the range's end), the pair moves the idler and so loads
    the pendulum as designed: x and the torque through the slider springs both within their
    requirements at every point of the fine grid, none unresolved."""
    import json
    balancer.save(tmp_path, figures=False)
    report = json.loads((tmp_path / "verification.json").read_text())
    assert {c["quantity"] for c in report["checks"]} == {"torque", "x"}
    for check in report["checks"]:
        assert check["passed"] and check["unresolved_points"] == 0, check
    assert report["passed"]


@pytest.mark.slow  # the balancer's design takes minutes on two cores
def test_a_warm_redesign_of_the_differential_balancer_is_no_worse_than_a_cold_one(balancer):
    """Fedorov's balancer on the design page's path: an edit of the spring's travel leaves the
    output law, and so the envelope's cable length, as it was (its rate and preload are the
    law's own, :func:`cadcam.app.state.in_step`, and move it), so the last answer and its
    multipliers start the design; it succeeds, in fewer iterations than the default start takes
    and to no worse an objective. The page designs the spec with spring 1's travel 2 % shorter
    first, then the spec itself warm from that answer; the cold design of the spec to compare
    with is this module's ``balancer`` (a design from the default start, through the same kept
    NLP), not designed a third time."""
    from cadcam.app.state import DesignState

    state = DesignState.template("fedorov2018_balancer")
    travel = state.field("springs.1.travel").value
    assert travel == load_spec(BALANCER).springs[0].travel
    state.edit("springs.1.travel", repr(0.98 * travel))
    first = state.design()
    assert first.result.success
    assert first.result.problem.mechanisms[0].cable_length == balancer.problem.mechanisms[0].cable_length
    state.edit("springs.1.travel", repr(travel))
    assert state.overrides == {}  # the spec itself
    warm = state.design("springs.1.travel").result
    cold = balancer
    assert warm.success and cold.success
    assert warm.message.endswith("(warm start from the last design)")
    assert warm.nit < cold.nit
    assert warm.fun <= cold.fun * (1 + 1e-6)
