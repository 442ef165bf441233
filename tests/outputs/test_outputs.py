"""Outputs are all or nothing: a design's files are staged in a hidden folder and moved into
place with result.json last, so a run that fails or is interrupted leaves the previous set as it
was and never a final-looking result.json beside a partial set; temporary files of a killed run
are recognised and removed by the next; output paths are checked before any work."""
import errno
import os
import signal
import subprocess
import sys

import importlib.util

import numpy as np
import pytest
from PIL import Image

import cadcam.outputs.plots
from cadcam.cli import main
from cadcam.files import MANIFEST, TEMP_PREFIX, NotCadcams, recorded_sets, staged_folder, write_text
from cadcam.solve.transcription import Transcription
from cadcam.optimize import optimize
from cadcam.spec import load_spec

from ..conftest import ROOT, SPEC_1DOF, SPEC_RR, TABLE3


@pytest.fixture(scope="module")
def demo(result_1dof):
    return result_1dof


@pytest.fixture
def design(monkeypatch, demo, capsys):
    """``cadcam design`` of the 1-DOF spec with the solve replaced by a finished one."""
    module = importlib.import_module("cadcam.optimize")  # the package exports a function of that name
    importlib.import_module("cadcam.api")  # first: its own name for optimize stays the real function
    monkeypatch.setattr(module, "optimize", lambda problem: demo)

    def run(out, *flags):
        code = main(["design", str(SPEC_1DOF), "-o", str(out), *flags])
        captured = capsys.readouterr()
        run.stdout = captured.out  # what the run printed, for the tests that read it
        return code, captured.err
    return run


def _snapshot(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def _fail_at_torque_png(monkeypatch, exc):
    real = cadcam.outputs.plots.save_figure

    def broken(fig, path):
        real(fig, path)  # the figure is half-way through the set when the environment fails
        if path.name == "torque.png":
            raise exc
    monkeypatch.setattr(cadcam.outputs.plots, "save_figure", broken)


def test_a_complete_design_leaves_no_hidden_file(tmp_path, design):
    code, _ = design(tmp_path / "o")
    names = sorted(os.listdir(tmp_path / "o"))
    assert code == 0 and "result.json" in names and "torque.png" in names
    assert [n for n in names if n.startswith(".")] == [MANIFEST]  # the set's record, no temporary file
    assert sorted(recorded_sets(tmp_path / "o")["result.json"]) == [n for n in names if n != MANIFEST]


def test_no_figures_writes_every_file_but_those_matplotlib_draws_and_says_so(tmp_path, design):
    code, _ = design(tmp_path / "o", "--no-figures")
    names = set(os.listdir(tmp_path / "o"))
    assert code == 0 and {"result.json", "torque.csv", "torque_recheck.csv", "profile.csv", "cam1.dxf",
                          "cam1.svg", "cam1_points.csv"} <= names
    assert not [n for n in names if n.endswith((".png", ".pdf"))]
    assert ".png" not in design.stdout and "cam1: " in design.stdout


def test_a_disk_full_midway_leaves_no_folder_and_one_line(tmp_path, design, monkeypatch):
    _fail_at_torque_png(monkeypatch, OSError(errno.ENOSPC, "No space left on device",
                                             str(tmp_path / "o" / "torque.png")))
    code, err = design(tmp_path / "new" / "o")
    assert code == 1 and err.count("\n") == 1 and "No space left on device" in err
    assert not (tmp_path / "new").exists()  # the folders this run created are gone too


@pytest.mark.slow  # two designs with every file: make test-slow
def test_a_failure_midway_keeps_the_previous_set_byte_for_byte(tmp_path, design, monkeypatch):
    assert design(tmp_path / "o")[0] == 0
    before = _snapshot(tmp_path / "o")
    _fail_at_torque_png(monkeypatch, PermissionError(errno.EACCES, "Permission denied"))
    code, err = design(tmp_path / "o")
    assert code == 1 and "Permission denied" in err
    assert _snapshot(tmp_path / "o") == before


def test_an_interrupt_midway_exits_130_and_leaves_nothing(tmp_path, design, monkeypatch):
    _fail_at_torque_png(monkeypatch, KeyboardInterrupt())
    code, err = design(tmp_path / "o")
    assert code == 130 and "interrupted" in err and not (tmp_path / "o").exists()


def _signal_during_solves(monkeypatch, signum):
    """Have another process send this one ``signum`` 20 ms into every IPOPT solve (the 1-DOF
    solve takes ten times that) and wait for it before the solve returns, so no signal comes
    later; returns the solvers, whose stats say whether IPOPT was stopped."""
    solvers, build = [], Transcription.__init__

    class Signalled:
        def __init__(self, real):
            self.real = real

        def __call__(self, **kwargs):
            sender = subprocess.Popen(["sh", "-c", f"sleep 0.02; kill -{signum.name[3:]} {os.getpid()}"])
            try:
                return self.real(**kwargs)
            finally:
                sender.wait()

        def stats(self):
            return self.real.stats()

    def built(self, *args, **kwargs):
        build(self, *args, **kwargs)
        solvers.append(self.solver)
        self.solver = Signalled(self.solver)
    monkeypatch.setattr(Transcription, "__init__", built)
    return solvers


def test_ctrl_c_during_the_solve_interrupts_instead_of_returning_a_failed_design(monkeypatch):
    """CasADi stops IPOPT on Ctrl-C but swallows the KeyboardInterrupt; it must come out."""
    solvers = _signal_during_solves(monkeypatch, signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        optimize(load_spec(SPEC_1DOF))
    assert solvers[0].stats()["return_status"] == "NonIpopt_Exception_Thrown"  # IPOPT was stopped
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_sigterm_during_the_solve_exits_130_and_leaves_nothing(tmp_path, monkeypatch, capsys):
    solvers = _signal_during_solves(monkeypatch, signal.SIGTERM)
    code = main(["design", str(SPEC_1DOF), "-o", str(tmp_path / "o")])
    assert code == 130 and "interrupted" in capsys.readouterr().err and not (tmp_path / "o").exists()
    assert solvers[0].stats()["return_status"] == "NonIpopt_Exception_Thrown"


def test_a_move_that_fails_leaves_the_earlier_set_whole(tmp_path, monkeypatch):
    """The old result.json was removed first, so a failed move left half a set (issue 48)."""
    with staged_folder(tmp_path, "result.json") as stage:  # an earlier set of cadcam's
        for name in ("result.json", "a.csv", "c.csv"):
            (stage / name).write_text(f"old {name}")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    real, moved = os.replace, []

    def replace(src, dst):
        if "-stage-" in os.path.dirname(src) and os.path.dirname(dst) == str(tmp_path):  # moves into place
            if moved:  # the second move fails: the set is half old, half new
                raise OSError(errno.EIO, "Input/output error")
            moved.append(os.path.basename(dst))
        real(src, dst)
    with pytest.raises(OSError, match="the earlier one is left whole"):
        with staged_folder(tmp_path, "result.json") as stage:
            for name in ("result.json", "a.csv", "b.csv"):
                (stage / name).write_text(f"new {name}")
            monkeypatch.setattr(os, "replace", replace)
    monkeypatch.undo()
    assert moved == ["a.csv"]  # result.json is never moved before the others
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # c.csv too, and no hidden folder


def test_a_folder_of_the_users_in_the_way_is_never_deleted(tmp_path):
    """A folder (or a link to one) named like an output stops the move before anything moves;
    it kept being replaced by the output, with everything in it, before."""
    with staged_folder(tmp_path, "result.json") as stage:
        (stage / "result.json").write_text("old")
    (tmp_path / "torque.csv").mkdir()
    (tmp_path / "torque.csv" / "mine.txt").write_text("the user's")
    with pytest.raises(NotCadcams, match="not a file") as refused:
        with staged_folder(tmp_path, "result.json") as stage:
            (stage / "result.json").write_text("new")
            (stage / "torque.csv").write_text("new")
    assert str(refused.value).startswith(f"{tmp_path / 'torque.csv'}: ")
    assert (tmp_path / "torque.csv" / "mine.txt").read_text() == "the user's"
    assert (tmp_path / "result.json").read_text() == "old"  # nothing moved
    assert sorted(os.listdir(tmp_path)) == [MANIFEST, "result.json", "torque.csv"]


def test_design_into_a_folder_holding_a_users_folder_is_refused_before_work(tmp_path, capsys):
    """The folder in the way was found at the move, after the solve (exit 1)."""
    from cadcam.cli import main

    (tmp_path / "torque.csv").mkdir()
    (tmp_path / "torque.csv" / "mine.txt").write_text("the user's")
    assert main(["design", str(SPEC_1DOF), "--grid", "12", "--no-figures", "-o", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # nothing was solved
    assert len(captured.err.strip().splitlines()) == 1 and "torque.csv" in captured.err
    assert sorted(os.listdir(tmp_path)) == ["torque.csv"]
    assert (tmp_path / "torque.csv" / "mine.txt").read_text() == "the user's"


def _dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_leftovers_of_a_killed_run_are_removed_and_a_live_writers_kept(tmp_path):
    dead, live = _dead_pid(), os.getppid()
    (tmp_path / f"{TEMP_PREFIX}{dead}-stage-x1y2").mkdir()
    (tmp_path / f"{TEMP_PREFIX}{dead}-stage-x1y2" / "torque.csv").write_text("partial")
    (tmp_path / f"{TEMP_PREFIX}{dead}-result.json.abc.json").write_text("partial")
    (tmp_path / f"{TEMP_PREFIX}{live}-result.json.def.json").write_text("being written")
    (tmp_path / ".keep").write_text("the user's own")
    write_text(tmp_path / "note.txt", "x")
    assert sorted(os.listdir(tmp_path)) == sorted([".keep", "note.txt", f"{TEMP_PREFIX}{live}-result.json.def.json"])


@pytest.mark.parametrize("argv", [
    ["export", str(SPEC_RR), "--design", str(TABLE3), "-o", "{file}"],
    ["export", str(SPEC_RR), "--design", str(TABLE3), "-o", "{file}/sub"],
    ["sweep", str(ROOT / "studies" / "basis_order.toml"), "-o", "{folder}"],
    ["sweep", str(ROOT / "studies" / "basis_order.toml"), "-o", "{file}/x.db"],
    ["sweep-export", "{file}", "--csv", "{folder}"],
    ["plot-study", "{file}", "--x", "a", "--y", "b", "-o", "{folder}"],
    ["plot-study", "{file}", "--x", "a", "--y", "b", "-o", "{file}/x.png"],
])
def test_output_paths_are_checked_before_any_work(tmp_path, capsys, argv):
    (tmp_path / "file").write_text("x")
    (tmp_path / "folder").mkdir()
    names = {"file": str(tmp_path / "file"),
             "folder": str(tmp_path / "folder")}
    code = main([a.format(**names) for a in argv])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and ("is a folder" in err or "is a file" in err)
    assert sorted(os.listdir(tmp_path)) == ["file", "folder"] and not os.listdir(tmp_path / "folder")


def test_no_figures_loads_no_matplotlib():
    """``--no-figures`` neither draws nor imports the figures' library (a fresh interpreter)."""
    code = ("import sys, tempfile; from cadcam.cli import main; "
            f"code = main(['design', {str(SPEC_1DOF)!r}, '-o', tempfile.mkdtemp(), '--no-figures']); "
            "print(code, 'matplotlib' in sys.modules)")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout.strip().splitlines()[-1] == "0 False"


def test_a_rerun_removes_the_earlier_runs_files_it_does_not_write_and_nothing_else(tmp_path, design):
    out = tmp_path / "o"
    assert design(out)[0] == 0
    (out / "notes.txt").write_text("mine")
    (out / "cam1_notes.txt").write_text("mine")
    assert design(out, "--no-figures")[0] == 0
    names = set(os.listdir(out))
    assert not [n for n in names if n.endswith((".png", ".pdf"))]
    assert {"result.json", "cam1.dxf", "notes.txt", "cam1_notes.txt"} <= names


# -- figures and sheets drawn side by side (tests/outputs/test_forked.py tests the drawing processes)
@pytest.mark.slow  # seconds of designs: make test-slow
def test_figures_drawn_side_by_side_are_the_figures_drawn_one_after_another(tmp_path):
    code = ("from cadcam import load_spec; from cadcam.optimize import optimize; "
            f"r = optimize(load_spec({str(SPEC_1DOF)!r})); "
            f"r.save({str(tmp_path / 'one')!r}, workers=1); r.save({str(tmp_path / 'two')!r}, workers=2)")
    subprocess.run([sys.executable, "-c", code], check=True)
    one, two = (sorted(p.name for p in (tmp_path / d).iterdir()) for d in ("one", "two"))
    assert one == two and {"profile.png", "convergence.png", "cam1_sheet.png", "cam1_sheet.pdf"} <= set(one)
    for name in (n for n in one if n.endswith(".png")):
        a, b = (np.asarray(Image.open(tmp_path / d / name)) for d in ("one", "two"))
        assert np.array_equal(a, b), name


def test_a_second_run_into_a_held_folder_is_refused_before_work(tmp_path, capsys):
    """Two `cadcam design` runs into one folder: the later one replaced the earlier one's files
    while it reported success. A run holds its folder from start to end; another is refused."""
    from cadcam.cli import main
    from cadcam.files import held_folder

    out = tmp_path / "out"
    with held_folder(out):  # a run under way
        assert main(["design", str(SPEC_1DOF), "--grid", "12", "--no-figures", "-o", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "another cadcam run is writing into this folder" in err
        assert os.listdir(out) == []  # nothing written by the refused run
    assert main(["design", str(SPEC_1DOF), "--grid", "12", "--no-figures", "-o", str(out)]) == 0
    assert (out / "result.json").is_file()


def test_a_file_cadcam_did_not_write_is_never_replaced(tmp_path, capsys, design):
    """A user's own torque.csv in the output folder was overwritten (and a user's cam3.dxf
    deleted as a stale output): cadcam replaces only files it recorded writing, and leaves
    those under names it does not write."""
    (tmp_path / "torque.csv").write_text("the user's")
    assert main(["design", str(SPEC_1DOF), "--grid", "12", "--no-figures", "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "torque.csv: a file with no record of cadcam's writing it" in err
    assert (tmp_path / "torque.csv").read_text() == "the user's"
    with pytest.raises(NotCadcams, match="replaces or removes only the files it recorded"):  # the same for the API
        with staged_folder(tmp_path, "result.json") as stage:
            (stage / "torque.csv").write_text("new")
            (stage / "result.json").write_text('{"cadcam_version": "0"}')
    assert sorted(os.listdir(tmp_path)) == ["torque.csv"]
    (tmp_path / "cam3.dxf").write_text("the user's")  # named like an output of a 3-cam design, not this one
    (tmp_path / "torque.csv").unlink()
    assert design(tmp_path, "--no-figures")[0] == 0
    assert (tmp_path / "cam3.dxf").read_text() == "the user's" and "cam3.dxf" not in recorded_sets(tmp_path)["result.json"]


def test_a_folder_of_cadcams_own_is_written_again(tmp_path):
    from cadcam.cli import main

    for _ in range(2):
        assert main(["design", str(SPEC_1DOF), "--grid", "12", "--no-figures", "-o", str(tmp_path)]) == 0
    assert (tmp_path / "result.json").is_file()
