"""Issue 48, rule 5: study databases are read only through the expected schema, with a row and a
time bound, and a database that is not this study's is only read, read-only, never changed.

Generated databases (hypothesis): cadcam's tables replaced by views (an endless recursive
one among them), virtual tables or tables short of columns, foreign databases, another
study's, each in rollback or WAL journal mode; every entry point that reads one (``cadcam
sweep``, ``sweep-export``, ``plot-study``, :func:`cadcam.read_study`) must refuse it in one
line, promptly, with its bytes unchanged and no ``-wal``, ``-shm`` or ``-journal`` file beside it.
"""
from __future__ import annotations

import hashlib
import json
import os
import sqlite3
import time

import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

import cadcam
import cadcam.outputs.plots  # noqa: F401 - imported once here: plot-study's import is not a read
from cadcam.cli import main
from cadcam.sweep import runner
from cadcam.sweep.study import StudyError, load_study

from ..conftest import SPEC_1DOF

#: How soon a refusal must come [s]: an endless view would never end.
PROMPT_S = 10.0
SIDE_FILES = ("-wal", "-shm", "-journal")


def _study_file(folder, name: str = "s", rates=(1000.0, 1100.0)):
    path = folder / f"{name}.toml"
    path.write_text(f'name = "{name}"\nbase = "{SPEC_1DOF}"\n[[parameters]]\nkey = "springs.1.rate"\n'
                    f"values = {list(rates)}\n")
    return path


def _case(k: int) -> dict:
    return {"case_id": f"c{k}", "idx": k, "params": json.dumps({"springs.1.rate": 1000.0 + k}),
            "status": "success", "metrics": json.dumps({"rmse": [0.001 * k]}), "recheck": None,
            "cadcam_version": cadcam.__version__}


def _our_database(path, study_file, cases: int = 2, close: bool = True):
    """A study database as ``cadcam sweep`` writes it, with ``cases`` rows; left open in WAL mode
    (its ``-wal`` file beside it) unless ``close``."""
    db = runner.open_db(path, load_study(study_file))
    for k in range(cases):
        runner.record(db, _case(k))
    if close:
        runner._close(db)
    return db


STUDY_COLUMNS = "id INTEGER PRIMARY KEY, definition TEXT, cadcam_version TEXT, created REAL"
ENDLESS = ("WITH RECURSIVE n(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM n) SELECT "
           + ", ".join(f"i AS {c}" if c in ("case_id", "idx") else f"'{{}}' AS {c}" if c == "params"
                       else f"NULL AS {c}" for c in runner.COLUMNS) + " FROM n")


def _foreign(path, kind: str, wal: bool) -> None:
    """A database that is not a study's: ``kind`` says how it differs."""
    db = sqlite3.connect(path)
    if wal:
        db.execute("PRAGMA journal_mode=WAL")
    definition = json.dumps({"name": "x", "record": [], "parameters": []})
    tables = {
        "cases_endless_view": [f"CREATE TABLE study ({STUDY_COLUMNS})", f"CREATE VIEW cases AS {ENDLESS}"],
        "study_view": ["CREATE VIEW study AS SELECT 1 AS id, '{}' AS definition",
                       f"CREATE TABLE cases ({', '.join(runner.COLUMNS)})"],
        "cases_short": [f"CREATE TABLE study ({STUDY_COLUMNS})", "CREATE TABLE cases (case_id, params, status)"],
        "cases_virtual": [f"CREATE TABLE study ({STUDY_COLUMNS})",
                          f"CREATE VIRTUAL TABLE cases USING fts4({', '.join(runner.COLUMNS)})"],
        "unrelated": ["CREATE TABLE measurements (t REAL, value REAL)", "CREATE INDEX m_t ON measurements (t)"],
    }[kind]
    for statement in tables:
        db.execute(statement)
    if kind not in ("study_view", "unrelated"):
        db.execute("INSERT INTO study VALUES (1, ?, 'x', 0)", (definition,))
    if kind == "unrelated":
        db.executemany("INSERT INTO measurements VALUES (?, ?)", [(k, k * k) for k in range(100)])
    db.commit()
    db.close()


def _fingerprint(path) -> tuple:
    """The file's bytes (hash) and which side files lie beside it."""
    return hashlib.sha256(path.read_bytes()).hexdigest(), [s for s in SIDE_FILES if os.path.lexists(f"{path}{s}")]


def _entry(name: str, database, folder, capsys) -> tuple[int, str]:
    """Read ``database`` through the entry point ``name``: (exit code, stderr); the API's
    StudyError counts as exit 2 with its message."""
    args = {"sweep": ["sweep", str(_study_file(folder, "other", (900.0,))), "-o", str(database), "--workers", "0"],
            "sweep-export": ["sweep-export", str(database), "--csv", str(folder / "t.csv")],
            "plot-study": ["plot-study", str(database), "--x", "springs.1.rate", "--y", "rmse_1",
                           "-o", str(folder / "p.png")]}
    if name == "read_study":
        try:
            cadcam.read_study(database)
        except StudyError as exc:
            return 2, f"cadcam: error: {exc}\n"
        return 0, ""
    code = main(args[name])
    return code, capsys.readouterr().err


ENTRIES = ["sweep", "sweep-export", "plot-study", "read_study"]
KINDS = ["cases_endless_view", "study_view", "cases_short", "cases_virtual", "unrelated", "another_study"]


@settings(max_examples=40, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))
@given(kind=st.sampled_from(KINDS), wal=st.booleans(), entry=st.sampled_from(ENTRIES))
def test_a_database_that_is_not_this_studys_is_refused_promptly_and_left_as_it_was(
        tmp_path_factory, capsys, kind, wal, entry):
    folder = tmp_path_factory.mktemp("db")
    database = folder / "study.db"
    if kind == "another_study":
        if entry != "sweep":  # another study's database is a study database to its readers
            return
        db = _our_database(database, _study_file(folder), close=not wal)
        if wal:
            db.close()  # in WAL mode, its -wal and -shm files removed on closing
    else:
        _foreign(database, kind, wal)
    before = _fingerprint(database)
    note(f"{kind}, WAL {wal}, {entry}: {before}")
    t0 = time.monotonic()
    code, err = _entry(entry, database, folder, capsys)
    assert time.monotonic() - t0 < PROMPT_S
    assert code == 2 and err.startswith("cadcam: error: ") and err.count("\n") == 1, err
    assert str(database) in err
    assert _fingerprint(database) == before  # not written, not switched to WAL, no side files
    assert not (folder / "t.csv").exists() and not (folder / "p.png").exists()


def test_our_database_is_read_while_a_runner_holds_it_in_wal_mode(tmp_path):
    """The bounds refuse nothing a sweep wrote: read while the runner still has it open (its rows
    in the -wal file), and after it closed it."""
    study = _study_file(tmp_path)
    db = _our_database(tmp_path / "s.db", study, close=False)
    try:
        assert os.path.lexists(f"{tmp_path / 's.db'}-wal")
        assert list(cadcam.read_study(tmp_path / "s.db")["case_id"]) == ["c0", "c1"]
    finally:
        runner._close(db)
    assert _fingerprint(tmp_path / "s.db")[1] == []
    before = _fingerprint(tmp_path / "s.db")
    assert list(cadcam.read_study(tmp_path / "s.db")["case_id"]) == ["c0", "c1"]
    assert _fingerprint(tmp_path / "s.db") == before  # read without -wal or -shm files


def test_more_rows_than_a_study_has_cases_are_refused(tmp_path, monkeypatch):
    _our_database(tmp_path / "s.db", _study_file(tmp_path), cases=3)
    monkeypatch.setenv("CADCAM_CAP_CASES", "2")
    with pytest.raises(StudyError, match=r"holds more than 2 cases.*CADCAM_CAP_CASES"):
        cadcam.read_study(tmp_path / "s.db")
    monkeypatch.setenv("CADCAM_CAP_CASES", "3")
    assert len(cadcam.read_study(tmp_path / "s.db")) == 3


def test_a_read_that_outlasts_its_time_bound_is_stopped_in_one_line(tmp_path, monkeypatch, capsys):
    _our_database(tmp_path / "s.db", _study_file(tmp_path))
    monkeypatch.setattr(runner, "READ_TIME_S", 0.0)
    monkeypatch.setattr(runner, "READ_CHECK_STEPS", 1)
    code = main(["sweep-export", str(tmp_path / "s.db"), "--csv", str(tmp_path / "t.csv")])
    err = capsys.readouterr().err
    assert code == 2 and "reading it took over 0 s" in err and err.count("\n") == 1


def test_a_sweep_on_another_studys_database_leaves_its_journal_mode(tmp_path, capsys):
    """The case of the issue: refused, as before, but no longer switched to WAL on the way."""
    _our_database(tmp_path / "s.db", _study_file(tmp_path))
    header = (tmp_path / "s.db").read_bytes()[18:20]
    assert header == b"\x01\x01"  # rollback journal, as a finished sweep leaves it
    code, err = _entry("sweep", tmp_path / "s.db", tmp_path, capsys)
    assert code == 2 and "holds the results of a different study" in err
    assert (tmp_path / "s.db").read_bytes()[18:20] == header
