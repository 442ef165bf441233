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

Only libraries this user compiled are loaded. The cache is a folder of this user's that no one
else may write (created mode 700; one owned by another user or writable by group or others,
such as a shared 1777 folder, is not used at all), and each library's SHA-256 is recorded
beside it when it is compiled (:data:`RECORD_NAME`) and checked before it is loaded: a library
with no record, another content (truncated, damaged, replaced), another owner, loose
permissions or that is not a regular file is never loaded; it is compiled again, and until
then the design solves with expanded functions, saying so in one line on stderr.

``functions = "auto"`` (the default) loads a structure's library where the cache holds it and
otherwise solves with expanded functions while :func:`compile_in_background` compiles the
library in a detached process of low priority (``python -m cadcam.solve.compiled``), so that
the next build of that structure, in any process, loads it.
"""
from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import os
import re
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import casadi as ca

from ..files import TEMP_PREFIX, atomic_path, process_alive, remove_leftovers
from ..library_files import ipopt_options
from ..version import __version__

#: The functions IPOPT calls (CasADi's names), in the order they are generated; ``nlp_grad``
#: is called once, after the solve.
ORACLE = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l", "nlp_grad")
#: C compiler flags of each function's file. Measured on this project's problems: at -O0 the
#: 1-DOF solve took 0.72 s, no faster than CasADi's virtual machine, against 0.17 s at -O1; -O2
#: compiles about twice as long as -O1 (the similar C of ``cadcam export --what problem``).
CFLAGS = ("-O1", "-fPIC")
#: The functions of :data:`ORACLE` a solve calls once, after its iterations (``nlp_grad``, for
#: the multipliers of the parameters, which cadcam does not read), and the C compiler flags of
#: their files: unoptimized, their C compiles in a fraction of -O1's time (the Lagrangian
#: gradient's is the third largest file), and one call per solve costs next to nothing more.
AFTER_SOLVE, AFTER_SOLVE_CFLAGS = ("nlp_grad",), ("-O0", "-fPIC")
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
#: File name of a library's record in the cache, by its key: JSON of the library's size
#: [bytes] and SHA-256 as cadcam compiled it. A library is loaded only where its record says
#: cadcam wrote that very content, and ``cadcam cache --clear`` removes only such libraries.
RECORD_NAME = "nlp_{}.json"
#: Largest record read [bytes] (one holds some 200).
RECORD_MAX_BYTES = 4096
#: Mode of the cache folder cadcam creates: this user's alone.
FOLDER_MODE = 0o700
#: Mode of a library in the cache: this user may read it, no one may write it in place (a
#: copy over it would change what every later design loads).
LIBRARY_MODE = 0o500
#: Mode of a library's record.
RECORD_MODE = 0o600
#: Permission bits that make a folder or file of the cache another's to change (group or
#: others may write): such a cache folder is not used, such a library or record not read.
LOOSE_BITS = 0o022
#: Name of a background compile's folder (:func:`compile_in_background`), by its library's
#: key: there while the compile is under way, holding its process (:data:`OWNER_FILE`) and
#: the NLP it compiles (:data:`NLP_FILE`).
PENDING_NAME = ".pending_{}"
#: File of a background compile's folder naming its process: ``<pid> <host>``.
OWNER_FILE = "process"
#: File of a background compile's folder holding the serialized NLP it compiles.
NLP_FILE = "nlp.casadi"
#: File name of a failed background compile's first lines of error, by its library's key: the
#: structure is not compiled in the background again (``cadcam cache --clear`` removes it).
FAILED_NAME = "nlp_{}.failed"
#: A background compile whose process is gone (on this host) is taken for dead at once; one
#: pending for longer than this is taken for dead too (its process on another host, or its
#: process id since reused) and started again [s].
PENDING_STALE_S = 900.0
#: What a design does when the cache gives it no library (the end of the line saying why).
EXPANDED = "solving with expanded functions"
#: How to give cadcam a cache folder it uses, where the one it has may not be used.
MAKE_PRIVATE = "chmod 700 it if it is yours, or set CADCAM_CACHE_DIR to a folder of your own"
#: Longest line of a compiler's error kept in an error message [characters].
FAILURE_CHARS = 300
#: A SHA-256 as a record holds it.
_SHA256 = re.compile(r"[0-9a-f]{64}")
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
    solver = ca.nlpsol("oracle", "ipopt", nlp, ipopt_options({"oracle_options": {"max_num_dir": DIRECTIONS}}))
    functions = {"nlp": solver.oracle(), **{name: solver.get_function(name) for name in ORACLE}}
    return {name: rebuilt(f, FUNCTION_OPTIONS) for name, f in functions.items()}


def rebuilt(f: ca.Function, options: dict) -> ca.Function:
    """``f`` (MX) rebuilt with its body inlined (not called), with ``options``."""
    args = f.mx_in()
    return ca.Function(f.name(), args, f.call(args, True, False), f.name_in(), f.name_out(), options)


def library_key(nlp: dict, cc: str) -> str:
    """Hex digest naming the library of ``nlp`` compiled by ``cc``: its serialized graph, the
    cadcam and CasADi versions, the compiler, :data:`CFLAGS`, :data:`AFTER_SOLVE_CFLAGS`,
    :data:`DIRECTIONS` and :data:`FUNCTION_OPTIONS`."""
    graph = _nlp_function(nlp).serialize()
    digest = hashlib.sha256()
    flags = f"{' '.join(CFLAGS)}; {' '.join(AFTER_SOLVE)}: {' '.join(AFTER_SOLVE_CFLAGS)}"
    for part in (__version__, ca.__version__, cc, flags, str(DIRECTIONS),
                 json.dumps(FUNCTION_OPTIONS, sort_keys=True), graph):
        digest.update(part.encode())
        digest.update(b"\0")
    return digest.hexdigest()[:32]


def key_of(nlp: dict) -> str | None:
    """The :func:`library_key` of ``nlp`` with this machine's compiler; None without one."""
    cc = _found()
    return None if cc is None else library_key(nlp, cc)


def cached_library(key: str | None) -> Path | None:
    """The compiled library of :func:`key_of` ``key`` in the cache where it may be loaded
    (:func:`library_refusal`), else None (also for no key); where something that may not
    stands under its name, one line on stderr says why."""
    if key is None:
        return None
    folder = _private_folder(create=False)
    if folder is None:
        return None
    path = folder / LIBRARY_NAME.format(key)
    return path if _loadable(path, then=EXPANDED) else None


def library(nlp: dict, source=None, key: str | None = None, claimed: bool = False) -> tuple[Path | None, bool]:
    """The compiled library of ``nlp``'s :data:`ORACLE` functions, and whether it was compiled
    now (False: found in the cache). ``source()``, if given, is the same NLP (its variables,
    parameters and rows in the same order) written as the functions are to be generated from;
    it is called only to compile. ``key`` is the library's :func:`library_key`, if the caller
    has it.

    A library in the cache that may not be loaded (:func:`library_refusal`) is compiled again
    in its place. ``(None, False)``, said in one line on stderr, where the cache may not be
    used (:func:`folder_refusal`) or a folder stands under the library's name: the caller
    solves with expanded functions. While it compiles, the library is claimed as a background
    compile claims it (:data:`PENDING_NAME`; ``claimed``: the caller holds that claim), so that
    no other process compiles it too: one that finds it claimed waits for that compile and
    loads its library (:func:`_claim_or_wait`).

    Raises
    ------
    CompileError
        Without a C compiler, or if compiling fails (the compiler's first line of error).
    """
    cc = compiler()
    folder = _private_folder(create=True)
    if folder is None:
        return None, False
    key = key or library_key(nlp, cc)
    path = folder / LIBRARY_NAME.format(key)
    replaceable = _replaceable(path)
    if _loadable(path, then="compiling it again" if replaceable else EXPANDED):
        return path, False
    if not replaceable:
        return None, False
    pending = None if claimed else _claim_or_wait(folder, key, path)
    if pending is None and not claimed:  # compiled meanwhile by the process that held the claim
        return path, False
    try:
        _compile_library(source() if source is not None else nlp, cc, folder, path)
    finally:
        if pending is not None:
            _remove(pending)
    return path, True


#: How often a design waiting for another process's compile of its library looks again [s].
WAIT_POLL_S = 0.2


def _claim_or_wait(folder: Path, key: str, path: Path) -> Path | None:
    """Claim the compile of the library ``key`` (``path``) in the cache ``folder``: its
    :data:`PENDING_NAME` folder, made now; or, where another process holds the claim (a
    background compile, another design compiling it), wait until that compile is over and
    return None where its library may be loaded. A claim whose process ended without a
    library, or one pending for :data:`PENDING_STALE_S`, is taken over (:func:`_claimed`)."""
    while True:
        pending = _claimed(folder, key)
        if pending is not None:
            return pending
        time.sleep(WAIT_POLL_S)
        if os.path.lexists(path) and library_refusal(path) is None:
            return None


def _compile_library(nlp: dict, cc: str, folder: Path, path: Path) -> None:
    """Generate the C of ``nlp``'s :data:`ORACLE` functions, compile it (each function's file on
    a core of its own) and install the library as ``path`` in the cache ``folder``."""
    remove_leftovers(folder)  # the build folders of compiles killed before they ended
    # absolute: the compiler runs in a folder of its own (run_compiler)
    with tempfile.TemporaryDirectory(dir=folder.absolute(), prefix=f"{TEMP_PREFIX}{os.getpid()}-build-") as tmp:
        sources = []
        for name, f in oracle_functions(nlp).items():
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
        _install(folder, path, built)


def folder_refusal(create: bool = False) -> str | None:
    """Why :func:`cache_dir` may not be used, or None where it may, or is not there (with
    ``create``, it is created first, mode :data:`FOLDER_MODE`). It must be a folder of this
    user's that group and others may not write: a library there is loaded into this user's
    processes, and anyone who may rename its files could swap one between its check and its
    loading."""
    folder = cache_dir()
    try:
        if create:
            folder.parent.mkdir(parents=True, exist_ok=True)
            with contextlib.suppress(FileExistsError):
                os.mkdir(folder, FOLDER_MODE)
        st = os.stat(folder)
    except FileNotFoundError:
        return "it cannot be created (a link to nothing?)" if create else None
    except OSError as exc:
        return f"it cannot be {'created' if create else 'read'} ({exc.strerror or exc})"
    if not stat.S_ISDIR(st.st_mode):
        return "it is not a folder"
    return _not_private(st, "it")


def _private_folder(create: bool) -> Path | None:
    """:func:`cache_dir` where it may be used (:func:`folder_refusal`; created if ``create``),
    else None: where it may not, one line on stderr says why."""
    why = folder_refusal(create)
    if why is not None:
        _warn(f"compile cache {str(cache_dir())!r} not used: {why}; {EXPANDED} ({MAKE_PRIVATE})")
        return None
    folder = cache_dir()
    return folder if folder.is_dir() else None


def _not_private(st: os.stat_result, what: str) -> str | None:
    """Why the file or folder of status ``st`` (called ``what``) is not this user's alone to
    change, or None."""
    if st.st_uid != os.geteuid():
        return f"{what} belongs to user id {st.st_uid}, not to you ({os.geteuid()})"
    if st.st_mode & LOOSE_BITS:
        return f"group or others may write {what} (mode {stat.S_IMODE(st.st_mode):o})"
    return None


class _Refused(Exception):
    """Why a file of the cache is not read: one clause."""


@contextlib.contextmanager
def _own_file(path: Path, what: str):
    """The open descriptor and status of ``path`` (called ``what``), a regular file of this
    user's that group and others may not write; :class:`_Refused` for anything else (missing,
    a link, a folder, a FIFO, another user's). Opened without following a link or waiting on
    a FIFO, and checked as opened: what is read is what was checked."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        if exc.errno == errno.ENOENT:
            raise _Refused(f"{what} is missing") from None
        if exc.errno == errno.ELOOP:
            raise _Refused(f"{what} is a link, not a file cadcam wrote") from None
        raise _Refused(f"{what} cannot be read ({exc.strerror or exc})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise _Refused(f"{what} is {'a folder' if stat.S_ISDIR(st.st_mode) else 'not a regular file'}")
        why = _not_private(st, what)
        if why is not None:
            raise _Refused(why)
        yield fd, st
    finally:
        os.close(fd)


def library_refusal(path: Path) -> str | None:
    """Why the library ``path`` may not be loaded, or None where it may: a regular file of this
    user's that group and others may not write, whose size and SHA-256 are those its record
    (:data:`RECORD_NAME`, as private) gives."""
    try:
        with _own_file(path, "it") as (fd, st):
            record = _read_record(record_path(path))
            if st.st_size != record["bytes"] or _sha256(fd) != record["sha256"]:
                raise _Refused("its content is not what cadcam compiled (damaged or replaced)")
    except _Refused as why:
        return str(why)
    return None


def _loadable(path: Path, then: str) -> bool:
    """Whether the library ``path`` may be loaded (:func:`library_refusal`); where something
    that may not stands under its name, one line on stderr says why and what is done
    ``then``."""
    if not os.path.lexists(path):
        return False
    why = library_refusal(path)
    if why is not None:
        _warn(f"compiled library {str(path)!r} not loaded: {why}; {then}")
    return why is None


def _replaceable(path: Path) -> bool:
    """Whether a library compiled now may take the name ``path``: anything but a folder (a
    link is replaced, not what it points to; a folder is the user's to remove)."""
    return path.is_symlink() or not path.is_dir()


def record_path(path: Path) -> Path:
    """The record (:data:`RECORD_NAME`) of the library ``path``."""
    head, tail = LIBRARY_NAME.split("{}")
    return path.with_name(RECORD_NAME.format(path.name[len(head):len(path.name) - len(tail)]))


def _read_record(path: Path) -> dict:
    """The record ``path``: ``{"bytes": int, "sha256": str}`` and more; :class:`_Refused`
    where there is none, it is not this user's alone (:func:`_own_file`) or it is no record."""
    with _own_file(path, "its record") as (fd, st):
        text = os.read(fd, RECORD_MAX_BYTES + 1)
    try:
        record = json.loads(text) if len(text) <= RECORD_MAX_BYTES else None
    except (ValueError, RecursionError):
        record = None
    if (not isinstance(record, dict) or not isinstance(record.get("bytes"), int)
            or not isinstance(record.get("sha256"), str) or not _SHA256.fullmatch(record["sha256"])):
        raise _Refused("its record is damaged")
    return record


def _sha256(fd: int) -> str:
    """Hex SHA-256 of what the open file ``fd`` holds."""
    digest, offset = hashlib.sha256(), 0
    while chunk := os.pread(fd, 1 << 20, offset):
        digest.update(chunk)
        offset += len(chunk)
    return digest.hexdigest()


def _install(folder: Path, path: Path, built: Path) -> None:
    """Put the library ``built`` into the cache ``folder`` as ``path``, its record
    (:data:`RECORD_NAME`) first, so that a reader finds a library only with its record; unless
    a library there may be loaded already (another process compiled it meanwhile: that one
    stays, as other processes may have loaded it)."""
    os.chmod(built, LIBRARY_MODE)
    with open(built, "rb") as fh:
        record = {"library": path.name, "bytes": os.fstat(fh.fileno()).st_size,
                  "sha256": _sha256(fh.fileno()), "cadcam_version": __version__}
    with _locked(folder):
        if os.path.lexists(path) and library_refusal(path) is None:
            return
        with atomic_path(record_path(path)) as tmp:
            tmp.write_text(json.dumps(record) + "\n")
            tmp.chmod(RECORD_MODE)
        os.replace(built, path)


@contextlib.contextmanager
def _locked(folder: Path):
    """Hold the cache ``folder`` for this block alone among the processes and threads that
    write into it (a lock on the folder itself): installs, background compiles' claims and
    clearing, one at a time."""
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def compile_in_background(nlp: dict, source=None, key: str | None = None) -> bool:
    """Start compiling ``nlp``'s library (:func:`library`, from ``source()`` if given; ``key``
    its :func:`key_of`, if the caller has it) into the cache in a detached process of low
    priority (:data:`BACKGROUND_NICENESS`), unless one is under way, it failed before, there is
    no C compiler, the cache may not be used, a folder stands under the library's name or
    :data:`BACKGROUND_ENV` is ``0``. Returns whether a compile is under way.

    The compile's folder in the cache (:data:`PENDING_NAME`) names its process and holds the
    NLP as its serialized graph; the process removes it when it is done. One whose process
    was killed is removed, and the compile started again, by the next call (:func:`_over`).
    """
    if os.environ.get(BACKGROUND_ENV, "1") == "0":
        return False
    key = key or key_of(nlp)
    if key is None:
        return False
    folder = _private_folder(create=True)
    if (folder is None or (folder / FAILED_NAME.format(key)).exists()
            or not _replaceable(folder / LIBRARY_NAME.format(key))):
        return False
    pending = _claimed(folder, key)
    if pending is None:
        return True
    try:
        _nlp_function(source() if source is not None else nlp).save(str(pending / NLP_FILE))
        # -P: python -m would put the working folder first on sys.path (cadcam.library_files)
        process = subprocess.Popen([sys.executable, "-P", "-m", __name__, key, str(pending)], start_new_session=True,
                                   stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                   stderr=subprocess.DEVNULL)
    except BaseException as exc:
        _remove(pending)
        if isinstance(exc, OSError):  # no process could be started: expanded, as without a compiler
            return False
        raise
    _write_owner(pending, process.pid)
    return True


def _claimed(folder: Path, key: str) -> Path | None:
    """The folder of a background compile of ``key`` in the cache ``folder``
    (:data:`PENDING_NAME`), made now and naming this process; None where a compile of ``key``
    is under way. The folder of one that is over without having removed it (:func:`_over`) is
    removed first."""
    pending = folder / PENDING_NAME.format(key)
    with _locked(folder):
        if _over(pending):
            _remove(pending)
        try:
            os.mkdir(pending, FOLDER_MODE)
        except FileExistsError:
            return None
        _write_owner(pending, os.getpid())
    return pending


def _over(pending: Path) -> bool:
    """Whether the background compile whose folder is ``pending`` is over, though the folder
    is there (its process was killed): its process is gone on this host, or it has been
    pending for :data:`PENDING_STALE_S`; also where something else stands under its name."""
    try:
        st = os.lstat(pending)
    except FileNotFoundError:
        return False
    if not stat.S_ISDIR(st.st_mode) or time.time() - st.st_mtime > PENDING_STALE_S:
        return True
    owner = _owner(pending)
    return owner is not None and owner[1] == socket.gethostname() and _ended(owner[0])


def _ended(pid: int) -> bool:
    """Whether process ``pid`` (of this host) has ended. One this process started and that
    ended is reaped here: until then it answers as a running one would (a design page's server
    outlives the compiles it starts)."""
    with contextlib.suppress(ChildProcessError):  # not a child of this process
        if os.waitpid(pid, os.WNOHANG)[0] == pid:
            return True
    return not process_alive(pid)


def _owner(pending: Path) -> tuple[int, str] | None:
    """(process id, host) of the background compile whose folder is ``pending``
    (:data:`OWNER_FILE`), or None where that cannot be read (the folder just made)."""
    try:
        with _own_file(pending / OWNER_FILE, "it") as (fd, _):
            pid, host = os.read(fd, 512).decode().split()
        return int(pid), host
    except (_Refused, ValueError):
        return None


def _write_owner(pending: Path, pid: int) -> None:
    """Name process ``pid`` of this host as the background compile of ``pending``."""
    with atomic_path(pending / OWNER_FILE) as tmp:
        tmp.write_text(f"{pid} {socket.gethostname()}\n")


def _remove(path: Path) -> None:
    """Remove ``path``, a folder with what it holds, or a file or link (not what it points
    to); nothing if it is gone."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def _nlp_function(nlp: dict) -> ca.Function:
    """``nlp`` as one function (x, p) → (f, g)."""
    return ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]])


def compile_pending(key: str, pending: Path) -> None:
    """Compile the serialized NLP in the folder ``pending`` (:data:`NLP_FILE`) into the cache
    as the library of ``key`` (the detached process :func:`compile_in_background` starts),
    then remove ``pending``; a failure is written beside the libraries
    (:data:`FAILED_NAME`)."""
    try:
        f = ca.Function.load(str(pending / NLP_FILE))
        x, p = f.mx_in()
        obj, g = f.call([x, p], True, False)
        library({"x": x, "p": p, "f": obj, "g": g}, key=key, claimed=True)
    except (CompileError, RuntimeError, OSError, MemoryError) as e:
        (pending.parent / FAILED_NAME.format(key)).write_text(str(e)[:2000])
    finally:
        _remove(pending)


def _compile(cc: str, source: Path) -> Path:
    """Compile one C file into an object file beside it (:data:`CFLAGS`; a function of
    :data:`AFTER_SOLVE`'s, :data:`AFTER_SOLVE_CFLAGS`)."""
    obj = source.with_suffix(".o")
    _run([cc, *(AFTER_SOLVE_CFLAGS if source.stem in AFTER_SOLVE else CFLAGS), "-c", str(source), "-o", str(obj)])
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
    """Run ``command`` (a compiler driver, its paths absolute) in a session of its own and in an
    empty private folder, its output captured (as text, any bytes that are not UTF-8
    replaced). The folder: GNU ld opens a linker script's relative names (``libgcc_s.so.1``) in
    its working folder, and links in a library planted there (:mod:`cadcam.library_files`).
    Should anything stop the wait (Ctrl-C, SIGTERM), the whole session is killed and waited
    for: the driver's own children (cc1, as, ld) are not left running as orphans.
    CompileError if the driver cannot be run."""
    with tempfile.TemporaryDirectory(prefix="cadcam-cc-") as empty:
        try:
            proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                    errors="replace", start_new_session=True, cwd=empty)
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


def cache_entries() -> list[tuple[Path, str | None]]:
    """Each file named like a library (:data:`LIBRARY_NAME`) in the cache, with why it may not
    be loaded (:func:`library_refusal`; None where it may); none where the cache is not there
    or may not be used (:func:`folder_refusal`)."""
    folder = cache_dir()
    if folder_refusal() is not None or not folder.is_dir():
        return []
    return [(path, library_refusal(path)) for path in sorted(folder.glob(LIBRARY_NAME.format("*")))]


def cached_libraries() -> list[Path]:
    """The libraries in the cache that may be loaded (:func:`cache_entries`)."""
    return [path for path, why in cache_entries() if why is None]


def clear_cache() -> tuple[int, int, list[tuple[str, str]]]:
    """Remove from the cache what cadcam wrote there: the libraries that their records say it
    compiled, with their records, the notes of failed background compiles and what compiles
    that were killed left behind. Returns how many libraries and their bytes, and the files
    named like libraries left in place (not cadcam's, or changed since), each with why. A
    process that has a library loaded keeps using it; a later build compiles it again.
    Compiles under way are left alone; nothing is removed where the cache may not be used."""
    folder, removed, left = cache_dir(), [], []
    if folder_refusal() is not None or not folder.is_dir():
        return 0, 0, left
    with _locked(folder):  # no install between a library's check and its removal
        for path, why in cache_entries():
            if why is None:
                removed.append(path.stat().st_size)
                path.unlink()
            else:
                left.append((path.name, why))
        for record in folder.glob(RECORD_NAME.format("*")):
            with contextlib.suppress(_Refused):
                _read_record(record)  # cadcam's, of a library removed now, gone or changed since
                record.unlink()
        for note in folder.glob(FAILED_NAME.format("*")):
            with contextlib.suppress(_Refused), _own_file(note, "it"):
                note.unlink()
        for pending in folder.glob(PENDING_NAME.format("*")):
            if _over(pending):
                _remove(pending)
        remove_leftovers(folder)
    return len(removed), sum(removed), left


#: The warnings this process has written (:func:`_warn`).
_WARNED: set[str] = set()


def _warn(message: str) -> None:
    """Write ``message`` as one line on stderr, once per process (a sweep's or a design
    page's builds of one structure say it once)."""
    if message not in _WARNED:
        _WARNED.add(message)
        print(f"cadcam: warning: {message}", file=sys.stderr, flush=True)


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
