"""Issue 51, item 4: the workshop drawing (sheet 1 of a part) states what a workshop makes the part
from — the bore's fit, the thickness, the datum mark that fixes the part's angle on its shaft,
tolerances, the cable and the springs — and the checking sheet stays as sheet 2.

One design of the tutorial with a spring of free length (so that it hangs from a mount and its
cable has a length to cut) is written once for the module.
"""
from __future__ import annotations

import copy
import re
import struct
import tomllib
from pathlib import Path

import ezdxf
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from cadcam.library_files import matplotlib_defaults
from cadcam.make.biarc import ArcChain, segment_distance
from cadcam.make.datum import MARK_DIRECTIONS, datum_mark
from cadcam.make.drawing import DPI, MARGIN, SHEET, PartNotes, part_sheets, save_pdf, workshop_figure
from cadcam.make.fits import angular_tolerance, bore_limits, linear_tolerance
from cadcam.make.workshop import MIN_WALL, closed_outline, holes
from cadcam.optimize import optimize
from cadcam.outputs.forked import draw
from cadcam.outputs.run_files import SHEET_FILES, run_file_names, write_workshop_files
from cadcam.physics.profile import Basis
from cadcam.problem import SOLID_THICKNESS
from cadcam.spec import parse_spec
from cadcam.verify.file_model import read_dxf

from ..conftest import check_output_file

#: A full design per module fixture and more: too heavy for make test's five minutes.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = tomllib.loads((ROOT / "docs" / "first_balancer.toml").read_text())
#: A free length [m] the tutorial's spring fits with, hung 0.2 m from the joint.
FREE_LENGTH = 0.17


def _texts(fig) -> list:
    """Every text artist of a figure that shows something."""
    return [t for t in [*fig.texts, *(t for ax in fig.axes for t in ax.texts)] if t.get_text().strip()]


def _text(fig) -> str:
    """Every text of a figure, its lines and wrapped lines joined by single spaces."""
    return " ".join(" ".join(t.get_text().split()) for t in _texts(fig))


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The tutorial with a mounted spring: its result, the folder its workshop files are in and
    its two sheets as figures."""
    data = copy.deepcopy(TUTORIAL)
    data["springs"][0]["free_length"] = FREE_LENGTH
    result = optimize(parse_spec(data))
    assert result.status == "success", result.message
    out = tmp_path_factory.mktemp("sheets")
    drawings, there = [], []

    def send(sheets):  # as a Drawer's: what the folder holds when the sheets are sent
        drawings.extend(sheets)
        there.extend(path.name for path in out.iterdir())

    write_workshop_files(result, out, result.problem.workshop, True, send)
    # sent once the DXF is fitted, drawn while the other files are written and checked
    assert "cam1.dxf" in there and not {"cam1_points.csv", "cam1.svg", "verification.json"} & set(there)
    files, *sizes, part, words = next(d for d in drawings if out / "cam1_sheet.pdf" in d.args[0]).args
    assert files[out / "cam1_sheet.pdf"] == (1, 2)
    figures = part_sheets(*sizes, PartNotes(**part), **words)  # the sheets the PDF holds
    draw(drawings, workers=2)
    return result, out, figures


def test_the_sheets_are_the_files_foreseen_and_the_checking_sheet_stays(written):
    result, out, (first, second) = written
    sheets = {f"cam1{kind}" for kind in SHEET_FILES}
    assert sheets == {"cam1_sheet.pdf", "cam1_sheet.png", "cam1_sheet2.png"}
    assert sheets <= {p.name for p in out.iterdir()}
    assert sheets <= set(run_file_names(result.problem, True, result.problem.workshop))
    assert not sheets & set(run_file_names(result.problem, False, result.problem.workshop))
    check_output_file(out / "cam1_sheet.pdf")
    for name in ("cam1_sheet.png", "cam1_sheet2.png"):  # A4 landscape at 300 dpi, each
        header = (out / name).read_bytes()[:24]
        assert header[:8] == b"\x89PNG\r\n\x1a\n"
        np.testing.assert_allclose(struct.unpack(">II", header[16:24]), np.array(SHEET) / 25.4 * DPI, atol=1)
    pdf = (out / "cam1_sheet.pdf").read_bytes()
    assert len(re.findall(rb"/Type /Page\b", pdf)) == 2  # one page per sheet
    one, two = _text(first), _text(second)
    assert "1 of 2 · A4" in one and "2 of 2 · A4" in two
    assert "(least radius of the red arc)" in two  # the checking sheet, as before
    assert "(largest radius)" in two and "(largest radius)" not in one


def test_the_bore_is_toleranced_by_its_fit(written):
    _, _, (first, _) = written
    text = _text(first)
    assert "Ø6.00 H7 bore 6.000 to 6.012" in text  # ISO 286-1: IT7 over 3 up to 6 mm is 12 µm
    assert "general tolerances ISO 2768-m unless stated" in text
    assert "within ±0.05 mm of it" in text  # [tolerances] profile, the band's


def test_the_thickness_is_the_default_plate_and_says_so(written):
    result, _, (first, _) = written
    assert result.problem.workshop.stl is None
    text = _text(first)
    assert f"Thickness {SOLID_THICKNESS * 1e3:.2f} mm (no [workshop] stl: cadcam's default plate)" in text
    assert "Material: as ordered." in text


def test_the_mounted_spring_and_its_cable_length_are_on_the_sheet(written):
    result, _, (first, _) = written
    (row,) = result.installation
    text = _text(first)
    assert f"cable cut length {row['cable_length'] * 1e3:.1f}, anchor hole to hook" in text
    assert f"cable {1e3 * row['cable_length']:.1f} mm" in result.summary()  # the same length
    low, high = (FREE_LENGTH + x for x in row["extension"])
    assert f"installed length {low * 1e3:.1f} to {high * 1e3:.1f}" in text
    assert f"force {row['force'][0]:.4g} to {row['force'][1]:.4g} N" in text
    assert "no [cable]: its load and bend are not checked" in text


def test_the_datum_mark_points_along_a_world_axis_at_theta_zero(written):
    """The mark's angle on the sheet, turned into the world by the mechanism's own placement of
    the profile at θ = 0, is one of the spec's axes, the one the sheet names; the DXF carries it
    on its own layer, inside the outline and clear of the anchor hole, and the file the
    verification reads still holds one outline and two holes."""
    result, out, (first, _) = written
    text = _text(first)
    found = re.search(r"at (-?[\d.]+)° ±([\d.]+)° from the \+x axis", text)
    beta = np.radians(float(found.group(1)))
    x, y = result.problem.mechanisms[0].world_points(0.0, beta, 1.0, 0)
    world = np.degrees(np.arctan2(y, x)) % 360
    axis = {0: "+x", 90: "+y", 180: "−x", 270: "−y"}[int(round(world)) % 360]
    assert min(abs(world - d) % 360 for d in (0, 90, 180, 270, 360)) < 0.06  # the text's 0.1° rounding
    assert f"M pointing along the world's {axis} axis" in text
    assert f"M {np.degrees(beta):.1f}° (note 5)" in text  # named on the view
    msp = ezdxf.readfile(out / "cam1.dxf").modelspace()
    (line,) = [e for e in msp if e.dxf.layer == "MARK"]
    start, end = np.array(line.dxf.start)[:2] / 1e3, np.array(line.dxf.end)[:2] / 1e3
    assert np.hypot(*start) == pytest.approx(3e-3)  # from the bore's edge
    assert np.degrees(np.arctan2(end[1], end[0])) == pytest.approx(np.degrees(beta), abs=0.05)
    assert float(found.group(2)) == pytest.approx(angular_tolerance(np.hypot(*(end - start)) * 1e3), abs=0.005)
    part = read_dxf(out / "cam1.dxf")
    assert len(part.circles) == 2
    edge = ArcChain(part.vertices, part.bulges, 0.0).sample(64)
    polar = np.arctan2(edge[:, 1], edge[:, 0])
    k = np.argmin(np.abs(np.angle(np.exp(1j * (polar - beta)))))
    assert np.hypot(*end) <= np.hypot(*edge[k]) - MIN_WALL + 1e-4  # a wall short of the edge
    (hole, diameter), = [c for c in part.circles if np.hypot(*c[0]) > 0]
    assert segment_distance(hole, start, end) >= diameter / 2 + MIN_WALL - 1e-9


def _assert_legible(fig) -> None:
    """No text of ``fig`` overlaps another, and each lies inside the frame, as rendered."""
    with matplotlib_defaults():
        renderer = FigureCanvasAgg(fig).get_renderer()
        boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in _texts(fig)]
    dpi = fig.dpi / 25.4  # pixels per mm of paper
    for k, (name, box) in enumerate(boxes):
        assert box.x0 >= MARGIN * dpi and box.x1 <= (SHEET[0] - MARGIN) * dpi, name
        assert box.y0 >= MARGIN * dpi and box.y1 <= (SHEET[1] - MARGIN) * dpi, name
        for other, b in boxes[k + 1:]:
            assert not box.overlaps(b), (name, other)


def test_no_text_of_the_sheets_overlaps_another_or_leaves_the_frame(written):
    for fig in written[2]:
        _assert_legible(fig)


# -- the pieces, on simple parts ------------------------------------------------------------------
def test_fits_and_general_tolerances_follow_the_standards_ranges():
    assert bore_limits(3.0) == (0.0, 0.010) and bore_limits(3.001) == (0.0, 0.012)  # "over 3 up to 6"
    assert bore_limits(6.0) == (0.0, 0.012) and bore_limits(10.0) == (0.0, 0.015)
    assert bore_limits(1000.0) == (0.0, 0.090)
    with pytest.raises(ValueError, match="1000"):
        bore_limits(1000.5)
    assert linear_tolerance(0.2) == linear_tolerance(6.0) == 0.1
    assert linear_tolerance(30.0) == 0.2 and linear_tolerance(30.5) == 0.3 and linear_tolerance(-50.0) == 0.3
    assert angular_tolerance(10.0) == 1.0 and angular_tolerance(10.5) == 0.5 and angular_tolerance(500) == 1 / 12


@pytest.fixture(scope="module")
def spiral():
    """A spiral falling from 50 mm at the anchor: the mark is longest towards the anchor, where
    the anchor hole cuts it short."""
    return closed_outline(Basis("monomial", 1, (0.0, 4.0)), [0.05, -0.004], 4.0)


def test_the_mark_stops_a_wall_short_of_the_anchor_hole(spiral):
    circles = holes(spiral, 0.006, 0.0025)
    (_, _), (anchor, hole) = circles
    mark = datum_mark(spiral, circles, 0.0, 1.0)
    assert (mark.angle, mark.world, mark.inner) == (0.0, 0.0, 0.003)
    start, end = mark.segment
    # just clear of the hole: a wall from its edge to the mark's end
    assert segment_distance(anchor, start, end) == pytest.approx(hole / 2 + MIN_WALL, abs=1e-12)
    others = [spiral.radius_at(np.pi / 2 * k) - MIN_WALL for k in (1, 2, 3)]
    assert mark.outer > max(others)  # still the longest


def test_the_mark_turns_with_the_part_and_mirrors_with_it(spiral):
    """On a clockwise-wound part (drawn from its back) the mark for the same world axis lies at
    the mirrored angle; the part turned by 30° turns the mark back by 30° in the drawing."""
    circles = holes(spiral, 0.006, 0.0025)
    for zero, winding in ((np.radians(30), 1.0), (np.radians(30), -1.0), (np.radians(-100), -1.0)):
        mark = datum_mark(spiral, circles, zero, winding)
        assert mark.world in MARK_DIRECTIONS
        # a point at polar angle β of the drawing lies at world angle zero + winding·β
        assert np.cos(zero + winding * mark.angle - mark.world) == pytest.approx(1.0)
        assert -np.pi < mark.angle <= np.pi


def test_a_given_thickness_a_cable_and_an_enlarged_small_part(tmp_path):
    """A 14 mm disc is drawn at 5:1, legibly; a thickness the spec gives is stated as such; a
    cable's report is in the table."""
    disc = closed_outline(Basis("monomial", 0, (0.0, 2.0)), [0.007], 2.0)
    circles = holes(disc, 0.004, 0.0015)
    cable = {"name": "", "kind": "wire rope", "diameter": 0.0015, "peak_tension": 305.0, "working_load": 308.0,
             "breaking_load": 1540.0, "safety_factor": 5.0, "min_bend_radius": 0.018, "curvature_radius_min": [0.0188]}
    part = PartNotes(0.004, True, 5e-5, 1e-5, datum_mark(disc, circles, 0.0, 1.0), "cam1.dxf", cable=cable,
                     cable_diameter=0.0015)
    fig, n = workshop_figure(disc, 0.004, 0.0015, "disc", part, spec="demo", drawing="cam1", date="2024-01-02")
    assert n == 0.2
    text = _text(fig)
    assert "5:1" in text and "Thickness 4.00 mm ([workshop] stl)." in text and "4.00" in text
    assert "Ø4.00 H7 bore 4.000 to 4.012" in text
    assert "given in full, Ø1.50 wire rope" in text and "working load 308 N (1540 N / 5)" in text
    assert "least bend radius 18.00; the profile's least radius of curvature 18.80" in text
    _assert_legible(fig)
    first, second = part_sheets(disc, 0.004, 0.0015, 0.005, 0.05, "disc", part, date="2024-01-02")
    assert "2024-01-02" in _text(first) and "2024-01-02" in _text(second)
    save_pdf([first, second], tmp_path / "disc.pdf")
    check_output_file(tmp_path / "disc.pdf")
