"""Issue 48, rule 5: SIGHUP (a closed terminal) stops a run as Ctrl-C and SIGTERM do.

Every stopping signal (:data:`cadcam.interrupts.STOPPING`) raises KeyboardInterrupt, so that the
run removes what it was writing and exits 130; a run started with SIGHUP ignored (``nohup``)
keeps ignoring it. The commands run as the console script does, signalled by another process
at the moment they stage their outputs (a hidden ``.cadcam-<pid>-stage-…`` folder in the output
folder), where the default action of SIGHUP left that folder behind and exited −1.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from cadcam.interrupts import INTERRUPTED, STOPPING, signals_stop_the_run
from cadcam.outputs import forked

from ..conftest import ROOT, SPEC_1DOF
from ..test_interrupts import SWEEP_ENDS_WITHIN_S, _running, sweep_solving


def _command(*args: str, nohup: bool = False) -> subprocess.Popen:
    """``cadcam`` with ``args`` as a child process leading a process group of its own, as a
    terminal's job does; with ``nohup``, started with SIGHUP ignored."""
    ignore = (lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN)) if nohup else None
    return subprocess.Popen([sys.executable, "-m", "cadcam", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, preexec_fn=ignore,
                            start_new_session=True)


def _staging(folder, proc: subprocess.Popen, timeout: float = 120.0) -> bool:
    """Wait until ``proc`` stages its outputs in ``folder``; False if it ended first."""
    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None:
        if folder.is_dir() and any(n.startswith(".cadcam-") for n in os.listdir(folder)):
            return True
        time.sleep(0.005)
    return False


def _caught(pid: int) -> set[int]:
    """The signals process ``pid`` has a handler for (its SigCgt mask in /proc)."""
    with open(f"/proc/{pid}/status") as f:
        mask = next(int(line.split()[1], 16) for line in f if line.startswith("SigCgt:"))
    return {s for s in range(1, 65) if mask & (1 << (s - 1))}


def test_every_stopping_signal_raises_once_and_comes_back_after_the_run():
    for s in STOPPING:
        before = signal.getsignal(s)
        with pytest.raises(KeyboardInterrupt):
            with signals_stop_the_run():
                os.kill(os.getpid(), s)
                time.sleep(1)  # the handler raises in here
        assert signal.getsignal(s) is before


def test_a_hangup_ignored_at_start_stays_ignored():
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        with signals_stop_the_run():
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)  # nothing happens
            time.sleep(0.05)
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, previous)


def test_the_drawing_processes_stop_on_the_same_signals():
    """One declaration of the stopping signals: the forked drawing processes block and unblock
    what the command stops on, SIGHUP among them."""
    assert forked.STOPPING is STOPPING and signal.SIGHUP in STOPPING


def test_a_design_hung_up_while_it_stages_exits_as_ctrl_c_does_and_leaves_nothing(tmp_path):
    """Exit 130, Ctrl-C's (tests/test_interrupts.py), with no output or staging folder: the
    hang-up reaches the command and the processes drawing its figures, as a closed terminal's."""
    out = tmp_path / "o"
    proc = _command("design", str(SPEC_1DOF), "-o", str(out), "--grid", "12")
    assert _staging(out, proc), proc.communicate()
    time.sleep(0.3)  # the figures are being drawn
    os.killpg(proc.pid, signal.SIGHUP)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == INTERRUPTED, err
    assert err.strip().splitlines()[-1].startswith("cadcam: interrupted")
    assert os.listdir(tmp_path) == []  # no output folder, no staging folder


def test_a_design_under_nohup_outlives_a_hangup(tmp_path):
    out = tmp_path / "o"
    proc = _command("design", str(SPEC_1DOF), "-o", str(out), "--grid", "12", "--no-figures", nohup=True)
    deadline = time.time() + 30
    while signal.SIGTERM not in _caught(proc.pid) and time.time() < deadline:
        time.sleep(0.005)
    assert signal.SIGHUP not in _caught(proc.pid)
    proc.send_signal(signal.SIGHUP)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert (out / "result.json").is_file()


def test_a_sweep_hung_up_while_its_workers_solve_ends_them_and_exits_130(tmp_path):
    """A closed terminal hangs up the whole process group: the command, its workers and
    multiprocessing's resource tracker, which must outlive them to release their semaphores
    (killed, it is started again and prints tracebacks)."""
    proc, workers = sweep_solving(tmp_path, _command)
    os.killpg(proc.pid, signal.SIGHUP)
    _, err = proc.communicate(timeout=SWEEP_ENDS_WITHIN_S)
    assert proc.returncode == INTERRUPTED
    assert err.strip().splitlines()[-1] == "cadcam: interrupted; no partial outputs were left", err
    assert "Traceback" not in err and "leak" not in err
    time.sleep(0.5)
    assert not [pid for pid in workers if _running(pid)]
    assert not (tmp_path / "s.db").exists()  # created by this run, nothing recorded
