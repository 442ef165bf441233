"""Walls measured with a sign and convexity judged from the exact arcs (issue 51, item 1): the
signed distance from a point to a chain of arcs, the chain's concavity, where the anchor hole
goes, and the walls a written DXF keeps, read back."""
import json
import re
import types

import ezdxf
import numpy as np
import pytest

import cadcam
from cadcam.make.biarc import biarc_fit, concavity, signed_distance
from cadcam.make.workshop import MIN_WALL, ROUNDING, cut_outline, hole_walls, holes, hull_outline, write_dxf
from cadcam.outputs.verification import cam_report, passed
from cadcam.physics.outline import NOTCH
from cadcam.physics.profile import Basis
from cadcam.verify.file_model import read_dxf

from ..conftest import ROOT

BORE, ANCHOR = 6e-3, 2.5e-3  # [m]


def circle(radius, count=7):
    """A circle of ``radius`` [m] about the origin as ``count`` arcs, counter-clockwise:
    vertices and bulges."""
    angle = np.linspace(0.0, 2 * np.pi, count, endpoint=False)
    return radius * np.column_stack([np.cos(angle), np.sin(angle)]), np.full(count, np.tan(np.pi / (2 * count)))


def teardrop(kink=0.0, radius=0.01, apex=0.03):
    """The hull of a circle of ``radius`` [m] about the origin and the point (``apex``, 0): an
    arc from the tangent point T above round the far side to the tangent point below, the line
    on to the apex and the line back to T. With a ``kink`` δ [rad] the apex is turned about T
    so that the line arrives at T turned δ into the part: there the outline turns δ clockwise."""
    half = np.arccos(radius / apex)
    high, low = radius * np.array([np.cos(half), np.sin(half)]), radius * np.array([np.cos(half), -np.sin(half)])
    turn = np.array([[np.cos(kink), -np.sin(kink)], [np.sin(kink), np.cos(kink)]])
    tip = high + turn @ (np.array([apex, 0.0]) - high)
    return np.array([high, low, tip]), np.array([np.tan((2 * np.pi - 2 * half) / 4), 0.0, 0.0])


def sharp_pulley():
    """A spiral pulley ρ = 22 mm − 25 mm/rad·φ over 0.46 rad closed by the hull round a 4 mm hub:
    its anchor at φ = 0 is a sharp corner (as Endo2010's five-bar cam 2), where the inward
    normal runs out of the part within 2.25 mm."""
    return hull_outline(Basis("monomial", 1, (0.0, 1.0)), np.array([0.022, -0.025]), 0.46, 0.004)


# ------------------------------------------------------------------------------ signed distance

def test_signed_distance_to_a_circle_of_arcs_is_its_radius_less_the_distance_from_its_centre():
    vertices, bulges = circle(0.01)
    points = np.array([[0.0, 0.0], [0.004, -0.003], [0.0099, 0.0], [0.0, 0.0101], [0.02, 0.015], [-0.0071, 0.0071]])
    np.testing.assert_allclose(signed_distance(points, vertices, bulges), 0.01 - np.hypot(*points.T),
                               rtol=0, atol=1e-15)


def test_a_hole_outside_or_across_the_outline_has_a_negative_wall():
    """A Ø2.5 mm hole in a Ø20 mm disc: centred 8 mm out it leaves 0.75 mm; centred 9.5 mm out
    its edge is 0.75 mm outside (centre inside); centred 12.26 mm out, 2.26 mm outside the outline
    as on Endo2010's five-bar cam 2, its wall is −3.51 mm. Unsigned, the last would read 1.01 mm."""
    vertices, bulges = circle(0.01)
    chain = types.SimpleNamespace(vertices=vertices, bulges=bulges)
    walls = [hole_walls(chain, [x, 0.0], ANCHOR, BORE)[0] for x in (0.008, 0.0095, 0.01226)]
    np.testing.assert_allclose(walls, [0.75e-3, -0.75e-3, -3.51e-3], rtol=0, atol=1e-15)


def test_the_lens_of_an_arc_counts_inside_where_it_bulges_out_and_outside_where_it_bulges_in():
    """A 10 mm square whose top side bulges 1 mm out (an arc of bulge 0.2) and whose bottom side
    bulges 1 mm in: a point in the top lens is inside, one in the bottom lens outside, each by
    its distance to the arc."""
    vertices = 0.01 * np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    bulges = np.array([-0.2, 0.0, 0.2, 0.0])  # sagitta = chord · bulge / 2 = 1 mm
    radius = 0.01 * (1 + 0.2**2) / (4 * 0.2)  # of an arc of chord 10 mm and sagitta 1 mm
    top, bottom = np.array([0.005, 0.0105]), np.array([0.005, 0.0005])
    np.testing.assert_allclose(signed_distance([top, bottom], vertices, bulges),
                               [0.0005, -0.0005], rtol=0, atol=1e-15)
    # beside the lenses: inside near the bottom corner, the top arc's circle decides near the top
    centre_top = np.array([0.005, 0.011 - radius])
    near = np.array([0.009, 0.0102])
    assert signed_distance([near], vertices, bulges)[0] == pytest.approx(radius - np.hypot(*(near - centre_top)),
                                                                         abs=1e-15)


# -------------------------------------------------------------------------------------- convexity

def test_a_circle_and_a_teardrop_of_arcs_are_convex():
    assert abs(concavity(*circle(0.01))) <= 1e-17
    assert abs(concavity(*teardrop())) <= 1e-17


@pytest.mark.parametrize("kink", [1e-4, 1e-3, 1e-2])
def test_a_joint_turning_inwards_dips_beyond_its_tangent_by_the_circles_sag(kink):
    """A line arriving at an arc of radius R turned δ into the part: the arc dips beyond the
    line's extension by R(1 − cos δ), the exact arcs' concavity (the line's far end reaches
    beyond the arc's tangent far more, δ·20 mm). At 1e-4 rad that is 5e-11 m, convex to
    rounding, as Fedorov2018's balancer's anchor; at 1e-3 rad 5e-9 m, a notch."""
    depth = concavity(*teardrop(kink))
    assert depth == pytest.approx(0.01 * (1 - np.cos(kink)), rel=1e-6)
    assert (depth <= NOTCH) == (kink == 1e-4)


def test_an_arc_turning_inwards_is_as_concave_as_its_sag():
    vertices = 0.01 * np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    assert concavity(vertices, np.array([0.0, 0.0, -0.1, 0.0])) == pytest.approx(0.01 * 0.1 / 2, rel=1e-12)
    assert concavity(vertices, np.array([0.0, 0.0, 0.1, 0.0])) == 0.0


def test_a_chain_wound_clockwise_is_not_convex():
    vertices, bulges = circle(0.01)
    assert concavity(vertices[::-1], -bulges[::-1]) == np.inf


# ---------------------------------------------------------------------------------- hole places

def test_the_hub_of_a_hull_closure_is_written_exactly():
    """The hull's lines and the hub's arc are fitted piece by piece, each exactly: the DXF's
    least radius is the hub's, so the bore keeps its wall to rounding (fitted across the
    pieces' joints, the arcs strayed up to the tolerance inside the hub)."""
    outline = sharp_pulley()
    chain = biarc_fit(outline, 1e-5)
    assert signed_distance(np.zeros((1, 2)), chain.vertices, chain.bulges)[0] == pytest.approx(0.004, abs=1e-15)


def test_an_anchor_hole_whose_normal_runs_out_of_the_part_goes_into_the_corner():
    """On the sharp pulley the hole a wall and its radius in along the inward normal would lie
    outside the part (its wall −2.64 mm); the hole goes to the nearest place that leaves 1 mm
    to the outline and to the bore, 6 mm into the corner, against the outline."""
    outline, tolerance = sharp_pulley(), 1e-6
    chain = biarc_fit(outline, tolerance)
    point = outline.xy(0.0)[0]
    tx, ty = outline.unit_tangents(0.0, closing=False)[0]
    along_normal = point - (ANCHOR / 2 + MIN_WALL) * np.array([ty, -tx])
    assert hole_walls(chain, along_normal, ANCHOR, BORE)[0] < -2e-3
    (bore, d_bore), (anchor, d_anchor) = holes(outline, BORE, ANCHOR, tolerance)
    assert np.all(bore == 0) and (d_bore, d_anchor) == (BORE, ANCHOR)
    to_outline, to_bore = hole_walls(chain, anchor, ANCHOR, BORE)
    assert MIN_WALL - ROUNDING <= to_outline <= MIN_WALL + 1e-8 and to_bore >= MIN_WALL
    assert 5e-3 < np.hypot(*(anchor - point)) < 7e-3
    # no place nearer the anchor point leaves the wall: every point of the disc within that reach
    reach = np.hypot(*(anchor - point))
    r, a = np.meshgrid(np.linspace(0.0, reach * (1 - 1e-3), 60), np.linspace(0.0, 2 * np.pi, 120))
    nearer = point + np.column_stack([(r * np.cos(a)).ravel(), (r * np.sin(a)).ravel()])
    walls = signed_distance(nearer, chain.vertices, chain.bulges) - ANCHOR / 2
    assert walls.max() < MIN_WALL


def test_a_hole_that_fits_nowhere_is_refused_with_the_largest_that_does():
    outline = sharp_pulley()
    with pytest.raises(ValueError, match="anchor_diameter = 0.006 m") as err:
        holes(outline, BORE, 6e-3, 1e-6)
    largest = float(re.search(r"the largest hole that does is ([\d.e-]+) m", str(err.value)).group(1))
    assert 4e-3 < largest < 6e-3 and "\n" not in str(err.value)
    holes(outline, BORE, largest * (1 - 1e-4), 1e-6)  # it fits


def test_a_file_whose_anchor_hole_lies_outside_fails_its_verification(tmp_path):
    """A DXF whose anchor hole was moved 2.26 mm outside the outline reads back with a negative
    anchor wall and fails; the file as written passes, every wall at least the rule."""
    outline, tolerance = sharp_pulley(), 1e-6
    write_dxf(tmp_path / "cam1.dxf", outline, BORE, ANCHOR, tolerance)
    as_written = cam_report(1, outline, read_dxf(tmp_path / "cam1.dxf"), tolerance, tolerance, 0.0, None)
    assert as_written["walls_hold"] and as_written["convex"] and passed([], [as_written]) is None
    assert min(as_written[k] for k in ("bore_wall_m", "anchor_wall_m", "holes_wall_m")) >= MIN_WALL - ROUNDING
    doc = ezdxf.readfile(tmp_path / "cam1.dxf")
    (hole,) = [c for c in doc.modelspace().query("CIRCLE") if c.dxf.radius < 2]
    hole.dxf.center = (24.26, 0.0)  # the anchor point is at 22 mm on +x
    doc.saveas(tmp_path / "moved.dxf")
    moved = cam_report(1, outline, read_dxf(tmp_path / "moved.dxf"), tolerance, tolerance, 0.0, None)
    assert moved["anchor_wall_m"] == pytest.approx(-2.26e-3 - ANCHOR / 2, abs=1e-9)
    assert not moved["walls_hold"] and passed([], [moved]) is False


@pytest.mark.slow
def test_the_five_bar_arms_files_keep_every_wall(tmp_path):
    """Endo2010's five-bar arm, designed and written: every hole of both DXFs, read back, leaves
    at least the rule to the exact arcs, measured with a sign, and the report passes (its cam 2
    anchor hole lay 2.26 mm outside the part)."""
    result = cadcam.design(ROOT / "models" / "endo2010_five_bar.toml")
    result.save(tmp_path, figures=False)
    report = json.loads((tmp_path / "verification.json").read_text())
    assert report["passed"] is True
    for cam in report["cams"]:
        chain = read_dxf(tmp_path / f"cam{cam['cam']}.dxf")
        (bore, d_bore), (anchor, d_anchor) = sorted(chain.circles, key=lambda c: -c[1])
        to_outline, to_bore = hole_walls(chain, anchor, d_anchor, d_bore)
        assert min(to_outline, to_bore, hole_walls(chain, bore, d_bore, 0.0)[0]) >= MIN_WALL - ROUNDING
        assert cam["walls_hold"] and cam["convex"] and cam["anchor_wall_m"] == to_outline


def test_a_smooth_closure_keeps_the_files_tolerance_clear_of_the_hub():
    """A spiral ρ = 10 mm + 6 mm/rad·φ over 3.5 rad closed round an 8 mm hub: the smoothest
    closure presses on the hub (within 0.1 µm); asked to keep the files' 0.01 mm tolerance
    clear of it, it does, and its DXF fitted within that tolerance keeps the hub's radius."""
    basis, c = Basis("monomial", 1, (0.0, 4.0)), np.array([0.01, 0.006])
    phi = np.linspace(0.0, 2 * np.pi, 20001)
    pressed = cut_outline(basis, c, 3.5, 0.008)
    assert np.hypot(*pressed.xy(phi).T).min() - 0.008 < 2e-7
    clear = cut_outline(basis, c, 3.5, 0.008, fit=1e-5)
    assert 1e-5 <= np.hypot(*clear.xy(phi).T).min() - 0.008 <= 1.02e-5
    chain = biarc_fit(clear, 1e-5)
    assert signed_distance(np.zeros((1, 2)), chain.vertices, chain.bulges)[0] >= 0.008
