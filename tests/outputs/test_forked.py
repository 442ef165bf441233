"""Drawings side by side: forked from a process of one Python thread, the first error comes
back as raised, a worker killed is named (one ended by a stopping signal interrupts), Ctrl-C (twice) and the parent's death end every
worker, and with other threads running nothing is forked."""
import os
import signal
import subprocess
import sys
import threading
import time

from cadcam.files import process_alive
from cadcam.outputs.forked import draw

SCRIPT = """
import os, signal, sys, time
from functools import partial
from pathlib import Path
from cadcam.outputs.forked import draw
out = Path(sys.argv[1])
def mark(name, seconds=0.1):
    (out / f"{name}.pid").write_text(str(os.getpid()))
    time.sleep(seconds)
    (out / name).write_text(str(os.getpid()))
def fail():
    (out / "fail.pid").write_text(str(os.getpid()))
    raise ValueError("this drawing failed")
def killed():
    os.kill(os.getpid(), signal.SIGKILL)
def hung_up():
    os.kill(os.getpid(), signal.SIGHUP)
print(os.getpid(), flush=True)
"""


def _start(code: str, out) -> subprocess.Popen:
    """``code`` after :data:`SCRIPT` in a new process (of one thread, as ``cadcam design``)."""
    return subprocess.Popen([sys.executable, "-c", SCRIPT + code, str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _run(code: str, out) -> tuple[int, str, str]:
    proc = _start(code, out)
    stdout, stderr = proc.communicate(timeout=120)
    return proc.returncode, stdout, stderr


def _workers(out, names) -> list[int]:
    """The pids that started the drawings ``names``, once all have started."""
    deadline = time.monotonic() + 60
    while not all((out / f"{n}.pid").exists() for n in names):
        assert time.monotonic() < deadline, "the drawings did not start"
        time.sleep(0.05)
    time.sleep(0.05)  # the pid is written
    return [int((out / f"{n}.pid").read_text()) for n in names]


def _gone(pids, seconds: float = 10.0) -> bool:
    deadline = time.monotonic() + seconds
    while any(process_alive(p) for p in pids):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


def test_drawings_are_drawn_by_processes_forked_from_this_one(tmp_path):
    code, stdout, stderr = _run("draw([partial(mark, f'd{i}') for i in range(4)], 2)", tmp_path)
    assert code == 0, stderr
    drawers = {(tmp_path / f"d{i}").read_text() for i in range(4)}
    assert stdout.strip() not in drawers and len(drawers) <= 2


def test_the_first_error_comes_back_as_raised_and_no_drawing_starts_after_it(tmp_path):
    code, stdout, stderr = _run("draw([fail] + [partial(mark, f'd{i}', 0.5) for i in range(6)], 2)", tmp_path)
    assert code == 1 and stderr.strip().endswith("ValueError: this drawing failed")
    assert (tmp_path / "fail.pid").read_text() != stdout.strip()  # raised in a worker
    assert len(list(tmp_path.glob("d?.pid"))) <= 1  # at most the one the other worker had begun


def test_a_worker_killed_while_drawing_is_named(tmp_path):
    code, _, stderr = _run("draw([killed, partial(mark, 'd0')], 2)", tmp_path)
    assert code == 1
    assert "DrawingProcessError: a process drawing the figures ended by signal 9" in stderr


def test_a_worker_ended_by_a_stopping_signal_stops_the_run_as_the_signal_does(tmp_path):
    """A hang-up of the process group can end a drawing process before this one has handled
    its own copy: the run is interrupted, not failed."""
    code, _, stderr = _run("draw([hung_up, partial(mark, 'd0')], 2)", tmp_path)
    assert code != 0 and stderr.strip().endswith("KeyboardInterrupt"), stderr
    assert "DrawingProcessError" not in stderr


def test_ctrl_c_twice_ends_every_worker_and_the_run(tmp_path):
    proc = _start("draw([partial(mark, f'd{i}', 60) for i in range(4)], 2)", tmp_path)
    workers = _workers(tmp_path, ["d0", "d1"])
    proc.send_signal(signal.SIGINT)
    time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode != 0 and "KeyboardInterrupt" in stderr
    assert _gone(workers)
    assert not any((tmp_path / f"d{i}").exists() for i in range(4))


def test_the_workers_end_with_their_parent(tmp_path):
    proc = _start("draw([partial(mark, f'd{i}', 60) for i in range(2)], 2)", tmp_path)
    workers = _workers(tmp_path, ["d0", "d1"])
    proc.kill()
    proc.communicate(timeout=30)
    assert _gone(workers)


def test_with_other_threads_running_the_drawings_are_drawn_here():
    """Forking a process that runs other threads copies whatever lock they hold: not done."""
    drawers, stop = [], threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        draw([lambda: drawers.append(os.getpid())] * 3, 2)
    finally:
        stop.set()
        other.join()
    assert drawers == [os.getpid()] * 3


def test_a_ctrl_c_while_the_workers_start_ends_them_too(tmp_path):
    """A Ctrl-C held back while the first worker is forked (the others are forked by it) is
    raised once it runs, and ends it before it comes out of :func:`draw`."""
    code = ("import multiprocessing.context as mc; real = mc.ForkProcess.start; started = []\n"
            "def start(self):\n"
            "    real(self); started.append(self.pid)\n"
            "    if len(started) == 1: os.kill(os.getpid(), signal.SIGINT)  # pending: signals held back\n"
            "mc.ForkProcess.start = start\n"
            "try:\n"
            "    draw([partial(mark, f'd{i}', 30) for i in range(4)], 2)\n"
            "except KeyboardInterrupt:\n"
            "    from cadcam.files import process_alive\n"
            "    print(sum(process_alive(p) for p in started), len(started))\n")
    returncode, stdout, stderr = _run(code, tmp_path)
    assert returncode == 0, stderr
    assert stdout.split()[1:] == ["0", "1"]  # when the interrupt arrives, the worker is gone
