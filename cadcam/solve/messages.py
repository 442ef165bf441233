"""CasADi's warnings during a solve, kept instead of printed; IPOPT's printing sent to stderr.

CasADi writes its warnings (a NaN in an evaluation of the NLP's functions at a trial point, …)
through Python's ``sys.stderr`` (``PySys_WriteStderr``), alike for expanded, MX and compiled
functions; IPOPT handles such a point itself (it shortens the step) and a solve that cannot
recover ends with its own status, so the warnings are worth keeping with the result, not
printing: a study's cases printed dozens of them. While :func:`kept_warnings` runs,
``sys.stderr`` is a :class:`_Router` that keeps what the capturing thread writes and passes
every other thread's writes on, so that a design in a worker thread (the design page's) takes
nothing from the server's log and gives it nothing.

IPOPT prints (its iteration log, at a ``print_level`` a spec raised) through ``sys.stdout``
(``PySys_WriteStdout``); standard output is the verdict's, first line first, so while
:func:`printed_to_stderr` runs, what the thread writes there goes to standard error instead.
"""
from __future__ import annotations

import contextlib
import re
import sys
import threading
from collections import Counter
from collections.abc import Callable

#: One CasADi warning as written: ``CasADi - <date> <time> WARNING("<message>") [<source>]``.
CASADI_WARNING = re.compile(r'^CasADi - \S+ \S+ WARNING\("(?P<message>.*)"\)(?: \[.*\])?$')

_lock = threading.Lock()


class _Router:
    """``sys.stderr`` or ``sys.stdout`` while some threads' writes go elsewhere: the text a
    routed thread writes goes to its sink (a callable of the text), any other thread's to the
    stream this one replaced (``stream``), which answers everything else (``encoding``,
    ``fileno``, ``isatty``, …: not an ``io`` class, whose own answers would hide the
    stream's)."""

    def __init__(self, stream):
        self.stream = stream
        self.sinks: dict[int, Callable[[str], object]] = {}

    def write(self, text: str) -> int:
        sink = self.sinks.get(threading.get_ident())
        if sink is None:
            return self.stream.write(text)
        sink(text)
        return len(text)

    def flush(self) -> None:
        self.stream.flush()

    def __getattr__(self, name):
        return getattr(self.stream, name)


@contextlib.contextmanager
def _routed(name: str, sink: Callable[[str], object]):
    """Inside the block, what this thread writes to ``sys.<name>`` (``stderr`` or ``stdout``)
    goes to ``sink``; an outer block's sink is this thread's again after it."""
    ident = threading.get_ident()
    with _lock:
        current = getattr(sys, name)
        router = current if isinstance(current, _Router) else _Router(current)
        setattr(sys, name, router)
        outer = router.sinks.get(ident)
        router.sinks[ident] = sink
    try:
        yield
    finally:
        with _lock:
            if outer is None:
                del router.sinks[ident]
            else:
                router.sinks[ident] = outer
            if not router.sinks and getattr(sys, name) is router:
                setattr(sys, name, router.stream)


def parse_warnings(text: str) -> list[dict]:
    """The distinct messages in what CasADi wrote, in their first order, each with how many
    times it came: ``[{"message": str, "count": int}]`` (the date and source location of a
    CasADi warning dropped; any other line kept as it is)."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    counts = Counter(m.group("message") if (m := CASADI_WARNING.match(line)) else line for line in lines)
    return [{"message": message, "count": count} for message, count in counts.items()]


def merged(runs: list[list[dict]]) -> list[dict]:
    """The warnings of several runs (:func:`parse_warnings`'s lists) as one list, counts added."""
    counts: Counter[str] = Counter()
    for run in runs:
        for w in run:
            counts[w["message"]] += w["count"]
    return [{"message": message, "count": count} for message, count in counts.items()]


def count(warnings: list[dict]) -> int:
    """How many warnings a list of :func:`parse_warnings` holds, repeats included."""
    return sum(w["count"] for w in warnings)


@contextlib.contextmanager
def kept_warnings():
    """Keep what this thread writes to ``sys.stderr`` inside the block; yields the list that
    holds, after the block, :func:`parse_warnings` of it."""
    kept: list[dict] = []
    buffer: list[str] = []
    try:
        with _routed("stderr", buffer.append):
            yield kept
    finally:
        kept += parse_warnings("".join(buffer))


@contextlib.contextmanager
def printed_to_stderr():
    """Inside the block, what this thread writes to ``sys.stdout`` goes to standard error, past
    any :func:`kept_warnings` (IPOPT's log is no warning): standard output keeps the verdict
    first whatever IPOPT prints."""
    stderr = sys.stderr.stream if isinstance(sys.stderr, _Router) else sys.stderr
    with _routed("stdout", stderr.write if stderr is not None else len):
        yield
