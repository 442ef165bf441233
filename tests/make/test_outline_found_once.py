"""An outline's biarc fit and holes are found once per tolerance and travel with it: the DXF, the
SVG, their checks and the drawing sheets (drawn in other processes) all ask for them."""
import pickle

import numpy as np
import pytest

import cadcam.make.workshop as workshop
from cadcam.make.biarc import biarc_fit
from cadcam.make.workshop import holes, hull_outline, write_dxf, write_svg
from cadcam.physics.profile import Basis

#: A spiral pulley closed round a 4 mm hub, with a bore and an anchor hole that fit [m].
BORE, ANCHOR = 3e-3, 1.5e-3


@pytest.fixture
def fits(monkeypatch):
    """The tolerances :func:`cadcam.make.biarc.biarc_fit` is called with, from here on."""
    calls = []
    monkeypatch.setattr(workshop, "biarc_fit", lambda outline, tolerance: calls.append(tolerance)
                        or biarc_fit(outline, tolerance))
    return calls


def _pulley():
    return hull_outline(Basis("monomial", 1, (0.0, 1.0)), np.array([0.022, -0.025]), 0.46, 0.004)


def test_the_files_and_the_holes_of_an_outline_fit_it_once_per_tolerance(tmp_path, fits):
    outline = _pulley()
    circles = holes(outline, BORE, ANCHOR, 1e-6)
    write_dxf(tmp_path / "cam1.dxf", outline, BORE, ANCHOR, 1e-6)
    write_svg(tmp_path / "cam1.svg", outline, BORE, ANCHOR, 1e-6)
    assert holes(outline, BORE, ANCHOR, 1e-6) is circles
    assert fits == [1e-6]
    holes(outline, BORE, ANCHOR, 1e-5)  # another tolerance: its own fit
    assert fits == [1e-6, 1e-5]
    fresh = biarc_fit(outline, 1e-6)  # the kept fit is the fit
    np.testing.assert_array_equal(outline.arcs(1e-6).vertices, fresh.vertices)
    np.testing.assert_array_equal(outline.arcs(1e-6).bulges, fresh.bulges)


def test_what_an_outline_found_is_read_only_and_travels_with_it(fits):
    outline = _pulley()
    circles = holes(outline, BORE, ANCHOR, 1e-6)
    with pytest.raises(ValueError, match="read-only"):
        circles[1][0][0] = 0.0
    with pytest.raises(ValueError, match="read-only"):
        outline.arcs(1e-6).bulges[0] = 0.0
    copy = pickle.loads(pickle.dumps(outline))  # as it is sent to the processes drawing its sheets
    np.testing.assert_array_equal(holes(copy, BORE, ANCHOR, 1e-6)[1][0], circles[1][0])
    assert fits == [1e-6]


def test_a_hole_that_does_not_fit_is_refused_each_time(fits):
    outline = _pulley()
    for _ in range(2):
        with pytest.raises(ValueError, match="anchor_diameter = 0.006 m"):
            holes(outline, BORE, 6e-3, 1e-6)
    assert fits == [1e-6]  # the fit is kept; the refusal is not
