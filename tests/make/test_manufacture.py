"""Closed outlines, chordal polylines and the DXF / SVG / CSV / STL / sheet writers."""
import re
import xml.etree.ElementTree as ET

import ezdxf
import numpy as np
import pytest
from matplotlib.image import imread

from cadcam import evaluate, optimize
from cadcam.make.drawing import draw_sheet
from cadcam.make.workshop import (DEFAULT_TOLERANCE, MIN_WALL, anchor_centre, closed_outline, holes,
                                polyline, segment_distance, write_points_csv, write_dxf, write_stl,
                                write_svg)
from cadcam.make.biarc import arc_distance, biarc_fit
from cadcam.physics.profile import Basis

TWO_PI = 2 * np.pi
BORE, ANCHOR, THICKNESS = 6e-3, 1.5e-3, 5e-3  # [m]


@pytest.fixture(scope="module")
def optimum_1dof(problem_1dof):
    # the geometry tests need one fixed smooth design whose closure inside the ρ bounds exists:
    # the 1-DOF optimum under the force model is one (the energy model's needs the closing arc
    # to leave [ρ_min, ρ_max], which the default unbounded closure allows)
    return optimize(problem_1dof.with_torque_model("force"))


@pytest.fixture(scope="module")
def cam_1dof(optimum_1dof):
    d = optimum_1dof.design
    return closed_outline(d.bases[0], d.coefficients[0],
                          optimum_1dof.evaluation.metrics.alpha_max[0])


@pytest.fixture(scope="module")
def cams_table3(rr_problem, table3):
    alpha = evaluate(rr_problem, table3).metrics.alpha_max
    return [closed_outline(b, c, a) for b, c, a in zip(table3.bases, table3.coefficients, alpha)]


@pytest.fixture(params=["1-DOF optimum", "Table 3 cam 1", "Table 3 cam 2"])
def outline(request, cam_1dof, cams_table3):
    return {"1-DOF optimum": cam_1dof, "Table 3 cam 1": cams_table3[0],
            "Table 3 cam 2": cams_table3[1]}[request.param]


def cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def shoelace(p):
    return 0.5 * np.sum(cross(p, np.roll(p, -1, axis=0)))


def perimeter(p):
    return np.sum(np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1))


def tangent(outline, phi):
    rho, d1, _ = outline.derivatives(phi)
    c, s = np.cos(phi), np.sin(phi)
    t = np.column_stack((d1 * c - rho * s, d1 * s + rho * c))
    return t / np.linalg.norm(t, axis=1, keepdims=True)


# ----------------------------------------------------------------------------- closed outline

def test_outline_is_convex_without_reflex_vertex(outline):
    for pts in (outline.points, polyline(outline, 1e-6)):
        edges = np.roll(pts, -1, axis=0) - pts
        turn = cross(edges, np.roll(edges, -1, axis=0))
        assert np.all(turn > 0), f"{np.sum(turn <= 0)} reflex vertices of {len(pts)}"
    phi = np.linspace(outline.phi_end, TWO_PI, 20001)
    rho = outline.rho(phi)
    margin = outline.margin(phi)  # Johnston2023 Eq. 40
    assert rho.min() > 0
    assert np.min(margin / rho**3) > 0  # u + u″ on the closing arc


def test_outline_is_closed_and_c2_at_both_joints(outline):
    for joint in (outline.phi_end, TWO_PI):
        before, after = outline.derivatives([joint - 1e-7, joint + 1e-7]).T
        np.testing.assert_allclose(before, after, rtol=1e-4, atol=1e-8)  # ρ, ρ′, ρ″
        t = tangent(outline, np.array([joint - 1e-7, joint + 1e-7]))
        assert abs(np.arcsin(cross(t[0], t[1]))) < 1e-5  # tangent direction [rad]
    ends = outline.xy([TWO_PI - 1e-12, 0.0])
    assert np.linalg.norm(ends[0] - ends[1]) < 1e-12


def test_designed_arc_is_kept_and_closure_respects_rho_bounds(cam_1dof, optimum_1dof,
                                                              problem_1dof):
    d, cam = optimum_1dof.design, problem_1dof.profiles[0]
    bounded = closed_outline(d.bases[0], d.coefficients[0], cam_1dof.phi_end,
                             rho_bounds=(cam.rho_min, cam.rho_max))
    phi = np.linspace(0, cam_1dof.phi_end, 50)
    np.testing.assert_array_equal(bounded.rho(phi), cam_1dof.rho(phi))
    assert cam_1dof.rho_range[0] < cam.rho_min  # unbounded, the closure dips below ρ_min
    assert bounded.rho_range[0] > cam.rho_min - 1e-8
    assert bounded.rho_range[1] < cam.rho_max


def test_no_convex_closure_is_a_value_error(rr_problem, table3, cams_table3):
    cam = rr_problem.profiles[0]  # Table 3 cam 1 starts at ρ_min with ρ′ > 0: below ρ_min before 2π
    with pytest.raises(ValueError, match="no convex closure.*rho_bounds"):
        closed_outline(table3.bases[0], table3.coefficients[0], cams_table3[0].phi_end,
                       rho_bounds=(cam.rho_min, cam.rho_max))
    spiral = Basis("monomial", 1, (0.0, 6.0))  # ρ = 10 mm (1 + φ) over 330°: no way back
    with pytest.raises(ValueError, match="no convex closure"):
        closed_outline(spiral, [0.01, 0.01], np.radians(330))
    wavy = Basis("monomial", 2, (0.0, 2.0))
    with pytest.raises(ValueError, match="not positive and convex"):
        closed_outline(wavy, [0.01, 0.0, 0.02], 2.0)
    with pytest.raises(ValueError, match="phi_max"):
        closed_outline(spiral, [0.01, 0.01], TWO_PI)


# ----------------------------------------------------------------------------------- polyline

def test_polyline_meets_the_chordal_tolerance_everywhere(outline):
    tol = DEFAULT_TOLERANCE
    pts = polyline(outline, tol)
    angles = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), TWO_PI)
    knots = np.append(angles, TWO_PI)
    assert np.all(np.diff(knots) > 0)
    assert angles[0] == 0 and np.min(np.abs(angles - outline.phi_end)) < 1e-12
    np.testing.assert_allclose(np.hypot(*pts.T), outline.rho(angles), rtol=1e-12)  # on the curve
    s = np.linspace(0, 1, 402)[1:-1]
    inner = outline.xy((knots[:-1, None] + np.diff(knots)[:, None] * s).ravel())
    inner = inner.reshape(len(pts), s.size, 2)
    sag = segment_distance(inner, pts[:, None], np.roll(pts, -1, axis=0)[:, None]).max(axis=1)
    assert sag.max() <= tol * (1 + 1e-9)
    assert sag.max() > 0.5 * tol  # no needless points


def test_polyline_contains_the_designed_arc(outline):
    tol = DEFAULT_TOLERANCE
    pts = polyline(outline, tol)
    arc = outline.xy(np.linspace(0, outline.phi_end, 20001))
    dist = segment_distance(arc[:, None], pts[None], np.roll(pts, -1, axis=0)[None]).min(axis=1)
    assert dist.max() <= tol + 1e-12


def test_polyline_point_count_is_near_the_least_possible(outline):
    """A chord of length ℓ on curvature κ sags ℓ²κ/8: at least ∮ √(κ/8·tol) ds chords."""
    phi = np.linspace(0, TWO_PI, 40001)
    rho, d1, _ = outline.derivatives(phi)
    density = np.sqrt(outline.margin(phi) / 8) / (rho**2 + d1**2) ** 0.25
    least = np.trapezoid(density, phi) / np.sqrt(DEFAULT_TOLERANCE)
    n = len(polyline(outline))
    print(f"\n{n} points at {DEFAULT_TOLERANCE * 1e3} mm (least possible ≈ {least:.1f})")
    assert least <= n <= 1.15 * least + 4
    finer = len(polyline(outline, DEFAULT_TOLERANCE / 100))
    assert finer / n == pytest.approx(10, rel=0.1)  # chords ∝ tolerance^(-1/2)


def test_point_count_of_the_1dof_cam_at_the_default_tolerance(cam_1dof):
    n = len(polyline(cam_1dof))
    print(f"\n1-DOF cam: {n} points at 0.01 mm")
    assert 60 <= n <= 90


# ------------------------------------------------------------------------------------ writers

def test_dxf_reads_back_with_the_outline_and_holes(tmp_path, cam_1dof):
    path = tmp_path / "cam.dxf"
    write_dxf(path, cam_1dof, BORE, ANCHOR)
    doc = ezdxf.readfile(path)
    assert doc.header["$INSUNITS"] == 4
    assert {"PROFILE", "HOLES"} <= {layer.dxf.name for layer in doc.layers}
    msp = doc.modelspace()
    (profile,) = msp.query("LWPOLYLINE")
    assert profile.dxf.layer == "PROFILE" and profile.closed
    chain = biarc_fit(cam_1dof, DEFAULT_TOLERANCE)
    np.testing.assert_allclose(np.array(profile.get_points("xyb")),
                               np.column_stack([chain.vertices * 1e3, chain.bulges]), rtol=0, atol=1e-9)
    circles = sorted(msp.query("CIRCLE"), key=lambda c: -c.dxf.radius)
    assert [c.dxf.layer for c in circles] == ["HOLES", "HOLES"]
    assert circles[0].dxf.radius == pytest.approx(BORE / 2 * 1e3, abs=1e-12)
    assert np.allclose(circles[0].dxf.center, 0, atol=1e-12)
    assert circles[1].dxf.radius == pytest.approx(ANCHOR / 2 * 1e3, abs=1e-12)
    anchor = np.array(circles[1].dxf.center)[:2]
    np.testing.assert_allclose(anchor, anchor_centre(cam_1dof, chain, ANCHOR, BORE) * 1e3, atol=1e-9)
    ends = np.roll(chain.vertices, -1, axis=0)
    wall = arc_distance(anchor / 1e3, chain.vertices, ends, chain.bulges).min() - ANCHOR / 2
    assert wall == pytest.approx(MIN_WALL, abs=1e-12)  # measured on the arcs written


def test_svg_is_true_scale_in_millimetres(tmp_path, outline):
    """The SVG holds the DXF's biarcs (one A or L command per segment) at 1:1 in millimetres,
    its box the outline's to within the fit's tolerance."""
    path = tmp_path / "cam.svg"
    write_svg(path, outline, BORE, ANCHOR)
    root = ET.parse(path).getroot()
    ns = {"svg": "http://www.w3.org/2000/svg"}
    pts = outline.xy(np.linspace(0, TWO_PI, 20000)) * 1e3
    size = np.ptp(pts, axis=0)
    assert root.get("width").endswith("mm") and root.get("height").endswith("mm")
    np.testing.assert_allclose([float(root.get("width")[:-2]), float(root.get("height")[:-2])],
                               size, atol=2 * DEFAULT_TOLERANCE * 1e3)
    box = [float(v) for v in root.get("viewBox").split()]
    np.testing.assert_allclose(box, [pts[:, 0].min(), -pts[:, 1].max(), *size], atol=2 * DEFAULT_TOLERANCE * 1e3)
    (path_el,) = root.findall(".//svg:path", ns)
    chain = biarc_fit(outline, DEFAULT_TOLERANCE)
    commands = re.findall(r"[MALZ]", path_el.get("d"))
    assert commands.count("A") == np.count_nonzero(chain.bulges)
    assert commands.count("A") + commands.count("L") == len(chain.vertices)
    radii = sorted(float(c.get("r")) for c in root.findall(".//svg:circle", ns))
    np.testing.assert_allclose(radii, [ANCHOR / 2 * 1e3, BORE / 2 * 1e3])


def test_csv_lists_the_polyline_in_millimetres(tmp_path, cam_1dof):
    path = tmp_path / "cam.csv"
    write_points_csv(path, cam_1dof)
    lines = path.read_text().splitlines()
    assert lines[0] == "x_mm,y_mm"
    np.testing.assert_array_equal(np.loadtxt(lines[1:], delimiter=","), polyline(cam_1dof) * 1e3)


def read_stl(path):
    data = path.read_bytes()
    n = int(np.frombuffer(data, "<u4", 1, 80)[0])
    assert len(data) == 84 + 50 * n
    rec = np.frombuffer(data, [("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")], n, 84)
    return rec["v"].astype(float)


def check_closed_manifold(corners):
    """Every edge in exactly two triangles, once each way; returns the Euler characteristic."""
    verts, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    tri = index.reshape(-1, 3)
    assert np.all(np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                          corners[:, 2] - corners[:, 0]), axis=1) > 0)
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    key = directed[:, 0] * len(verts) + directed[:, 1]
    reverse = directed[:, 1] * len(verts) + directed[:, 0]
    assert np.unique(key).size == key.size, "an edge is used twice in the same direction"
    assert np.array_equal(np.sort(key), np.sort(reverse)), "an edge has no opposite half"
    return len(verts) - key.size // 2 + len(tri)


@pytest.mark.parametrize("depth, width", [(0.0, 0.0), (5e-4, 2e-3)])
def test_stl_is_watertight_with_the_right_volume(tmp_path, outline, depth, width):
    """The STL with its bore and anchor hole, and a groove shallower than the anchor hole's
    1 mm wall (a deeper one cuts into the hole)."""
    path = tmp_path / "cam.stl"
    volume = write_stl(path, outline, THICKNESS, holes(outline, BORE, ANCHOR), depth, width)
    corners = read_stl(path)
    assert check_closed_manifold(corners) == -2  # the bore and the anchor hole through it: χ = 2 − 2·2
    mesh_volume = np.sum(np.linalg.det(corners)) / 6 * 1e-9
    assert mesh_volume == pytest.approx(volume, rel=1e-6)
    pts = polyline(outline)
    area, length = shoelace(pts), perimeter(pts)
    groove = width * (length * depth - np.pi * depth**2)  # Steiner: area − inner parallel area
    expected = (area - np.pi * (BORE**2 + ANCHOR**2) / 4) * THICKNESS - groove
    print(f"\nSTL volume {volume * 1e9:.3f} mm³, expected {expected * 1e9:.3f} mm³")
    assert volume == pytest.approx(expected, rel=1e-3)
    assert np.ptp(corners[:, :, 2]) == pytest.approx(THICKNESS * 1e3, abs=1e-5)


def test_bad_sizes_raise_naming_the_parameter(tmp_path, cam_1dof):
    path = tmp_path / "cam.stl"
    rho_min = cam_1dof.rho_range[0]
    cases = [
        ("bore_diameter", lambda: write_stl(path, cam_1dof, THICKNESS, [(np.zeros(2), 2 * rho_min)])),
        ("bore_diameter", lambda: write_dxf(path, cam_1dof, -1e-3, ANCHOR)),
        ("groove_depth",
         lambda: write_stl(path, cam_1dof, THICKNESS, [(np.zeros(2), BORE)], rho_min - BORE / 2, 1e-3)),
        ("groove_width", lambda: write_stl(path, cam_1dof, THICKNESS, [(np.zeros(2), BORE)], 1e-3, THICKNESS)),
        ("groove_width", lambda: write_stl(path, cam_1dof, THICKNESS, [(np.zeros(2), BORE)], 1e-3, 0.0)),
        ("thickness", lambda: write_stl(path, cam_1dof, 0.0, [(np.zeros(2), BORE)])),
        ("anchor_diameter", lambda: write_svg(path, cam_1dof, BORE, 6e-3)),
        ("tolerance", lambda: write_points_csv(path, cam_1dof, tolerance=0.0)),
    ]
    for name, call in cases:
        with pytest.raises(ValueError, match=name):
            call()
    assert not list(tmp_path.iterdir())  # nothing written, not even a temporary file


# -------------------------------------------------------------------------------------- sheet

def test_sheet_is_a4_at_true_scale(tmp_path, cam_1dof, problem_1dof):
    cam = problem_1dof.profiles[0]
    args = (cam_1dof, BORE, ANCHOR, cam.rho_min, cam.rho_max, "1-DOF cam")
    assert draw_sheet(tmp_path / "cam.png", *args) == 1
    height, width = imread(tmp_path / "cam.png").shape[:2]
    assert abs(width - 297 / 25.4 * 300) < 1 and abs(height - 210 / 25.4 * 300) < 1
    assert draw_sheet(tmp_path / "cam.pdf", *args) == 1
    pdf = (tmp_path / "cam.pdf").read_bytes()
    box = re.search(rb"/MediaBox \[ *0 0 ([\d.]+) ([\d.]+) *\]", pdf)
    np.testing.assert_allclose([float(v) for v in box.groups()], [841.89, 595.28], atol=0.01)
    with pytest.raises(ValueError, match="png or .pdf"):
        draw_sheet(tmp_path / "cam.jpg", *args)


def test_large_cam_is_drawn_reduced(tmp_path):
    disc = closed_outline(Basis("monomial", 0, (0.0, 2.0)), [0.2], 2.0)  # Ø400 mm
    np.testing.assert_allclose(disc.rho_range, 0.2, rtol=1e-12)
    # 400 mm at 1:2 is 200 mm, more than the 160 mm high drawing area: 1:5
    assert draw_sheet(tmp_path / "disc.pdf", disc, 0.05, 0.01, 0.15, 0.25, "disc") == 5


def test_hull_closure_goes_round_the_hub_and_keeps_the_arc():
    """A growing spiral over 200°: the chord back to the anchor would cut a 9 mm hub, so the
    hull runs straight to the hub, round it and straight on; the designed arc is kept."""
    from cadcam.make.workshop import HullClosing, hull_outline
    basis, c, end, hub = Basis("monomial", 1, (0.0, 3.5)), np.array([0.012, 0.004]), np.radians(200), 0.009
    outline = hull_outline(basis, c, end, hub)
    assert isinstance(outline.closing, HullClosing) and outline.closing.starts.size == 3
    phi = np.linspace(0.0, end, 50)
    np.testing.assert_allclose(outline.rho(phi), c[0] + c[1] * phi, rtol=1e-12)
    assert outline.rho_range[0] == pytest.approx(hub, rel=1e-6)
    xy = outline.xy(np.linspace(0.0, TWO_PI, 5000, endpoint=False))
    edge = np.diff(np.vstack((xy, xy[:1])), axis=0)
    nxt = np.roll(edge, -1, axis=0)
    assert (edge[:, 0] * nxt[:, 1] - edge[:, 1] * nxt[:, 0]).min() > -1e-15
    # the closing lines touch the hub: each is a tangent, at distance hub from the axis
    for j in (0, 2):
        a, b = outline.closing.a[j], outline.closing.b[j]
        assert 1 / np.hypot(a, b) == pytest.approx(hub, rel=1e-12)


def test_hull_closure_refuses_an_arc_that_leaves_the_hull():
    """A spiral of nearly a turn whose end overhangs its anchor: the arc near φ = 0 is not on
    the hull (the design broke its outline rows), and the closure says so."""
    from cadcam.make.workshop import hull_outline
    with pytest.raises(ValueError, match="does not lie on the convex hull"):
        hull_outline(Basis("monomial", 1, (0.0, 6.0)), np.array([0.01, 0.002]), 6.0, 0.004)


def test_a_clockwise_wound_part_says_its_drawing_is_seen_from_the_back(tmp_path):
    """Outlines are drawn with the cable counter-clockwise; a clockwise-wound pulley's DXF and
    SVG say that they show it from the back, and a counter-clockwise one's say nothing."""
    from pathlib import Path

    from cadcam.make.workshop import MIRRORED_NOTE
    from cadcam.outputs.run_files import _mirrored
    from cadcam.spec import load_spec
    pendulum = load_spec(Path(__file__).resolve().parents[2] / "models" / "ludovico2021_pendulum.toml")
    assert [_mirrored(pendulum, i) for i in range(2)] == [True, False]  # its winding: "cw", "ccw"
    disc = closed_outline(Basis("monomial", 0, (0.0, 2.0)), [0.03], 2.0)
    for mirrored in (True, False):
        write_dxf(tmp_path / "c.dxf", disc, BORE, ANCHOR, mirrored=mirrored)
        write_svg(tmp_path / "c.svg", disc, BORE, ANCHOR, mirrored=mirrored)
        texts = [t.dxf.text for t in ezdxf.readfile(tmp_path / "c.dxf").modelspace().query("TEXT")]
        assert texts == ([MIRRORED_NOTE] if mirrored else [])
        assert (MIRRORED_NOTE in (tmp_path / "c.svg").read_text()) == mirrored
