"""Drawings (figures, sheets) drawn side by side by processes forked from this one.

A drawing is mostly Python inside matplotlib, so threads would take turns; forked processes
draw on every core. A :class:`Drawer` forks its first process as soon as it is made — before
the drawings exist, so that this process designs while that one imports matplotlib (imported
on a thread here, it would take turns with the design) — and that process forks the others
once it has imported it. The drawings are sent to them as they come (pickled: a
:class:`Call` names its function by module, so that this process need not import it) and
taken in their order from a shared counter. Forking is done only where it is safe: on Linux,
from a process that runs no other Python thread and is not a pool's daemon worker; elsewhere
the drawings are drawn here as they are sent. A failure comes back through a pipe; the
processes are ended with their parent: on Ctrl-C or SIGTERM the parent stops them and waits
for them before it goes on, so no process draws into a folder the parent is removing, and
one whose parent is killed is ended by the kernel.
"""
from __future__ import annotations

import contextlib
import ctypes
import importlib
import multiprocessing
import os
import pickle
import signal
import sys
import tempfile
import threading
import warnings
from collections.abc import Callable
from dataclasses import dataclass

from ..interrupts import STOPPING

#: A figure or sheet to draw: a function of no arguments that writes its file(s) atomically.
Drawing = Callable[[], None]

#: Linux prctl option: the signal a process gets when its parent ends.
PR_SET_PDEATHSIG = 1
#: Largest pickled error a worker sends back [bytes] (a pipe holds 64 KiB unread).
MAX_ERROR_BYTES = 32_000
#: Most batches of drawings a :class:`Drawer` is sent (``cadcam design`` sends two: the
#: figures, then the sheets).
MAX_BATCHES = 8

# the shared state of a Drawer's processes, a table of integers: the drawings sent and taken,
# whether the sender has closed and whether a drawing failed, the batches sent; then, for each
# process the first one forks, its exit code; then each batch's offset and length in the batch
# file and the index of its first drawing
_SENT, _TAKEN, _CLOSED, _FAILED, _BATCHES = range(5)
_OTHERS = 5


def _codes(workers: int) -> slice:
    """Where the exit codes of the processes the first one forks are in the shared state."""
    return slice(_OTHERS, _OTHERS + workers - 1)


def _batch(workers: int, b: int) -> slice:
    """Where batch ``b``'s offset, length and first drawing are."""
    start = _OTHERS + workers - 1 + 3 * b
    return slice(start, start + 3)


@dataclass(frozen=True)
class Call:
    """A drawing that calls ``module.function(*args)``: it is sent to the drawing processes by
    names, so that the process that makes it need not import ``module`` (matplotlib)."""

    module: str
    function: str
    args: tuple = ()

    def __call__(self) -> None:
        getattr(importlib.import_module(self.module), self.function)(*self.args)


class DrawingProcessError(ChildProcessError):
    """A drawing process ended without drawing or reporting (killed by a signal, out of
    memory)."""


def forkable() -> bool:
    """Whether processes may be forked from this one: on Linux, not from a pool's daemon
    worker, nor while this process runs other Python threads (a forked child holds a copy of
    whatever lock they held)."""
    return (sys.platform.startswith("linux") and not multiprocessing.current_process().daemon
            and threading.active_count() == 1)


def draw(drawings: list[Drawing], workers: int = 1) -> None:
    """Run ``drawings`` in their order (the longest first finishes soonest), on up to
    ``workers`` processes forked from this one (:class:`Drawer`); here, one after another,
    with one worker or where forking is not safe.

    Raises
    ------
    BaseException
        A drawing's error, as it raised it, once every worker has ended; no drawing starts
        after it.
    DrawingProcessError
        A worker ended without reporting (a signal: killed, out of memory).
    KeyboardInterrupt
        Ctrl-C or SIGTERM; the workers are ended and waited for first.
    """
    with Drawer(min(workers, len(drawings))) as drawer:
        drawer.send(drawings)
        drawer.wait()


class Drawer:
    """Up to ``workers`` processes that draw what :meth:`send` sends them, side by side, while
    this process works on; :meth:`wait` waits for them. The first is forked now and imports
    ``modules`` (the drawings' libraries; one that fails to import is left to the drawing
    that needs it) before it forks the others; with one worker, or where forking is not safe
    (:func:`forkable`), nothing is forked and :meth:`send` draws here. As a context manager,
    leaving the block without :meth:`wait` (an error) ends the processes and waits for them.
    """

    def __init__(self, workers: int, modules: tuple[str, ...] = ()):
        self.workers = workers if workers > 1 and forkable() else 1
        self.process = None  # None once the processes have ended
        if self.workers == 1:
            return
        context = multiprocessing.get_context("fork")
        self.batches = tempfile.TemporaryFile()  # unlinked: nothing is left behind
        self.end = 0
        self.changed = context.Condition()
        self.state = context.Array("q", _batch(self.workers, MAX_BATCHES).start, lock=False)
        self.pipes = [context.Pipe(duplex=False) for _ in range(self.workers)]
        # every drawing process holds the writing end of this pipe: it reads end of file once
        # they have all ended, the ones the first forked too
        self.alive, held = os.pipe()
        self.process = context.Process(target=_first, daemon=True, args=(
            self.batches.fileno(), self.state, self.changed, [sender for _, sender in self.pipes], os.getpid(),
            modules))
        try:
            with _blocked(STOPPING), warnings.catch_warnings():
                # Python 3.12+ warns on fork when native threads run (numpy's OpenBLAS pool,
                # which re-creates itself in the child); the Python threads were checked above
                warnings.filterwarnings("ignore", "This process .* is multi-threaded", DeprecationWarning)
                try:
                    self.process.start()
                finally:
                    os.close(held)
            # a Ctrl-C held back during the start is raised here
        except BaseException:
            self.__exit__()
            raise

    def __enter__(self) -> Drawer:
        return self

    def __exit__(self, *exc) -> None:
        if self.process is not None:
            with _blocked(STOPPING):  # a second Ctrl-C waits until the processes are gone
                self._stop()
                self._close()

    def send(self, drawings: list[Drawing]) -> None:
        """Draw ``drawings``, in their order, after those sent before (here, now, where nothing
        is forked)."""
        if self.process is None:
            for drawing in drawings:
                drawing()
            return
        if not drawings:
            return
        data = pickle.dumps(list(drawings), protocol=pickle.HIGHEST_PROTOCOL)
        os.pwrite(self.batches.fileno(), data, self.end)
        with self.changed:
            b = self.state[_BATCHES]
            if b == MAX_BATCHES:
                raise ValueError(f"a Drawer takes at most {MAX_BATCHES} batches of drawings")
            self.state[_batch(self.workers, b)] = [self.end, len(data), self.state[_SENT]]
            self.state[_BATCHES] = b + 1
            self.state[_SENT] += len(drawings)
            self.changed.notify_all()
        self.end += len(data)

    def wait(self) -> None:
        """Wait until every drawing sent is drawn, or one failed, and the processes ended.

        Raises
        ------
        BaseException
            A drawing's error, as it raised it; no drawing starts after it.
        DrawingProcessError
            A process ended without reporting (killed, out of memory).
        KeyboardInterrupt
            A process was ended by a stopping signal (:data:`cadcam.interrupts.STOPPING`): a
            hang-up or ``kill`` of the process group stops the run, whether or not this
            process has handled its own copy of the signal yet.
        """
        if self.process is None:
            return
        with self.changed:
            self.state[_CLOSED] = 1
            self.changed.notify_all()
        self.process.join()
        codes = [self.process.exitcode, *self.state[_codes(self.workers)]]
        self._stop()
        try:
            for (receiver, sender), code in zip(self.pipes, codes):
                sender.close()  # then the pipe ends after what the process sent
                if code == 0:
                    continue
                try:
                    error = pickle.loads(receiver.recv_bytes())
                except EOFError:  # nothing sent: the process was killed
                    if -code in STOPPING:  # stopped as the run is: a hang-up or kill of the group
                        raise KeyboardInterrupt from None
                    how = f"by signal {-code}" if code < 0 else f"with exit code {code}"
                    raise DrawingProcessError(f"a process drawing the figures ended {how} (killed, or out of "
                                              "memory?)") from None
                raise error
        finally:
            self._close()

    def _close(self) -> None:
        """Close the pipes and the batch file (the processes have ended), once."""
        if self.pipes:
            os.close(self.alive)
            for receiver, sender in self.pipes:
                receiver.close()
                sender.close()
            self.batches.close()
            self.pipes = []

    def _stop(self) -> None:
        """End the processes and wait until they are gone: SIGTERM ends the first, which ends
        the ones it forked first (or, killed, the kernel sends them SIGTERM)."""
        if self.process.pid is not None:
            if self.process.exitcode is None:
                self.process.terminate()
            self.process.join()
            while os.read(self.alive, 4096):  # nothing is written: end of file once all have ended
                pass
        self.process = None


@contextlib.contextmanager
def _blocked(signals):
    """Hold ``signals`` back (pending, delivered on leaving) in this thread."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, signals)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _as_worker(parent: int) -> None:
    """Signals of a drawing process: Ctrl-C is left to the cadcam process; the other stopping
    signals (SIGTERM, SIGHUP) end it (not through the handler it inherited), and so does the
    end of ``parent``, the process that forked it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for s in set(STOPPING) - {signal.SIGINT}:
        if signal.getsignal(s) is not signal.SIG_IGN:  # SIGHUP under nohup stays ignored
            signal.signal(s, signal.SIG_DFL)
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != parent:  # the parent ended before prctl
        os._exit(1)


def _first(fd: int, state, changed, senders, parent: int, modules: tuple[str, ...]) -> None:
    """The first drawing process: import ``modules``, fork the others, draw with them, wait
    for them and record their exit codes; its own is its drawings'. A stopping signal ends the
    others first and waits for them (held back while it forks one), so that once it has ended
    they have too."""
    _as_worker(parent)
    me, workers, others = os.getpid(), len(senders), []

    def end(signum, frame):
        for pid in others:
            os.kill(pid, signal.SIGKILL)
        for pid in others:
            with contextlib.suppress(ChildProcessError):
                os.waitpid(pid, 0)
        signal.signal(signum, signal.SIG_DFL)
        os.kill(me, signum)

    for s in set(STOPPING) - {signal.SIGINT}:
        if signal.getsignal(s) is not signal.SIG_IGN:
            signal.signal(s, end)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPPING)
    for name in modules:
        with contextlib.suppress(Exception):  # reported by the drawing that needs it
            importlib.import_module(name)
    with _blocked(STOPPING):
        for sender in senders[1:]:
            pid = os.fork()
            if pid == 0:  # never returns to the first's code, whatever happens
                code = 1
                try:
                    _as_worker(me)
                    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPPING)
                    code = _take(fd, state, changed, sender, workers)
                finally:
                    os._exit(code)
            others.append(pid)
    code, codes = _take(fd, state, changed, senders[0], workers), []
    for pid in list(others):
        status = os.waitpid(pid, 0)[1]
        with _blocked(STOPPING):  # reaped: its pid is no longer one to end
            others.remove(pid)
        codes.append(os.waitstatus_to_exitcode(status))
    state[_codes(workers)] = codes
    sys.exit(code)


def _take(fd: int, state, changed, sender, workers: int) -> int:
    """Draw the next drawing sent until the sender has closed and none is left, or one failed;
    on an error send it and stop the others taking more. Returns the exit code."""
    loaded: dict[int, list] = {}
    while True:
        with changed:
            while not state[_FAILED] and state[_TAKEN] == state[_SENT] and not state[_CLOSED]:
                changed.wait()
            if state[_FAILED] or state[_TAKEN] == state[_SENT]:
                return 0
            job = state[_TAKEN]
            state[_TAKEN] = job + 1
            tables = [state[_batch(workers, b)] for b in range(state[_BATCHES])]
        b = max(b for b, (_, _, first) in enumerate(tables) if first <= job)
        try:
            if b not in loaded:
                offset, length, _ = tables[b]
                loaded[b] = pickle.loads(os.pread(fd, length, offset))
            loaded[b][job - tables[b][2]]()
        except BaseException as exc:  # raised again by the parent, whatever it is
            with changed:
                state[_FAILED] = 1
                changed.notify_all()
            sender.send_bytes(_pickled(exc))
            return 1


def _pickled(exc: BaseException) -> bytes:
    """``exc`` pickled, or a RuntimeError with its message if it cannot be (or is too large)."""
    with contextlib.suppress(Exception):
        data = pickle.dumps(exc)
        if len(data) <= MAX_ERROR_BYTES:
            return data
    return pickle.dumps(RuntimeError(f"{type(exc).__name__}: {str(exc)[:500]}"))
