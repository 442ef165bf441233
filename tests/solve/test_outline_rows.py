"""The NLP's outline rows: deferred, and imposed by a warm second solve where the optimum without
them breaks them, so that every outline closes convex round its hub."""
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from cadcam import optimize
from cadcam.make.workshop import TWO_PI, cut_outline, holes
from cadcam.physics.profile import profile_function, support_distance

BORE, CABLE = 0.012, 0.002  # [m]: hub 7 mm, anchor 10.5 mm out, each a cable's radius more on the
# designed curve (the cable's centre line); the 1-DOF cam's ρ(0) is about 10.07 mm


@pytest.fixture(scope="module")
def wide_bore(problem_1dof, result_1dof):
    problem = dataclasses.replace(problem_1dof, workshop=dataclasses.replace(
        problem_1dof.workshop, bore_diameter=BORE, cable_diameter=CABLE))
    return result_1dof, optimize(problem)


def test_rows_that_never_bind_leave_the_design_as_it_was(wide_bore, problem_1dof):
    """At the default bore the 1-DOF cam meets its outline rows without them: one solve."""
    default, _ = wide_bore
    d = default.design
    rho0 = float(profile_function(d.bases[0])(0.0, d.coefficients[0])[0])
    assert rho0 > problem_1dof.workshop.anchor_radius and default.success
    assert default.solve.iterations == len(default.solve.history["iteration"]) - 1


def test_a_bore_that_binds_designs_the_arc_round_it(wide_bore):
    default, wide = wide_bore
    workshop = wide.problem.workshop
    d0 = default.design
    assert float(profile_function(d0.bases[0])(0.0, d0.coefficients[0])[0]) < workshop.anchor_radius  # broken
    assert wide.success and wide.solve.iterations > default.solve.iterations  # solved again, with them
    d, alpha = wide.design, float(wide.evaluation.profiles[0].alpha.max())
    phi = np.linspace(0.0, alpha, 20001)
    rho, drho, ddrho, margin = (np.asarray(v).ravel() for v in profile_function(d.bases[0]).map(phi.size)(phi, d.coefficients[0]))
    assert np.asarray(support_distance(rho, drho)).min() >= (workshop.hub_radius + workshop.cable_radius) * (1 - 1e-4)
    assert rho[0] >= (workshop.anchor_radius + workshop.cable_radius) * (1 - 1e-6)
    assert np.max(margin / (rho**2 + drho**2) ** 1.5) <= workshop.greatest_curvature
    outline = cut_outline(d.bases[0], d.coefficients[0], alpha, workshop.hub_radius, workshop.cable_radius)
    assert outline.rho_range[0] >= workshop.hub_radius - 1e-9
    holes(outline, BORE, workshop.anchor_diameter)  # raises if a wall is short
    xy = outline.xy(np.linspace(0.0, TWO_PI, 4000, endpoint=False))
    edge = np.diff(np.vstack((xy, xy[:1])), axis=0)
    nxt = np.roll(edge, -1, axis=0)
    assert (edge[:, 0] * nxt[:, 1] - edge[:, 1] * nxt[:, 0]).min() > -1e-15  # convex


@pytest.mark.slow  # a grooved design with its solids: make test-slow
def test_a_groove_widens_the_hub_every_outline_closes_round(tmp_path):
    """A groove cut round the outline needs its depth of material outside the bore's wall: the
    hub grows by it, the outline keeps clear of it, and the STL with its groove is made."""
    from cadcam.cli import main
    from cadcam.verify.file_model import read_dxf
    spec = Path(__file__).resolve().parents[2] / "docs" / "first_balancer.toml"
    out = tmp_path / "o"
    assert main(["design", str(spec), "-o", str(out), "--no-figures",
                 "--stl", "0.005", "--groove-depth", "0.008", "--groove-width", "0.002"]) == 0
    record = json.loads((out / "result.json").read_text())
    assert record["workshop"]["status"] == "written" and (out / "cam1.stl").is_file()
    outline = read_dxf(out / "cam1.dxf")
    assert np.hypot(*outline.vertices.T).min() >= (0.006 / 2 + 0.001 + 0.008) - 1e-9
