"""IPOPT's functions of a design NLP as compiled C, built once per problem structure and cached
on disk.

The transcription's NLP is a graph of mapped per-angle functions (CasADi MX), so its generated
C holds each per-angle function once, inside loops over the grid. Each of IPOPT's functions is
written to a C file of its own and the files compile side by side on the machine's cores, then
link into one library: the constraint Jacobian and the Lagrangian Hessian, the two largest,
compile at the same time instead of one after the other (Sec. 10.4's first build: 9.3 s
against 16.5 s as one file, on 2 cores). The library is cached under :func:`cache_dir`, keyed
by the serialized graph of the NLP as the transcription writes it for expanded functions (which
holds its structure and nothing of a case's numbers: those are parameters and bounds; the
functions themselves are generated from the same NLP with each mapped function's outputs
called apart, so a cached library is found without building that second graph) and by the cadcam and CasADi versions, the compiler and its
flags; a later build of the same structure, in this process or another, loads it in
milliseconds.

Concurrent writers are safe: each compiles in a private temporary folder inside the cache and
moves its library into place with an atomic rename, so a reader sees a whole library or none.

``functions = "auto"`` (the default) loads a structure's library where the cache holds it and
otherwise solves with expanded functions while :func:`compile_in_background` compiles the
library in a detached process of low priority (``python -m cadcam.solve.compiled``), so that
the next build of that structure, in any process, loads it.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import casadi as ca

from ..version import __version__

#: The functions IPOPT calls (CasADi's names), in the order they are generated; ``nlp_grad``
#: is called once, after the solve.
ORACLE = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l", "nlp_grad")
#: C compiler flags of each function's file. Measured on this project's problems: at -O0 the
#: 1-DOF solve took 0.72 s, no faster than CasADi's virtual machine, against 0.17 s at -O1; -O2
#: compiles about twice as long as -O1 (the similar C of ``cadcam export --what problem``).
CFLAGS = ("-O1", "-fPIC")
#: Directions per call of a derivative in the generated functions (CasADi's ``max_num_dir``).
#: CasADi writes each batch of directions out as straight-line code, so one direction keeps the
#: C small: measured against CasADi's default batching (with the library as one C file, with
#: CasADi's comment per operation), the 1-DOF library compiles in 4.5 s
#: instead of 11.3 s and solves as fast; Sec. 10.4's in 12.5 s instead of 19.0 s, solving
#: 10 % slower (0.30 s against 0.27 s); the three-cam arm's in 20.4 s instead of 34.7 s, as
#: fast.
DIRECTIONS = 1
#: Options of each generated function: CasADi's common subexpression elimination merges the
#: repeated nodes of a derivative's graph (Sec. 10.4's constraint Jacobian: 4603 instructions
#: against 8518), so its C is smaller and compiles faster; the values are the same to the bit
#: (the same operations on the same operands).
FUNCTION_OPTIONS = {"cse": True}


#: File name of a compiled library in the cache, by its key (:func:`library_key`).
LIBRARY_NAME = "nlp_{}.so"
#: File name of a background compile's NLP (:func:`compile_in_background`), by its library's
#: key: there while the compile is under way.
PENDING_NAME = ".pending_{}.casadi"
#: File name of a failed background compile's first lines of error, by its library's key: the
#: structure is not compiled in the background again (``cadcam cache --clear`` removes it).
FAILED_NAME = "nlp_{}.failed"
#: A background compile pending for longer than this is taken for dead and started again [s].
PENDING_STALE_S = 900.0
#: Longest line of a compiler's error kept in an error message [characters].
FAILURE_CHARS = 300
#: Environment variable that, set to ``0``, keeps ``functions = "auto"`` from compiling
#: libraries in the background (it then loads the ones in the cache and expands the rest): for
#: processes whose structures are short-lived, such as a test suite's.
BACKGROUND_ENV = "CADCAM_BACKGROUND_COMPILE"
#: Niceness added to a background compile: the design that started it goes on at full speed.
BACKGROUND_NICENESS = 10
#: Address space each process of a background compile may take [bytes] (the Python process and
#: each compiler it runs): a structure whose C needs more is noted as failed (:data:`FAILED_NAME`)
#: and keeps expanded functions, instead of a compile no one asked for filling a small
#: machine's memory.
BACKGROUND_MEMORY_BYTES = 2 * 2**30
#: CPU time each process of a background compile may take [s], for the same reason.
BACKGROUND_CPU_S = 300


class CompileError(RuntimeError):
    """No C compiler, or the generated code did not compile."""


def cache_dir() -> Path:
    """The folder of compiled libraries: ``$CADCAM_CACHE_DIR``, else ``$XDG_CACHE_HOME/cadcam``,
    else ``~/.cache/cadcam`` (created on first use)."""
    env = os.environ.get("CADCAM_CACHE_DIR")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "cadcam"


def available() -> bool:
    """Whether a C compiler is on PATH (:func:`compiler` finds one)."""
    return _found() is not None


def _found() -> str | None:
    return shutil.which("cc") or shutil.which("gcc")


def compiler() -> str:
    """Path of the C compiler (``cc`` or ``gcc`` on PATH); CompileError if there is none."""
    found = _found()
    if found is None:
        raise CompileError("solver.functions = 'compiled' needs a C compiler (cc or gcc) on PATH; "
                           "install one or use functions = 'auto' (expanded without one)")
    return found


def oracle_functions(nlp: dict) -> dict[str, ca.Function]:
    """By name, the NLP function ``nlp`` (x, p) → (f, g) and the functions of :data:`ORACLE` as
    nlpsol derives them from ``nlp`` (a dict ``x``, ``p``, ``f``, ``g`` of MX), unexpanded:
    objective, constraints, objective gradient, constraint Jacobian, the Lagrangian Hessian's
    upper triangle and the Lagrangian's gradient (for the multipliers of the parameters),
    their derivatives taken :data:`DIRECTIONS` at a time, each rebuilt with
    :data:`FUNCTION_OPTIONS`. A library of these is what ``nlpsol(name, "ipopt", library)``
    loads."""
    solver = ca.nlpsol("oracle", "ipopt", nlp, {"oracle_options": {"max_num_dir": DIRECTIONS}})
    functions = {"nlp": solver.oracle(), **{name: solver.get_function(name) for name in ORACLE}}
    return {name: rebuilt(f, FUNCTION_OPTIONS) for name, f in functions.items()}


def rebuilt(f: ca.Function, options: dict) -> ca.Function:
    """``f`` (MX) rebuilt with its body inlined (not called), with ``options``."""
    args = f.mx_in()
    return ca.Function(f.name(), args, f.call(args, True, False), f.name_in(), f.name_out(), options)


def library_key(nlp: dict, cc: str) -> str:
    """Hex digest naming the library of ``nlp`` compiled by ``cc``: its serialized graph, the
    cadcam and CasADi versions, the compiler, :data:`CFLAGS`, :data:`DIRECTIONS` and
    :data:`FUNCTION_OPTIONS`."""
    graph = _nlp_function(nlp).serialize()
    digest = hashlib.sha256()
    for part in (__version__, ca.__version__, cc, " ".join(CFLAGS), str(DIRECTIONS),
                 json.dumps(FUNCTION_OPTIONS, sort_keys=True), graph):
        digest.update(part.encode())
        digest.update(b"\0")
    return digest.hexdigest()[:32]


def key_of(nlp: dict) -> str | None:
    """The :func:`library_key` of ``nlp`` with this machine's compiler; None without one."""
    cc = _found()
    return None if cc is None else library_key(nlp, cc)


def cached_library(key: str | None) -> Path | None:
    """The compiled library of :func:`key_of` ``key`` in the cache, or None (also for no key)."""
    if key is None:
        return None
    path = cache_dir() / LIBRARY_NAME.format(key)
    return path if path.exists() else None


def library(nlp: dict, source=None, key: str | None = None) -> tuple[Path, bool]:
    """The compiled library of ``nlp``'s :data:`ORACLE` functions, and whether it was compiled
    now (False: found in the cache). ``source()``, if given, is the same NLP (its variables,
    parameters and rows in the same order) written as the functions are to be generated from;
    it is called only to compile. ``key`` is the library's :func:`library_key`, if the caller
    has it.

    Raises
    ------
    CompileError
        Without a C compiler, or if compiling fails (the compiler's first lines of error).
    """
    folder, cc = cache_dir(), compiler()
    path = folder / LIBRARY_NAME.format(key or library_key(nlp, cc))
    if path.exists():
        return path, False
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=folder, prefix=".build-") as tmp:
        sources = []
        for name, f in oracle_functions(source() if source is not None else nlp).items():
            # without CasADi's comment per operation, which doubles the C
            gen = ca.CodeGenerator(f"{name}.c", {"verbose": False})
            gen.add(f)
            gen.generate(tmp + os.sep)
            sources.append(Path(tmp) / f"{name}.c")
        sources.sort(key=lambda source: source.stat().st_size, reverse=True)  # longest first
        with ThreadPoolExecutor(min(len(sources), os.cpu_count() or 1)) as pool:
            # a failed compile raises here, and map cancels the files not yet started
            objects = list(pool.map(lambda source: _compile(cc, source), sources))
        built = Path(tmp) / path.name
        _run([cc, "-shared", *map(str, objects), "-o", str(built), "-lm"])
        os.replace(built, path)
    return path, True


def compile_in_background(nlp: dict, source=None, key: str | None = None) -> bool:
    """Start compiling ``nlp``'s library (:func:`library`, from ``source()`` if given; ``key``
    its :func:`key_of`, if the caller has it) into the cache in a detached process of low
    priority (:data:`BACKGROUND_NICENESS`), unless one is under way, it failed before, there is
    no C compiler or :data:`BACKGROUND_ENV` is ``0``. Returns whether a compile is under way.

    The NLP goes to the process as its serialized graph in the cache folder
    (:data:`PENDING_NAME`), which the process removes when it is done.
    """
    if os.environ.get(BACKGROUND_ENV, "1") == "0":
        return False
    key = key or key_of(nlp)
    if key is None:
        return False
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    pending = folder / PENDING_NAME.format(key)
    if (folder / FAILED_NAME.format(key)).exists():
        return False
    with contextlib.suppress(FileNotFoundError):
        if time.time() - pending.stat().st_mtime > PENDING_STALE_S:
            pending.unlink()
    try:  # the pending file is the lock: one compile per structure
        os.close(os.open(pending, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return True
    _nlp_function(source() if source is not None else nlp).save(str(pending))
    subprocess.Popen([sys.executable, "-m", __name__, key, str(pending)], start_new_session=True,
                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return True


def _nlp_function(nlp: dict) -> ca.Function:
    """``nlp`` as one function (x, p) → (f, g)."""
    return ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]])


def compile_pending(key: str, pending: Path) -> None:
    """Compile the serialized NLP ``pending`` into the cache as the library of ``key`` (the
    detached process :func:`compile_in_background` starts), then remove ``pending``; a failure
    is written beside the libraries (:data:`FAILED_NAME`)."""
    try:
        f = ca.Function.load(str(pending))
        x, p = f.mx_in()
        obj, g = f.call([x, p], True, False)
        library({"x": x, "p": p, "f": obj, "g": g}, key=key)
    except (CompileError, RuntimeError, OSError, MemoryError) as e:
        (pending.parent / FAILED_NAME.format(key)).write_text(str(e)[:2000])
    finally:
        pending.unlink(missing_ok=True)


def _compile(cc: str, source: Path) -> Path:
    """Compile one C file into an object file beside it (:data:`CFLAGS`)."""
    obj = source.with_suffix(".o")
    _run([cc, *CFLAGS, "-c", str(source), "-o", str(obj)])
    return obj


def _run(command: list[str]) -> None:
    """Run a compiler command; CompileError with its first line of error if it fails."""
    run = run_compiler(command)
    if run.returncode != 0:
        raise CompileError(f"compiling the NLP failed: {compiler_failure(run)}")


def compiler_failure(run: subprocess.CompletedProcess) -> str:
    """What a failed compiler ``run`` says, as one line for an error message: the first line of
    its output that names an error (else its first line, else how it ended), its control
    characters escaped, cut to :data:`FAILURE_CHARS`."""
    lines = [line.strip() for line in run.stderr.splitlines() if line.strip()]
    line = next((line for line in lines if "error" in line.lower()), lines[0] if lines else None)
    if line is None:
        code = run.returncode
        line = (f"{Path(run.args[0]).name} was killed by {signal.Signals(-code).name}" if code < 0
                else f"{Path(run.args[0]).name} exited with code {code} and no message")
    line = "".join(c if c.isprintable() else repr(c)[1:-1] for c in line)
    return line if len(line) <= FAILURE_CHARS else line[:FAILURE_CHARS - 1] + "…"


def run_compiler(command: list[str]) -> subprocess.CompletedProcess:
    """Run ``command`` (a compiler driver) in a session of its own, its output captured (as
    text, any bytes that are not UTF-8 replaced). Should anything stop the wait (Ctrl-C,
    SIGTERM), the whole session is killed and waited for: the driver's own children (cc1, as,
    ld) are not left running as orphans. CompileError if the driver cannot be run."""
    try:
        proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                errors="replace", start_new_session=True)
    except OSError as exc:
        raise CompileError(f"the C compiler {command[0]!r} cannot be run ({exc.strerror or exc}); "
                           "install a working one or use functions = 'expanded'") from None
    try:
        out, err = proc.communicate()
    except BaseException:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        raise
    return subprocess.CompletedProcess(command, proc.returncode, out, err)


def cached_libraries() -> list[Path]:
    """The compiled libraries in :func:`cache_dir` (none if the folder does not exist)."""
    folder = cache_dir()
    return sorted(folder.glob(LIBRARY_NAME.format("*"))) if folder.is_dir() else []


def clear_cache() -> tuple[int, int]:
    """Remove the compiled libraries and the notes of failed background compiles from
    :func:`cache_dir`; return how many libraries and their bytes. A process that has one
    loaded keeps using it; a later build compiles it again. Compiles under way are left alone."""
    removed = [(path, path.stat().st_size) for path in cached_libraries()]
    for path, _ in removed:
        path.unlink(missing_ok=True)
    folder = cache_dir()
    for note in folder.glob(FAILED_NAME.format("*")) if folder.is_dir() else ():
        note.unlink(missing_ok=True)
    return len(removed), sum(size for _, size in removed)


def _limit_background() -> None:
    """Lower this process's priority and cap its memory and CPU time (and so its compilers'):
    :data:`BACKGROUND_NICENESS`, :data:`BACKGROUND_MEMORY_BYTES`, :data:`BACKGROUND_CPU_S`."""
    import resource

    os.nice(BACKGROUND_NICENESS)
    resource.setrlimit(resource.RLIMIT_AS, (BACKGROUND_MEMORY_BYTES, BACKGROUND_MEMORY_BYTES))
    # past the soft limit this process gets SIGXCPU, raised here so that the failure is noted
    # (a compiler past it is killed, and its compile fails); the hard limit a minute later
    resource.setrlimit(resource.RLIMIT_CPU, (BACKGROUND_CPU_S, BACKGROUND_CPU_S + 60))
    signal.signal(signal.SIGXCPU, _out_of_cpu_time)


def _out_of_cpu_time(signum, frame):
    raise RuntimeError(f"the background compile took more than {BACKGROUND_CPU_S} s of CPU time")


if __name__ == "__main__":  # the detached process of compile_in_background
    _limit_background()
    compile_pending(sys.argv[1], Path(sys.argv[2]))
