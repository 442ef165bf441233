"""Output hygiene (issue 48, rule 7): control characters escaped in every message and in CSV
cells, spreadsheet formulas neutralised; the verdict the first line of standard output whatever
IPOPT prints; a write that fails changes that first line; any output encoding survives."""
import contextlib
import csv
import errno
import io
import json
import os
import subprocess
import sys
import unicodedata
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import cadcam
from cadcam.__main__ import _escaping_streams
from cadcam.cli import NOT_WRITTEN, _say, main
from cadcam.files import FORMULA_STARTS, UNPRINTABLE, csv_text, printable, write_csv
from cadcam.sweep.runner import _case_words

from ..conftest import SPEC_1DOF

PACKAGE = Path(cadcam.__file__).parent
FUNCTION_SCOPED = [HealthCheck.function_scoped_fixture]

#: Text with what a hostile name would hold: escape codes, line breaks, C1 controls,
#: bidirectional overrides, zero widths, surrogates (an undecodable file name), as well as text.
hostile = st.lists(st.one_of(st.sampled_from(["\x1b[31m", "\x1b]0;title\x07", "\n", "\r", "\t", "\x85", "\u2028",
                                              "\u202e", "\u200b", "\udcff", "\x7f", "\x9b"]),
                             st.characters(codec="utf-8", exclude_characters="\0")), max_size=20).map("".join)


def _no_raw_controls(text: str) -> bool:
    return not any(unicodedata.category(ch) in UNPRINTABLE for ch in text)


# -- messages --------------------------------------------------------------------------------------
@settings(deadline=None)
@given(text=hostile)
def test_printable_leaves_nothing_a_terminal_acts_on_and_changes_nothing_else(text):
    shown = printable(text)
    assert _no_raw_controls(shown) and "\n" not in shown
    assert printable(shown) == shown
    rest = iter(shown)  # every other character kept, in its order
    assert all(ch in rest for ch in text if unicodedata.category(ch) not in UNPRINTABLE)
    if _no_raw_controls(text):
        assert shown == text


@settings(max_examples=60, deadline=None, suppress_health_check=FUNCTION_SCOPED)
@given(text=hostile, where=st.sampled_from(["spec", "set", "example", "variant", "design", "database", "output"]))
def test_every_refusal_is_one_line_whatever_a_name_holds(text, where, tmp_path, capsys):
    """Refusals that name what the user gave (a spec path, a key, an example, a variant, a
    design file, a study database, an output folder) print it escaped, on one line."""
    spec, out, name = str(SPEC_1DOF), str(tmp_path / "out"), f"no-such-{text}"
    argv = {"spec": ["design", name + ".toml", "-o", out],
            "set": ["design", spec, "--set", f"{name}=1", "-o", out],
            "example": ["design", "--example", name, "-o", out],
            "variant": ["design", spec, "--variant", name, "-o", out],
            "design": ["evaluate", spec, "--design", name + ".json"],
            "database": ["sweep-export", name + ".db", "--csv", out],
            "output": ["design", spec, "-o", f"{__file__}/{name}"]}[where]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith("cadcam: error: ") and captured.err.count("\n") == 1
    assert _no_raw_controls(captured.err[:-1])


@settings(max_examples=20, deadline=None, suppress_health_check=FUNCTION_SCOPED)
@given(name=hostile)
def test_a_summary_keeps_each_line_whatever_the_names_hold(name, design_1dof):
    """The summary names the problem; a line break or escape code in the name stays escaped
    in its line (so the verdict stays the first line, and the lines are as many)."""
    named = replace(design_1dof, problem=replace(design_1dof.problem, name=name))
    lines = named.summary().split("\n")
    assert len(lines) == len(design_1dof.summary().split("\n"))
    assert lines[0] == design_1dof.summary().split("\n")[0]
    assert all(_no_raw_controls(line) for line in lines)


@settings(deadline=None)
@given(value=hostile)
def test_a_sweeps_progress_line_names_a_catalogue_id_escaped(value):
    words = _case_words({"params": json.dumps({"springs.1": value, "springs.1.rate": 1200.0})})
    assert _no_raw_controls(words) and words.endswith("springs.1.rate = 1200")


@settings(max_examples=40, deadline=None)
@given(text=hostile, encoding=st.sampled_from(["ascii", "latin-1", "cp1252", "utf-8", "koi8-r"]))
def test_the_commands_streams_write_what_their_encoding_lacks_as_escapes(text, encoding):
    """``PYTHONIOENCODING=ascii`` and the like: every message is written, escaped where the
    encoding lacks a character (the command line's streams, :func:`_escaping_streams`)."""
    streams = [io.TextIOWrapper(io.BytesIO(), encoding=encoding) for _ in range(2)]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sys, "stdout", streams[0])
        patch.setattr(sys, "stderr", streams[1])
        _escaping_streams()
        _say(f"success: N·mm ρ ≤ {text}")
        _say(f"cadcam: error: {text} ≤", err=True)
    for stream in streams:
        stream.flush()
        written = stream.buffer.getvalue().decode(encoding)
        assert written.count("\n") == 1 and written.startswith(("success: N", "cadcam: error: "))


def test_a_design_under_an_ascii_terminal_prints_its_verdict_and_writes_its_files(tmp_path):
    run = subprocess.run([sys.executable, "-P", "-m", "cadcam", "design", "--example", "johnston2023_1dof",
                          "--grid", "8", "-o", str(tmp_path / "out"), "--no-figures"], capture_output=True,
                         timeout=300, env={**os.environ, "PYTHONIOENCODING": "ascii",
                                           "PYTHONPATH": str(PACKAGE.parent)})
    assert run.returncode == 0, run.stderr.decode(errors="replace")[-2000:]
    out = run.stdout.decode("ascii")  # nothing but ASCII was written
    assert out.startswith("success: ") and "[N\\xb7mm]" in out
    assert (tmp_path / "out" / "result.json").exists()


# -- CSV cells -------------------------------------------------------------------------------------
cells = st.one_of(hostile, st.sampled_from(["=1+2*3", "+cmd|' /C calc'!A0", "-2+3", "@SUM(A1:A9)", "\t=1", "\r=1",
                                            "=HYPERLINK(\"http://x\")", "'=1"]),
                  st.floats(allow_nan=False), st.integers(-10**18, 10**18), st.none())


@given(rows=st.lists(st.lists(cells, min_size=3, max_size=3), max_size=5), header=st.lists(hostile, min_size=3,
                                                                                           max_size=3))
@settings(deadline=None, suppress_health_check=FUNCTION_SCOPED)
def test_csv_text_never_starts_like_a_formula_and_numbers_stay_numbers(rows, header, tmp_path):
    path = tmp_path / "t.csv"
    write_csv(path, header, rows)
    with open(path, newline="", encoding="utf-8") as fh:
        read = list(csv.reader(fh))
    assert read[0] == [csv_text(h) for h in header]
    for written, row in zip(read[1:], rows):
        for cell, value in zip(written, row):
            if value is None:
                assert cell == ""
            elif isinstance(value, str):
                assert not cell.startswith(FORMULA_STARTS) and _no_raw_controls(cell)
                shown = printable(value)
                assert cell == ("'" + shown if shown.startswith(FORMULA_STARTS) else shown)
            else:  # a number as itself: an integer to the last digit
                assert type(value)(cell) == value


def test_a_catalogue_id_like_a_formula_is_exported_as_text(tmp_path, capsys):
    """A spring catalogue's ids appear in a study's table: ``=1+2*3`` is written as text."""
    ids = ["=1+2*3", "@SUM(A1)"]
    (tmp_path / "cat.csv").write_text("id,source,rate_N_per_m,travel_m,pretension_N,notes\n"
                                      + "".join(f'"{i}",test,1100,0.04,,\n' for i in ids))
    (tmp_path / "study.toml").write_text(f'name = "formulas"\nbase = "{SPEC_1DOF}"\n'
                                         '[[parameters]]\nkey = "springs.1"\ncatalogue = "cat.csv"\n'
                                         '[[parameters]]\nkey = "solver.grid"\nvalues = [8]\n')
    assert main(["sweep", str(tmp_path / "study.toml"), "-o", str(tmp_path / "s.db"), "--workers", "0"]) in (0, 1)
    assert main(["sweep-export", str(tmp_path / "s.db"), "--csv", str(tmp_path / "s.csv")]) == 0
    with open(tmp_path / "s.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert sorted(row["springs.1"] for row in table) == sorted(f"'{i} (test)" for i in ids)  # the spring's name
    assert all(float(row["rmse_1"]) > 0 for row in table)  # the numbers are numbers


# -- the verdict first -----------------------------------------------------------------------------
def test_ipopts_printing_goes_to_stderr_below_the_verdict(tmp_path, capfd):
    assert main(["design", str(SPEC_1DOF), "--grid", "8", "-o", str(tmp_path / "out"), "--no-figures",
                 "--ipopt", "print_level=5"]) == 0
    captured = capfd.readouterr()
    assert captured.out.startswith("success: ") and "Ipopt" not in captured.out
    assert "Number of Iterations" in captured.err  # shown, where it does not hide the verdict


@settings(max_examples=2, deadline=None, suppress_health_check=FUNCTION_SCOPED)
@given(level=st.integers(1, 7))  # from 8 on IPOPT prints every vector too: slow, and no other route
def test_an_api_design_prints_nothing_on_standard_output(level, capfd):
    result = cadcam.design(SPEC_1DOF, grid=8, ipopt={"print_level": level})
    assert result.success and capfd.readouterr().out == ""


# -- a write that fails ----------------------------------------------------------------------------
@contextlib.contextmanager
def _failing_write(folder: Path, nth: int, code: int):
    """Inside the block, the ``nth`` file opened for writing under ``folder`` (0 the first)
    fails with OSError ``code`` (a full disk, a quota, a read-only file system, …)."""
    import builtins

    real, count = io.open, [0]

    def opened(file, mode="r", *args, **kwargs):
        if isinstance(file, (str, os.PathLike)) and any(m in mode for m in "wax") and \
                Path(file).resolve().is_relative_to(folder.resolve()):
            count[0] += 1
            if count[0] == nth + 1:
                raise OSError(code, os.strerror(code), str(file))
        return real(file, mode, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(io, "open", opened)
        patch.setattr(builtins, "open", opened)
        yield count


@settings(max_examples=8, deadline=None, suppress_health_check=FUNCTION_SCOPED)
@example(nth=0, code=errno.ENOSPC)
@given(nth=st.integers(0, 12), code=st.sampled_from([errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EROFS,
                                                      errno.EACCES, errno.EFBIG]))
@pytest.mark.slow  # a whole cadcam design with every file: make test-slow
def test_a_failed_write_is_the_first_line_never_a_success(nth, code, design_1dof, tmp_path_factory, capsys):
    """The design (solved once, :func:`cadcam.optimize.optimize` standing in) written into a
    folder where the ``nth`` file opened for writing fails with the error ``code``."""
    out = tmp_path_factory.mktemp("out")
    with pytest.MonkeyPatch.context() as patch, _failing_write(out, nth, code) as opened:
        patch.setattr(sys.modules["cadcam.optimize"], "optimize", lambda problem: design_1dof)
        exit_code = main(["design", str(SPEC_1DOF), "--grid", "12", "-o", str(out), "--no-figures"])
    printed = capsys.readouterr()
    lines = printed.out.split("\n")
    if opened[0] > nth:  # the nth write failed
        assert exit_code == 1
        assert lines[0].startswith(f"{NOT_WRITTEN}: ") and os.strerror(code) in lines[0]
        assert lines[1] == design_1dof.summary().split("\n")[0]  # the design's own verdict after it
        assert printed.err.startswith("cadcam: error: ") and printed.err.count("\n") == 1
    else:  # fewer files than that: all written
        assert exit_code == 0 and lines[0].startswith("success: ") and printed.err == ""
