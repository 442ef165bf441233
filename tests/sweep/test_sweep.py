"""Parameter sweeps: same rows on every executor, resumable after SIGKILL, failures recorded."""
import os
import signal
import sqlite3
import subprocess
import sys
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cadcam.sweep.runner as runner_module
from cadcam.files import short_repr
from cadcam.sweep.study import Study, StudyError, load_study
from cadcam.sweep.runner import SweepError, check_dask_address, read_rows, run_sweep, runner

from ..conftest import SPEC_1DOF, at_once, check_output_file

STUDY = f'''
name = "small"
base = "{SPEC_1DOF}"
[[parameters]]
key = "cams.1.idler.offset"
range = [0.010, 0.020]
num = {{num}}
[[parameters]]
key = "springs.1.rate"
values = [1000.0, 1200.0]
[[parameters]]
key = "solver.grid"
values = [12]
'''


def _study(tmp_path, num=2, name="study.toml"):
    path = tmp_path / name
    path.write_text(STUDY.format(num=num))
    return load_study(path)


def _values(path):
    _, rows = read_rows(path)
    return {r["case_id"]: (r["status"], r["iterations"], r["metrics"]["rmse"], r["design"]) for r in rows}


@pytest.mark.slow  # a study twice, once on a LocalCluster: make test-slow
def test_local_pool_and_dask_local_cluster_give_identical_rows(tmp_path):
    pytest.importorskip("dask.distributed")
    study = _study(tmp_path)
    run_sweep(study, tmp_path / "pool.db", workers=2, progress=False)
    run_sweep(study, tmp_path / "dask.db", workers=2, dask="local", progress=False)
    pool, dask = _values(tmp_path / "pool.db"), _values(tmp_path / "dask.db")
    assert len(pool) == 4 and pool == dask
    assert all(v[0] == "success" for v in pool.values())


@pytest.mark.slow  # seconds of designs: make test-slow
def test_sigkill_midway_then_resume_gives_one_row_per_case(tmp_path):
    study = _study(tmp_path, num=4)
    reference = tmp_path / "reference.db"
    run_sweep(study, reference, workers=0, progress=False)
    db = tmp_path / "killed.db"
    cmd = [sys.executable, "-m", "cadcam", "sweep", str(tmp_path / "study.toml"), "-o", str(db), "--workers", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 120
    done = 0
    while time.time() < deadline and proc.poll() is None:
        if db.exists():
            try:
                with sqlite3.connect(db) as con:
                    done = con.execute("SELECT COUNT(*) FROM cases").fetchone()[0]
            except sqlite3.OperationalError:
                done = 0
            if done >= 2:
                break
        time.sleep(0.02)
    assert proc.poll() is None, "the sweep finished before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)  # the whole process tree: parent and workers
    proc.wait()
    with sqlite3.connect(db) as con:
        killed_at = con.execute("SELECT COUNT(*) FROM cases").fetchone()[0]
    assert 2 <= killed_at < 8
    assert subprocess.run(cmd, capture_output=True).returncode == 0
    with sqlite3.connect(db) as con:
        ids = [r[0] for r in con.execute("SELECT case_id FROM cases")]
    assert len(ids) == len(set(ids)) == 8
    ours, theirs = _values(db), _values(reference)
    assert ours.keys() == theirs.keys()
    for k in ours:  # the same numbers as an uninterrupted (serial) run
        assert ours[k][0] == theirs[k][0] and ours[k][1] == theirs[k][1]
        np.testing.assert_allclose(ours[k][2], theirs[k][2], rtol=1e-12)


def test_a_case_that_raises_is_recorded_and_the_others_complete(tmp_path, monkeypatch):
    module = sys.modules["cadcam.optimize"]  # the package re-exports the function by this name
    real = module.optimize

    def flaky(problem, **kw):
        if problem.springs[0].rate == 1200.0 and problem.mechanisms[0].idler_offset == 0.010:
            raise RuntimeError("Error in Function::call for 'cadcam' [IpoptInterface]: boom")
        return real(problem, **kw)

    monkeypatch.setattr(module, "optimize", flaky)
    study = _study(tmp_path)
    summary = run_sweep(study, tmp_path / "s.db", workers=0, progress=False)
    _, rows = read_rows(tmp_path / "s.db")
    assert summary["statuses"] == {"error": 1, "success": 3} and len(rows) == 4
    (bad,) = [r for r in rows if r["status"] == "error"]
    assert bad["error"] == "RuntimeError: Error in Function::call for 'cadcam' [IpoptInterface]: boom"
    assert bad["params"] == {"cams.1.idler.offset": 0.01, "springs.1.rate": 1200.0, "solver.grid": 12}
    # a re-run retries nothing that is recorded, failed cases included
    assert run_sweep(study, tmp_path / "s.db", workers=0, progress=False)["ran"] == 0


@pytest.mark.parametrize("body,message", [
    ('name = "x"\nbase = "{spec}"\n', "varies no parameter"),
    ('name = "x"\nbase = "{spec}"\n[[parameters]]\nkey = "springs.1.ratee"\nvalues = [1.0]\n',
     "unknown key 'springs[1].ratee'"),
    ('name = "x"\nbase = "{spec}"\n[[parameters]]\nkey = "springs.9.rate"\nvalues = [1.0]\n', "has 2 entries"),
    ('name = "x"\nbase = "{spec}"\n[[parameters]]\nkey = "springs.1.rate"\nrange = ["a", 2]\nnum = 3\n',
     "range = ['a', 2]: expected [low, high] numbers"),
    ('name = "x"\nbase = "{spec}"\n[[parameters]]\nkey = "springs.1.rate"\nrange = [1.0, 2.0]\n',
     "num = 0: expected an integer ≥ 2"),
    ('name = "x"\nbase = "{spec}"\n[[parameters]]\nkey = "springs.1.rate"\nvalues = [-5.0]\n',
     "springs.1.rate = -5.0"),
    ('name = "x"\nbase = "{spec}"\n[[parameters]]\nkey = "springs.1.rate"\nvalues = []\n', "non-empty list"),
    ('name = "x"\nbase = "{spec}"\ncolour = 2\n', "unknown key 'colour'"),
    ('name = "x"\nbase = "{spec}"\n[[parameters]]\nkey = "springs.1.rate"\nrange = [1.0, 2.0]\nnum = 10000000\n',
     "10000000 cases, over the cap of 10000"),
    ('name = "x"\nbase = "{spec}"\ndesign = "latin_hypercube"\nsamples = 1000000000\n[[parameters]]\n'
     'key = "springs.1.rate"\nrange = [1.0, 2.0]\n', "1000000000 cases, over the cap"),
    ('name = "x"\nbase = "{spec}"\ndesign = "latin_hypercube"\nsamples = 3\nseed = -1\n[[parameters]]\n'
     'key = "springs.1.rate"\nrange = [1.0, 2.0]\n', "seed = -1"),
])
def test_bad_study_files_are_refused_before_any_case_runs(tmp_path, body, message, capsys):
    from cadcam.cli import main
    path = tmp_path / "bad.toml"
    path.write_text(body.format(spec=SPEC_1DOF))
    with pytest.raises(StudyError) as err:
        load_study(path).validate()
    assert message in str(err.value) and "\n" not in str(err.value)
    assert main(["sweep", str(path), "-o", str(tmp_path / "bad.db")]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert not (tmp_path / "bad.db").exists()  # nothing ran, nothing was created


def test_export_csv_and_plot(tmp_path):
    from cadcam.cli import main
    study = _study(tmp_path)
    run_sweep(study, tmp_path / "s.db", workers=0, progress=False)
    assert main(["sweep-export", str(tmp_path / "s.db"), "--csv", str(tmp_path / "s.csv")]) == 0
    lines = (tmp_path / "s.csv").read_text().splitlines()
    assert len(lines) == 5 and "cams.1.idler.offset" in lines[0] and "rmse_1" in lines[0]
    assert main(["plot-study", str(tmp_path / "s.db"), "--x", "cams.1.idler.offset", "--y", "rmse_1",
                 "--color", "springs.1.rate", "--pareto", "-o", str(tmp_path / "p.png")]) == 0
    check_output_file(tmp_path / "p.png")


def test_catalogue_parameters_update_the_spring_and_keep_its_ports(tmp_path):
    cat = tmp_path / "cat.csv"
    cat.write_text("id,source,rate_N_per_m,travel_m,pretension_N,notes\nA,test,900,0.05,,\nB,test,1500,0.06,4.5,\n")
    path = tmp_path / "c.toml"
    path.write_text(f'name = "c"\nbase = "{SPEC_1DOF}"\n[[parameters]]\nkey = "springs.1"\ncatalogue = "cat.csv"\n')
    study = load_study(path)
    p = study.problem(study.cases()[1])
    assert (p.springs[0].rate, p.springs[0].travel, p.springs[0].name) == (1500.0, 0.06, "B (test)")
    assert p.springs[0].preload == 4.5  # the pretension is read, not dropped
    assert study.problem(study.cases()[0]).springs[0].preload == 0.0  # blank: none published
    assert p.springs[0].ports == load_study(path).problem(study.cases()[0]).springs[0].ports
    assert Study.case_id(study.cases()[0]) != Study.case_id(study.cases()[1])


@pytest.mark.parametrize("make,message", [
    (lambda tmp: tmp, "is a folder; give a file name"),
    (lambda tmp: ((tmp / "t.db").write_text("not sqlite at all " * 100), tmp / "t.db")[1], "not a study database"),
])
def test_a_database_path_that_is_a_folder_or_not_sqlite_is_one_line(tmp_path, capsys, make, message):
    from cadcam.cli import main
    _study(tmp_path)
    assert main(["sweep", str(tmp_path / "study.toml"), "-o", str(make(tmp_path))]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_a_negative_worker_count_is_refused(tmp_path, capsys):
    from cadcam.cli import main
    _study(tmp_path)
    assert main(["sweep", str(tmp_path / "study.toml"), "-o", str(tmp_path / "w.db"), "--workers", "-1"]) == 2
    assert "--workers -1: expected 0" in capsys.readouterr().err
    assert not (tmp_path / "w.db").exists()


@pytest.mark.slow  # a study's designs in three runners: make test-slow
def test_a_second_runner_skips_cases_another_holds_and_takes_over_a_dead_runners(tmp_path):
    study = _study(tmp_path)
    run_sweep(study, tmp_path / "reference.db", workers=0, progress=False)
    db_path = tmp_path / "shared.db"
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    try:
        run_sweep(study, db_path, workers=0, progress=False)  # creates the database, runs all 4
        with sqlite3.connect(db_path) as con:  # forget two cases and let the other runner hold them
            held = [r[0] for r in con.execute("SELECT case_id FROM cases ORDER BY idx LIMIT 2 OFFSET 1")]
            con.executemany("DELETE FROM cases WHERE case_id = ?", [(c,) for c in held])
            con.executemany("INSERT INTO claims VALUES (?, ?, ?, ?)",
                            [(c, runner()[0], other.pid, time.time()) for c in held])
        summary = run_sweep(study, db_path, workers=0, progress=False)
        assert (summary["ran"], summary["skipped"], summary["elsewhere"]) == (0, 2, 2)
    finally:
        other.kill()
        other.wait()  # reaped: its process is gone, and so are its claims' owner
    summary = run_sweep(study, db_path, workers=0, progress=False)
    assert (summary["ran"], summary["elsewhere"]) == (2, 0)
    assert _values(db_path) == _values(tmp_path / "reference.db")
    with sqlite3.connect(db_path) as con:
        assert con.execute("SELECT COUNT(*) FROM claims").fetchone()[0] == 0


@pytest.mark.slow  # a study's designs in two runners: make test-slow
def test_two_runners_on_one_database_finish_the_study_once_between_them(tmp_path):
    _study(tmp_path, num=4)
    db_path = tmp_path / "shared.db"
    cmd = [sys.executable, "-m", "cadcam", "sweep", str(tmp_path / "study.toml"), "-o", str(db_path),
           "--workers", "0"]
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=300)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0]
    ran = [int(out.split(" run now")[0].rsplit(" ", 1)[1]) for out in outs]
    assert sum(ran) == 8  # no case solved twice, none left out
    _, rows = read_rows(db_path)
    assert len({r["case_id"] for r in rows}) == len(rows) == 8 and {r["status"] for r in rows} == {"success"}


def test_runners_that_open_one_new_database_at_the_same_moment_both_join_the_study(tmp_path):
    """Two runners started together on a new file: one's ``study`` row failed the other's insert
    (IntegrityError, exit 1), or one's switch to WAL was refused as locked."""
    study = _study(tmp_path)
    for attempt in range(50):
        path = tmp_path / f"new{attempt}.db"
        assert at_once(lambda: runner_module._close(runner_module.open_db(path, study))) == []
        with sqlite3.connect(path) as con:
            assert con.execute("SELECT COUNT(*) FROM study").fetchone()[0] == 1


def test_a_database_that_is_not_a_study_is_refused_and_left_as_it_is(tmp_path):
    """`cadcam sweep -o app.db` on another application's SQLite file added cadcam's tables to it."""
    import sqlite3

    from cadcam.sweep.runner import SweepError

    app = tmp_path / "app.db"
    db = sqlite3.connect(app)
    db.execute("CREATE TABLE users (name TEXT)")
    db.commit()
    db.close()
    before = app.read_bytes()
    with pytest.raises(SweepError, match="not a study database that cadcam wrote"):
        run_sweep(_study(tmp_path), app, workers=0, progress=False)
    assert app.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["app.db", "study.toml"]


@pytest.mark.parametrize("name", ["run#2.db", "r%41.db", "a?b.db"])
def test_a_study_reads_back_from_a_file_whose_name_holds_uri_characters(tmp_path, name):
    """The read-only connection named the file in a URI unescaped: 'run#2.db' read 'run' (a
    stray empty file), 'r%41.db' read 'rA.db'."""
    study = _study(tmp_path)
    run_sweep(study, tmp_path / name, workers=0, progress=False)
    definition, rows = read_rows(tmp_path / name)
    assert definition["name"] == "small" and len(rows) == 4
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "study.toml"])


@settings(max_examples=200, deadline=None, derandomize=True, database=None)
@given(address=st.one_of(st.text(max_size=30),
                         st.from_regex(r"(tcp|tls|ws|wss|http|inproc)?(://)?[a-z0-9.:\[\]/@%?#-]{0,25}",
                                       fullmatch=True)))
def test_any_dask_address_is_either_a_scheduler_address_or_one_line(address):
    """'--dask ::::x' ended in a traceback; an address is now checked before anything starts."""
    try:
        check_dask_address(address)
    except SweepError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(f"--dask {short_repr(address)}:")
    else:
        assert address == "local" or ":" in address


@pytest.mark.parametrize("address, ok", [("local", True), ("127.0.0.1:8786", True), ("tcp://scheduler:8786", True),
                                         ("tls://[::1]:8786", True), ("::::x", False), ("tcp://host", False),
                                         ("http://host:80", False), ("host:80/path", False), ("host:99999", False)])
def test_a_dask_address_is_checked_by_its_form(address, ok):
    if ok:
        check_dask_address(address)
    else:
        with pytest.raises(SweepError, match="expected 'local' or a scheduler address"):
            check_dask_address(address)


def test_a_scheduler_that_does_not_answer_is_one_line_and_leaves_no_database(tmp_path, monkeypatch):
    """'--dask tcp://127.0.0.1:9' took 30 s, blamed the disk and left an empty database."""
    pytest.importorskip("dask.distributed")
    monkeypatch.setattr(runner_module, "DASK_CONNECT_TIMEOUT_S", 1.0)
    with pytest.raises(SweepError, match="no Dask scheduler answered within 1 s"):
        run_sweep(_study(tmp_path), tmp_path / "s.db", dask="tcp://127.0.0.1:9", progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.toml"]


@pytest.fixture(scope="module")
def recorded_study(tmp_path_factory):
    """A database of the small study, run once."""
    folder = tmp_path_factory.mktemp("recorded")
    run_sweep(_study(folder), folder / "s.db", workers=0, progress=False)
    return folder / "s.db"


@pytest.mark.parametrize("record", [[1], [None], [["rmse"]], "rmse"])
def test_a_study_definition_of_the_wrong_shape_is_not_a_study(tmp_path, recorded_study, record):
    """A database whose definition records a non-string ended 'sweep-export' in a traceback."""
    import json
    import shutil

    db = shutil.copy(recorded_study, tmp_path / "s.db")
    with sqlite3.connect(db) as con:
        definition = json.loads(con.execute("SELECT definition FROM study").fetchone()[0])
        con.execute("UPDATE study SET definition = ?", (json.dumps({**definition, "record": record}),))
    con.close()
    with pytest.raises(SweepError, match="not a cadcam study database"):
        read_rows(db)
