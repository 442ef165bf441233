"""Nothing reads a file cadcam did not choose (issue 48, rule 1).

The files that IPOPT, the linker, Python, ezdxf, OpenCascade and matplotlib would read on their
own from the working folder (:mod:`cadcam.library_files` lists them) are planted in the working
folder of every entry point — ``cadcam design``, ``cadcam sweep`` and its worker processes,
``cadcam export``, ``cadcam.design``, ``cadcam.optimize``, the page's designs — and change
nothing: no canary library or module is loaded, no file is written, the verdict is the first
line printed, the numbers are those of a run without them.
"""
import ast
import ctypes
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import cadcam
from cadcam.app.state import DesignState
from cadcam.cli import main
from cadcam.library_files import CASADI_PLUGINS, IPOPT_QUIET, ipopt_options, libraries_imported
from cadcam.solve import compiled
from cadcam.solve.builds import forget_builds
from cadcam.spec import _ipopt_refusal
from cadcam.sweep.runner import read_rows

from ..conftest import SPEC_1DOF

PACKAGE = Path(cadcam.__file__).parent
#: The design grid of the designs here: that of the ``design_1dof`` fixture they are compared with.
GRID = 12

#: Lines of a planted ``ipopt.opt``: options that load a library, write or print, or loosen the
#: problem; ``{lib}`` is the canary library, ``{out}`` a file IPOPT would write.
IPOPT_LINES = ("linear_system_scaling mc19", "linear_solver ma27", "hsllib {lib}", "pardisolib {lib}",
               "output_file {out}", "file_print_level 12", "print_level 12", "print_user_options yes",
               "print_options_documentation yes", "bound_relax_factor 1", "tol 1", "max_iter 1",
               "acceptable_tol 1e10", "acceptable_iter 1", "constr_viol_tol 1", "derivative_test second-order",
               "mu_strategy monotone", "nlp_scaling_method none")

#: A ``matplotlibrc`` that would change every figure (and run LaTeX for its text).
MATPLOTLIBRC = ("figure.figsize: 2, 2\nfigure.dpi: 20\nsavefig.facecolor: red\naxes.facecolor: black\n"
                "lines.linewidth: 9\nfont.size: 31\ntext.usetex: True\n")

#: Python modules a worker started with ``python -c`` would import from its working folder.
PYTHON_MODULES = ("multiprocessing", "numpy", "casadi", "cadcam")


@pytest.fixture
def planted_folder(tmp_path, planted, monkeypatch):
    """A working folder holding every file of :mod:`cadcam.library_files`'s list, each one that
    would leave a trace if read (the canary library loaded, ``ipopt.out`` written, a module's
    marker file), made the working folder; no NLP built before is reused."""
    folder = tmp_path / "planted"
    folder.mkdir()
    _plant(folder, planted, IPOPT_LINES)
    monkeypatch.chdir(folder)
    forget_builds()
    yield folder
    forget_builds()
    assert not (planted.parent / "loaded").exists(), "the canary library was loaded"
    assert not (folder / "ipopt.out").exists(), "IPOPT wrote the planted output_file"
    assert not list(folder.glob("imported-*")), "a planted Python module was imported"


def _plant(folder: Path, library: Path, ipopt_lines, occt: str = "file") -> None:
    """Plant the files in ``folder``: ``ipopt.opt`` of ``ipopt_lines``, a ``matplotlibrc``, an
    ``ezdxf.ini`` ezdxf cannot parse, OpenCascade's message files (``occt``: ``file`` or
    ``fifo``, which blocks whoever opens it), ``library`` as ``libgcc_s.so.1``, and Python
    modules that leave a marker file and fail."""
    (folder / "ipopt.opt").write_text("\n".join(ipopt_lines).format(lib=library, out=folder / "ipopt.out") + "\n")
    (folder / "matplotlibrc").write_text(MATPLOTLIBRC)
    (folder / "ezdxf.ini").write_text("this is no ini file: it has no [section]\n")
    for name in ("XSTEP.us", "SHAPE.us"):
        if occt == "fifo":
            os.mkfifo(folder / name)
        else:
            (folder / name).write_text(".XSTEP_1\nplanted %s\n")
    shutil.copy(library, folder / "libgcc_s.so.1")
    for name in PYTHON_MODULES:
        (folder / f"{name}.py").write_text(f"open({str(folder / f'imported-{name}')!r}, 'w').close()\n"
                                           f"raise SystemExit('planted {name} imported')\n")


def _same_design(design: dict, reference) -> None:
    """``design`` (a design's dict) is ``reference``'s, made in an empty working folder, to the
    last bit (as JSON has it)."""
    assert json.loads(json.dumps(design)) == json.loads(json.dumps(reference.design.to_dict()))


# -- every entry point ----------------------------------------------------------------------------
def _api_design(folder, capfd):
    return cadcam.design(SPEC_1DOF, grid=GRID).design.to_dict()


def _page_design(folder, capfd):
    state = DesignState(SPEC_1DOF)
    assert state.edit("solver.grid", str(GRID)) is None
    outcome = state.design()
    assert outcome.error is None, outcome.error
    return outcome.result.design.to_dict()


def _sweep_worker(folder, capfd):
    (folder / "study.toml").write_text(f'name = "planted"\nbase = "{SPEC_1DOF}"\n'
                                       f'[[parameters]]\nkey = "solver.grid"\nvalues = [{GRID}]\n')
    assert main(["sweep", "study.toml", "-o", "s.db", "--workers", "1"]) == 0
    _, rows = read_rows(folder / "s.db")
    assert [r["status"] for r in rows] == ["success"]
    return rows[0]["design"]


@pytest.mark.parametrize("entry", [_api_design, _page_design, _sweep_worker],
                         ids=lambda f: f.__name__.strip("_"))
def test_files_planted_in_the_working_folder_change_no_entry_point(entry, planted_folder, design_1dof, capfd):
    design = entry(planted_folder, capfd)
    _same_design(design, design_1dof)
    assert "Ipopt" not in capfd.readouterr().out  # nothing the planted print_level asked for


def _command(folder: Path, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    """``python -P`` with ``args`` in ``folder``, as the ``cadcam`` command starts (no working
    folder on ``sys.path``), importing this cadcam."""
    return subprocess.run([sys.executable, "-P", *args], cwd=folder, capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, "PYTHONPATH": str(PACKAGE.parent)})


def test_cadcam_design_as_a_command_reads_none_of_them(planted_folder, design_1dof):
    """``cadcam design`` in a process of its own, which imports ezdxf there (its workshop files)."""
    run = _command(planted_folder, "-m", "cadcam", "design", "--example", "johnston2023_1dof", "--grid", str(GRID),
                   "-o", "out", "--no-figures")
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.startswith("success: "), run.stdout[:300]
    assert "Ipopt" not in run.stdout + run.stderr  # nothing the planted print_level asked for
    _same_design(json.loads((planted_folder / "out" / "result.json").read_text())["design"], design_1dof)
    assert (planted_folder / "out" / "cam1.dxf").stat().st_size > 0


#: A figure drawn and a STEP solid written (as build123d writes one: OpenCascade's STEP writer,
#: imported as :mod:`cadcam.make.step` imports build123d), in a process of their own.
DRAWING = """
from cadcam.library_files import libraries_imported
from cadcam.outputs.plots import save_figure, study_figure
save_figure(study_figure(TABLE, "a", "b"), "figure.png")
with libraries_imported():
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
writer = STEPControl_Writer()
writer.Transfer(BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape(), STEPControl_AsIs)
writer.Write("box.step")
"""
TABLE = [{"status": "success", "a": float(i), "b": float(i * i)} for i in range(5)]


def test_figures_and_solids_made_in_a_planted_folder_are_made_as_anywhere(tmp_path, planted):
    """matplotlib's ``matplotlibrc`` is read when it is imported, OpenCascade's message files
    when a STEP solid is first written (planted as FIFOs here: whoever opens one waits for
    ever): in a process of its own, the figure is the one drawn here, and the solid is
    written."""
    folder = tmp_path / "planted"
    folder.mkdir()
    _plant(folder, planted, IPOPT_LINES, occt="fifo")
    run = _command(folder, "-c", f"TABLE = {TABLE!r}\n{DRAWING}", timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert (folder / "box.step").stat().st_size > 0
    import matplotlib.image

    from cadcam.outputs.plots import save_figure, study_figure
    save_figure(study_figure(TABLE, "a", "b"), tmp_path / "figure.png")
    np.testing.assert_array_equal(matplotlib.image.imread(folder / "figure.png"),
                                  matplotlib.image.imread(tmp_path / "figure.png"))
    assert not list(folder.glob("imported-*"))


#: Libraries that read files of the working folder when imported or first used, which cadcam
#: imports only inside :func:`cadcam.library_files.libraries_imported`.
GUARDED = ("ezdxf", "build123d", "OCP")


def test_cadcam_imports_those_libraries_only_inside_the_guard():
    """Every import of :data:`GUARDED` in cadcam sits in a ``with libraries_imported():``."""
    found = 0
    for path in PACKAGE.rglob("*.py"):
        tree = ast.parse(path.read_text())
        guarded = {id(node) for w in ast.walk(tree) if isinstance(w, ast.With)
                   and any(getattr(item.context_expr.func, "id", None) == "libraries_imported"
                           for item in w.items if isinstance(item.context_expr, ast.Call))
                   for node in ast.walk(w)}
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else [])
            if any(name.split(".")[0] in GUARDED for name in names):
                found += 1
                assert id(node) in guarded, f"{path.name}:{node.lineno}: {names[0]} imported outside the guard"
    assert found >= 4


# -- IPOPT's options file ---------------------------------------------------------------------------
def test_without_the_switch_ipopt_reads_the_planted_file(tmp_path, monkeypatch):
    """The control: IPOPT on its own reads ``ipopt.opt`` in the working folder and writes the
    file it names; built with :func:`ipopt_options` it does not."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ipopt.opt").write_text(f"output_file {tmp_path / 'ipopt.out'}\n")
    x = ca.SX.sym("x")
    ca.nlpsol("own", "ipopt", {"x": x, "f": (x - 1) ** 2}, IPOPT_QUIET)
    assert (tmp_path / "ipopt.out").exists()
    (tmp_path / "ipopt.out").unlink()
    ca.nlpsol("cadcam", "ipopt", {"x": x, "f": (x - 1) ** 2}, ipopt_options())
    assert not (tmp_path / "ipopt.out").exists()


ipopt_lines = st.lists(st.one_of(
    st.sampled_from(IPOPT_LINES),
    st.builds("bound_relax_factor {:g}".format, st.floats(1e-3, 1e3)),
    st.builds("print_level {}".format, st.integers(1, 12)),
    st.builds("tol {:g}".format, st.floats(1e-3, 1e3)),
    st.builds("max_iter {}".format, st.integers(0, 3)),
    st.builds("output_file {}".format, st.sampled_from(["{out}", "ipopt.out", "./ipopt.out"]))), min_size=1)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(lines=ipopt_lines)
def test_no_ipopt_solver_of_cadcam_reads_a_planted_options_file(lines, planted, tmp_path, monkeypatch, capfd):
    """Generated ``ipopt.opt`` files, under each kind of IPOPT solver cadcam builds: a solve
    (:func:`ipopt_options`), the spec's probe of an option's value, and the compile's oracle."""
    folder = tmp_path / "generated"
    folder.mkdir(exist_ok=True)
    (folder / "ipopt.opt").write_text("\n".join(lines).format(lib=planted, out=folder / "ipopt.out") + "\n")
    monkeypatch.chdir(folder)
    x = ca.SX.sym("x")
    nlp = {"x": x, "f": (x - 1) ** 2, "g": x}
    solved = ca.nlpsol("cadcam", "ipopt", nlp, ipopt_options())(x0=0, lbg=2, ubg=3)
    assert float(solved["x"]) == pytest.approx(2.0, abs=1e-7)  # not loosened by a bound_relax_factor
    assert _ipopt_refusal.__wrapped__("mu_init", 0.1) is None
    mx = ca.MX.sym("x")
    compiled.oracle_functions({"x": mx, "p": ca.MX.sym("p"), "f": (mx - 1) ** 2, "g": mx})
    assert capfd.readouterr().out == ""
    assert not (folder / "ipopt.out").exists() and not (planted.parent / "loaded").exists()


def test_every_ipopt_solver_is_built_with_the_shared_options():
    """Each ``nlpsol`` call in cadcam passes its options through :func:`ipopt_options`, or
    options made by it and held in a name (transcription's ``ipopt``), maybe unpacked first
    into a dict (``{**ipopt, "expand": …}``)."""
    calls = [(path.name, node) for path in PACKAGE.rglob("*.py") for node in ast.walk(ast.parse(path.read_text()))
             if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "nlpsol"]
    assert len(calls) >= 6
    for name, call in calls:
        options = call.args[3]
        if isinstance(options, ast.Dict) and options.keys[0] is None:
            options = options.values[0]
        shared = (isinstance(options, ast.Call) and getattr(options.func, "id", None) == "ipopt_options"
                  or isinstance(options, ast.Name) and options.id == "ipopt")
        assert shared, f"{name}:{call.lineno}: an IPOPT solver built without ipopt_options"


def test_every_casadi_plugin_cadcam_asks_for_ships_in_casadis_folder():
    """CasADi looks for a plugin in its own folder first and in the working folder last: each
    one cadcam uses is found before the search gets there."""
    folder = Path(ca.__file__).parent
    for kind, name in CASADI_PLUGINS:
        assert (folder / f"libcasadi_{kind}_{name}.so").is_file(), (kind, name)
        assert getattr(ca, f"has_{kind}")(name)


# -- the compiler ------------------------------------------------------------------------------------
def _needed(library: Path) -> str:
    """The libraries ``library`` loads with it (its dynamic section)."""
    return subprocess.run(["readelf", "-d", str(library)], capture_output=True, text=True, check=True).stdout


@pytest.mark.skipif(not compiled.available() or shutil.which("readelf") is None,
                    reason="no C compiler or readelf on this machine")
def test_a_compile_links_no_library_of_the_working_folder(tmp_path, planted, monkeypatch):
    """GNU ld opens ``libgcc_s.so.1`` in its working folder and links it in when it defines a
    symbol the code calls (``memset`` here): the control shows it, in the working folder;
    :func:`cadcam.solve.compiled.run_compiler` compiles elsewhere."""
    source = tmp_path / "uses_memset.c"
    source.write_text("#include <string.h>\nvoid clear(char *x, int n) { memset(x, 0, n); }\n")
    folder = tmp_path / "planted"
    folder.mkdir()
    shutil.copy(planted, folder / "libgcc_s.so.1")
    command = [compiled.compiler(), "-shared", "-fPIC", str(source), "-o"]
    subprocess.run([*command, str(tmp_path / "control.so")], cwd=folder, check=True)
    assert str(planted) in _needed(tmp_path / "control.so")
    monkeypatch.chdir(folder)
    assert compiled.run_compiler([*command, str(tmp_path / "cadcam.so")]).returncode == 0
    assert str(planted) not in _needed(tmp_path / "cadcam.so")
    ctypes.CDLL(str(tmp_path / "cadcam.so"))
    assert not (planted.parent / "loaded").exists()


# -- ezdxf's configuration -------------------------------------------------------------------------
FIXED_METADATA = b"[core]\nWRITE_FIXED_META_DATA_FOR_TESTING = true\n"


def test_without_the_guard_ezdxf_reads_the_planted_configuration(tmp_path, monkeypatch):
    """The control: ezdxf's options, made in a working folder with an ``ezdxf.ini``, take it."""
    from ezdxf._options import Options

    monkeypatch.chdir(tmp_path)
    (tmp_path / "ezdxf.ini").write_bytes(FIXED_METADATA)
    assert Options().get_bool("core", "WRITE_FIXED_META_DATA_FOR_TESTING")
    with libraries_imported():
        assert not Options().get_bool("core", "WRITE_FIXED_META_DATA_FOR_TESTING")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(content=st.one_of(st.just(FIXED_METADATA), st.binary(max_size=300),
                         st.text(max_size=300).map(lambda t: ("[core]\n" + t).encode())))
def test_ezdxf_takes_no_configuration_from_the_working_folder(content, tmp_path, monkeypatch):
    """Generated ``ezdxf.ini`` files — what ezdxf would take, what it cannot parse or decode
    (a traceback when ezdxf is imported) — are not read while cadcam imports ezdxf."""
    from ezdxf._options import Options, default_config

    monkeypatch.chdir(tmp_path)
    (tmp_path / "ezdxf.ini").write_bytes(content)
    with libraries_imported():
        options = Options()
    for key, value in default_config()["core"].items():
        assert options.get("core", key) == value, key
