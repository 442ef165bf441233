"""camN.step (the extra ``step``: build123d): written, imported back and measured."""
import numpy as np
import pytest

from cadcam.make.biarc import arc_geometry, biarc_fit
from cadcam.make.step import write_step
from cadcam.make.workshop import closed_outline, holes
from cadcam.physics.profile import Basis

BORE, ANCHOR, THICKNESS = 6e-3, 2.5e-3, 5e-3  # [m]


def chain_area(chain) -> float:
    """Area [m²] inside a counter-clockwise chain: its polygon (shoelace) plus each arc's
    circular segment R²(θ − sin θ)/2."""
    a, b = chain.vertices, np.roll(chain.vertices, -1, axis=0)
    area = 0.5 * np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    arcs = chain.bulges != 0
    _, radius, sweep = arc_geometry(a[arcs], b[arcs], chain.bulges[arcs])
    return area + float(np.sum(radius**2 * (sweep - np.sin(sweep)) / 2))


@pytest.fixture(scope="module")
def bd():
    """build123d, or the module's tests skipped without it: imported by the tests, not at the
    module's import, where every worker would take its 5 s while collecting."""
    return pytest.importorskip("build123d")


@pytest.fixture(scope="module")
def part(tmp_path_factory, bd):
    b = Basis("monomial", 2, (0.0, 4.0))
    outline = closed_outline(b, b.from_monomial(np.array([0.03, 0.002, -2e-4])), 4.0)
    chain = biarc_fit(outline, 1e-7)
    path = tmp_path_factory.mktemp("step") / "cam1.step"
    circles = holes(outline, BORE, ANCHOR)
    volume = write_step(path, chain, circles, THICKNESS)
    return chain, circles, volume, bd.import_step(str(path))


def test_step_solid_is_the_extruded_outline_less_its_holes(part):
    """The solid read back has the outline's area less the two holes' times the thickness, to
    1e-9 of it (the kernel's arcs are the file's arcs)."""
    chain, circles, volume, solid = part
    expected = (chain_area(chain) - sum(np.pi * d**2 / 4 for _, d in circles)) * THICKNESS
    assert solid.volume / 1e9 == pytest.approx(expected, rel=1e-9)
    assert volume == pytest.approx(expected, rel=1e-9)


def test_step_box_and_bore(part, bd):
    """The box is the outline's in x and y and the thickness in z (mm); the bore is a circle of
    its diameter about the axis, the anchor hole one of its own at its centre."""
    chain, circles, _, solid = part
    box = solid.bounding_box()
    points = chain.sample(256) * 1e3
    np.testing.assert_allclose([box.min.X, box.min.Y, box.max.X, box.max.Y],
                               [*points.min(axis=0), *points.max(axis=0)], atol=1e-3)
    assert (box.min.Z, box.max.Z) == pytest.approx((0.0, THICKNESS * 1e3), abs=1e-9)
    bottom = solid.faces().sort_by(bd.Axis.Z)[0]  # z = 0: the outline with its two holes
    found = sorted((e.radius, e.arc_center.X, e.arc_center.Y)
                   for w in bottom.inner_wires() for e in w.edges())
    (anchor, d_anchor), (bore, d_bore) = circles[1], circles[0]
    np.testing.assert_allclose(found, [[d_anchor / 2 * 1e3, *(anchor * 1e3)], [d_bore / 2 * 1e3, *bore]],
                               atol=1e-9)


def test_step_groove_removes_its_band(tmp_path, part):
    """A groove d deep and w wide removes (P d − π d²) w: the band between a convex outline of
    perimeter P and its inward offset by d (Steiner), to 1e-6 of it."""
    chain, circles, volume, _ = part
    depth, width = 1e-3, 2e-3
    grooved = write_step(tmp_path / "g.step", chain, circles, THICKNESS, depth, width)
    a, b = chain.vertices, np.roll(chain.vertices, -1, axis=0)
    _, radius, sweep = arc_geometry(a, b, chain.bulges)
    perimeter = float(np.sum(radius * sweep))
    assert volume - grooved == pytest.approx((perimeter * depth - np.pi * depth**2) * width, rel=1e-6)
