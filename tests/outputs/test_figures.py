"""Figures as objects (no pyplot, no backend chosen on import), binding constraints, the
workshop sheet's title block and dimensions, study labels and the reports' provenance."""
import importlib.util
import io
import os
import re
import subprocess
import sys
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from cadcam.verify.binding import RTOL, binding_constraints, limit_state
from cadcam.verify.evaluate import METRIC_NAMES, evaluate
from cadcam.optimize import start_design
from cadcam.physics.profile import Basis
from cadcam.spec import load_spec
from cadcam.version import __version__
from cadcam.make.drawing import draw_sheet, sheet_figure
from cadcam.outputs.run_files import write_outputs
from cadcam.outputs.plots import (METRIC_LABELS, axis_label, catalogue_figure, convergence_figure, figures,
                                pose_frames, study_figure, torque_figure)
from cadcam.make.workshop import closed_outline

from ..conftest import ROOT, check_output_file, circle_design

HISTORY = {"iteration": [0, 1, 2, 3], "objective": [100.0, 3.0, 1.0, 0.9],
           "inf_pr": [1e-1, 1e-3, 1e-6, 1e-9], "inf_du": [1.0, 1e-2, 1e-5, 1e-8],
           "mu": [0.1, 1e-2, 1e-4, 1e-9], "d_norm": [1.0, 0.5, 1e-2, 1e-5], "alpha_pr": [0.0, 1.0, 1.0, 1.0]}


def _texts_of(artists) -> str:
    return "\n".join(t.get_text() for t in artists)


def _texts(fig) -> str:
    """Every string drawn on a figure: figure texts, axes texts, titles, labels, tick labels,
    legends."""
    out = [t.get_text() for t in fig.texts]
    for ax in fig.axes:
        out += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()] + [t.get_text() for t in ax.texts]
        out += [t.get_text() for t in ax.get_xticklabels() + ax.get_yticklabels()]
        if ax.get_legend():
            out += [t.get_text() for t in ax.get_legend().get_texts()]
    for legend in fig.legends:
        out += [t.get_text() for t in legend.get_texts()]
    return "\n".join(out)


# ------------------------------------------------------------------------------- no backend
def test_importing_the_views_selects_no_backend_and_no_pyplot():
    code = ("import matplotlib, sys; before = matplotlib.rcParams['backend']; "
            "import cadcam.outputs.plots, cadcam.make.drawing, cadcam.outputs.run_files; "
            "print(before, matplotlib.rcParams['backend'], 'matplotlib.pyplot' in sys.modules)")
    env = {**os.environ, "MPLBACKEND": "svg"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                         cwd=ROOT).stdout.split()
    assert out == ["svg", "svg", "False"]


# ------------------------------------------------------------------------------------ figures
@pytest.fixture(scope="module")
def ev_rr(rr_problem, table3):
    return evaluate(rr_problem.with_torque_model("force-as-printed"), table3, grid=12)


@pytest.fixture(scope="module")
def ev_1dof(problem_1dof):
    return evaluate(problem_1dof, circle_design(problem_1dof, 0.02, [0.0, 0.002]), grid=12)


def test_figures_of_one_joint(ev_1dof):
    figs = figures(ev_1dof)
    assert sorted(figs) == ["profile", "springs", "torque"]
    assert all(isinstance(f, Figure) for f in figs.values())
    assert sorted(figures(ev_1dof, HISTORY)) == ["convergence", "profile", "springs", "torque"]
    # one mechanism at three joint angles: θ = 0°, 45°, 90° of the 12-angle grid's ends and middle
    titles = [ax.get_title() for ax in figs["profile"].axes]
    assert titles == ["cam: θ = 0°", "cam: θ = 49°", "cam: θ = 90°"]
    # a circle of 20 mm, far from ρ_min = 10 and ρ_max = 100 mm: no limit marked
    assert "ρ at its limit" not in _texts(figs["profile"])


def test_the_torque_error_shows_the_band_the_acceptance_allows(problem_1dof, ev_1dof):
    plain = torque_figure(ev_1dof).axes[1]
    assert not plain.patches and plain.get_legend() is None
    joint = replace(problem_1dof.joints[0], acceptance=(("rmse", 1e-3), ("max_abs_error", 2e-3)))
    banded = replace(problem_1dof, joints=(joint,))
    error = torque_figure(evaluate(banded, circle_design(banded, 0.02, [0.0, 0.002]), grid=12)).axes[1]
    (band,) = error.patches
    assert np.allclose(band.get_extents().transformed(error.transData.inverted()).get_points()[:, 1], [-2.0, 2.0])
    assert [t.get_text() for t in error.get_legend().get_texts()] == ["acceptance: |τ − τ_d| ≤ 2 N·mm"]


def test_pose_frames_draw_one_joint_angle_each_in_one_view(ev_1dof):
    count, frame = pose_frames(ev_1dof, 5)
    assert count == 5
    first, last = frame(0).axes[0], frame(count - 1).axes[0]
    assert (first.get_title(), last.get_title()) == ("cam: θ = 0°", "cam: θ = 90°")
    assert first.get_xlim() == last.get_xlim() and first.get_ylim() == last.get_ylim()


def test_figures_of_two_joints_flag_what_binds(ev_rr):
    figs = figures(ev_rr)
    assert sorted(figs) == ["profile", "springs", "torque"]
    assert len(figs["profile"].axes) == 6  # two cams × three angles
    # Table 3's cam 1 sits at ρ_min = 25 mm and its spring 1 goes beyond its travel
    assert "ρ at its limit" in _texts(figs["profile"])
    right = next(ax for ax in figs["springs"].axes if "of 105.00 mm" in _texts_of(ax.get_yticklabels()))
    spring3, spring2, spring1 = (t.get_text() for t in right.get_yticklabels())  # bottom to top
    assert re.match(r"0\.00–57\.9\d of 57\.66 mm: BEYOND its travel", spring1)
    assert spring1.endswith("at zero extension")  # Table 3: x₁ = 0 at θ₁ = 0
    assert re.fullmatch(r"0\.00–7\d\.\d\d of 105\.00 mm: at zero extension", spring3)  # far below its travel
    assert spring2.endswith("of 32.00 mm")


def test_profile_view_draws_a_published_design_in_its_own_basis(ev_rr):
    from cadcam.outputs.plots import _row
    for u in range(2):  # Table 3 is typed in as monomials; the spec's cams are Chebyshev
        panels, _, _ = _row(ev_rr, u, 3)
        for _, prof, _, circles, *_ in panels:
            departure = prof[0][3]
            (centre, radius), = circles
            # Johnston2023's cam touches its idler where the wire departs (Eq. 7, 15) [mm]
            assert np.hypot(*(departure - centre)) == pytest.approx(radius, abs=1e-6)


def test_output_figure_only_with_an_output_law():
    problem = load_spec(ROOT / "models" / "fedorov2018_balancer.toml")
    start_problem, start = start_design(problem)
    figs = figures(evaluate(start_problem, start, grid=12))
    assert sorted(figs) == ["output", "profile", "springs", "torque"]
    assert "idler (+ centre)" in _texts(figs["profile"])
    assert len(figs["profile"].axes) == 3


def test_output_figure_shows_the_error_between_the_design_grids_angles():
    """With a finer re-check, the error line is the re-check's and the NLP's angles are marked on
    it: the error between those angles is what the figure is for (an NLP meeting its law at
    every grid angle would otherwise show none)."""
    from cadcam.verify.evaluate import output_error
    problem = load_spec(ROOT / "models" / "fedorov2018_balancer.toml")
    start_problem, start = start_design(problem)
    coarse, fine = evaluate(start_problem, start, grid=12), evaluate(start_problem, start, grid=60)
    fig = figures(coarse, recheck=fine)["output"]
    line, marks = fig.axes[1].get_lines()[:2]
    mech = start_problem.mechanisms[0]
    np.testing.assert_allclose(line.get_ydata(), 1e6 * output_error(mech, fine.units[0]))
    np.testing.assert_allclose(marks.get_xdata(), np.degrees(coarse.units[0].theta))
    assert "(re-check grid)" in _texts(fig)
    assert "(design grid)" in _texts(figures(coarse)["output"])


def test_convergence_figure_draws_every_iterate():
    fig = convergence_figure(HISTORY)
    obj, infeas, step = fig.axes[:3]
    assert obj.get_yscale() == "log"  # 100 … 0.9 spans more than 20×
    assert [ln.get_label() for ln in infeas.get_lines()] == ["primal infeasibility", "dual infeasibility", "barrier μ"]
    np.testing.assert_allclose(infeas.get_lines()[0].get_ydata(), HISTORY["inf_pr"])
    np.testing.assert_allclose(step.get_lines()[0].get_ydata(), HISTORY["d_norm"])
    assert "4 iterates; last objective 0.9" in _texts(fig)


def test_write_outputs_adds_convergence_only_with_a_history(tmp_path, ev_1dof):
    for name, history in (("with", HISTORY), ("without", None)):
        result = SimpleNamespace(evaluation=ev_1dof, recheck=ev_1dof, history=history or {}, band=None, friction=None, builds=None,
                                 to_dict=lambda h=history: {"solver": {"history": h} if h else {}})
        write_outputs(result, tmp_path / name)
    assert (tmp_path / "with" / "convergence.png").is_file()
    check_output_file(tmp_path / "with" / "convergence.png")
    assert not (tmp_path / "without" / "convergence.png").exists()
    assert (tmp_path / "without" / "springs.png").is_file()


# -------------------------------------------------------------------------- binding constraints
def _metrics(x_max, x_min=(0.01, 0.01, 0.01), rho_lo=(0.03, 0.03), rho_hi=(0.06, 0.06), conv=(1e-4, 1e-4)):
    return {"extension_max": list(x_max), "extension_min": list(x_min), "rho_min": list(rho_lo),
            "rho_max": list(rho_hi), "convexity_min": list(conv), "curvature_radius_min": [0.1, 0.1],
            "margins": {"mechanism": [{}, {}]}}


def test_a_spring_at_its_travel_binds_and_one_below_does_not(rr_problem):
    travel = rr_problem.springs[1].travel  # spring 2: 32 mm
    assert travel == pytest.approx(0.032)
    at = binding_constraints(_metrics([0.05, travel * (1 - 0.5 * RTOL), 0.05]), rr_problem)
    assert at == ["spring 2 (McMaster-Carr 7749N634) at its travel limit: 31.98 mm of 32.00 mm"]
    assert binding_constraints(_metrics([0.05, travel * (1 - 3 * RTOL), 0.05]), rr_problem) == []
    over = binding_constraints(_metrics([0.05793, 0.02, 0.05]), rr_problem)
    assert over == ["spring 1 (McMaster-Carr 5667N212) beyond its travel limit: 57.93 mm of 57.66 mm"]


def test_zero_extension_rho_limits_and_convexity_bind(rr_problem):
    eps = rr_problem.options.convexity_epsilon
    rho_min = rr_problem.profiles[0].rho_min  # 25 mm
    found = binding_constraints(_metrics([0.05, 0.02, 0.05], x_min=(0.0, 0.01, 0.01), rho_lo=(rho_min, 0.03),
                                         conv=(eps * rho_min**2, 1e-4)), rr_problem)
    assert found == ["spring 1 (McMaster-Carr 5667N212) at zero extension: least extension 0.000 mm "
                     "(travel 57.66 mm)",
                     "cam 1 at ρ_min: ρ down to 25.00 mm, ρ_min 25.00 mm",
                     "cam 1 convexity margin near zero: ρ² + 2ρ′² − ρρ″ down to 0.625 mm² "
                     "(the NLP asks ≥ 0.625 mm², ρ_min² = 625 mm²)"]
    # below the NLP's margin but convex: still only near zero; below zero: not convex
    for conv, word in ((0.5 * eps * rho_min**2, "convexity margin near zero"), (-0.01 * rho_min**2, "not convex")):
        found = binding_constraints(_metrics([0.05, 0.02, 0.05], conv=(conv, 1e-4)), rr_problem)
        assert [f.split(":")[0] for f in found] == [f"cam 1 {word}"]


def test_a_mechanism_limit_binds_with_its_value():
    problem = load_spec(ROOT / "models" / "ludovico2021_pendulum.toml")  # min moment arm 5 mm
    metrics = {"extension_max": [0.05, 0.05], "extension_min": [0.015, 0.015],
               "margins": {"mechanism": [{"moment_arm": 1e-9, "free_span": 0.02},
                                         {"moment_arm": 0.004, "free_span": -0.001}]}}
    assert binding_constraints(metrics, problem) == [
        "pulley 1 moment arm at its lower limit: 5.00 mm of 5.00 mm",
        "pulley 2 free cable span beyond its lower limit: 4.00 mm of 5.00 mm"]


def test_limit_state_is_relative():
    assert limit_state(0.0, 1.0) == "at" and limit_state(RTOL * 0.9, 1.0) == "at"
    assert limit_state(RTOL * 1.1, 1.0) is None and limit_state(-RTOL * 1.1, 1.0) == "beyond"
    assert limit_state(5e-6, 1e-3) is None and limit_state(5e-7, 1e-3) == "at"


def test_the_published_table3_design_binds_as_the_paper_left_it(ev_rr):
    found = binding_constraints(ev_rr.metrics, ev_rr.problem)
    assert "spring 1 (McMaster-Carr 5667N212) beyond its travel limit: 57.93 mm of 57.66 mm" in found
    assert not any(s.startswith("spring 3") and "travel limit" in s for s in found)


# ------------------------------------------------------------------------------ drawing sheet
@pytest.fixture(scope="module")
def disc():
    return closed_outline(Basis("monomial", 0, (0.0, 2.0)), [0.03], 2.0)  # Ø60 mm disc


def test_sheet_has_a_title_block_and_dimensions(disc):
    fig, n = sheet_figure(disc, 0.006, 0.0025, 0.01, 0.1, "cam 7", spec="demo_spec", drawing="cam7",
                          date="2024-01-02")
    assert n == 1
    text = _texts(fig)
    for field in ("PART", "cam 7", "SPEC", "demo_spec", "DRAWING No.", "cam7", "SCALE", "1:1", "UNITS",
                  "mm", "SHEET", "A4", "DATE", "2024-01-02", f"cadcam {__version__}"):
        assert field in text, field
    assert "Ø6.00 bore" in text and "Ø2.50 anchor hole" in text
    assert "R30.00 (largest radius)" in text and "R30.00 (least radius of the red arc)" in text
    anchor = re.search(r"centre x ([\d.]+), y (-?[\d.]+)", text)
    # the anchor hole sits on the inward normal at φ = 0, 1 mm of wall + its radius deep
    assert float(anchor.group(1)) == pytest.approx(30 - 1 - 1.25, abs=0.02)
    assert float(anchor.group(2)) == pytest.approx(0.0, abs=0.02)


def test_sheet_strings_are_in_the_written_file(tmp_path, disc):
    import matplotlib
    fig, _ = sheet_figure(disc, 0.006, 0.0025, 0.01, 0.1, "cam 7", spec="demo_spec", date="2024-01-02")
    buf = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        fig.savefig(buf, format="svg")
    svg = buf.getvalue()
    for field in ("cam 7", "demo_spec", "1:1", "2024-01-02", f"cadcam {__version__}", "Ø6.00 bore"):
        assert field in svg, field
    assert draw_sheet(tmp_path / "cam7_sheet.pdf", disc, 0.006, 0.0025, 0.01, 0.1, "cam 7") == 1
    check_output_file(tmp_path / "cam7_sheet.pdf")


# ---------------------------------------------------------------------------------- study labels
def test_axis_labels_name_quantity_index_and_unit():
    assert axis_label("rmse_1") == ("RMSE, joint 1 [N·mm]", 1e3)
    assert axis_label("cams.1.idler.offset") == ("cams 1 idler offset [mm]", 1e3)
    assert axis_label("springs.2.rate") == ("springs 2 rate [N/mm]", 1e-3)
    assert axis_label("sensitivity_integral_1_2") == ("∫|∂τ/∂k|, joint 1, spring 2 [m²·rad^m]", 1.0)
    assert axis_label("extension_max_3") == ("largest extension, spring 3 [mm]", 1e3)
    assert axis_label("objective") == ("objective (Eq. 46/47) [-]", 1.0)
    assert axis_label("something_else") == ("something_else", 1.0)
    assert set(METRIC_LABELS) | {"margins", "violations"} == set(METRIC_NAMES)


def test_study_figure_draws_in_the_labelled_units():
    table = [{"status": "success", "cams.1.idler.offset": 0.01 * k, "rmse_1": 1e-4 * k, "mu": k}
             for k in range(1, 4)] + [{"status": "failed", "cams.1.idler.offset": 0.5, "rmse_1": None}]
    fig = study_figure(table, "cams.1.idler.offset", "rmse_1", "mu", pareto=False, title="t")
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("cams 1 idler offset [mm]", "RMSE, joint 1 [N·mm]")
    np.testing.assert_allclose(ax.collections[0].get_offsets(), [[10, 0.1], [20, 0.2], [30, 0.3]])
    assert ax.get_title() == "t: 3 successful cases of 4"


def test_the_catalogue_figure_draws_each_verdict_in_n_per_mm_and_rings_the_best():
    """Each verdict's springs in its colour, the best drawn on top; the error panel holds the
    springs given an rmse, in N·mm; the best is ringed where it lies on both."""
    colours = {"feasible": "green", "near": "orange", "infeasible": "red"}
    rate, preload = [1000.0, 2000.0, 4000.0, 500.0], [1.0, 2.0, 3.0, 4.0]
    fig = catalogue_figure(rate, preload, ["infeasible", "feasible", "near", "feasible"],
                           [np.nan, 2e-6, 5e-3, 1e-6], 3, colours, title="t")
    springs, errors = fig.axes
    drawn = {c.get_label().split(" (")[0]: c.get_offsets().tolist() for c in springs.collections}
    assert drawn == {"infeasible": [[1.0, 1.0]], "near": [[4.0, 3.0]], "feasible": [[2.0, 2.0], [0.5, 4.0]]}
    assert [c.get_label() for c in springs.collections] == ["infeasible (1)", "near (1)", "feasible (2)"]
    errs = {c.get_label().split(" (")[0]: c.get_offsets().tolist() for c in errors.collections}
    assert errs == {"near": [[4.0, 5.0]], "feasible": [[2.0, pytest.approx(2e-3)], [0.5, pytest.approx(1e-3)]]}
    ring = [line for line in springs.lines if line.get_label() == "the best"][0]
    assert (list(ring.get_xdata()), list(ring.get_ydata())) == ([0.5], [4.0])
    assert springs.get_xlabel() == "rate [N/mm]" and errors.get_ylabel() == "design rmse [N·mm]"
    assert [t.get_text() for t in springs.get_legend().get_texts()][:2] == ["the best", "feasible (2)"]
    none = catalogue_figure(rate, preload, ["infeasible"] * 4, [np.nan] * 4, None, colours).axes[1]
    assert none.get_legend() is None and [t.get_text() for t in none.texts] == ["no design converged"]


# -------------------------------------------------------------------------------- provenance
@pytest.fixture(scope="module")
def reporting():
    spec = importlib.util.spec_from_file_location("reporting", ROOT / "studies" / "reporting.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_provenance_has_every_field(reporting):
    import casadi
    import platform
    import scipy
    info = reporting.provenance_info()
    assert tuple(info) == reporting.PROVENANCE_FIELDS
    assert (info["cadcam"], info["python"], info["casadi"], info["numpy"], info["scipy"]) == (
        __version__, platform.python_version(), casadi.__version__, np.__version__, scipy.__version__)
    assert info["cores"] == os.cpu_count()
    assert info["commit"] == "unknown" or re.fullmatch(r"[0-9a-f]{40}", info["commit"])
    assert info["dirty"] in (True, False, "unknown")
    assert re.fullmatch(r"\d+\.\d+\.\d+", info["ipopt"])  # the IPOPT CasADi ships
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", info["date"])
    section = "\n".join(reporting.provenance_section(info))
    assert section.startswith("## Provenance") and f"| IPOPT | {info['ipopt']} |" in section
    assert f"{info['cores']} logical cores" in section


def test_provenance_without_git_says_unknown(reporting, monkeypatch):
    def no_git(*args, **kwargs):
        raise FileNotFoundError("git")
    monkeypatch.setattr(reporting.subprocess, "run", no_git)
    info = reporting.provenance_info()
    assert (info["commit"], info["dirty"]) == ("unknown", "unknown")
    assert "| working tree dirty | unknown |" in reporting.provenance_section(info)


def test_limit_lines_report_the_published_violation(reporting, ev_rr):
    lines = reporting.limit_lines("Table 3", ev_rr)
    assert lines[0].startswith("- **Table 3** (force-as-printed model, 12-angle grid per joint): **violates")
    assert "  - beyond a limit: spring 1 (McMaster-Carr 5667N212) beyond its travel limit: 57.93 mm of 57.66 mm" in lines
    assert not any(line.startswith("  - violated: spring above its travel") for line in lines)  # said above
    assert any(line.startswith("  - binding (within 0.1 % of the limit): cam 1 at ρ_min") for line in lines)


def test_the_pose_figure_draws_the_link_to_its_mass_where_the_mechanism_knows_it():
    """A pulley on a pendulum's link (turning = "pulley") turns with it: the link points up at
    θ = 0 and at σθ from the upright; drawn from the joint axis towards the mass."""
    from cadcam.designs import default_start
    from cadcam.outputs.plots import profile_figure

    problem = load_spec(ROOT / "docs" / "first_balancer.toml")
    mech, target = problem.mechanisms[0], problem.joints[0].target
    ev = evaluate(problem, default_start(problem), grid=7)
    fig = profile_figure(ev, n_poses=3)
    for ax, theta in zip(fig.axes, ev.units[0].theta[[0, 3, 6]]):
        end, words = mech.arm(theta, target)
        np.testing.assert_allclose(end, 0.2 * np.array([-np.sin(theta), np.cos(theta)]), atol=1e-15)
        lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == 0]
        assert any(np.allclose([ln.get_xdata()[1], ln.get_ydata()[1]], 1e3 * end) for ln in lines)
        assert any(words in t.get_text() for t in ax.texts) and words == "arm: 0.5 kg at 200 mm"
    assert mech.arm(0.3, replace(target, kind="expression")) is None


def test_the_pose_figure_draws_each_spring_from_its_end_to_its_length():
    """Ludovico2021's springs hang from their ends on the link along the free cable; each is
    drawn as a zigzag from the spring end over its drawn free length plus its extension at
    that pose, so that it is longer where it is stretched more."""
    from cadcam.designs import default_start
    from cadcam.outputs.plots import COIL_FILL, _mechanism_springs, profile_figure

    problem = load_spec(ROOT / "models" / "ludovico2021_pendulum.toml")
    ev = evaluate(problem, default_start(problem), grid=7)
    fig = profile_figure(ev, n_poses=3)
    for u, mech in enumerate(problem.mechanisms):
        (j, port, x), = _mechanism_springs(ev, u)
        unit, c = ev.units[u], ev.design.coefficients[u]
        np.testing.assert_allclose(x, ev.x[j])  # one joint: the spring's extension on its grid
        spans = [np.hypot(*np.subtract(*mech.segments(th, unit.z[:, k], c)[0])) for k, th in enumerate(unit.theta)]
        drawn = [0, 3, 6]
        free = min(problem.springs[j].travel, COIL_FILL * min(spans[k] for k in drawn) - x.max())
        for ax, k in zip(fig.axes[3 * u:3 * u + 3], drawn):
            coils = [ln.get_xydata() for ln in ax.get_lines() if ln.get_color() == "tab:purple" and len(ln.get_xdata()) > 5]
            (points,) = coils
            end = 1e3 * mech.spring_end(unit.theta[k])
            np.testing.assert_allclose(points[0], end, atol=1e-9)
            np.testing.assert_allclose(np.hypot(*(points[-1] - points[0])), 1e3 * (free + x[k]), rtol=1e-12)
            cable = (mech.segments(unit.theta[k], unit.z[:, k], c)[0][0] - end / 1e3) * 1e3
            along = points[-1] - points[0]
            assert abs(cable[0] * along[1] - cable[1] * along[0]) < 1e-9 * np.hypot(*cable) ** 2  # on the cable
    assert "spring: extension + a free length to fit (none given)" in _texts(fig)


@pytest.mark.parametrize("spec", ["models/roller_follower_pendulum.toml", "models/fedorov2018_balancer.toml",
                                  "docs/first_balancer.toml"])
def test_the_link_turns_with_its_body_and_gravity_on_its_mass_is_the_target(spec):
    """The link to a pendulum's mass is fixed to the body that turns with the joint (it turns as
    the profile's anchor does) and points where gravity along −y on its mass asks the springs
    for the target's torque, −m g dy/dθ = m g l sin(θ + phase), at three angles; drawn from the
    joint axis to the mass. A spec's ``link_angle`` turns it to point there at θ = 0."""
    from cadcam.designs import default_start
    from cadcam.outputs.plots import profile_figure

    problem = load_spec(ROOT / spec)
    mech, target = problem.mechanisms[0], problem.joints[0].target
    mass, length, g = (target.data[k] for k in ("mass", "length", "g"))
    ev = evaluate(problem, default_start(problem), grid=7)
    fig = profile_figure(ev, n_poses=3)
    h = 1e-6
    for ax, k in zip(fig.axes, [0, 3, 6]):
        theta = ev.units[0].theta[k]
        end, words = mech.arm(theta, target)
        assert np.hypot(*end) == pytest.approx(length) and words == f"arm: {mass:g} kg at {1e3 * length:g} mm"
        lift = (mech.arm(theta + h, target)[0][1] - mech.arm(theta - h, target)[0][1]) / (2 * h)
        assert -mass * g * lift == pytest.approx(ev.tau_d[0, k], rel=1e-6, abs=1e-9)
        turned = [np.arctan2(*np.array(mech.world_points(t, 0.0, 1.0))[::-1]) for t in (0.0, theta)]
        link = [np.arctan2(*mech.arm(t, target)[0][::-1]) for t in (0.0, theta)]
        assert np.cos((link[1] - link[0]) - (turned[1] - turned[0])) == pytest.approx(1.0)
        lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == 0]
        assert any(np.allclose([ln.get_xdata()[1], ln.get_ydata()[1]], 1e3 * end) for ln in lines)
    pointed = load_spec(ROOT / spec, overrides=[("mechanisms.1.link_angle", 0.25)]).mechanisms[0]
    assert pointed.link_angle == 0.25
    np.testing.assert_allclose(pointed.arm(0.0, target)[0], length * np.array([np.cos(0.25), np.sin(0.25)]))


def test_a_cable_span_stops_where_its_spring_begins():
    """A span ending at a spring's fixed end is cut back to the coil's far end; others are kept."""
    from cadcam.outputs.plots import _cable_to_coils
    coil = np.array([[0.0, -200.0], [3.0, -190.0], [-3.0, -180.0], [0.0, -170.0]])
    spans = [(np.array([30.0, 0.0]), np.array([0.0, -200.0])), (np.array([5.0, 5.0]), np.array([9.0, 9.0]))]
    (a, b), kept = _cable_to_coils(spans, [(coil, True)])
    np.testing.assert_array_equal(b, coil[-1])
    np.testing.assert_array_equal(a, spans[0][0])
    assert kept[1] is spans[1][1]


def test_pose_views_draw_one_angle_in_each_view_and_name_the_spring_off_a_close_up():
    """The same joint angle in the profile view's own box and in a close-up of the pulley; the
    close-up names the spring its cable leaves to once, with the coil's two ends (not a second
    label for the spring's end)."""
    from cadcam.designs import default_start
    from cadcam.outputs.plots import pose_views

    problem = load_spec(ROOT / "docs" / "first_balancer.toml")
    ev = evaluate(problem, default_start(problem), grid=7)
    close = ((-45.0, -45.0), (55.0, 55.0))
    fig = pose_views(ev, [None, close], pose=1, n_poses=3)
    whole, near = fig.axes
    assert whole.get_title() == near.get_title() == f"pulley: θ = {np.degrees(ev.units[0].theta[3]):.0f}°"
    assert (near.get_xlim(), near.get_ylim()) == ((-45.0, 55.0), (-45.0, 55.0))
    assert whole.get_ylim()[0] < -200 and "one joint angle" in fig.get_suptitle()
    (coil,) = [ln.get_xydata() for ln in whole.get_lines() if ln.get_color() == "tab:purple" and len(ln.get_xdata()) > 5]
    labels = [t.get_text() for t in near.texts if "spring" in t.get_text()]
    assert labels == [f"spring ({coil[-1][0]:.0f}, {coil[-1][1]:.0f}) to its end ({coil[0][0]:.0f}, {coil[0][1]:.0f}) mm"]
    assert np.allclose(coil[0], [0.0, -200.0])  # the spec's spring_end, fixed to the base


def test_convergence_figure_marks_matplotlibs_minor_ticks_without_tick_objects():
    fig = convergence_figure(HISTORY)
    for ax in fig.axes[:3]:
        marks = [a.line for a in ax.artists if isinstance(getattr(a, "line", None), Line2D)]
        own = Figure().add_subplot(yscale="log")  # the same data on matplotlib's own log axis
        for line in ax.get_lines():
            own.plot(line.get_xdata(), line.get_ydata())
        lo, hi = own.get_ylim()
        assert ax.get_ylim() == pytest.approx((lo, hi))
        expected = [v for v in own.yaxis.get_minorticklocs() if lo <= v <= hi]
        assert len(ax.yaxis.get_minorticklocs()) == 0 and len(marks) == 1
        np.testing.assert_allclose(marks[0].get_ydata(), expected)
    assert len(expected) > 8  # the step's axis, 10⁻⁵ to 1, has its minor ticks
