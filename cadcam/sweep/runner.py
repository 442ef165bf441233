"""Run a study's cases on a process pool or a Dask cluster, recording each to SQLite.

One database per study (WAL journal): a ``study`` row holding the study's definition and one
``cases`` row per case, committed the moment the case finishes — parameters, status,
metrics, design, iterations, times, the error of a failed case, the cadcam version and the
torque model. Running the same study on the same database again resumes it: cases already
recorded are skipped (the case id, a hash of its values, is the primary key), so nothing is
repeated or duplicated, also after the whole process tree was killed.

Sweeps that share a database share the work: a runner claims each case (a ``claims`` row
naming its host and process) before it submits it, and skips cases recorded or claimed by
another runner, so two runners started on one study finish it once between them. A claim is
released when its case is recorded; the claims of a runner that was killed are recognised
and taken over by the next run — at once on the same host (its process is gone), after
:data:`CLAIM_LEASE_S` without a recorded case for a runner on another host.

Workers keep the NLP of each problem structure (:mod:`cadcam.solve.builds`, up to
:data:`~cadcam.solve.builds.KEPT_BUILDS` of them) and reuse it for every case that only changes
numbers (CasADi parameters), so a sweep builds each NLP once per worker. With ``warm_start`` a
case starts from the design of the nearest case already solved (in normalised parameter space)
instead of the default start, and is solved again from the default start when it ends much
worse than that case (:data:`cadcam.optimize.WARM_GUARD`); its row's message names the case it
started from. Which case that is depends on the order cases
finish, so warm-started sweeps are reproducible only serially.
"""
from __future__ import annotations

import contextlib
import importlib
import json
import math
import os
import signal
import socket
import sqlite3
import sys
import time
import urllib.parse
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from multiprocessing import get_context, resource_tracker
from pathlib import Path

from ..files import printable, process_alive, short_repr
from ..library_files import PYTHON_SAFE_PATH
from ..problem import cap
from ..version import __version__
from .study import Study, StudyError

SCHEMA = """
CREATE TABLE IF NOT EXISTS study (
    id INTEGER PRIMARY KEY CHECK (id = 1), definition TEXT NOT NULL,
    cadcam_version TEXT NOT NULL, created REAL NOT NULL);
CREATE TABLE IF NOT EXISTS cases (
    case_id TEXT PRIMARY KEY, idx INTEGER NOT NULL, params TEXT NOT NULL,
    status TEXT NOT NULL, message TEXT, metrics TEXT, recheck TEXT, design TEXT,
    iterations INTEGER, solve_time_s REAL, build_time_s REAL, wall_time_s REAL, error TEXT,
    cadcam_version TEXT NOT NULL, torque_model TEXT, finished REAL NOT NULL);
CREATE TABLE IF NOT EXISTS claims (
    case_id TEXT PRIMARY KEY, host TEXT NOT NULL, pid INTEGER NOT NULL, claimed REAL NOT NULL);
"""
#: A claim of a runner on another host whose process cannot be checked is taken over when that
#: runner has recorded no case for this long [s].
CLAIM_LEASE_S = 3600.0
#: How long a runner waits for another that holds the study database's lock [s].
LOCK_WAIT_S = 60.0
#: How long a sweep waits for a Dask scheduler to answer [s].
DASK_CONNECT_TIMEOUT_S = 10.0
#: The address schemes of a Dask scheduler cadcam accepts.
DASK_SCHEMES = ("tcp", "tls", "ws", "wss")
COLUMNS = ("case_id", "idx", "params", "status", "message", "metrics", "recheck", "design",
           "iterations", "solve_time_s", "build_time_s", "wall_time_s", "error",
           "cadcam_version", "torque_model", "finished")
#: The tables a study database is read through, with the columns a reader needs: each must be
#: a real table (not a view, whose query could run without end, nor a virtual table).
READ_TABLES = {"study": ("id", "definition"), "cases": COLUMNS}
#: Longest a read of a study database may take [s] (its schema, its study and its cases; a
#: study of :data:`cadcam.problem.CAPS` ``cases`` rows reads in well under a second).
READ_TIME_S = 30.0
#: SQLite virtual-machine steps between two looks at the clock while a database is read.
READ_CHECK_STEPS = 10_000


class SweepError(StudyError):
    """A sweep that cannot start (a database holding another study, a bad executor), or a
    study database that cannot be read: a :class:`~cadcam.sweep.study.StudyError`."""


# -- worker side ----------------------------------------------------------------------------
def run_case(study: dict, case: dict, start: dict | None = None,
             start_objective: float | None = None, start_case: str | None = None) -> dict:
    """Solve one case and return its database row; never raises (a failure is a row).

    ``start`` is the design of the solved case ``start_case`` (its id) to warm-start from,
    ``start_objective`` that case's objective (see :data:`cadcam.optimize.WARM_GUARD`). A
    warm-started row's message names the case it started from, or says that the default
    start's answer was kept.
    """
    from ..designs import Design
    from ..optimize import warm_optimize
    from ..solve.builds import built_for

    t0 = time.perf_counter()
    row = {"case_id": Study.case_id(case), "params": json.dumps(case, sort_keys=True),
           "cadcam_version": __version__}
    try:
        problem = Study.from_dict(study).problem(case)
        row["torque_model"] = problem.torque_model
        tr, built = built_for(problem)
        result = warm_optimize(problem, tr, Design.from_dict(start, problem) if start else None,
                               start_objective, f"case {start_case}")
        d = result.to_dict()
        row.update(status=result.status, message=result.message, metrics=json.dumps(d["metrics"]),
                   recheck=json.dumps(d["recheck"]), design=json.dumps(d["design"]),
                   iterations=result.solve.iterations, solve_time_s=result.solve.solve_time_s,
                   build_time_s=tr.build_time_s if built else 0.0)
    except Exception as exc:  # noqa: BLE001 - any failure of a case is recorded, the sweep goes on
        row.update(status="error", error=f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}")
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def compile_structures(study: dict, cases: list[dict]) -> int:
    """Build, in this process, the NLP of every structure among ``cases`` whose problem asks
    for ``compiled`` functions, so that a pool's workers load its library from the disk cache
    (:mod:`cadcam.solve.compiled`) instead of each compiling it at once. Returns the number of
    structures built; a case whose problem cannot be built is left to its worker, which records
    the error."""
    from ..solve.builds import structure_key
    from ..solve.transcription import Transcription

    built, definition = set(), Study.from_dict(study)
    for case in cases:
        try:
            problem = definition.problem(case)
            key = structure_key(problem)
            if problem.options.functions == "compiled" and key not in built:
                Transcription(problem)  # compiles into the disk cache; the workers build their own
                built.add(key)
        except Exception:  # noqa: BLE001 - the worker solving this case records why it failed
            continue
    return len(built)


# -- database ---------------------------------------------------------------------------------
def open_db(path, study: Study) -> sqlite3.Connection:
    """Open (or create, with its folder) the study database; refuse one that holds a different
    study, or none, before writing anything to it: such a file is only read, read-only, and
    its journal mode is left as it is."""
    if Path(path).exists() and not Path(path).is_file():
        raise SweepError(f"{path}: not a file; give the path of a study database (SQLite)")
    definition = json.dumps(study.to_dict(), sort_keys=True)
    if Path(path).is_file() and Path(path).stat().st_size:
        stored = _stored_definition(path)
        if stored is None:
            raise SweepError(f"{path}: not a study database that cadcam wrote (left as it is); give a new path")
        if stored != definition:
            raise SweepError(f"{path}: holds the results of a different study (left as it is); use another -o file")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    try:
        db = sqlite3.connect(str(path), timeout=LOCK_WAIT_S)
        _create_tables(db, definition)
        if db.execute("SELECT definition FROM study WHERE id = 1").fetchone()[0] != definition:
            db.close()  # another runner created it for its study a moment ago: left in its mode
            raise SweepError(f"{path}: holds the results of a different study; use another -o file")
        _use_wal(db)
        db.execute("PRAGMA synchronous=FULL")
    except sqlite3.Error as exc:
        raise SweepError(f"{path}: not a study database ({exc}); give a new path or a database "
                         "this study wrote") from None
    return db


def _create_tables(db: sqlite3.Connection, definition: str) -> None:
    """Create the tables and the ``study`` row in one transaction, unless another runner that
    started on the same new file at the same moment has: its tables and row stand (they are
    compared with this study's by the caller), and no runner sees tables without their row."""
    db.execute("BEGIN IMMEDIATE")  # the write lock first: a second runner waits here
    try:
        for statement in filter(str.strip, SCHEMA.split(";")):
            db.execute(statement)
        db.execute("INSERT OR IGNORE INTO study VALUES (1, ?, ?, ?)", (definition, __version__, time.time()))
    except BaseException:
        db.rollback()
        raise
    db.commit()


def _use_wal(db: sqlite3.Connection) -> None:
    """Put the database in WAL mode, waiting up to :data:`LOCK_WAIT_S` for a runner that is
    closing it at this moment (SQLite answers "locked" to this change without waiting)."""
    deadline = time.monotonic() + LOCK_WAIT_S
    while True:
        try:
            db.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.01)


def _close(db: sqlite3.Connection) -> None:
    """Close a runner's connection, leaving the database in rollback-journal mode if no other
    runner has it open: WAL serves runners that share it, but a read-only reader of a WAL file
    must create its ``-wal`` and ``-shm`` files and cannot remove them."""
    try:
        db.execute("PRAGMA busy_timeout = 0")  # another runner still at work: leave WAL to it
        db.execute("PRAGMA journal_mode = DELETE")
    except sqlite3.OperationalError:
        pass
    finally:
        db.close()


def _remove_database(path) -> None:
    """Remove a study database with its SQLite side files."""
    for suffix in ("", "-wal", "-shm", "-journal"):
        with contextlib.suppress(FileNotFoundError):
            os.unlink(f"{path}{suffix}")


@contextlib.contextmanager
def _reading(path):
    """A read-only connection to the SQLite file ``path`` whose statements stop after
    :data:`READ_TIME_S` (:class:`SweepError`), closed on leaving. It never writes beside the
    file: without a ``-wal`` file there (no runner at work, nothing to read from one) the file
    is opened immutable, so that a database in WAL mode gets no ``-wal`` and ``-shm`` files
    from being read; with one, as SQLite needs to read it. The name is escaped in the URI (a
    ``#``, ``?`` or ``%`` in a file name is part of the name)."""
    mode = "ro" if os.path.lexists(f"{path}-wal") else "ro&immutable=1"
    db = sqlite3.connect(f"{Path(path).resolve().as_uri()}?mode={mode}", uri=True)
    deadline = time.monotonic() + READ_TIME_S
    db.set_progress_handler(lambda: time.monotonic() > deadline, READ_CHECK_STEPS)
    try:
        yield db
    except sqlite3.OperationalError:
        if time.monotonic() > deadline:
            raise SweepError(f"{path}: reading it took over {READ_TIME_S:g} s: not a study database that "
                             "`cadcam sweep` wrote") from None
        raise
    finally:
        db.close()


def _has_study_tables(db: sqlite3.Connection) -> bool:
    """Whether ``db`` holds each of :data:`READ_TABLES` as a real table with its columns."""
    created = dict(db.execute("SELECT name, sql FROM sqlite_master WHERE type = 'table' AND name IN "
                              f"({','.join('?' * len(READ_TABLES))})", tuple(READ_TABLES)).fetchall())
    for name, columns in READ_TABLES.items():
        sql = created.get(name)
        if not (isinstance(sql, str) and sql.upper().startswith("CREATE TABLE")):  # none, or a virtual table
            return False
        if not set(columns) <= {row[1] for row in db.execute(f"PRAGMA table_info({name})")}:
            return False
    return True


def _stored_definition(path) -> str | None:
    """The study definition (JSON text) a study database at ``path`` holds, read through its
    tables (:func:`_has_study_tables`, read-only); None for any other file."""
    try:
        with _reading(path) as db:
            row = db.execute("SELECT definition FROM study WHERE id = 1").fetchone() if _has_study_tables(db) else None
    except sqlite3.Error:
        return None
    return row[0] if row is not None and isinstance(row[0], str) else None


def record(db: sqlite3.Connection, row: dict) -> None:
    """Commit one case's row (a repeated case id is ignored, never duplicated) and release its
    claim."""
    row = {**row, "finished": time.time()}
    with db:
        db.execute(f"INSERT OR IGNORE INTO cases ({','.join(COLUMNS)}) VALUES ({','.join('?' * len(COLUMNS))})",
                   [row.get(c) for c in COLUMNS])
        db.execute("DELETE FROM claims WHERE case_id = ?", (row["case_id"],))
        db.execute("UPDATE claims SET claimed = ? WHERE host = ? AND pid = ?", (row["finished"], *runner()))


def runner() -> tuple[str, int]:
    """This runner, as its claims name it: (host, process id)."""
    return socket.gethostname(), os.getpid()


def release_stale_claims(db: sqlite3.Connection) -> int:
    """Delete the claims of runners that are gone (see the module docstring); return how many."""
    host, pid = runner()
    stale = [(h, p) for h, p, last in db.execute("SELECT host, pid, MAX(claimed) FROM claims GROUP BY host, pid")
             if (h == host and p != pid and not process_alive(p))
             or (h != host and time.time() - last > CLAIM_LEASE_S)]
    with db:
        return sum(db.execute("DELETE FROM claims WHERE host = ? AND pid = ?", hp).rowcount for hp in stale)


def claim(db: sqlite3.Connection, case_id: str) -> bool:
    """Claim a case for this runner: ``False`` if it is recorded or another runner holds it.
    One INSERT statement, so two runners never both claim a case."""
    with db:
        return db.execute(
            "INSERT OR IGNORE INTO claims (case_id, host, pid, claimed) SELECT ?, ?, ?, ? "
            "WHERE NOT EXISTS (SELECT 1 FROM cases WHERE case_id = ?)",
            (case_id, *runner(), time.time(), case_id)).rowcount == 1


def read_rows(path) -> tuple[dict, list[dict]]:
    """The study definition and every recorded case (parsed JSON), ordered by case index, read
    only through the study tables (:func:`_has_study_tables`), at most :data:`~cadcam.problem.CAPS`
    ``cases`` rows, within :data:`READ_TIME_S`."""
    if not Path(path).is_file():
        raise SweepError(f"{str(path)!r}: no such study database (a file that `cadcam sweep` wrote)")
    most = cap("cases")
    try:
        with _reading(path) as db:
            if not _has_study_tables(db):
                raise TypeError("not a study database")
            study = json.loads(db.execute("SELECT definition FROM study WHERE id = 1").fetchone()[0])
            records = db.execute(f"SELECT {','.join(COLUMNS)} FROM cases ORDER BY idx LIMIT ?", (most + 1,)).fetchall()
        if not _is_study_definition(study):
            raise TypeError("not a study definition")
        if len(records) > most:
            raise SweepError(f"{path}: holds more than {most} cases, beyond the cap on a study's cases (raise it "
                             "deliberately with CADCAM_CAP_CASES)")
        rows = [_case_row(r) for r in records]
    except SweepError:  # said in its own words (a ValueError too)
        raise
    except (sqlite3.Error, ValueError, TypeError, RecursionError):
        raise SweepError(f"{path}: not a cadcam study database (give a file that `cadcam sweep` wrote)") from None
    return study, rows


def _case_row(record: tuple) -> dict:
    """One ``cases`` record as a row, its JSON columns parsed (TypeError if malformed)."""
    row = dict(zip(COLUMNS, record))
    for k in ("params", "metrics", "recheck", "design"):
        row[k] = json.loads(row[k]) if row[k] else None
    if not isinstance(row["params"], dict) or not all(
            isinstance(row[k], (dict, type(None))) for k in ("metrics", "recheck")):
        raise TypeError("a case without parameters or with malformed metrics")
    return row


def _is_study_definition(study) -> bool:
    """Whether ``study`` (JSON read from a database) has the shape :meth:`Study.to_dict`
    gives the parts a reader uses: a name, the names it records, the keys it varies."""
    return (isinstance(study, dict) and isinstance(study.get("name"), str)
            and isinstance(study.get("record"), list) and all(isinstance(r, str) for r in study["record"])
            and isinstance(study.get("parameters"), list)
            and all(isinstance(p, dict) and isinstance(p.get("key"), str) for p in study["parameters"]))


# -- executors --------------------------------------------------------------------------------
#: Worker processes run single-threaded BLAS: a sweep is parallel across cases, and threads
#: inside each worker only compete for the same cores (measured: 2 workers 1.7× slower without).
#: They are started with ``python -c``, which would put the working folder first on
#: ``sys.path``: :data:`cadcam.library_files.PYTHON_SAFE_PATH` keeps it off.
WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", **PYTHON_SAFE_PATH}


class _WorkerEnv:
    """Sets :data:`WORKER_ENV` while worker processes are started, restoring it afterwards."""

    def __enter__(self):
        self.saved = {k: os.environ.get(k) for k in WORKER_ENV}
        os.environ.update(WORKER_ENV)

    def __exit__(self, *exc):
        for k, v in self.saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _start_resource_tracker() -> None:
    """Start multiprocessing's resource tracker (it tracks the pool's semaphores) with SIGHUP
    blocked, as multiprocessing blocks SIGINT and SIGTERM for it: a closed terminal hangs up the
    whole process group, and the tracker, ended by it, would leave the semaphores unreleased
    and, started again, print tracebacks below the run's last line."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGHUP})
    try:
        resource_tracker.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _imported(module: str) -> None:
    """Import ``module`` in a worker (a failure is raised again by the worker's first case)."""
    importlib.import_module(module)


class _Local:
    """``task`` (a module-level function; default :func:`run_case`) run on a process pool of
    ``workers`` processes started with :data:`WORKER_ENV`."""

    def __init__(self, workers: int, task=None):
        self.task = task if task is not None else run_case  # looked up now: a test may wrap it
        # every worker started now, and the pool's resource tracker (SIGHUP blocked for it), in the
        # worker environment
        with _WorkerEnv():
            _start_resource_tracker()
            self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"))
            list(self.pool.map(abs, range(workers)))
        # not waited for: each worker imports its task's module while this process goes on (a
        # search compiles the NLP's functions meanwhile), rather than when its first case comes
        for _ in range(workers):
            self.pool.submit(_imported, self.task.__module__)

    def submit(self, *args):
        return self.pool.submit(self.task, *args)

    def wait(self, futures):
        return wait(futures, return_when=FIRST_COMPLETED)[0]

    def close(self, interrupted: bool = False):
        """Wait for the workers to end; after an interrupt, end them first (a signal reaches
        this process alone, and a worker in the middle of a case would run it to its end)."""
        if interrupted:
            # ProcessPoolExecutor has no public way to stop a running worker before Python 3.14
            for process in list(self.pool._processes.values()):
                process.terminate()
        self.pool.shutdown(cancel_futures=True)


class _Serial:
    """Cases run one after another in this process (``workers = 0``): for debugging and
    profiling, and the one executor whose warm starts are reproducible."""

    def __init__(self, task=None):
        self.task = task if task is not None else run_case  # looked up now: a test may wrap it

    def submit(self, *args):
        fut = Future()
        fut.set_result(self.task(*args))
        return fut

    def wait(self, futures):
        return futures

    def close(self, interrupted: bool = False):
        pass


class _Dask:
    """``task`` (a module-level function; default :func:`run_case`) run on a Dask cluster: a
    LocalCluster of ``workers`` processes for ``address`` ``local``, else the scheduler at
    ``address``."""

    def __init__(self, address: str, workers: int, task=None):
        self.task = task if task is not None else run_case  # looked up now: a test may wrap it
        try:
            from dask.distributed import Client, LocalCluster, wait as dask_wait
        except ImportError:
            raise SweepError("--dask needs the optional extra: pip install 'cadcam[dask]'") from None
        self._wait = dask_wait
        if address == "local":
            with _WorkerEnv():
                self.cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                            host="127.0.0.1", dashboard_address=None)
            self.client = Client(self.cluster)
        else:
            self.cluster = None
            try:
                self.client = Client(address, timeout=DASK_CONNECT_TIMEOUT_S)
            except (OSError, TimeoutError):
                raise SweepError(f"--dask {address}: no Dask scheduler answered within "
                                 f"{DASK_CONNECT_TIMEOUT_S:g} s; start it, correct the address or use "
                                 "--dask local") from None

    def submit(self, *args):
        return self.client.submit(self.task, *args, pure=False)

    def wait(self, futures):
        return self._wait(list(futures), return_when="FIRST_COMPLETED").done

    def close(self, interrupted: bool = False):
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def check_dask_address(address: str) -> None:
    """SweepError unless ``address`` is ``local`` or a scheduler address ``[scheme://]host:port``
    (scheme one of :data:`DASK_SCHEMES`)."""
    if address != "local" and not _is_scheduler_address(address):
        raise SweepError(f"--dask {short_repr(address)}: expected 'local' or a scheduler address "
                         f"[scheme://]host:port with scheme {', '.join(DASK_SCHEMES)} "
                         "(for example tcp://127.0.0.1:8786)")


def _is_scheduler_address(address: str) -> bool:
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    try:
        parts = urllib.parse.urlsplit(f"//{rest}")
        return (scheme in DASK_SCHEMES and bool(parts.hostname) and parts.port is not None
                and not (parts.path or parts.query or parts.fragment or parts.username or parts.password))
    except ValueError:  # a port that is not a number in 0 … 65535, a bracket left open
        return False


def _nearest(case: dict, solved: list[tuple[dict, dict, float, str]], scales: dict):
    """(design, objective, case id) of the solved case nearest to ``case`` in normalised
    numeric parameters; three Nones if none is solved."""
    def dist(other):
        total = 0.0
        for k, v in case.items():
            w = other[k]
            if isinstance(v, (int, float)) and isinstance(w, (int, float)):
                total += ((v - w) / scales[k]) ** 2
            elif v != w:
                total += 1.0
        return total
    return min(solved, key=lambda s: dist(s[0]))[1:] if solved else (None, None, None)


def _case_words(row: dict) -> str:
    """A case by its parameters (``springs.1.rate = 1200``), as progress lines name it (a
    catalogue id's control characters escaped)."""
    return printable(", ".join(f"{key} = {value:g}" if isinstance(value, float) else f"{key} = {value}"
                               for key, value in json.loads(row["params"]).items()))


def _reporter(total: int, done: int):
    """A progress bar on a terminal (tqdm), plain log lines otherwise."""
    if sys.stderr.isatty():
        from tqdm import tqdm
        bar = tqdm(total=total, initial=done, unit="case", dynamic_ncols=True)
        return lambda row: (bar.set_postfix_str(f"{_case_words(row)}: {row['status']}"), bar.update(1)), bar.close
    t0, count = time.perf_counter(), [done]

    def line(row):
        count[0] += 1
        rate = (count[0] - done) / max(time.perf_counter() - t0, 1e-9)
        eta = (total - count[0]) / rate if rate > 0 else math.inf
        print(f"[{count[0]}/{total}] {_case_words(row)}: {row['status']} "
              f"({rate * 60:.1f} cases/min, ETA {eta:.0f} s)", file=sys.stderr, flush=True)
    return line, lambda: None


def run_sweep(study: Study, db_path, workers: int | None = None, dask: str | None = None,
              progress: bool = True) -> dict:
    """Run every case of ``study`` not yet recorded in ``db_path`` nor claimed by another
    runner; return counts and timing: ``cases`` in the study, ``ran`` by this call,
    ``skipped`` (recorded before it started), ``elsewhere`` (held by another runner still
    working when this one finished), ``statuses`` of every recorded case, ``wall_time_s`` and
    ``cases_per_min``.

    ``workers`` defaults to the machine's cores (0: run serially in this process); ``dask``
    is ``None`` (local process pool), ``"local"`` (a Dask LocalCluster on loopback) or a
    scheduler address.
    """
    cases = study.validate()
    workers = (os.cpu_count() or 1) if workers is None else workers
    if dask:
        check_dask_address(dask)
    created = not os.path.lexists(db_path)
    db = open_db(db_path, study)
    try:
        release_stale_claims(db)
        done_ids = {r[0] for r in db.execute("SELECT case_id FROM cases")}
        todo = [(i, c) for i, c in enumerate(cases) if Study.case_id(c) not in done_ids]
        ran, elapsed = _run_todo(db, study, cases, todo, workers, dask, progress) if todo else (0, 0.0)
        statuses = dict(db.execute("SELECT status, COUNT(*) FROM cases GROUP BY status").fetchall())
        elsewhere = db.execute("SELECT COUNT(*) FROM claims").fetchone()[0]
    except BaseException:
        empty = created and not db.execute("SELECT COUNT(*) FROM cases").fetchone()[0]
        _close(db)
        if empty:  # a database this run created and recorded nothing in is not left behind
            _remove_database(db_path)
        raise
    _close(db)
    return {"cases": len(cases), "ran": ran, "skipped": len(cases) - len(todo), "elsewhere": elsewhere,
            "wall_time_s": elapsed, "statuses": statuses,
            "cases_per_min": 60 * ran / elapsed if ran and elapsed > 0 else float("nan")}


def _run_todo(db: sqlite3.Connection, study: Study, cases: list[dict], todo: list[tuple[int, dict]],
              workers: int, dask: str | None, progress: bool) -> tuple[int, float]:
    """Claim, run and record the cases ``todo`` ((index, case) pairs of the study's ``cases``)
    on the executor :func:`run_sweep` names; return how many this runner ran and its time [s]."""
    warm = _WarmStarts(db, cases) if study.warm_start else None
    executor = _Dask(dask, max(workers, 1)) if dask else _Local(workers) if workers else _Serial()
    report, finish = (_reporter(len(cases), len(cases) - len(todo)) if progress
                      else (lambda r: None, lambda: None))
    definition = study.to_dict()
    t0 = time.perf_counter()
    if workers and not dask:  # a local pool's workers would each compile the same library
        compile_structures(definition, [c for _, c in todo])
    # two cases per worker keep a pool busy; serially a case is solved when submitted,
    # so one at a time lets the next warm-start from it
    room = 2 * max(workers, 1) if dask or workers else 1
    interrupted = True
    try:
        ran = _submit_and_record(db, executor, definition, list(todo), room, warm, report)
        interrupted = False
    finally:
        finish()
        executor.close(interrupted)
        with db:  # cases this runner claimed but did not finish (an interrupt) are free again
            db.execute("DELETE FROM claims WHERE host = ? AND pid = ?", runner())
    return ran, time.perf_counter() - t0


def _submit_and_record(db: sqlite3.Connection, executor, definition: dict, queue: list, room: int,
                       warm: _WarmStarts | None, report) -> int:
    """Keep up to ``room`` cases of ``queue`` ((index, case) pairs, consumed) that this runner
    claims running on ``executor``, each warm-started by ``warm`` if given, and record each
    as it finishes; return how many were run."""
    pending, ran = {}, 0
    while queue or pending:
        while queue and len(pending) < room:
            idx, case = queue.pop(0)
            if not claim(db, Study.case_id(case)):  # recorded or held by another runner
                continue
            start = warm.nearest(case) if warm else (None,) * 3
            pending[executor.submit(definition, case, *start)] = idx
        for fut in executor.wait(list(pending)):
            row = {**fut.result(), "idx": pending.pop(fut)}
            record(db, row)
            ran += 1
            report(row)
    return ran


class _WarmStarts:
    """The successful cases recorded in a study database by any runner, read as they appear,
    and the scale of each numeric parameter over the study's ``cases`` (its range, or 1)."""

    def __init__(self, db: sqlite3.Connection, cases: list[dict]):
        numeric = {k: [c[k] for c in cases if isinstance(c[k], (int, float))] for k in cases[0]}
        self.scales = {k: (max(v) - min(v)) or 1.0 if v else 1.0 for k, v in numeric.items()}
        self.db, self.solved, self.seen = db, [], 0  # solved cases up to rowid ``seen``

    def nearest(self, case: dict):
        """(design, objective, case id) of the recorded successful case nearest to ``case``
        (:func:`_nearest`), or three Nones."""
        for rowid, params, design, metrics in self.db.execute(
                "SELECT rowid, params, design, metrics FROM cases WHERE status = 'success' AND rowid > ?",
                (self.seen,)):
            params = json.loads(params)
            self.solved.append((params, json.loads(design), json.loads(metrics)["objective"],
                                Study.case_id(params)))
            self.seen = max(self.seen, rowid)
        return _nearest(case, self.solved, self.scales)


def sweep_and_read(study: Study, db_path, workers: int | None = None) -> tuple[dict, list[dict]]:
    """Run (or resume) ``study`` into ``db_path`` (creating its folder) and read every row back:
    the run's summary (see :func:`run_sweep`) and the rows (see :func:`read_rows`)."""
    Path(db_path).parent.mkdir(parents=True, exist_ok=True)
    summary = run_sweep(study, db_path, workers=workers)
    return summary, read_rows(db_path)[1]


# -- tables -------------------------------------------------------------------------------------
def _flat(prefix: str, value, out: dict) -> None:
    if isinstance(value, list):
        for i, v in enumerate(value):
            _flat(f"{prefix}_{i + 1}", v, out)
    elif isinstance(value, dict):
        out[prefix] = value.get("name", json.dumps(value, sort_keys=True))
    else:
        out[prefix] = value


def flat_table(study: dict, rows: list[dict]) -> list[dict]:
    """One flat dict per case: its parameters, run facts, recorded metrics (per-joint lists as
    ``rmse_1``, ``rmse_2``…) and the number of re-check violations."""
    table = []
    for r in rows:
        out = {"case_id": r["case_id"], "idx": r["idx"]}
        for k, v in r["params"].items():
            _flat(k, v, out)
        out.update({k: r[k] for k in ("status", "iterations", "solve_time_s", "build_time_s",
                                      "wall_time_s", "error", "torque_model", "cadcam_version")})
        for name in study["record"]:
            _flat(name, (r["metrics"] or {}).get(name), out)
        out["recheck_violations"] = len(r["recheck"]["violations"]) if r["recheck"] else None
        table.append(out)
    return table
