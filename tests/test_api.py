"""The Python API: cadcam.design/evaluate/check_derivatives/read_study, the Result's fields,
summary, figures and files, and the CLI's check command, --ipopt and --version."""
import copy
import subprocess
import sys
import json
import time
import tomllib

import matplotlib
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import cadcam
from cadcam.verify import derivatives
from cadcam.verify.evaluate import evaluate as check_evaluate
from cadcam.cli import main
from cadcam.sweep.study import load_study
from cadcam.sweep.runner import run_sweep

from .conftest import SPEC_1DOF, SPEC_RR, TABLE3


@pytest.fixture(scope="module")
def small():
    """The 1-DOF spec designed on a 12-angle grid through the API."""
    return cadcam.design(SPEC_1DOF, grid=12)


def test_design_returns_a_result_with_scipy_like_fields(small):
    d = small.to_dict()
    assert small.success is (small.status == "success") and small.success
    assert small.nit == d["solver"]["iterations"] > 0
    assert small.fun == d["solver"]["objective"]
    assert np.array_equal(small.x, np.concatenate([*small.design.coefficients, small.design.preextension]))
    assert small.problem.options.grid == 12
    history = d["solver"]["history"]
    assert history["iteration"] == list(range(small.nit + 1))
    assert all(len(history[k]) == small.nit + 1 for k in ("objective", "inf_pr", "inf_du", "mu", "d_norm",
                                                         "alpha_pr"))
    assert history["inf_du"][-1] < history["inf_du"][0]  # IPOPT converged from where it started


def test_the_result_times_its_build_solve_and_fine_recheck():
    t0 = time.perf_counter()
    result = cadcam.design(SPEC_1DOF, grid=12)
    wall = time.perf_counter() - t0
    d = result.to_dict()["solver"]
    parts = [d["build_time_s"], d["solve_time_s"], d["recheck_time_s"]]
    assert all(0 < t for t in parts) and sum(parts) < wall
    assert d["recheck_time_s"] == result.recheck_time_s
    assert f"fine re-check {result.recheck_time_s:.3f} s" in result.summary()


def test_the_repr_is_a_short_summary(small):
    text = repr(small)
    assert len(text) < 2000 and text.count("\n") < 15
    assert text.startswith("success: ") and f"{1e3 * small.evaluation.metrics.rmse[0]:.4g}" in text
    assert text == small.summary()


def test_a_dict_spec_with_overrides_equals_the_edited_file(tmp_path):
    data = tomllib.loads(SPEC_1DOF.read_text())
    edited = copy.deepcopy(data)
    edited["springs"][0]["rate"] = 1200.0
    by_override = cadcam.load_problem(data, overrides={"springs.1.rate": 1200.0}, grid=12)
    by_edit = cadcam.load_problem(edited, grid=12)
    assert by_override.to_dict() == by_edit.to_dict()
    assert by_override.springs[0].rate == 1200.0 and by_override.options.grid == 12
    assert data["springs"][0]["rate"] == 1100.0  # the caller's dict is left alone


def test_a_problem_with_options_is_checked_like_a_spec():
    problem = cadcam.load_spec(SPEC_1DOF)
    assert cadcam.load_problem(problem) is problem
    assert cadcam.load_problem(problem, grid=20).options.grid == 20
    with pytest.raises(cadcam.SpecError, match="unknown option 'gird'"):
        cadcam.load_problem(problem, gird=20)
    with pytest.raises(cadcam.SpecError, match="solver.grid"):
        cadcam.load_problem(problem, grid=1)
    with pytest.raises(cadcam.SpecError, match="solver.ipopt.no_such_option"):
        cadcam.load_problem(problem, ipopt={"no_such_option": 1})


def test_evaluate_takes_files_and_equals_the_check_layer():
    problem = cadcam.load_spec(SPEC_RR)
    design = cadcam.Design.from_dict(json.loads(TABLE3.read_text()), problem)
    by_files = cadcam.evaluate(SPEC_RR, TABLE3, grid=12, torque_model="force-as-printed")
    direct = check_evaluate(problem.with_torque_model("force-as-printed"), design, grid=12)
    assert by_files.metrics.rmse == direct.metrics.rmse
    assert by_files.metrics.extension_max == direct.metrics.extension_max


def test_plot_returns_figures_and_leaves_the_backend_alone(small):
    backend = matplotlib.get_backend()
    figs = small.plot()
    assert {"profile", "torque", "springs", "convergence"} <= set(figs)
    assert all(isinstance(f, matplotlib.figure.Figure) for f in figs.values())
    assert small.plot("torque").axes and matplotlib.get_backend() == backend
    with pytest.raises(ValueError, match="output"):
        small.plot("output")  # no output law in this problem


def test_the_result_is_a_dataframe_and_a_notebook_cell(small, tmp_path):
    """to_frame holds the fine re-check as torque_recheck.csv does; a notebook shows the summary."""
    import pandas as pd
    frame = small.to_frame()
    small.save(tmp_path / "f", workshop=None, figures=False)
    written = pd.read_csv(tmp_path / "f" / "torque_recheck.csv")
    assert list(frame.columns) == list(written.columns) and len(frame) == small.recheck.theta.shape[1]
    np.testing.assert_allclose(frame.to_numpy(), written.to_numpy(), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(frame["error1_Nm"], frame["tau1_Nm"] - frame["tau_d1_Nm"], rtol=0, atol=1e-15)
    cell = small._repr_html_()
    assert cell.startswith("<pre>") and cell.endswith("</pre>")
    assert __import__("html").unescape(cell[len("<pre>"):-len("</pre>")]) == small.summary()


@pytest.mark.slow  # a design through the API and again through the command line: make test-slow
def test_save_writes_what_the_cli_writes(small, tmp_path):
    notes = small.save(tmp_path / "r")
    names = {p.name for p in (tmp_path / "r").iterdir()}
    assert {"result.json", "torque.csv", "torque_recheck.csv", "profile.csv", "profile.png", "torque.png",
            "springs.png", "convergence.png", "cam1.dxf", "cam1.svg", "cam1_points.csv",
            "cam1_sheet.pdf"} <= names
    assert notes and notes[0].startswith("cam1:")
    saved = json.loads((tmp_path / "r" / "result.json").read_text())
    assert saved["status"] == small.status and saved["solver"]["iterations"] == small.nit
    small.save(tmp_path / "bare", workshop=None)
    assert not list((tmp_path / "bare").glob("cam*"))


def test_the_derivative_check_passes_on_the_model_and_the_nlp():
    report = cadcam.check_derivatives(SPEC_1DOF, grid=12, points=2)
    names = {(r.of, r.wrt) for r in report.rows}
    assert {("torque model: tau", "theta"), ("torque model: tau", "k"), ("exported Jacobian: tau", "c"),
            ("NLP: objective", "x"), ("NLP: constraints", "x"), ("NLP: Lagrangian gradient (Hessian)", "x")} <= names
    assert report.passed and max(r.rel_error for r in report.rows) < 1e-6
    assert all(r.norm > 0 for r in report.rows if r.wrt != "k" or "tau" in r.of)  # not zero blocks


def test_a_wrong_derivative_is_caught():
    x = np.array([0.3, -1.2, 2.0])

    def value(v):
        return np.array([np.sin(v[0]) * v[1], v[2] ** 3])
    exact = np.array([[np.cos(x[0]) * x[1], np.sin(x[0]), 0.0], [0.0, 0.0, 3 * x[2] ** 2]])
    good = derivatives.compare(value, x, exact, "f", "x")
    assert good.passed(1e-6) and good.rel_error < 1e-8
    wrong = exact.copy()
    wrong[1, 2] *= 1 + 1e-4  # one entry off by 0.01 %
    bad = derivatives.compare(value, x, wrong, "f", "x")
    assert not bad.passed(1e-6) and 1e-5 < bad.rel_error < 1e-4


def test_cadcam_check_exits_1_beyond_its_tolerance(capsys):
    assert main(["check", str(SPEC_1DOF), "--grid", "12", "--no-nlp", "--points", "1"]) == 0
    assert "every block agrees" in capsys.readouterr().out
    assert main(["check", str(SPEC_1DOF), "--grid", "12", "--no-nlp", "--points", "1", "--tol", "1e-13",
                 "--json"]) == 1  # differences are not that exact
    report = json.loads(capsys.readouterr().out)
    assert report["passed"] is False and any(not r["passed"] for r in report["rows"])
    assert main(["check", str(SPEC_1DOF), "--points", "0"]) == 2


def test_ipopt_options_reach_ipopt(tmp_path, capfd):
    """(The design without figures: IPOPT's log is printed before any is drawn.)"""
    assert main(["design", str(SPEC_1DOF), "--grid", "12", "-o", str(tmp_path / "o"), "--no-figures",
                 "--ipopt", "print_level=5"]) == 0
    printed = capfd.readouterr()
    assert "iter    objective    inf_pr" in printed.err  # IPOPT's own iteration log, on stderr
    assert printed.out.startswith("success: ")  # the verdict first
    assert main(["design", str(SPEC_1DOF), "-o", str(tmp_path / "p"), "--ipopt", "print_level"]) == 2
    assert main(["design", str(SPEC_1DOF), "-o", str(tmp_path / "p"), "--ipopt", "tol=1e-3"]) == 2
    assert not (tmp_path / "p").exists()


def test_version_and_help(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0 and capsys.readouterr().out.strip() == f"cadcam {cadcam.__version__}"
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert "``" not in text and "check" in text and text.rstrip().endswith("options.")


def test_read_study_returns_one_row_per_case(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(f'name = "two"\nbase = "{SPEC_1DOF}"\n[[parameters]]\nkey = "springs.1.rate"\n'
                     'values = [1000.0, 1200.0]\n[[parameters]]\nkey = "solver.grid"\nvalues = [12]\n')
    run_sweep(load_study(study), tmp_path / "s.db", workers=0, progress=False)
    table = cadcam.read_study(tmp_path / "s.db")
    assert type(table).__name__ == "DataFrame" and len(table) == 2
    column = table["springs.1.rate"]
    assert sorted(list(column)) == [1000.0, 1200.0] and list(table["status"]) == ["success", "success"]
    assert all(v > 0 for v in table["rmse_1"])


def _api_examples(page: str) -> list[str]:
    text = (SPEC_1DOF.parents[1] / page).read_text()
    return [part.split("```\n<!-- /api-example -->")[0] for part in text.split("<!-- api-example -->\n```python\n")[1:]]


@pytest.mark.slow  # every API example of the README and the guide, designs included
def test_the_readme_and_guide_api_examples_run_as_written(tmp_path, monkeypatch, capsys):
    (first,), guide = _api_examples("README.md"), _api_examples("docs/guide.md")
    assert len(guide) == 2
    (tmp_path / "models").symlink_to(SPEC_1DOF.parent)
    (tmp_path / "docs").symlink_to(SPEC_1DOF.parents[1] / "docs")
    monkeypatch.chdir(tmp_path)
    exec(compile(first, "README.md api-example", "exec"), {})
    out = capsys.readouterr().out
    assert out.startswith("success: ") and "tolerance band" in out
    assert (tmp_path / "out" / "first_balancer" / "verification.md").exists()
    exec(compile(guide[0], "docs/guide.md api-example", "exec"), {})
    out = capsys.readouterr().out
    assert out.startswith("success: ") and "every block agrees" in out
    assert (tmp_path / "torque.png").stat().st_size > 0 and (tmp_path / "out" / "api_demo" / "result.json").exists()
    exec(compile(guide[1], "docs/guide.md session example", "exec"), {})
    assert "(warm start from the last design)" in capsys.readouterr().out


def test_an_installed_example_is_a_spec(capsys):
    assert main(["evaluate", "--example", "johnston2023_rr_arm", "--design", str(TABLE3), "--grid", "12"]) == 0
    by_example = json.loads(capsys.readouterr().out)["metrics"]["rmse"]
    assert by_example == cadcam.evaluate(SPEC_RR, TABLE3, grid=12).metrics.rmse
    assert main(["evaluate", "--example", "no_such_spec", "--design", str(TABLE3)]) == 2
    assert "johnston2023_1dof" in capsys.readouterr().err
    assert main(["evaluate", str(SPEC_RR), "--example", "johnston2023_rr_arm", "--design", str(TABLE3)]) == 2


DOCUMENTED = (cadcam.SpecError, cadcam.DesignError, cadcam.StudyError)
#: Values of every type and shape an API argument might be given.
ANYTHING = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(allow_nan=True),
                     st.text(max_size=12), st.binary(max_size=4), st.lists(st.integers(), max_size=3),
                     st.dictionaries(st.integers(), st.integers(), max_size=2),
                     st.tuples(st.integers(), st.text(max_size=3)))


def _documented_or_fine(call) -> None:
    try:
        call()
    except DOCUMENTED as exc:
        assert "\n" not in str(exc), str(exc)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(overrides=ANYTHING, ipopt=ANYTHING, grid=ANYTHING)
def test_load_problem_raises_only_documented_errors_for_any_argument(overrides, ipopt, grid):
    """The API raised TypeError and AttributeError for arguments of the wrong type or shape."""
    _documented_or_fine(lambda: cadcam.load_problem(SPEC_1DOF, overrides=overrides, ipopt=ipopt, grid=grid))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(design=ANYTHING, grid=ANYTHING, points=ANYTHING, path=ANYTHING)
def test_evaluate_check_and_read_study_raise_only_documented_errors(design, grid, points, path):
    _documented_or_fine(lambda: cadcam.evaluate(SPEC_1DOF, design, grid=grid, profile=False))
    _documented_or_fine(lambda: cadcam.check_derivatives(SPEC_1DOF, points=points, nlp=False) if not (
        isinstance(points, int) and not isinstance(points, bool) and 1 <= points <= 20) else None)
    _documented_or_fine(lambda: cadcam.read_study(path))


def test_every_public_name_resolves_and_type_checkers_see_the_same_names():
    """``cadcam/__init__`` imports its names on first use; each must resolve to the object its
    module defines, and the block type checkers read must name the same ones."""
    import ast
    import importlib
    import inspect

    for name in cadcam.__all__:
        module = importlib.import_module(f"cadcam.{cadcam._MODULE_OF[name]}")
        assert getattr(cadcam, name) is getattr(module, name)
    assert callable(cadcam.optimize)  # not the module cadcam.optimize, once that is imported
    tree = ast.parse(inspect.getsource(cadcam))
    typed = {a.asname for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.level
             for a in node.names}
    assert typed == set(cadcam.__all__)


def test_the_command_imports_no_numerical_library_before_its_signal_handler():
    """The console script installs its handler first (an interrupt at start-up exits 130)."""
    code = "import sys, cadcam.__main__; print(sorted(m for m in ('numpy', 'casadi') if m in sys.modules))"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout.strip() == "[]"


def test_a_session_reuses_the_build_and_warm_starts_a_small_edit():
    """The design page's loop: an edit of a number re-solves through the kept NLP, from the
    last answer, in fewer iterations than the default start takes, to no worse an optimum."""
    from cadcam.solve import builds

    builds.forget_builds()
    session = cadcam.Session()
    first = session.design(SPEC_1DOF, grid=12)
    (kept,) = builds._BUILDS.values()
    edit = {"springs.1.rate": 1.02 * cadcam.load_spec(SPEC_1DOF).springs[0].rate}
    warm = session.design(SPEC_1DOF, grid=12, overrides=edit)
    assert list(builds._BUILDS.values()) == [kept]  # not built again
    cold = cadcam.design(SPEC_1DOF, grid=12, overrides=edit)
    assert first.success and warm.success and cold.success
    assert warm.message.endswith("(warm start from the last design)")
    assert warm.nit < cold.nit
    assert warm.fun <= cold.fun * (1 + 1e-6)


@pytest.mark.slow  # seconds of designs: make test-slow
def test_a_session_keeps_as_many_answers_as_builds():
    """A page that keeps changing the grid must not keep every structure's answer."""
    from cadcam.solve.builds import KEPT_BUILDS

    session = cadcam.Session()
    results = [session.design(SPEC_1DOF, grid=grid) for grid in range(10, 12 + KEPT_BUILDS)]
    assert sum(r.success for r in results) > KEPT_BUILDS  # premise: more answers than are kept
    assert len(session._last) == KEPT_BUILDS
