"""The anchored-spring pulley against an independent model fed only the files ``cadcam design``
writes (tests/mechanisms/anchored_pulley/independent_anchored_pulley.py; Ludovico2021 Sec. II
after Kim & Deshpande): the model alone on a polygonal circle, then the designed Ludovico2021
pendulum read back from its cam*_points.csv and result.json. A module of its own, apart from
tests/mechanisms/anchored_pulley/test_anchored_pulley.py (which designs the pendulum as its spec
states it), so that ``make test`` (``--dist loadfile``) can run the two designs side by side.

SI units throughout: m, N, N/m, rad, N·m.
"""
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import cadcam

from . import independent_anchored_pulley as ind

PENDULUM = Path(__file__).resolve().parents[3] / "models" / "ludovico2021_pendulum.toml"

CHORD = 1e-5  # m: the chordal tolerance cam*_points.csv is written at (the CLI default, 0.01 mm)


def test_independent_model_on_a_polygonal_circle():
    """The independent model alone (no cadcam): a regular polygon inscribed in a circle of
    radius R with chordal sag δ, for each turning/winding/sense, gives σ(kx + F0)R with
    x = x0 + Rσ(θ − θ_ref) — the σ of the docs derived here from world rotations alone. The
    polygon's moment arm is off the circle's by ≤ δ and its extension by ≤ δ·|θ − θ_ref|, hence
    the tolerance F·δ + kRδ|θ − θ_ref| (plus 1e-9 N·m for the central difference)."""
    R, ell, k, F0, x0, ref, delta = 0.03, 0.2, 1000.0, 5.0, 0.05, 0.1, CHORD
    n = int(np.ceil(np.pi / np.arccos(1 - delta / R)))
    phi = 2 * np.pi * np.arange(n) / n
    outline = R * np.c_[np.cos(phi), np.sin(phi)]
    theta = np.linspace(-0.4, 0.6, 9)
    for turning in ("pulley", "spring_end"):
        for winding, w in (("ccw", 1.0), ("cw", -1.0)):
            for sense in (1.0, -1.0):
                sigma = w * sense * (-1.0 if turning == "pulley" else 1.0)
                end = ell * np.array([np.cos(-1.2), np.sin(-1.2)])
                # anchor 1.5 rad behind the tangent point at θ = 0: always wound
                anchor = -1.2 - w * (np.arccos(R / ell) + 1.5)
                pulley = ind.Pulley(outline, end, turning, sense, winding, anchor, ref)
                system = ind.PulleySystem((pulley,), (k,), (F0,), (x0,), (((1.0, 0),),))
                x = x0 + R * sigma * (theta - ref)
                dx = np.abs(ind.extensions(system, theta)[0] - x)
                assert np.all(dx <= delta * np.abs(theta - ref) + 1e-12), dx
                tol = (k * x + F0) * delta + k * R * delta * np.abs(theta - ref) + 1e-9
                dtau = np.abs(ind.torque(system, theta) - sigma * (k * x + F0) * R)
                assert np.all(dtau <= tol), (dtau, tol)


@pytest.fixture(scope="module")
def designed_folder(tmp_path_factory):
    """models/ludovico2021_pendulum.toml designed and written as `cadcam design PENDULUM
    --tolerance 1e-05 --cable-diameter 0` designs and writes it (the spec's grid, 46: from the
    default start the coarser grids 21–36 do not converge), workshop polygons at 0.01 mm, under
    an ideal cable: the independent model wraps a thread on the polygon (a cable's diameter, the
    cut outline inside its centre line, is checked from the DXF by
    tests/make/test_file_accuracy.py). In this process, as the command does it (the flags
    replace the spec's workshop sizes; its files are :meth:`Result.save`'s), without the
    figures, which nothing here reads."""
    out = tmp_path_factory.mktemp("pendulum") / "out"
    problem = cadcam.load_problem(PENDULUM)
    problem = dataclasses.replace(problem, workshop=dataclasses.replace(problem.workshop, tolerance=CHORD,
                                                                        cable_diameter=0.0))
    result = cadcam.optimize(problem)
    assert result.success, result.message
    result.save(out, figures=False)
    return out


def test_independent_model_reproduces_the_cli_torque(designed_folder):
    """A third party's torque from cam{i}_points.csv and result.json alone agrees with
    torque_recheck.csv at 11 angles across the range.

    Tolerance, from the polygon: its chords lie within δ = 0.01 mm of the outline, so the
    tangent from the spring end to the polygon is within ≈ δ of the true cable line: each
    pulley's moment arm is off by ≲ δ and its extension by ≲ δ·|θ − θ_ref| ≤ δ·Δθ. With
    F ≤ F_max (from the CSV's extensions) and a moment arm ≤ the polygon's largest radius
    ρ_max, pulley u's torque is off by ≲ δ(F_max + k ρ_max Δθ): ≈ 0.12 N·m for the pair, 0.1 %
    of the 127 N·m peak (measured 0.020 N·m). Extensions are compared to δ·Δθ (measured
    6.3e-6 m). The departure polar angles must also reach the re-check's α_max (a polygon
    vertex, since the outline has one at the end of the designed arc)."""
    system = ind.load_system(designed_folder)
    result = json.loads((designed_folder / "result.json").read_text())
    assert result["status"] == "success"
    lines = (designed_folder / "torque_recheck.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert header == ["theta1_rad", "tau1_Nm", "tau_d1_Nm", "error1_Nm", "x1_m", "x2_m"]
    table = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    col = {h: table[:, i] for i, h in enumerate(header)}
    rows = np.linspace(0, len(table) - 1, 11).round().astype(int)
    theta = col["theta1_rad"][rows]
    span = np.ptp(col["theta1_rad"])

    x = ind.extensions(system, theta)
    for j in range(2):
        np.testing.assert_allclose(x[j], col[f"x{j + 1}_m"][rows], rtol=0, atol=CHORD * span)

    tau = ind.torque(system, theta)
    bound = 0.0
    for j, (k, f0) in enumerate(zip(system.rates, system.preloads)):
        f_max = (k * col[f"x{j + 1}_m"] + f0).max()
        rho_max = np.hypot(*system.pulleys[j].outline.T).max()
        bound += CHORD * (f_max + k * rho_max * span)
    peak = np.abs(col["tau1_Nm"]).max()
    err = np.abs(tau - col["tau1_Nm"][rows]).max()
    print(f"independent vs cadcam: max |Δτ| = {err:.4g} N·m, bound {bound:.3g} N·m, "
          f"peak {peak:.4g} N·m")
    assert bound < 0.005 * peak
    assert err <= bound

    for u, p in enumerate(system.pulleys):
        _, D, _ = ind.departure(p, col["theta1_rad"])
        phi = np.arctan2(D[:, 1], D[:, 0])
        assert phi.max() == pytest.approx(result["recheck"]["alpha_max"][u], abs=1e-9)
