"""How a run of ``cadcam`` stops: Ctrl-C, SIGTERM and SIGHUP (its terminal closed) alike raise
``KeyboardInterrupt``, so clean-up code (``finally`` blocks, context managers) removes
temporary files and ends child processes; a signal that arrives while an interrupt is being
handled is ignored, so that clean-up is never cut short, however many arrive. The command then
exits 130. A run started with SIGHUP ignored (``nohup``) keeps ignoring it.

This module imports nothing of cadcam's, so the command line can install the handler before
the engine (CasADi, NumPy) is imported.
"""
from __future__ import annotations

import contextlib
import signal
import sys
import threading

#: The signals that stop a run: Ctrl-C, ``kill``'s default and the hang-up of a closed
#: terminal, which would otherwise end the process where it stands, its temporary files left.
STOPPING = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: The stopping signals a process started ignoring keeps ignoring: ``nohup`` starts a command
#: with SIGHUP ignored so that it outlives its terminal.
KEPT_IGNORED = (signal.SIGHUP,)
#: The exit code of an interrupted command (128 + SIGINT, as shells report Ctrl-C).
INTERRUPTED = 130


class _Stop:
    """The handler of :data:`STOPPING`: the first signal raises ``KeyboardInterrupt``; a later
    one raises it again unless an exception is being handled (``except`` or ``finally`` blocks,
    a context manager's exit): that is the interrupt's clean-up, which must finish. (A library
    may turn the interrupt into an error of its own, as CasADi does, or swallow it and go on;
    :attr:`arrived` recognises the first, the next signal stops the second.) Once the command
    has :attr:`finished`, signals are ignored."""

    def __init__(self):
        self.arrived = False
        self.finished = False

    def __call__(self, signum, frame):
        first, self.arrived = not self.arrived, True
        if not self.finished and (first or sys.exc_info()[1] is None):
            raise KeyboardInterrupt


#: The one handler; the command line sets ``STOP.finished`` once it has handled an interrupt or
#: ended, with an attribute store, which (unlike a call) Python cannot interrupt to run a
#: handler. A later signal would otherwise raise in whatever runs next, a weak reference's
#: callback among them, where Python prints the exception and drops it.
STOP = _Stop()


def interrupt_arrived() -> bool:
    """Whether a :data:`STOPPING` signal has arrived since :func:`stop_on_signals`."""
    return STOP.arrived


@contextlib.contextmanager
def signals_stop_the_run():
    """Within the block, :data:`STOPPING` signals raise ``KeyboardInterrupt`` (module
    docstring); the previous handlers come back after it. Outside the main thread (where
    Python delivers no signals) the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = stop_on_signals()
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def stop_on_signals() -> dict:
    """Install the handler of :data:`STOPPING` (module docstring); return the previous
    handlers, by signal."""
    STOP.arrived = STOP.finished = False
    return {s: signal.signal(s, STOP) for s in STOPPING
            if not (s in KEPT_IGNORED and signal.getsignal(s) is signal.SIG_IGN)}


def ignore_further_signals() -> None:
    """From now on the process ignores :data:`STOPPING`: the command has finished, and the
    interpreter's own clean-up must not be cut short (Python puts back the default handlers,
    which end the process, as it finalizes, but leaves ignored signals ignored)."""
    for s in STOPPING:
        signal.signal(s, signal.SIG_IGN)
