"""The ``cadcam`` command: the console script and ``python -m cadcam``.

The signal handler of :mod:`cadcam.interrupts` is installed before the engine is imported, so
an interrupt at start-up exits 130 like one during the work; once the command has finished,
further signals are ignored while the interpreter ends.
"""
import os
import sys

from .interrupts import INTERRUPTED, STOP, ignore_further_signals, interrupt_arrived, stop_on_signals


def main() -> int:
    """Run ``cadcam`` with ``sys.argv``; return its exit code (:mod:`cadcam.cli`), or, when it
    was interrupted, end the process with :data:`INTERRUPTED` (see :func:`_end_interrupted`)."""
    _escaping_streams()
    stop_on_signals()
    try:
        from .cli import main as run_command
        code = run_command()
    except Exception:  # while importing: a library may turn the interrupt into its own error
        if not interrupt_arrived():
            raise
        code = _interrupted()
    except KeyboardInterrupt:  # before the command line took over the signals
        code = _interrupted()
    finally:
        STOP.finished = True  # first, and without a call: nothing can interrupt it
        ignore_further_signals()
    if code == INTERRUPTED:
        _end_interrupted()
    return code


def _escaping_streams() -> None:
    """Standard output and error write a character their encoding lacks as an escape (``·`` as
    ``\\xb7`` under ``PYTHONIOENCODING=ascii``) instead of failing the command."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)  # None: a closed descriptor at start-up
        if reconfigure is not None:
            reconfigure(errors="backslashreplace")


def _end_interrupted() -> None:
    """End the process now with :data:`INTERRUPTED`, its output flushed. CPython marks a
    KeyboardInterrupt raised inside code run by ``exec`` of a string (a dataclass's generated
    ``__init__`` while a module imports) as unhandled even when it was caught, and then ends
    the interpreter by SIGINT (exit −2) instead of with the code returned; the work that an
    interrupt stops has left nothing behind to clean up (:mod:`cadcam.cli`)."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(INTERRUPTED)



def _interrupted() -> int:
    print("cadcam: interrupted", file=sys.stderr)
    return INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
