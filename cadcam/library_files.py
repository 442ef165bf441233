"""Files that the libraries cadcam uses would read on their own, and what cadcam does about each,
so that nothing cadcam did not choose steers a design, its files or the code it runs.

Found by tracing every file a command opens (``strace -f``: ``cadcam design`` with figures,
workshop files and a STEP solid, ``cadcam sweep`` with its workers, ``cadcam app``, a compile
of the NLP) and planting a file of each name found. In the working folder:

- **IPOPT, ``ipopt.opt``**, read by every IPOPT solver CasADi builds, even one never solved:
  options past cadcam's allow-list, among them libraries to load (``hsllib``), a file to write
  (``output_file``), printing and looser problems (``bound_relax_factor``). *Switched off*:
  every solver's options pass through :func:`ipopt_options`, which ends with
  ``option_file_name = ""`` (IPOPT then opens no file; a missing or ``/dev/null`` name stops
  the read too, but IPOPT prints "Using option file" on standard output).
- **GNU ld, a linker script's names** (``libgcc_s.so.1``), opened in the working folder by the
  link of a compiled NLP or of ``cadcam export --format shared``: a library planted there is
  linked in when it defines a symbol the code calls, then loaded with it. *Switched off*: the
  compiler runs in an empty private folder (:func:`cadcam.solve.compiled.run_compiler`).
- **Python, any module**: ``python -c`` and ``python -m`` put the working folder first on
  ``sys.path``. Sweep workers (``multiprocessing``'s spawn, and its resource tracker) are
  started with ``python -c``, the background compile with ``python -m``. *Switched off*:
  :data:`PYTHON_SAFE_PATH` in the workers' environment, ``-P`` for the compile.
  ``python -m cadcam`` itself does the same before cadcam runs (Python's rule); the
  ``cadcam`` command and ``python -P -m cadcam`` do not.
- **ezdxf, ``ezdxf.ini``**, read when ezdxf is imported (also by build123d): fixed metadata
  "for testing" in every DXF, font folders; one it cannot parse fails the import with a
  traceback. *Switched off*: cadcam imports ezdxf and build123d inside
  :func:`libraries_imported`, where opening that name in the working folder fails as an
  unreadable file would (ezdxf skips it).
- **OpenCascade, ``XSTEP.us`` and ``SHAPE.us``** (build123d's kernel, writing a STEP solid):
  the texts of its own messages, looked for in the working folder unless ``CSF_XSMessage`` and
  ``CSF_SHMessage`` name a folder. *Switched off*: :func:`libraries_imported` points them where
  no file can be (:data:`OCCT_MESSAGE_FOLDERS`), so the built-in texts are used.
- **matplotlib, ``matplotlibrc``**, parsed when matplotlib is imported, before
  ``$MATPLOTLIBRC`` and the user's own: sizes, colours, fonts, ``text.usetex`` (which runs
  LaTeX). It cannot be skipped without changing the process's working folder, which other
  threads share. *Made harmless*: every figure cadcam draws, and every file it saves, is made
  inside :func:`matplotlib_defaults` (matplotlib's own defaults, whatever an rc file says). A
  ``matplotlibrc`` matplotlib cannot decode still stops its import.
- **CasADi, plugins** (``libcasadi_<kind>_<name>.so``), searched in CasADi's folder, then the
  loader's paths, then the working folder: every plugin cadcam asks for
  (:data:`CASADI_PLUGINS`) ships in CasADi's folder, so the search never reaches the working
  folder (tests/reliability checks it).
- Panel only checks whether a folder ``cache`` exists (for ``pn.cache(to_disk=True)``, unused).

In the home folder, the user's own configuration is the user's choice and is left alone:
ezdxf's ``~/.config/ezdxf/ezdxf.ini`` and ``$EZDXF_CONFIG_FILE``, matplotlib's
``~/.config/matplotlib`` (its rc file has no effect on cadcam's figures, as above) and font
cache, ezdxf's font cache, fontconfig's ``~/.config/fontconfig`` (OpenCascade's fonts), Bokeh's
``~/.bokeh/bokeh.yaml`` (the page), and cadcam's own compile cache.
"""
from __future__ import annotations

import contextlib
import errno
import os
import sys
import threading

#: CasADi ``nlpsol`` options every IPOPT solver of cadcam's starts from: quiet (the verdict is
#: cadcam's to print; a spec may raise ``print_level``), with CasADi's timing table off.
IPOPT_QUIET = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes"}

#: CasADi ``nlpsol`` option every IPOPT solver of cadcam's ends with, after all others: no
#: options file (IPOPT reads ``ipopt.opt`` in the working folder by default).
IPOPT_NO_FILE = {"ipopt.option_file_name": ""}

#: CasADi plugins cadcam's commands load (as traced), by kind and name: IPOPT, the tangency's
#: Newton rootfinder and its linear solver, the outline closure's QP and CasADi's file system.
CASADI_PLUGINS = (("nlpsol", "ipopt"), ("rootfinder", "newton"), ("linsol", "qr"), ("conic", "highs"),
                  ("filesystem", "ghc"))

#: Environment of processes that cadcam starts with ``python -c`` (sweep workers): Python puts
#: no working folder first on ``sys.path`` (Python 3.11's ``PYTHONSAFEPATH``).
PYTHON_SAFE_PATH = {"PYTHONSAFEPATH": "1"}

#: Files of the working folder that a library opens while cadcam imports it inside
#: :func:`libraries_imported`, refused there: ezdxf's configuration.
WORKING_FOLDER_CONFIGS = frozenset({"ezdxf.ini"})

#: OpenCascade's environment variables naming the folder of its message files, each set (unless
#: the user set it) to a path under which no file can exist: the null device is no folder.
OCCT_MESSAGE_FOLDERS = ("CSF_XSMessage", "CSF_SHMessage")

_importing = threading.local()
_hook_lock = threading.Lock()
_hook_installed = False


def ipopt_options(options: dict | None = None) -> dict:
    """CasADi ``nlpsol`` options of an IPOPT solver: :data:`IPOPT_QUIET`, then ``options``,
    then :data:`IPOPT_NO_FILE` (so that nothing given turns the options file on again)."""
    return {**IPOPT_QUIET, **(options or {}), **IPOPT_NO_FILE}


@contextlib.contextmanager
def libraries_imported():
    """Import ezdxf or build123d inside this block: a configuration file of
    :data:`WORKING_FOLDER_CONFIGS` that the importing thread opens in the working folder fails
    as an unreadable file (ezdxf then goes on without it), and OpenCascade's message files are
    not looked for there (:data:`OCCT_MESSAGE_FOLDERS`). Other threads are not affected."""
    _install_hook()
    for name in OCCT_MESSAGE_FOLDERS:
        os.environ.setdefault(name, os.devnull)
    _importing.depth = getattr(_importing, "depth", 0) + 1
    try:
        yield
    finally:
        _importing.depth -= 1


def _install_hook() -> None:
    """Add :func:`_refuse_working_folder_configs` to the interpreter's audit hooks, once."""
    global _hook_installed
    with _hook_lock:
        if not _hook_installed:
            sys.addaudithook(_refuse_working_folder_configs)
            _hook_installed = True


def _refuse_working_folder_configs(event: str, args: tuple) -> None:
    """Audit hook: an ``open`` of a file named in :data:`WORKING_FOLDER_CONFIGS` by a relative
    path (the working folder), by a thread inside :func:`libraries_imported`, raises
    PermissionError. Audit hooks cannot be removed: outside that block it does nothing."""
    if event != "open" or not getattr(_importing, "depth", 0):
        return
    path = args[0]
    if isinstance(path, (str, bytes, os.PathLike)):
        name = os.path.normpath(os.fsdecode(path))
        if name in WORKING_FOLDER_CONFIGS:
            raise PermissionError(errno.EACCES, "cadcam reads no library configuration from the "
                                  "working folder", name)


@contextlib.contextmanager
def matplotlib_defaults():
    """Inside this block (or a function it decorates), matplotlib's rc parameters are its own
    defaults, whatever a ``matplotlibrc`` (the working folder's, the user's) or the caller set;
    they are restored after it. Figures are drawn and saved inside it."""
    import matplotlib.style

    with matplotlib.style.context("default"):
        yield
