"""The ``cadcam`` command: the console script and ``python -m cadcam``.

The signal handler of :mod:`cadcam.interrupts` is installed before the engine is imported, so
an interrupt at start-up exits 130 like one during the work; once the command has finished,
further signals are ignored while the interpreter ends.
"""
import sys

from .interrupts import INTERRUPTED, STOP, ignore_further_signals, interrupt_arrived, stop_on_signals


def main() -> int:
    """Run ``cadcam`` with ``sys.argv``; return its exit code (:mod:`cadcam.cli`)."""
    stop_on_signals()
    try:
        from .cli import main as run_command
        return run_command()
    except Exception:  # while importing: a library may turn the interrupt into its own error
        if not interrupt_arrived():
            raise
        return _interrupted()
    except KeyboardInterrupt:  # before the command line took over the signals
        return _interrupted()
    finally:
        STOP.finished = True  # first, and without a call: nothing can interrupt it
        ignore_further_signals()



def _interrupted() -> int:
    print("cadcam: interrupted", file=sys.stderr)
    return INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
