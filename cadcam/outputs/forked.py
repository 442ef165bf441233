"""Drawings (figures, sheets) drawn side by side by processes forked from this one.

A drawing is mostly Python inside matplotlib, so threads would take turns; forked processes
share what this one has built (the figures, the fonts loaded) without pickling it. Forking is
done only where it is safe: on Linux, from a process that runs no other Python thread and is
not a pool's daemon worker. The workers take the drawings in their order from a shared counter,
report a failure through a pipe and are ended with their parent: on Ctrl-C or SIGTERM the
parent stops them and waits for them before it goes on, so no worker writes into a folder the
parent is removing, and a worker whose parent is killed is ended by the kernel.
"""
from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import pickle
import signal
import sys
import threading
import warnings
from collections.abc import Callable

from ..interrupts import STOPPING

#: A figure or sheet to draw: a function of no arguments that writes its file(s) atomically.
Drawing = Callable[[], None]

#: Linux prctl option: the signal a process gets when its parent ends.
PR_SET_PDEATHSIG = 1
#: Largest pickled error a worker sends back [bytes] (a pipe holds 64 KiB unread).
MAX_ERROR_BYTES = 32_000


class DrawingProcessError(ChildProcessError):
    """A drawing process ended without drawing or reporting (killed by a signal, out of
    memory)."""


def draw(drawings: list[Drawing], workers: int = 1) -> None:
    """Run ``drawings`` in their order (the longest first finishes soonest), on up to
    ``workers`` processes forked from this one; serially with one worker, outside Linux, from
    a daemon process and when this process runs other Python threads (a forked child holds a
    copy of whatever lock they held).

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
    with drawn_meanwhile(drawings, workers):
        pass


@contextlib.contextmanager
def drawn_meanwhile(drawings: list[Drawing], workers: int = 1):
    """:func:`draw` ``drawings`` while the block runs: the workers are forked on entering it
    and waited for on leaving it, so that this process does the block's work meanwhile (the
    drawings must need nothing the block makes). Where :func:`draw` would draw them here,
    they are drawn before the block. An error of the block ends the workers, and waits for
    them, before it comes out (a drawing's error comes out after the block)."""
    forkable = (sys.platform.startswith("linux") and not multiprocessing.current_process().daemon
                and threading.active_count() == 1)
    workers = min(workers, len(drawings)) if forkable else 1
    if workers <= 1:
        for drawing in drawings:
            drawing()
        yield
        return
    context = multiprocessing.get_context("fork")
    taken = context.Value("i", 0)  # the next drawing to take; len(drawings) once one failed
    pipes = [context.Pipe(duplex=False) for _ in range(workers)]
    processes = [context.Process(target=_work, args=(drawings, taken, sender, os.getpid()), daemon=True)
                 for _, sender in pipes]
    try:
        with _blocked(STOPPING), warnings.catch_warnings():
            # Python 3.12+ warns on fork when native threads run (numpy's OpenBLAS pool, which
            # re-creates itself in the child); the Python threads were checked above
            warnings.filterwarnings("ignore", "This process .* is multi-threaded", DeprecationWarning)
            for process in processes:
                process.start()
        # a Ctrl-C held back during the starts is raised on leaving the block, here
        yield
        for process in processes:
            process.join()
    except BaseException:
        with _blocked(STOPPING):  # a second Ctrl-C waits until the workers are gone
            for process in (p for p in processes if p.pid is not None):
                process.kill()
                process.join()
        raise
    for (receiver, sender), process in zip(pipes, processes):
        sender.close()  # then the pipe ends after what the worker sent
        if process.exitcode == 0:
            continue
        try:
            error = pickle.loads(receiver.recv_bytes())
        except EOFError:  # nothing sent: the worker was killed
            how = f"by signal {-process.exitcode}" if process.exitcode < 0 else f"with exit code {process.exitcode}"
            raise DrawingProcessError(f"a process drawing the figures ended {how} (killed, or out of memory?)") from None
        raise error


@contextlib.contextmanager
def _blocked(signals):
    """Hold ``signals`` back (pending, delivered on leaving) in this thread."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, signals)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _work(drawings: list[Drawing], taken, sender, parent: int) -> None:
    """A worker: take the next drawing until none is left; on an error send it and stop the
    others taking more. Ctrl-C is left to the parent; the other stopping signals (SIGTERM,
    SIGHUP) end it (not through the parent's handler, which it inherited), and so does its
    parent's end."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for s in set(STOPPING) - {signal.SIGINT}:
        if signal.getsignal(s) is not signal.SIG_IGN:  # SIGHUP under nohup stays ignored
            signal.signal(s, signal.SIG_DFL)
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPPING)
    if os.getppid() != parent:  # the parent ended before prctl
        os._exit(1)
    while True:
        with taken.get_lock():
            index = taken.value
            taken.value = min(index + 1, len(drawings))
        if index >= len(drawings):
            return
        try:
            drawings[index]()
        except BaseException as exc:  # raised again by the parent, whatever it is
            with taken.get_lock():
                taken.value = len(drawings)
            sender.send_bytes(_pickled(exc))
            sys.exit(1)


def _pickled(exc: BaseException) -> bytes:
    """``exc`` pickled, or a RuntimeError with its message if it cannot be (or is too large)."""
    with contextlib.suppress(Exception):
        data = pickle.dumps(exc)
        if len(data) <= MAX_ERROR_BYTES:
            return data
    return pickle.dumps(RuntimeError(f"{type(exc).__name__}: {str(exc)[:500]}"))
