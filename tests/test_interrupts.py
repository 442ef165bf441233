"""Interrupts (issue 29, item 5): Ctrl-C or SIGTERM at any moment of a run, once or many times,
ends ``cadcam`` with exit 130, leaves no partial output and no child process, and never hangs.

The commands run as the console script does (``python -m cadcam``), signalled by another process
as a user's shell or a job scheduler would. A signal within the interpreter's own start-up
(before any of cadcam's code runs: ~30 ms here) ends the process as Python's default does; the
delays are counted from the moment the process catches SIGTERM (Linux /proc), so a slow
machine's start-up does not count against cadcam.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cadcam.interrupts import INTERRUPTED, STOP, signals_stop_the_run

from .conftest import ROOT, SPEC_1DOF

#: Study of four 1-DOF cases on a fine grid: each takes over 10 s to build and solve.
STUDY = f'''
name = "interrupted"
base = "{SPEC_1DOF}"
[[parameters]]
key = "cams.1.order"
values = [5, 6, 7, 8]
[[parameters]]
key = "solver.grid"
values = [361]
'''
#: How soon an interrupted sweep must end [s]: well before its running cases could finish.
SWEEP_ENDS_WITHIN_S = 5.0


def _command(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "cadcam", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT)


def _catching(proc: subprocess.Popen, timeout: float = 30.0) -> None:
    """Wait until ``proc`` has a handler for SIGTERM (its SigCgt mask in /proc)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        with open(f"/proc/{proc.pid}/status") as f:
            caught = next(int(line.split()[1], 16) for line in f if line.startswith("SigCgt:"))
        if caught & (1 << (signal.SIGTERM - 1)):
            return
        time.sleep(0.001)
    raise AssertionError("the command never installed its SIGTERM handler")


def _signal(proc: subprocess.Popen, times: int, gap: float = 0.003) -> None:
    for _ in range(times):
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        time.sleep(gap)


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (Linux /proc)."""
    out = []
    for task in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{task}/children") as f:
            for child in map(int, f.read().split()):
                out += [child, *_descendants(child)]
    return out


def _running(pid: int) -> bool:
    """Whether ``pid`` is a process that has not ended (a zombie has)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rpartition(")")[2].split()[0] != "Z"
    except FileNotFoundError:
        return False


# -- the handler, in this process ---------------------------------------------------------------
def test_a_signal_raises_once_and_its_clean_up_is_not_cut_short():
    cleaned = []
    with pytest.raises(KeyboardInterrupt):
        with signals_stop_the_run():
            try:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(1)  # the handler raises in here
            finally:
                for _ in range(5):  # more signals while cleaning up are ignored
                    os.kill(os.getpid(), signal.SIGTERM)
                    time.sleep(0.01)
                cleaned.append(True)
    assert cleaned == [True]
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # the previous handler is back


def test_a_later_signal_stops_a_run_that_swallowed_the_first():
    with pytest.raises(KeyboardInterrupt):
        with signals_stop_the_run():
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(1)
            except KeyboardInterrupt:  # as a library that checks for signals and goes on
                pass
            assert STOP.arrived
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1)


# -- the command, signalled from outside ----------------------------------------------------------
@settings(max_examples=6, deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(delay=st.floats(0.0, 2.5), times=st.sampled_from([1, 2, 20]))
def test_design_ends_130_with_nothing_left_or_completes(tmp_path_factory, delay, times):
    """From start-up (imports) through the solve to the writing of the files: either the run
    completed before the signal (exit 0, every file) or it exits 130 with no output folder."""
    out = tmp_path_factory.mktemp("signalled") / "o"
    proc = _command("design", str(SPEC_1DOF), "-o", str(out), "--no-figures")
    _catching(proc)
    time.sleep(delay)
    _signal(proc, times)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        assert (out / "result.json").is_file()
    else:
        assert proc.returncode == INTERRUPTED, err
        assert err.strip().splitlines()[-1].startswith("cadcam: interrupted") and not out.exists()


def sweep_solving(tmp_path, command=None) -> tuple[subprocess.Popen, list[int]]:
    """A two-worker sweep of :data:`STUDY` started by ``command`` (default :func:`_command`),
    once its workers are solving their first cases, and the workers' pids."""
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    proc = (command or _command)("sweep", str(study), "-o", str(tmp_path / "s.db"), "--workers", "2")
    deadline = time.time() + 60
    while len(workers := _descendants(proc.pid)) < 2 and time.time() < deadline:
        time.sleep(0.05)
    time.sleep(1.0)  # the workers are solving their first cases
    assert proc.poll() is None and len(workers) >= 2
    return proc, workers


def test_a_sweep_signalled_while_its_workers_solve_ends_them_and_exits_130(tmp_path):
    proc, workers = sweep_solving(tmp_path)
    _signal(proc, 3, gap=0.05)
    proc.communicate(timeout=SWEEP_ENDS_WITHIN_S)  # the workers are ended, not waited for
    assert proc.returncode == INTERRUPTED
    time.sleep(0.5)
    assert not [pid for pid in workers if _running(pid)]
