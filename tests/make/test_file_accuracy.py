"""Workshop files as accurate as the design (issue 31): the biarc fit of the DXF, the torque and
x recomputed from the written file by plane geometry, and the verification report."""
import dataclasses
import json
import types
from pathlib import Path

import numpy as np
import pytest

import cadcam
from cadcam.make.biarc import arc_distance, biarc_fit
from cadcam.make.workshop import (GROOVE_ROWS, MIN_WALL, closed_outline, cut_outline, helical_groove, hull_outline,
                                  write_dxf, write_groove_csv)
from cadcam.mechanisms.anchored_pulley.file_model import anchored_path
from cadcam.outputs.run_files import write_workshop_files
from cadcam.outputs.verification import DISTANCE_SAMPLES, FIELDS, _polar_neighbours, file_error, recompute
from cadcam.physics.profile import Basis
from cadcam.verify.file_model import SAGITTA, STEP, file_torque, outline_points, read_dxf, read_groove, span_clearance

from ..mechanisms.anchored_pulley.test_anchored_pulley import random_convex_design

PENDULUM = Path(__file__).resolve().parents[2] / "models" / "ludovico2021_pendulum.toml"
BORE, ANCHOR = 6e-3, 2.5e-3  # [m]


def spiral(r0=0.03, s=0.002, q=-2e-4, phi_max=4.0):
    """A convex spiral pulley ρ = r0 + sφ + qφ² [m], closed into an outline."""
    b = Basis("monomial", 2, (0.0, phi_max))
    return closed_outline(b, b.from_monomial(np.array([r0, s, q])), phi_max)


def exact_distance(outline, chain, n=5001):
    """Largest distance [m] from ``n`` points of the outline to the chain's arcs."""
    points = outline.xy(np.linspace(0.0, 2 * np.pi, n, endpoint=False))[:, None]
    a, b = chain.vertices[None], np.roll(chain.vertices, -1, axis=0)[None]
    return arc_distance(points, a, b, chain.bulges[None]).min(axis=1).max()


# ----------------------------------------------------------------------------------- biarc fit

def test_biarcs_of_a_circle_lie_on_it():
    """A circle is fitted exactly: every vertex on it, every bulge tan(Δφ/4) of its span."""
    b = Basis("monomial", 0, (0.0, 3.0))
    chain = biarc_fit(closed_outline(b, b.from_monomial(np.array([0.04])), 3.0), 1e-6)
    np.testing.assert_allclose(np.hypot(*chain.vertices.T), 0.04, rtol=1e-12)
    phi = np.unwrap(np.arctan2(chain.vertices[:, 1], chain.vertices[:, 0]))
    span = np.diff(np.append(phi, phi[0] + 2 * np.pi))
    np.testing.assert_allclose(chain.bulges, np.tan(span / 4), rtol=1e-9)


@pytest.mark.parametrize("tolerance", [1e-6, 1e-8])
def test_biarc_fit_is_within_its_tolerance_everywhere(tolerance):
    """Measured point by point against the exact distance to the arcs (5001 points), the fit
    is within its tolerance and reports its error to within the samples' spare."""
    outline = spiral()
    chain = biarc_fit(outline, tolerance)
    measured = exact_distance(outline, chain)
    assert measured <= tolerance
    assert measured <= chain.error <= 1.1 * measured


def test_biarc_count_grows_as_the_cube_root_of_the_accuracy():
    """A biarc's error falls as the cube of its length (a polygon's as the square): 100× tighter
    takes about 100^(1/3) = 4.6× the vertices, not 10×."""
    outline = spiral()
    ratio = len(biarc_fit(outline, 1e-9).vertices) / len(biarc_fit(outline, 1e-7).vertices)
    assert 3.5 < ratio < 6.5


def test_dxf_holds_arcs_true_circles_and_millimetres(tmp_path):
    outline = spiral()
    chain = write_dxf(tmp_path / "cam1.dxf", outline, BORE, ANCHOR, 1e-7)
    back = read_dxf(tmp_path / "cam1.dxf")
    assert back.units == 4 and back.closed and back.reflex == 0
    np.testing.assert_allclose(back.vertices, chain.vertices, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.bulges, chain.bulges, rtol=0, atol=1e-15)
    assert back.vertices[0, 1] == 0 and back.vertices[0, 0] > 0  # the anchor on +x
    assert np.all(back.bulges > 0)  # arcs, each counter-clockwise
    (bore, d_bore), (_, d_anchor) = back.circles
    np.testing.assert_allclose([*bore, d_bore, d_anchor], [0, 0, BORE, ANCHOR], atol=1e-15)
    # convex curves within δ of each other differ in length by at most 2πδ
    assert back.length == pytest.approx(np.sum(np.hypot(*np.diff(outline.xy(
        np.linspace(0, 2 * np.pi, 200001)), axis=0).T)), abs=2 * np.pi * 1e-7)


# ------------------------------------------------------------------------------ file model

def test_the_files_error_measured_round_each_points_polar_angle_is_the_error_to_every_arc(tmp_path):
    """The verification's distance from the outline to its file, measured to the arcs round
    each point's polar angle only, is exactly the distance to the nearest of all the arcs, at
    its points, wound either way; a chain that does not wind round the axis (the same chain 1 m off it) or an
    open one is measured against every arc, and gives the same error for the same offset."""
    outline = spiral()
    write_dxf(tmp_path / "cam1.dxf", outline, BORE, ANCHOR, 1e-7)
    chain = read_dxf(tmp_path / "cam1.dxf")
    points = outline.xy(np.linspace(0.0, 2 * np.pi, DISTANCE_SAMPLES, endpoint=False))
    assert _polar_neighbours(points, chain) is not None
    assert file_error(outline, chain) == exact_distance(outline, chain, DISTANCE_SAMPLES) > 0
    mirrored = types.SimpleNamespace(xy=lambda phi: outline.xy(phi) * [1.0, -1.0])  # wound clockwise
    back = dataclasses.replace(chain, vertices=chain.vertices * [1.0, -1.0], bulges=-chain.bulges)
    assert _polar_neighbours(points * [1.0, -1.0], back) is not None
    assert file_error(mirrored, back) == exact_distance(mirrored, back, DISTANCE_SAMPLES)
    off = dataclasses.replace(chain, vertices=chain.vertices + [1.0, 0.0])
    assert _polar_neighbours(points, off) is None
    assert file_error(outline, off) == pytest.approx(exact_distance(outline, off, DISTANCE_SAMPLES), rel=1e-12)
    assert _polar_neighbours(points, dataclasses.replace(chain, closed=False)) is None


@pytest.fixture(scope="module")
def pendulum():
    return cadcam.load_spec(PENDULUM)


def test_cable_round_a_circle_from_the_file_is_the_closed_form(tmp_path, pendulum):
    """A circular pulley of radius r, the spring end at ℓ turning with the link: the path is
    r (θ − a₀ − acos(r/ℓ)) + √(ℓ² − r²) (tangent from a point; wrapped arc)."""
    r, ell, a0 = 0.03, 0.2, -0.5
    b = Basis("monomial", 0, (0.0, 4.0))
    write_dxf(tmp_path / "c.dxf", closed_outline(b, b.from_monomial(np.array([r])), 4.0), BORE, ANCHOR, 1e-9)
    mech = dataclasses.replace(pendulum.mechanisms[1], spring_end_x=ell, spring_end_y=0.0, turning="spring_end",
                               sense=1.0, winding="ccw", anchor_angle=a0)
    theta = np.linspace(1.5, 4.0, 7)
    expected = r * (theta - a0 - np.arccos(r / ell)) + np.sqrt(ell**2 - r**2)
    np.testing.assert_allclose(anchored_path(read_dxf(tmp_path / "c.dxf"), mech, theta), expected,
                               rtol=0, atol=1e-12)


def test_cable_to_an_idler_beyond_the_anchors_tangent_runs_straight_from_the_anchor(tmp_path):
    """A circular pulley of radius r anchored at (r, 0), an idler of radius q at P = (r − q + s,
    40 mm) (a differential pair's idler near the profile that unwinds): for s ≤ 0 the cable is
    wound to the two circles' common tangent, n·P + q = r at ψ = α − acos((r − q)/|P|), length
    rψ + √(|P|² − (r − q)²); for s > 0 the idler pokes out past the anchor's tangent and the
    cable runs straight from the anchor A, ψ = β + acos(q/|A − P|) < 0 (β the angle of A − P),
    length √(|A − P|² − q²): both sides by closed form, meeting at s = 0."""
    r, q = 0.03, 0.008
    b = Basis("monomial", 0, (0.0, 4.0))
    write_dxf(tmp_path / "c.dxf", closed_outline(b, b.from_monomial(np.array([r])), 4.0), BORE, ANCHOR, 1e-9)
    shift = np.linspace(-q / 2, q / 2, 9)
    target = np.column_stack([r - q + shift, np.full(shift.size, 0.04)])
    psi, point, wrapped = read_dxf(tmp_path / "c.dxf").tangent(target, np.arctan2(target[:, 1], target[:, 0]), q)
    wound = shift <= 0
    norm, away = np.hypot(*target.T), np.hypot(*(np.array([r, 0.0]) - target).T)
    beta = np.arctan2(-target[:, 1], r - target[:, 0])
    expected_psi = np.where(wound, np.arctan2(target[:, 1], target[:, 0]) - np.arccos((r - q) / norm),
                            beta + np.arccos(q / away))
    expected_length = np.where(wound, r * expected_psi + np.sqrt(norm**2 - (r - q) ** 2), np.sqrt(away**2 - q**2))
    n = np.column_stack([np.cos(psi), np.sin(psi)])
    np.testing.assert_allclose(psi, expected_psi, rtol=0, atol=1e-9)
    np.testing.assert_allclose(wrapped + np.hypot(*(target + q * n - point).T), expected_length, rtol=0, atol=1e-9)


def test_cable_wound_past_a_hull_closures_grazing_end_runs_on_round_the_hub(tmp_path, pendulum):
    """A spiral ρ = 25 mm − 2 mm/rad φ over 4.5 rad closed by its hull round a hub that its end
    tangent, at ρ₁²/√(ρ₁² + ρ′²) from the axis, misses by 10 pm (a design meeting its outline
    row to the solver's tolerance): the hull leaves the arc's end turning inwards by ~5e-9 rad, a
    notch 1e-11 m deep. The file's outline is convex and the cable wound a step past the arc's
    end (the central difference of the torque at the most-wound pose) runs on round the hub:
    from the pose leaving the arc's end, L grows by the hub's radius per radian the spring end
    turns about the axis (dL/dθ is the cable's distance from the axis), to the fit's 1 nm."""
    r0, slope, phi_max = 0.025, -0.002, 4.5
    b = Basis("monomial", 1, (0.0, phi_max))
    r1 = r0 + slope * phi_max
    arm = r1**2 / np.hypot(r1, slope)
    hub, fit = arm + 1e-11, 1e-9
    write_dxf(tmp_path / "h.dxf", hull_outline(b, b.from_monomial(np.array([r0, slope])), phi_max, hub),
              BORE, ANCHOR, fit)
    file = read_dxf(tmp_path / "h.dxf")
    assert file.reflex == 0 and file.end[-1] - file.start[0] == pytest.approx(2 * np.pi, abs=1e-12)
    ell, a0 = 0.2, -0.5
    mech = dataclasses.replace(pendulum.mechanisms[1], spring_end_x=ell, spring_end_y=0.0, turning="spring_end",
                               sense=1.0, winding="ccw", anchor_angle=a0)
    # the spring end on the end's tangent, ℓ from the axis: p₁ + t·T with |p₁ + t·T| = ℓ
    p1 = r1 * np.array([np.cos(phi_max), np.sin(phi_max)])
    tangent = np.array([slope * np.cos(phi_max) - r1 * np.sin(phi_max),
                        slope * np.sin(phi_max) + r1 * np.cos(phi_max)]) / np.hypot(r1, slope)
    t = -p1 @ tangent + np.sqrt((p1 @ tangent) ** 2 - p1 @ p1 + ell**2)
    leaving = np.unwrap([phi_max, np.arctan2(*(p1 + t * tangent)[::-1])])[1] + a0
    path = anchored_path(file, mech, leaving + np.array([0.0, STEP]))
    assert np.diff(path)[0] / STEP == pytest.approx(hub, abs=fit)


@pytest.fixture(scope="module")
def random_pendulum(pendulum):
    """Ludovico2021's antagonistic pair (pulley 1 wound clockwise) with a random convex design."""
    design = random_convex_design(pendulum, np.random.default_rng(31))
    return design, cadcam.evaluate(pendulum, design, grid=31)


def _file_torque(tmp_path, problem, design, ev, tolerance, coefficients=None):
    """The joint torque recomputed from DXFs of the design's pulleys fitted within ``tolerance``."""
    chains = {}
    for i, (b, c) in enumerate(zip(design.bases, coefficients or design.coefficients)):
        outline = closed_outline(b, c, float(ev.profiles[i].alpha.max()))
        write_dxf(tmp_path / f"cam{i + 1}.dxf", outline, BORE, ANCHOR, tolerance)
        chains[i] = read_dxf(tmp_path / f"cam{i + 1}.dxf")
    return file_torque(problem, design, {i: [c] for i, c in chains.items()}, np.atleast_2d(ev.units[0].theta))[0], chains


def test_torque_from_the_file_converges_to_the_design(tmp_path, pendulum, random_pendulum):
    """The torque from the written files meets cadcam's energy torque as the fit tightens: to
    1e-4 N·m at 1 nm (torques of 10–200 N·m), and 100× looser is over 10× further off (the
    recompute sees the file's error: a moment arm δ short costs about F·δ)."""
    design, ev = random_pendulum
    tight, _ = _file_torque(tmp_path, pendulum, design, ev, 1e-9)
    loose, _ = _file_torque(tmp_path, pendulum, design, ev, 1e-7)
    near, far = np.abs(tight - ev.tau[0]).max(), np.abs(loose - ev.tau[0]).max()
    assert near < 1e-4
    assert far > 10 * near


def test_a_file_of_another_outline_fails_the_check(tmp_path, pendulum, random_pendulum):
    """Files of the pulleys 20 µm larger than designed: the torque from them is off by at least
    the moment arms' share, |F₂ − F₁|·20 µm (measured twice that: the wrap, and so the springs'
    extensions, grow too), and a design whose own error were 1 µN·m fails the check by far."""
    design, ev = random_pendulum
    grown = [c + _constant(b, 2e-5) for b, c in zip(design.bases, design.coefficients)]
    _, chains = _file_torque(tmp_path, pendulum, design, ev, 1e-9, grown)
    accurate = types.SimpleNamespace(problem=pendulum, design=design, tensor=ev.tensor, units=ev.units,
                                     metrics=types.SimpleNamespace(max_abs_error=[1e-6]))
    (check,) = recompute(types.SimpleNamespace(problem=pendulum, evaluation=ev, recheck=accurate), chains)
    force = [s.rate * x + s.preload for s, x in zip(pendulum.springs, ev.x)]
    assert check["file_max_abs_error"] > np.max(np.abs(force[1] - force[0])) * 2e-5
    assert not check["passed"] and check["file_max_abs_error"] > 10 * check["required"]


def _constant(basis, value):
    """Coefficients of the constant ``value`` in ``basis``."""
    m = np.zeros(basis.size)
    m[0] = value
    return basis.from_monomial(m)


def test_every_design_writes_its_verification_report(tmp_path, pendulum, random_pendulum):
    """``verification.json`` holds every declared field and passes for files fitted to the
    design's accuracy; the DXF has at most 2000 vertices, closed, convex, in mm, and leaves the
    minimum wall."""
    design, ev = random_pendulum
    result = types.SimpleNamespace(problem=pendulum, evaluation=ev, recheck=ev)
    write_workshop_files(result, tmp_path, pendulum.workshop, sheets=False)
    report = json.loads((tmp_path / "verification.json").read_text())
    assert set(report["fields"]) == set(FIELDS)
    assert report["passed"] and all(c["passed"] for c in report["checks"])
    for cam in report["cams"]:
        assert cam["units"] == "mm" and cam["closed"] and cam["convex"] and cam["concavity_m"] <= 1e-9
        assert cam["vertices"] <= 2000
        assert cam["file_error_m"] <= cam["fit_tolerance_m"]
        assert cam["walls_hold"] and min(cam["bore_wall_m"], cam["anchor_wall_m"], cam["holes_wall_m"]) >= MIN_WALL - 1e-9
        # each free span tangent to the centre line, the cable's radius off the part
        assert cam["spans_clear"] and cam["cable_clearance_m"] == pytest.approx(cam["cable_radius_m"], abs=1e-12)
    assert "file_max_abs_error" in (tmp_path / "verification.md").read_text()


def test_biarcs_of_a_convex_outline_all_turn_left():
    """ρ = 20 mm − 0.5 mm/rad² φ² over 4.5 rad, fitted within 0.01 mm: one interval's equal-
    tangent biarc is S-shaped (its ends lean unevenly on its chord); the fit halves it, so that
    every arc turns counter-clockwise, like the outline."""
    chain = biarc_fit(spiral(r0=0.02, s=0.0, q=-5e-4, phi_max=4.5), 1e-5)
    assert np.all(chain.bulges > 0)


def test_a_cable_with_a_diameter_lies_on_the_designed_curve_and_the_part_is_cut_inside_it(tmp_path, pendulum,
                                                                                        random_pendulum):
    """Under a 1 mm cable the cut outline lies 0.5 mm inside the designed curve, the cable's
    centre line: the torque recomputed from the written DXFs about that centre line meets the
    design, and the same files taken as the centre line itself (no cable) are far off."""
    import dataclasses

    from cadcam.make.workshop import cut_outline, designed_values
    design, ev = random_pendulum
    cabled = dataclasses.replace(pendulum, workshop=dataclasses.replace(pendulum.workshop, cable_diameter=1e-3))
    result = types.SimpleNamespace(problem=cabled, evaluation=ev, recheck=ev)
    write_workshop_files(result, tmp_path, cabled.workshop, sheets=False)
    report = json.loads((tmp_path / "verification.json").read_text())
    assert report["passed"] and all(c["passed"] for c in report["checks"])
    for cam in report["cams"]:  # each free span tangent to the centre line, its radius off the part
        assert cam["spans_clear"] and cam["cable_clearance_m"] == pytest.approx(5e-4, abs=1e-9)
    b, c, end = design.bases[0], design.coefficients[0], float(ev.profiles[0].alpha.max())
    cut = cut_outline(b, c, end, cabled.workshop.hub_radius, 5e-4)
    phi = np.linspace(0.0, end, 300)
    rho = designed_values(cut.profile, c, phi)[0]
    centre = np.column_stack((rho * np.cos(phi), rho * np.sin(phi)))
    gap = np.min(np.linalg.norm(centre[:, None] - cut.xy(np.linspace(0.0, end, 20000))[None], axis=2), axis=1)
    np.testing.assert_allclose(gap, 5e-4, rtol=1e-4)
    chains = {i: read_dxf(tmp_path / f"cam{i + 1}.dxf") for i in range(len(design.bases))}
    (about_centre,), (ignored,) = (recompute(types.SimpleNamespace(problem=p, evaluation=ev, recheck=ev), chains)
                                   for p in (cabled, pendulum))
    assert ignored["file_max_abs_error"] > 100 * about_centre["file_max_abs_error"]


# ------------------------------------------------------------------------------------ wire cam

@pytest.fixture(scope="module")
def table3_ev(rr_problem, table3):
    """Johnston2023's Table 3 cams on the RR arm, evaluated on a 31 × 31 grid."""
    return cadcam.evaluate(rr_problem, table3, grid=31)


def _wire_cam_files(tmp_path, problem, design, ev, tolerance, grow=0.0):
    """The RR arm's cams (their designed curves ``grow`` [m] larger) written as DXFs fitted within
    ``tolerance`` and read back (the cut outlines, the cable's radius inside its centre line)."""
    chains = {}
    for i, (b, c) in enumerate(zip(design.bases, design.coefficients)):
        end = float(max(ev.profiles[i].alpha.max(), ev.profiles[i].phi.max()))
        outline = cut_outline(b, c + _constant(b, grow), end, problem.workshop.hub_radius,
                              problem.workshop.cable_radius)
        write_dxf(tmp_path / f"cam{i + 1}.dxf", outline, BORE, ANCHOR, tolerance)
        chains[i] = read_dxf(tmp_path / f"cam{i + 1}.dxf")
    return chains


def test_wire_cam_torque_from_the_file_converges_to_the_design(tmp_path, rr_problem, table3, table3_ev):
    """Each joint's torque of the RR arm recomputed from its cams' files (the follower idler
    pressed against the cam at its platform's height, the wire wrapped to it) meets cadcam's
    energy torque as the fit tightens: 100× looser is over 10× further off, so the recompute
    sees the file's error and not a floor of its own."""
    sample = table3_ev.tensor.sample(table3_ev.tensor.whole())
    off = {}
    for tolerance in (1e-9, 1e-7):
        chains = _wire_cam_files(tmp_path, rr_problem, table3, table3_ev, tolerance)
        centre = {i: [c.centre_line(rr_problem.workshop.cable_radius)] for i, c in chains.items()}
        off[tolerance] = np.abs(file_torque(rr_problem, table3, centre, sample["theta"]) - sample["tau"]).max()
    assert off[1e-9] < 1e-4 * np.abs(sample["tau"]).max()
    assert off[1e-7] > 10 * off[1e-9]


def test_a_wire_cam_file_of_a_larger_cam_fails_the_check(tmp_path, rr_problem, table3, table3_ev):
    """Cams 20 µm larger than designed push each idler, and so its platform spring, out: the
    torque from those files moves as the symbolic model's torque of the larger cams does (two
    paths, to 5 %), and the check of the files against the design fails."""
    grown = dataclasses.replace(table3, coefficients=[c + _constant(b, 2e-5)
                                                      for b, c in zip(table3.bases, table3.coefficients)])
    sample = table3_ev.tensor.sample(table3_ev.tensor.whole())
    chains = _wire_cam_files(tmp_path, rr_problem, grown, table3_ev, 1e-9)
    centre = {i: [c.centre_line(rr_problem.workshop.cable_radius)] for i, c in chains.items()}
    by_file = file_torque(rr_problem, table3, centre, sample["theta"]) - sample["tau"]
    by_model = cadcam.evaluate(rr_problem, grown, grid=31).tau - sample["tau"]
    np.testing.assert_allclose(by_file, by_model, atol=0.05 * np.abs(by_model).max())
    accurate = types.SimpleNamespace(problem=rr_problem, design=table3, tensor=table3_ev.tensor,
                                     units=table3_ev.units, metrics=types.SimpleNamespace(max_abs_error=[1e-6] * 2))
    result = types.SimpleNamespace(problem=rr_problem, evaluation=table3_ev, recheck=accurate)
    assert not any(c["passed"] for c in recompute(result, chains))


def test_a_force_model_design_is_judged_against_its_energy_torque(tmp_path, rr_problem, table3, table3_ev):
    """Under Johnston2023's force model as printed, the design's torque is not the energy torque
    the files give: the files are judged against the design's energy torque, exactly as under the
    energy model, and the force model's departure from it is stated."""
    chains = _wire_cam_files(tmp_path, rr_problem, table3, table3_ev, 1e-7)
    forced = rr_problem.with_torque_model("force-as-printed")
    printed = cadcam.evaluate(forced, table3, grid=31)
    energy = recompute(types.SimpleNamespace(problem=rr_problem, evaluation=table3_ev, recheck=table3_ev), chains)
    checks = recompute(types.SimpleNamespace(problem=forced, evaluation=printed, recheck=printed), chains)
    assert [c["file_max_abs_error"] for c in checks] == [c["file_max_abs_error"] for c in energy]
    gap = np.abs(printed.tau - table3_ev.tau).max(axis=1)
    np.testing.assert_allclose([c["model_gap"] for c in checks], gap, rtol=1e-12)
    assert gap.min() > 0 and all("passed" in c for c in checks)


# ------------------------------------------------------------------------------ roller follower

def test_roller_follower_torque_from_the_file_converges_to_the_design(tmp_path):
    """The roller pendulum's torque recomputed from its cam's file (the roller pressed onto the
    outline along its stem) meets cadcam's energy torque as the fit tightens, 100× looser
    over 10× further off."""
    problem = cadcam.load_problem(Path(__file__).resolve().parents[2] / "models" / "roller_follower_pendulum.toml",
                                  overrides={"solver.grid": 21})
    design = cadcam.design(problem).design
    ev = cadcam.evaluate(problem, design, grid=41)
    end = float(ev.profiles[0].alpha.max())
    off = {}
    for tolerance in (1e-9, 1e-7):
        outline = cut_outline(design.bases[0], design.coefficients[0], end, problem.workshop.hub_radius)
        write_dxf(tmp_path / "cam1.dxf", outline, BORE, ANCHOR, tolerance)
        tau = file_torque(problem, design, {0: [read_dxf(tmp_path / "cam1.dxf")]}, np.atleast_2d(ev.units[0].theta))
        off[tolerance] = np.abs(tau - ev.tau).max()
    assert off[1e-9] < 1e-4 * np.abs(ev.tau).max()
    assert off[1e-7] > 10 * off[1e-9]


def test_a_centre_lines_anchor_lies_the_cable_radius_out(tmp_path):
    """The cable is tied at the cut outline's first vertex: its centre line starts the cable's
    radius out along the outline's normal there, and a cable straight from the anchor leaves
    from that point (before, from the cut outline's vertex: a kink in its length where the
    cable's wrap runs out)."""
    write_dxf(tmp_path / "cam.dxf", spiral(), BORE, ANCHOR, 1e-8)
    cut = read_dxf(tmp_path / "cam.dxf")
    centre = cut.centre_line(5e-4)
    normal = np.array([np.cos(cut.start[0]), np.sin(cut.start[0])])
    np.testing.assert_allclose(centre.anchor, cut.vertices[0] + 5e-4 * normal, atol=1e-15)
    assert centre.support(np.array([cut.start[0]]))[1][0] == pytest.approx(centre.anchor, abs=1e-9)



# ----------------------------------------------------------------------------------- clearance

def test_outline_points_follow_the_arcs_within_the_sagitta(tmp_path):
    """The points of a circle's file lie on it, and no chord between neighbours strays more
    than the sagitta from it (its midpoint's distance inside)."""
    b = Basis("monomial", 0, (0.0, 3.0))
    write_dxf(tmp_path / "disc.dxf", closed_outline(b, b.from_monomial(np.array([0.04])), 3.0), BORE, ANCHOR, 1e-6)
    points = outline_points(read_dxf(tmp_path / "disc.dxf"))
    np.testing.assert_allclose(np.hypot(*points.T), 0.04, atol=1e-12)
    mid = (points + np.roll(points, -1, axis=0)) / 2
    assert 0.04 - np.hypot(*mid.T).min() <= SAGITTA


def test_span_clearance_is_signed_by_the_side_the_part_is_on():
    """Spans past a unit square: beside it at 0.25 on its left (+0.25), through it 0.25 deep
    (−0.25), and ending short of it (the distance from its end)."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    start = np.array([[2.0, 1.25], [2.0, 0.75], [3.0, 0.5]])
    end = np.array([[-1.0, 1.25], [-1.0, 0.75], [1.5, 0.5]])
    np.testing.assert_allclose(span_clearance(square, start, end), [0.25, -0.25, np.hypot(0.5, 0.5)])


def test_span_clearance_in_blocks_is_each_pair_measured_on_its_own(monkeypatch):
    """Random spans past random points, measured in blocks of a few spans: each span's least
    signed distance as measured pair by pair (the side of the span's line where the point is
    beside it, else its distance from the nearer end), to rounding."""
    import cadcam.verify.file_model as file_model

    rng = np.random.default_rng(7)
    points, start, end = rng.normal(size=(40, 2)), rng.normal(size=(25, 2)), rng.normal(size=(25, 2))
    monkeypatch.setattr(file_model, "CLEARANCE_BLOCK", 100)
    expected = []
    for s, e in zip(start, end):
        u = (e - s) / np.linalg.norm(e - s)
        each = [u[0] * (p - s)[1] - u[1] * (p - s)[0] if 0 < (p - s) @ u < np.linalg.norm(e - s)
                else min(np.linalg.norm(p - s), np.linalg.norm(p - e)) for p in points]
        expected.append(min(each))
    np.testing.assert_allclose(span_clearance(points, start, end), expected, rtol=0, atol=1e-15)


# ------------------------------------------------------------------------------- helical groove

def _archimedes_groove(tmp_path, tolerance, a=0.03, b=0.002, phi_max=5 * np.pi):
    """The spiral ρ = a + bφ over 2.5 turns written as a helical groove's centre line within
    ``tolerance`` [m] and read back: the rows written and the chain."""
    basis = Basis("monomial", 1, (0.0, phi_max))
    rows = helical_groove(basis, basis.from_monomial(np.array([a, b])), phi_max, 0.004, tolerance)
    write_groove_csv(tmp_path / "cam1_groove.csv", rows)
    return rows, read_groove(tmp_path / "cam1_groove.csv")


def test_a_groove_read_back_winds_the_spiral_by_closed_form(tmp_path):
    """ρ = a + bφ over 2.5 turns, its chords within 10 nm: the file's chain is open, from the
    anchor on +x winding on, its normal unwrapped across the turns, to the last row a step past
    the range. Its normal at φ is ψ = φ − atan(b/ρ) and its length from the anchor
    W(φ) = [ρq + b² ln(ρ + q)]/(2b) from 0, q = √(ρ² + b²). A chord sagging δ over a turn ε of
    the tangent is shorter than its arc by about δε/3, so the file's length is short of W by
    at most tolerance·(ψ − ψ₀)/3, never long; so is the cable wound to a target d along the
    spiral's tangent at φ (its path W(φ) + d), which leaves at ψ(φ) to within the support
    function's error over d."""
    a, b, tolerance, d = 0.03, 0.002, 1e-8, 0.1
    rows, chain = _archimedes_groove(tmp_path, tolerance, a, b)
    assert chain.groove and not chain.closed and chain.reflex == 0 and chain.units == 4
    np.testing.assert_allclose(chain.vertices[[0, -1]], rows[[0, -1], 2:4], rtol=0, atol=1e-15)

    def psi(phi):
        return phi - np.arctan(b / (a + b * phi))

    def wound(phi):
        r = a + b * phi
        return (r * np.hypot(r, b) + b**2 * np.log(r + np.hypot(r, b))) / (2 * b)

    last, step = rows[-1, 0], rows[1, 0]
    assert last == pytest.approx(5 * np.pi + step, abs=1e-12)
    # the normals run on across the turns, the chords' (parallel to the tangent near their middles)
    # from half a step past the anchor to half a step short of the last row
    assert chain.end[-1] - chain.start[0] == pytest.approx(psi(last - step / 2) - psi(step / 2), abs=step**2)
    short = wound(last) - wound(0.0) - chain.length
    assert 0 <= short <= tolerance * (psi(last) - psi(0.0)) / 3
    _, end, wrapped = chain.support(np.array([chain.end[-1]]))
    np.testing.assert_allclose([*end[0], wrapped[0]], [*chain.vertices[-1], chain.length], rtol=0, atol=1e-15)
    phi = np.linspace(0.5, 5 * np.pi, 9)
    r = a + b * phi
    tangent = np.column_stack([b * np.cos(phi) - r * np.sin(phi), b * np.sin(phi) + r * np.cos(phi)])
    tangent /= np.hypot(r, b)[:, None]
    target = np.column_stack([r * np.cos(phi), r * np.sin(phi)]) + d * tangent
    around = phi + np.arctan2(d * r / np.hypot(r, b), r + d * b / np.hypot(r, b))  # the target's polar angle
    leaving, point, wrapped = chain.tangent(target, around)
    np.testing.assert_allclose(leaving, psi(phi), rtol=0, atol=tolerance / d)
    short = wound(phi) - wound(0.0) + d - (wrapped + np.hypot(*(target - point).T))
    assert np.all(short >= 0) and np.all(short <= tolerance * (psi(phi) - psi(0.0)) / 3)


def test_groove_rows_follow_the_tolerance_up_to_their_cap(tmp_path):
    """The chords of the groove's CSV sag to within its tolerance and near it (equal steps sized
    where the spiral bends most: a circle-like spiral's sag varies little); 100× tighter takes
    10× the rows (sag ∝ step²), and a tolerance needing more than GROOVE_ROWS rows gets that
    many."""
    from cadcam.outputs.verification import groove_report

    basis = Basis("monomial", 1, (0.0, 5 * np.pi))
    coefficients = basis.from_monomial(np.array([0.03, 0.002]))
    rows = {}
    for tolerance in (1e-6, 1e-8):
        rows[tolerance], chain = _archimedes_groove(tmp_path, tolerance)
        error = groove_report(1, basis, coefficients, 5 * np.pi, chain, tolerance, 0.0)["file_error_m"]
        assert 0.5 * tolerance < error <= tolerance
    assert len(rows[1e-8]) / len(rows[1e-6]) == pytest.approx(10, rel=0.01)
    assert len(_archimedes_groove(tmp_path, 1e-12)[0]) == GROOVE_ROWS
