"""Command line: cadcam design, evaluate, check, export, sweep, springs, sweep-export and plot-study.

Exit codes: 0 success; 1 a solve that failed or did not pass its re-check (the result is still
written), a derivative check beyond its tolerance, or the environment failed after work began;
2 bad input (one line on stderr naming what is wrong); 130 interrupted.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

from .mechanisms.base import mechanism_class, mechanism_kinds, torque_models
from .solve.compiled import CompileError
from .designs import DesignError
from .interrupts import INTERRUPTED, STOP, interrupt_arrived, signals_stop_the_run
from .files import FolderBusy, NotCadcams, held_folder, printable, refuse_files_of_others
from .version import __version__
from .problem import SOLVER, WORKSHOP_LIMITS, cap, evaluation_size_error, size_error
from .spec import SpecError, parse_value
from .sweep.study import StudyError
from .sweep.runner import SweepError
from .targets import ExpressionError


class InputError(ValueError):
    """Bad command-line input."""


#: Ports ``cadcam app`` may serve on (TCP's; 0, "any free port", would leave the page's address
#: unknown to the browser tab it opens).
PORTS = (1, 65535)


def _say(*lines: str, err: bool = False) -> None:
    """Print ``lines`` on standard output (``err``: standard error), each on one line whatever
    the names, keys and paths in it hold (:func:`cadcam.files.printable`): every message of the
    command line goes out here."""
    print("\n".join(printable(line) for line in lines), file=sys.stderr if err else sys.stdout, flush=True)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line and exit code 2, like every other input
    error (argparse's own print a usage block)."""

    def error(self, message):
        raise InputError(f"{self.prog}: {message} (see {self.prog} --help)")


def _override(text: str):
    key, sep, value = text.partition("=")
    if not sep:
        raise InputError(f"--set {text!r}: expected KEY=VALUE such as springs.1.rate=1200.0")
    return key.strip(), parse_value(value.strip(), f"--set {key.strip()}")


def _ipopt(text: str) -> tuple:
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise InputError(f"--ipopt {text!r}: expected NAME=VALUE such as mu_strategy=monotone")
    return name.strip(), parse_value(value.strip(), f"--ipopt {name.strip()}")


def _spec_path(args) -> str:
    """The spec file: SPEC, or the installed example ``--example NAME``."""
    from . import examples

    if (args.spec is None) == (args.example is None):
        raise InputError("give a spec file or --example NAME (one of them), e.g. --example johnston2023_1dof")
    if args.example is None:
        return args.spec
    try:
        return str(examples.path(args.example))
    except examples.UnknownExample as exc:
        raise InputError(f"--example: {exc}") from None


def _problem(args, design_grid: bool = True):
    """The problem of the spec the command line names, with its overrides, checked against
    the caps. ``design_grid``: ``--grid`` sets the design grid (else the caller uses it on its
    own and checks it)."""
    from .api import load_problem

    ipopt = dict(_ipopt(t) for t in getattr(args, "ipopt", None) or ())
    problem = load_problem(_spec_path(args), variant=args.variant, overrides=[_override(t) for t in args.set or ()],
                           ipopt=ipopt or None)
    if getattr(args, "torque_model", None):
        try:
            problem = problem.with_torque_model(args.torque_model)
        except ValueError as exc:
            raise InputError(f"--torque-model: {exc}") from None
    given = {k: getattr(args, k) for k in ("grid", "multistart") if getattr(args, k, None) is not None}
    for name, value in given.items():
        if not SOLVER[name].ok(value):
            raise InputError(f"--{name} = {value}: expected {SOLVER[name].form()}")
    changes = {k: v for k, v in given.items() if design_grid or k != "grid"}
    problem = problem.with_options(**changes) if changes else problem
    too_big = size_error(problem.options, len(problem.joints))
    if too_big:
        flag = f"--{too_big[0]}" if too_big[0] in changes else f"solver.{too_big[0]}"
        raise InputError(f"{flag}: {too_big[1]}")
    return problem


def _design(args, problem):
    from .api import load_design

    return load_design(args.design, problem)


def _problem_and_design(args):
    """The problem, completed as a design run completes it (:func:`cadcam.optimize.completed`),
    and the design the command line names."""
    from .optimize import completed

    problem = completed(_problem(args))
    return problem, _design(args, problem)


def cmd_design(args) -> int:
    from .outputs.forked import Drawer

    _check_workshop_args(args)
    # forked first, the drawing processes import matplotlib while the spec is read and the
    # design made (ended at once if the input is refused)
    with Drawer((os.cpu_count() or 1) if args.figures else 1, FIGURE_WRITERS) as drawer:
        return _designed(args, drawer)


def _designed(args, drawer) -> int:
    """``cadcam design`` of the parsed ``args``, its figures and sheets drawn by ``drawer``."""
    from .api import refuse_unreachable
    from .verify.reachable import advice

    # each flag given overrides the spec's [workshop] (the NLP designs round the bore it gives);
    # result.json records the sizes used
    flags = {name: getattr(args, name) for name in WORKSHOP_FLAGS if getattr(args, name) is not None}
    problem = _problem(args)
    problem = replace(problem, workshop=replace(problem.workshop, **flags))
    _check_output_dir(args.output)
    refuse_unreachable(problem)  # bad input: one line, exit 2
    # before a solve that may take long (the summary repeats them)
    for warning in advice(problem):
        _say(f"cadcam: warning: {warning}", err=True)
    try:
        with held_folder(args.output) as out:
            _check_files_are_ours(out, problem, args.figures)
            return _design_into(args, problem, out, drawer)
    except _NotWritten as failed:  # out of the folder's hold: the folders this run made are gone if empty
        return _not_written(failed.result, failed.why)


def _check_files_are_ours(out: Path, problem, figures: bool) -> None:
    """Refuse, before any work, an output folder where the run would replace or remove
    something that is not a file cadcam recorded writing there (it replaces only its own files,
    unchanged)."""
    from .outputs.run_files import run_file_names

    refuse_files_of_others(out, run_file_names(problem, figures, problem.workshop), "result.json")


def _design_into(args, problem, out: Path, drawer) -> int:
    """Design ``problem``, print its summary and write its files into ``out`` (held), the
    figures and sheets drawn by ``drawer``."""
    from .optimize import optimize

    result = optimize(problem)
    return _saved(args, problem, result, out, drawer)


def _saved(args, problem, result, out: Path, drawer) -> int:
    """Write the files of ``result`` into ``out`` (drawn by ``drawer``), print its summary."""
    from .outputs.run_files import ADJUSTMENT_FILE, SHEET_FILES, WorkshopError

    try:
        notes = result.save(out, figures=args.figures, drawer=drawer)
    except WorkshopError as exc:
        named = [name for name in WORKSHOP_FLAGS if f"{name} = " in str(exc)]
        fix = "; ".join(f"set it with --{name.replace('_', '-')} or the spec's [workshop] {name}"
                        for name in named)
        raise _NotWritten(result, f"the workshop files cannot be made: {exc} (the design and its other "
                                  f"files are written to {out}{'; ' + fix if fix else ''})") from exc
    except OSError as exc:  # disk full, permissions: the verdict's first line says so
        raise _NotWritten(result, _os_error_words(exc)) from exc
    output = any(m.output_target is not None for m in problem.mechanisms)
    pngs = (f" profile.png{' torque.png springs.png' if problem.springs else ''} convergence.png"
            f"{' output.png' if output else ''}" if args.figures else "")
    sheets = "".join(f" cam*{kind}" for kind in SHEET_FILES) if args.figures else ""
    _say(*result.summary().split("\n"),
         f"  outputs in {out}/: result.json torque.csv torque_recheck.csv profile.csv"
         f"{' output.csv' if output else ''}{' ' + ADJUSTMENT_FILE if result.builds and result.builds.chosen else ''}"
         f"{pngs}",
         f"  workshop files: cam*.dxf cam*.svg cam*_points.csv{sheets} "
         f"or cam*_groove.csv{' cam*.stl' if problem.workshop.stl is not None else ''} ({'; '.join(notes)})")
    if _files_failed_verification(out):
        _say(f"cadcam: error: the written files miss what the design claims: see {out / 'verification.md'}",
             err=True)
        return 1
    return 0 if result.success else 1


def _files_failed_verification(out: Path) -> bool:
    """Whether the workshop files written in ``out`` failed their verification, read back from
    its ``verification.json`` (``passed`` false; a design without workshop files has none)."""
    path = out / "verification.json"
    return path.is_file() and json.loads(path.read_text(encoding="utf-8")).get("passed") is False


#: First words of ``cadcam design``'s output when its files could not all be written: its first
#: line says so, before the design's verdict (which says whether the design is good).
NOT_WRITTEN = "not written"


class _NotWritten(Exception):
    """A design (``result``) whose files could not all be written, and why (one line)."""

    def __init__(self, result, why: str):
        super().__init__(why)
        self.result, self.why = result, why


def _not_written(result, why: str) -> int:
    """Report a design whose files could not all be written (``why``): a first line saying
    so on standard output, the design's summary after it, ``why`` on standard error; exit 1."""
    _say(f"{NOT_WRITTEN}: {why}", *result.summary().split("\n"))
    _say(f"cadcam: error: {why}", err=True)
    return 1


#: The modules ``cadcam design``'s drawing processes draw the figures and sheets with,
#: imported while the design is made (:class:`cadcam.outputs.forked.Drawer`): matplotlib, with
#: the backends that draw the PNGs and the PDF, the font subsetting the PDF embeds (0.1 s of
#: the PDF's) and the styles that give every drawing matplotlib's defaults. ``--no-figures``
#: draws none and imports none of them.
FIGURE_WRITERS = ("cadcam.outputs.plots", "cadcam.make.drawing", "matplotlib.backends.backend_agg",
                  "matplotlib.backends.backend_pdf", "fontTools.subset", "matplotlib.style")


#: The ``cadcam design`` flags that size the workshop files (:class:`cadcam.problem.Workshop`).
WORKSHOP_FLAGS = ("bore_diameter", "anchor_diameter", "cable_diameter", "tolerance", "stl", "groove_depth", "groove_width",
                  "groove_pitch")


def cmd_check(args) -> int:
    from .api import check_derivatives

    problem = _problem(args)
    design = _design(args, problem) if args.design else None
    if not 1 <= args.points <= 20:
        raise InputError(f"--points {args.points}: give 1 … 20 poses")
    if not 0 < args.tol < 1:
        raise InputError(f"--tol {args.tol}: give a relative error between 0 and 1")
    report = check_derivatives(problem, design, points=args.points, tol=args.tol, nlp=not args.no_nlp)
    _say(*(json.dumps(report.to_dict(), indent=2) if args.json else repr(report)).split("\n"))
    return 0 if report.passed else 1


def _check_output_dir(text: str, flag: str = "-o") -> None:
    """Refuse, before any work, an output folder that is empty (an unset shell variable), a
    file, lies under a file or cannot be written."""
    if not text.strip():
        raise InputError(f"{flag} {text!r}: an empty path; give an output folder")
    path = Path(text)
    for parent in [path, *path.parents]:
        _refuse_dangling_link(parent, path, flag)
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{flag} {path}: {parent} is a file, not a folder; give a folder")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise InputError(f"{flag} {path}: {parent} is not writable; give a folder you can write to")
            return


def _check_output_file(text: str, flag: str) -> None:
    """Refuse, before any work, an output file that is empty, a folder or whose folder could
    not be made or written."""
    if not text.strip():
        raise InputError(f"{flag} {text!r}: an empty path; give a file name")
    path = Path(text)
    _refuse_dangling_link(path, path, flag)
    if path.is_dir():
        raise InputError(f"{flag} {path}: is a folder; give a file name")
    if path.exists() and not os.access(path, os.W_OK):
        raise InputError(f"{flag} {path}: is not writable; give a file you can write to")
    _check_output_dir(str(path.parent), flag)


def _refuse_dangling_link(link: Path, path: Path, flag: str) -> None:
    """InputError if ``link`` (``path`` or one of its folders) is a symbolic link that leads
    nowhere: to a missing path, or round a loop."""
    if link.is_symlink() and not link.exists():
        raise InputError(f"{flag} {path}: {link} is a symbolic link to nothing (a missing path or a loop); "
                         "remove it, create its target or give another path")


def _check_workshop_args(args) -> None:
    """Every workshop length a flag gives within :data:`cadcam.problem.WORKSHOP_LIMITS`, before
    any work."""
    for name, (lo, hi) in WORKSHOP_LIMITS.items():
        value = getattr(args, name)
        if value is not None and not lo <= value <= hi:
            raise InputError(f"--{name.replace('_', '-')} {value!r}: expected a length from {lo:g} to "
                             f"{hi:g} m")


def cmd_evaluate(args) -> int:
    """Metrics of a design as JSON on stdout. ``--grid`` is the evaluation's own grid, streamed
    exactly in bounded memory and nothing of its size written, so it is capped like the fine
    re-check (:func:`cadcam.problem.evaluation_size_error`), not like a design grid."""
    from .optimize import completed
    from .verify.evaluate import evaluate

    problem = _problem(args, design_grid=False)
    too_big = None if args.grid is None else evaluation_size_error(args.grid, len(problem.joints))
    if too_big:
        raise InputError(f"--grid: {too_big}")
    problem = completed(problem)
    design = _design(args, problem)
    ev = evaluate(problem, design, grid=args.grid)
    _say(*json.dumps({"torque_model": problem.torque_model, "design": design.to_dict(),
                       "metrics": ev.metrics.to_dict()}, indent=2).split("\n"))
    return 0


def cmd_export(args) -> int:
    from .export.codegen import ExportError, export

    problem, design = _problem_and_design(args)
    _check_output_dir(args.output)
    try:
        with held_folder(args.output) as out:  # one run at a time updates the folder's record of its files
            manifest = export(problem, design, args.what, args.format.split(","), out)
    except ExportError as exc:
        raise InputError(str(exc)) from None
    _say(f"exported {args.what} ({', '.join(f['name'] for f in manifest['functions'])}) to "
         f"{args.output}/: {' '.join(manifest['files'])} manifest.json")
    return 0


def cmd_sweep(args) -> int:
    from .sweep.study import load_study
    from .sweep.runner import run_sweep

    study = load_study(args.study)
    _check_output_file(args.output, "-o")
    if args.workers is not None and not 0 <= args.workers <= cap("workers"):
        raise InputError(f"--workers {args.workers}: expected 0 (serial) to {cap('workers')} worker processes")
    summary = run_sweep(study, args.output, workers=args.workers, dask=args.dask)
    elsewhere = (f", {summary['elsewhere']} still running in another sweep on this database"
                 if summary["elsewhere"] else "")
    _say(f"{study.name}: {summary['cases']} cases, {summary['ran']} run now, {summary['skipped']} "
         f"already recorded{elsewhere}; {summary['cases_per_min']:.1f} cases/min; statuses "
         f"{summary['statuses']}; results in {args.output}")
    failed = sum(n for k, n in summary["statuses"].items() if k != "success")
    return 0 if failed == 0 else 1


def cmd_springs(args) -> int:
    """``cadcam springs``: a spec's spring slot searched over a whole catalogue (module
    :mod:`cadcam.sweep.springs`); exit 0 when a feasible spring is found, 1 otherwise."""
    from .physics.catalogue import load_catalogue
    from .spec import parse_spec, read_spec_data
    from .sweep.runner import check_dask_address
    from .sweep.springs import search

    data = read_spec_data(args.spec)
    origin, base = str(args.spec), Path(args.spec).parent
    problem = parse_spec(data, origin, base)
    if not 1 <= args.slot <= len(problem.springs):
        raise InputError(f"--slot {args.slot}: the spec has {len(problem.springs)} spring(s); give 1 … "
                         f"{len(problem.springs)}")
    for flag, value, low, name in (("--workers", args.workers, 0, "workers"), ("--limit", args.limit, 1, "cases")):
        if value is not None and not low <= value <= cap(name):
            raise InputError(f"{flag} {value}: expected {low} to {cap(name)} (CADCAM_CAP_{name.upper()} "
                             "raises the cap)")
    if args.dask:
        check_dask_address(args.dask)
    given = args.catalogue or data["springs"][args.slot - 1].get("catalogue")
    path = None if given is None else str(Path(given) if args.catalogue or Path(given).is_absolute()
                                          else base / given)
    catalogue = load_catalogue(path)
    _check_output_dir(args.output)
    with held_folder(args.output) as out:
        _check_files_are_ours(out / "best", problem, args.figures)
        part_path = None if path is None else str(Path(path).resolve())
        found = search((data, origin, str(base)), args.slot - 1, catalogue, part_path,
                       os.cpu_count() or 1 if args.workers is None else args.workers,
                       args.limit or cap("cases"), _springs_progress(), args.dask, args.rank == "band")
        return _write_search(found, (data, origin, base), args, part_path, out)


def _springs_progress():
    """A report of each spring designed, one line on stderr: its count and part, verdict and
    rmse, the best so far and the time since the first."""
    from .sweep.springs import verdict

    t0 = time.perf_counter()

    def line(row: dict, found) -> None:
        word, reason = verdict(row)
        best = found.best()
        what = f"rmse {row['rmse']:.4g} N·m" if row.get("rmse") is not None else reason
        so_far = f"{best} (rmse {found.designed[best]['rmse']:.4g} N·m)" if best else "none"
        done = len(found.designed)
        elapsed = time.perf_counter() - t0
        eta = elapsed / done * (found.planned - done)
        _say(f"[{done}/{found.planned}] {row['part']}: {word}, {what} ({row['wall_time_s']:.1f} s); best so far: "
             f"{so_far}; {elapsed:.0f} s, ETA {eta:.0f} s", err=True)
    return line


#: The figure ``cadcam springs`` writes beside its table (:func:`cadcam.outputs.plots.catalogue_figure`).
CATALOGUE_FIGURE = "catalogue.png"


def _write_search(found, spec: tuple, args, part_path: str | None, out: Path) -> int:
    """Write ``springs.csv``, its figure (:data:`CATALOGUE_FIGURE`) and the best design's folder
    ``best/`` (its design solved again here from the search's answer with the spec's own solver
    options, then written as ``cadcam design`` writes it), the figures drawn side by side; print
    the summary; return the exit code."""
    from .outputs.forked import Drawer

    with Drawer((os.cpu_count() or 1) if args.figures else 1, FIGURE_WRITERS) as drawer:
        if args.figures:
            drawer.send([_catalogue_drawing(found, out / CATALOGUE_FIGURE, f"{Path(spec[1]).name}, spring {args.slot}")])
        code = _write_table_and_best(found, spec, args, part_path, out, drawer)
        drawer.wait()  # where no best design's folder waited for the figure (leaving ends the drawing)
        return code


def _catalogue_drawing(found, path: Path, title: str):
    """The drawing of the search ``found``'s :data:`CATALOGUE_FIGURE` into ``path`` (named by
    module: this process need not import matplotlib)."""
    from .outputs.forked import Call
    from .sweep.springs import VERDICT_COLOURS

    cat, best = found.catalogue, found.best()
    words = [word for word, _ in found.verdicts()]
    # the error of a design that converged: an undecided one's is only where its solve stopped
    rmse = [found.designed[part]["rmse"] if word in ("feasible", "near") else math.nan
            for part, word in zip(cat.parts, words)]
    return Call("cadcam.outputs.plots", "plot_catalogue",
                (cat.body.rate, cat.body.preload, words, rmse, None if best is None else cat.parts.index(best),
                 VERDICT_COLOURS, path, title))


def _write_table_and_best(found, spec: tuple, args, part_path: str | None, out: Path, drawer) -> int:
    """:func:`_write_search` with its figures drawn by ``drawer``."""
    from .files import write_csv
    from .outputs.run_files import WorkshopError
    from .spec import parse_spec
    from .sweep.springs import TABLE_COLUMNS, designed_again, part_spec

    data, origin, base = spec
    table = found.table(args.rank)
    write_csv(out / "springs.csv", list(TABLE_COLUMNS), table)
    words = [row[1] for row in table]
    best = found.best()
    summary = (f"{len(table)} springs: {int((~found.screened.passed).sum())} screened out, "
               f"{len(found.designed)} designed, {words.count('feasible')} feasible, {words.count('near')} near, "
               f"{words.count('undecided')} undecided; ")
    if best is None:
        print(summary + f"no feasible spring; the table in {out / 'springs.csv'}{_figure_words(args, out)}")
        return 1
    problem = parse_spec(part_spec(data, args.slot - 1, best, part_path), origin, base)
    result = designed_again(problem, found.designed[best])
    try:
        result.save(out / "best", figures=args.figures, drawer=drawer)
    except WorkshopError as exc:
        print(summary + f"the best: {best}; its workshop files cannot be made: {exc} (the table and the "
              f"design's other files are written to {out})", file=sys.stderr)
        return 1
    print(summary + f"the best: {best}, rmse {found.designed[best]['rmse']:.4g} N·m ({result.status} again "
          f"in {out / 'best'}); the table, ranked by {args.rank}, in {out / 'springs.csv'}{_figure_words(args, out)}")
    return 0


def _figure_words(args, out: Path) -> str:
    """Where the summary of ``cadcam springs`` says its figure is, if it drew one."""
    return f" (its figure: {out / CATALOGUE_FIGURE})" if args.figures else ""


def cmd_sweep_export(args) -> int:
    from .files import write_csv
    from .sweep.runner import flat_table, read_rows

    _check_output_file(args.csv, "--csv")
    study, rows = read_rows(args.database)
    table = flat_table(study, rows)
    header = list(dict.fromkeys(k for row in table for k in row))
    write_csv(args.csv, header, ([row.get(k) for k in header] for row in table))
    _say(f"{len(table)} cases of {study['name']} written to {args.csv}")
    return 0


def cmd_plot_study(args) -> int:
    from .outputs.plots import plot_study
    from .sweep.runner import flat_table, read_rows

    _check_output_file(args.output, "-o")
    study, rows = read_rows(args.database)
    table = flat_table(study, rows)
    for flag, name in (("--x", args.x), ("--y", args.y), ("--color", args.color)):
        if name is not None and not any(name in r for r in table):
            keys = sorted({k for r in table for k in r})
            raise InputError(f"{flag} {name!r}: no such column in {args.database}; columns: {', '.join(keys)}")
    plot_study(table, args.x, args.y, args.color, args.pareto, args.output, study["name"])
    _say(f"plot written to {args.output}")
    return 0


def cmd_cache(args) -> int:
    from .solve.compiled import MAKE_PRIVATE, cache_dir, cache_entries, clear_cache, folder_refusal

    def libraries(n: int) -> str:
        return f"{n} compiled NLP librar{'y' if n == 1 else 'ies'}"

    folder, refused = cache_dir(), folder_refusal()
    if refused is not None:
        if args.clear:
            raise InputError(f"{str(folder)!r}: not a cache cadcam uses or clears: {refused}; {MAKE_PRIVATE}")
        _say(f"{folder}: not used: {refused} (solver.functions = 'auto' and 'compiled' solve with expanded "
              f"functions; {MAKE_PRIVATE})")
        return 0
    if args.build is not None:
        return _compile_ahead(args.build)
    if args.clear:
        n, size, left = clear_cache()
        _say(f"removed {libraries(n)} ({size / 1e6:.1f} MB) from {folder}"
             + (f"; left in place, not cadcam's to remove: {_named(left)}" if left else ""))
        return 0
    entries = cache_entries()
    libs = [path for path, why in entries if why is None]
    others = [(path.name, why) for path, why in entries if why is not None]
    _say(f"{folder}: {libraries(len(libs))}, {sum(path.stat().st_size for path in libs) / 1e6:.1f} MB "
         "(solver.functions = 'auto' or 'compiled'; 'cadcam cache --clear' removes them, CADCAM_CACHE_DIR moves "
         "the folder)" + (f"; never loaded: {_named(others)}" if others else ""))
    return 0


def _compile_ahead(specs: list[str]) -> int:
    """``cadcam cache --build``: compile what the first design of each of ``specs`` (spec files
    or example names; default the design page's templates) loads
    (:func:`cadcam.api.compile_ahead`), one line each."""
    import time

    from . import examples
    from .api import compile_ahead

    for spec in specs or _template_specs():
        start = time.perf_counter()
        compiled_now = compile_ahead(spec if Path(spec).is_file() else examples.path(spec))
        if compiled_now is None:
            _say(f"{spec}: its design loads no compiled library")
        elif compiled_now:
            _say(f"{spec}: {compiled_now} librar{'y' if compiled_now == 1 else 'ies'} compiled "
                 f"({time.perf_counter() - start:.1f} s)")
        else:
            _say(f"{spec}: in the cache already")
    return 0


def _template_specs() -> list[str]:
    """The design page's templates (example names) whose first design compiles libraries: a
    template with a variant is left out, the base spec's libraries not being its own."""
    from .app.state import TEMPLATES

    return [t.spec for t in TEMPLATES if t.variant is None]


def compile_templates_in_background(specs: list[str]) -> subprocess.Popen | None:
    """Start ``cadcam cache --build`` of ``specs`` (example names) in a detached process, as
    ``cadcam app`` does at start-up for the page's templates, so that a template's first design
    loads its libraries instead of solving with expanded functions while they compile; not
    where :data:`cadcam.solve.compiled.BACKGROUND_ENV` is ``0`` or no process can be started."""
    import shutil

    from .solve.compiled import BACKGROUND_ENV, BACKGROUND_NICENESS

    if os.environ.get(BACKGROUND_ENV, "1") == "0":
        return None
    # at low priority where the system's nice is there: the page's own designs go first
    nice = ["nice", "-n", str(BACKGROUND_NICENESS)] if shutil.which("nice") else []
    try:
        # -P: python -m would put the working folder first on sys.path (cadcam.library_files)
        return subprocess.Popen([*nice, sys.executable, "-P", "-m", "cadcam", "cache", "--build", *specs],
                                start_new_session=True, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:  # the page works without it: its designs compile in the background themselves
        return None


#: How many files a listing names before it only counts the rest.
NAMED_FILES = 3


def _named(files: list[tuple[str, str]]) -> str:
    """``files`` (name, why) as one clause: the first :data:`NAMED_FILES` with their reasons."""
    shown = ", ".join(f"{name!r} ({why})" for name, why in files[:NAMED_FILES])
    return shown + (f" and {len(files) - NAMED_FILES} more" if len(files) > NAMED_FILES else "")


def cmd_app(args) -> int:
    if not PORTS[0] <= args.port <= PORTS[1]:
        raise InputError(f"--port {args.port}: expected a port from {PORTS[0]} to {PORTS[1]}")
    try:
        from .app import page
    except ImportError as exc:  # Panel is the app extra's
        raise InputError(f"cadcam app needs Panel ({exc.name} is not installed): pip install 'cadcam[app]'") from None
    spec = _spec_path(args) if args.spec or args.example else None
    if spec is not None:
        page.DesignState(Path(spec))  # a spec that cannot be read fails here, as one line
    compile_templates_in_background(_template_specs())
    page.serve(spec, port=args.port, address=args.address, show=args.show)
    return 0


def _add_spec_arguments(p) -> None:
    """The arguments of every command that reads a spec: which spec, and what overrides it."""
    from . import examples

    p.add_argument("spec", nargs="?", help="problem spec (TOML) or a cadcam result.json")
    p.add_argument("--example", metavar="NAME", help="use an example spec installed with cadcam instead "
                   "of SPEC: " + ", ".join(examples.names()))
    offered = "; ".join(f"{', '.join(mechanism_class(kind).force_models)} for {kind}"
                        for kind in mechanism_kinds() if mechanism_class(kind).force_models)
    p.add_argument("--torque-model", choices=torque_models(),
                   help=f"override the spec's torque model (energy: ∂V/∂θ, the default; the papers' "
                        f"force models: {offered})")
    p.add_argument("--grid", type=int, help=SOLVER["grid"].description)
    p.add_argument("--variant", help="apply the spec's [variants.NAME] overrides")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a spec value by dotted key, e.g. springs.1.rate=1200.0 "
                        "or 'cams.*.sensitivity_weights=[0, 0]' (repeatable)")
    p.add_argument("--ipopt", action="append", metavar="NAME=VALUE",
                   help="an IPOPT option, e.g. mu_strategy=monotone or print_level=5 (repeatable; "
                        "merged into the spec's [solver.ipopt])")


def _add_no_figures(p) -> None:
    """``--no-figures``, of every command that writes a design's folder."""
    p.add_argument("--no-figures", dest="figures", action="store_false",
                   help="write no PNG figures and no drawing sheets (what matplotlib draws: most of a "
                        "small design's time); the tables, outlines and result.json as usual")


def _add_design_command(sub) -> None:
    """``cadcam design``: its spec, output folder, starts, figures and workshop file sizes."""
    p = sub.add_parser("design", help="optimise a cam system and re-check it")
    _add_spec_arguments(p)
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.add_argument("--multistart", type=int, help=SOLVER["multistart"].description)
    _add_no_figures(p)
    w = p.add_argument_group("workshop files (lengths in metres; each flag overrides the spec's "
                             "[workshop] table, whose defaults are given)")
    w.add_argument("--bore-diameter", type=float, help="shaft bore (default 0.006)")
    w.add_argument("--anchor-diameter", type=float, help="cable anchor hole near φ = 0 (default 0.0025)")
    w.add_argument("--cable-diameter", type=float,
                   help="the cable's diameter: the designed profile is its centre line, the cut outline "
                        "lies its radius inside (default 0)")
    w.add_argument("--tolerance", type=float,
                   help="loosest fit of the DXF/SVG arcs and CSV/STL polygons (default 1e-5 = 0.01 mm); "
                        "tighter where the design's accuracy asks (verification.md)")
    w.add_argument("--stl", type=float, metavar="THICKNESS", help="also write cam*.stl of this thickness")
    w.add_argument("--groove-depth", type=float, help="cable groove depth in the STL (default 0)")
    w.add_argument("--groove-width", type=float, help="cable groove width in the STL (default 0)")
    w.add_argument("--groove-pitch", type=float,
                   help="rise per turn of a helical groove's centre line (default 0.004)")
    p.set_defaults(run=cmd_design)


def _add_design_file_commands(sub) -> None:
    """``cadcam evaluate``, ``check`` and ``export``: commands on a given (or the start) design."""
    p = sub.add_parser("evaluate", help="metrics of a given design, as JSON")
    _add_spec_arguments(p)
    p.add_argument("--design", required=True, help="design or result JSON")
    p.set_defaults(run=cmd_evaluate)
    p = sub.add_parser("check", help="automatic derivatives against finite differences, as a table")
    _add_spec_arguments(p)
    p.add_argument("--design", help="design or result JSON to check at (default: cadcam's start design)")
    p.add_argument("--points", type=int, default=3, help="random poses of the torque model (default 3)")
    p.add_argument("--tol", type=float, default=1e-6, help="largest relative error accepted (default 1e-6)")
    p.add_argument("--no-nlp", action="store_true", help="check only the torque model (do not build the NLP)")
    p.add_argument("--json", action="store_true", help="print the table as JSON")
    p.set_defaults(run=cmd_check)
    p = sub.add_parser("export", help="the model or the NLP as C, a shared library, .casadi")
    _add_spec_arguments(p)
    p.add_argument("--design", required=True, help="design or result JSON")
    p.add_argument("--what", choices=("model", "problem"), default="model",
                   help="model: torque, extensions, tangency and Jacobians; problem: the NLP")
    p.add_argument("--format", default="c,shared,casadi",
                   help="comma-separated: c, shared, casadi (default all three)")
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.set_defaults(run=cmd_export)


def _add_study_commands(sub) -> None:
    """``cadcam sweep``, ``sweep-export`` and ``plot-study``: parameter studies and their
    databases."""
    p = sub.add_parser("sweep", help="run a parameter study, recorded to SQLite (resumable)")
    p.add_argument("study", help="study file (TOML)")
    p.add_argument("-o", "--output", required=True, help="study database (SQLite)")
    p.add_argument("--workers", type=int, help="worker processes (default: the machine's cores; 0 runs serially in this process)")
    p.add_argument("--dask", metavar="ADDRESS", help="run on a Dask cluster: a scheduler address, "
                   "or 'local' for a LocalCluster on this machine")
    p.set_defaults(run=cmd_sweep)
    _add_springs_command(sub)
    p = sub.add_parser("sweep-export", help="a study database as a tidy CSV table")
    p.add_argument("database")
    p.add_argument("--csv", required=True, help="output CSV file")
    p.set_defaults(run=cmd_sweep_export)
    p = sub.add_parser("plot-study", help="plot a metric of a study against a parameter or metric")
    p.add_argument("database")
    p.add_argument("--x", required=True, help="parameter key or metric column (see sweep-export)")
    p.add_argument("--y", required=True, help="metric column, e.g. rmse_1")
    p.add_argument("--color", help="parameter key or metric column that colours the points")
    p.add_argument("--pareto", action="store_true", help="mark the front minimising both x and y")
    p.add_argument("-o", "--output", required=True, help="PNG file")
    p.set_defaults(run=cmd_plot_study)


def _add_springs_command(sub) -> None:
    """``cadcam springs``: a spec's spring slot searched over a whole catalogue."""
    from .sweep.springs import RANKS, VERDICTS

    p = sub.add_parser("springs", help="screen a whole spring catalogue for a spec's spring, design the "
                       "survivors, rank them (DIR/springs.csv) and write the best design (DIR/best/)",
                       epilog="Verdicts: " + "; ".join(f"{k}: {v}" for k, v in VERDICTS.items())
                       + ". Exit 0 when a feasible spring is found, 1 when none is.")
    p.add_argument("spec", help="problem spec (TOML)")
    p.add_argument("--catalogue", metavar="CSV", help="a spring catalogue (columns as "
                   "cadcam.physics.catalogue.COLUMNS; default: the slot's own catalogue, else the shipped "
                   "McMaster-Carr one)")
    p.add_argument("-o", "--output", required=True, help="output folder: springs.csv and best/")
    p.add_argument("--workers", type=int, help="worker processes (default: the machine's cores; 0 designs "
                   "in this process)")
    p.add_argument("--dask", metavar="ADDRESS", help="design on a Dask cluster: a scheduler address, or 'local' "
                   "for a LocalCluster of --workers processes on this machine")
    p.add_argument("--rank", choices=tuple(RANKS), default="error", help="the table's order within each "
                   "verdict (ties by rmse): " + "; ".join(f"{k}: {v}" for k, v in RANKS.items()))
    p.add_argument("--slot", type=int, default=1, help="the spring searched for, 1-based (default 1)")
    _add_no_figures(p)
    p.add_argument("--limit", type=int, help="design at most N springs that pass the screen, those "
                   "nearest the spec's own rate (|log k/k_spec|) first (default: all, up to the cases cap)")
    p.set_defaults(run=cmd_springs)


def _parser() -> _Parser:
    """The command line's parser: every command, each running its ``cmd_*`` function."""
    parser = _Parser(prog="cadcam", description="Design wire-wrapped cams and noncircular pulleys with "
                     "CasADi and IPOPT, re-check them, export them for a controller or a workshop.",
                     epilog="Exit codes: 0 success; 1 a failed solve, re-check or derivative check, or the "
                     "environment failed after work began; 2 bad input (one line on stderr); 130 interrupted. "
                     "Run 'cadcam COMMAND --help' for a command's options.")
    parser.add_argument("--version", action="version", version=f"cadcam {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_design_command(sub)
    _add_design_file_commands(sub)
    _add_study_commands(sub)
    p = sub.add_parser("app", help="a local design page in the browser: templates, a form, designs on each edit, "
                       "downloads (needs cadcam[app])")
    p.add_argument("spec", nargs="?", help="spec (TOML) or result.json to open (default: the first template)")
    p.add_argument("--example", metavar="NAME", help="open an example spec installed with cadcam")
    p.add_argument("--port", type=int, default=5006, help="port to serve on (default 5006)")
    p.add_argument("--address", default="127.0.0.1", help="address to serve on (default 127.0.0.1: this machine only)")
    p.add_argument("--no-browser", dest="show", action="store_false", help="do not open a browser tab")
    p.set_defaults(run=cmd_app)
    p = sub.add_parser("cache", help="the compiled NLP libraries cached on disk: where, how many, how large")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--clear", action="store_true",
                      help="remove those its records say cadcam compiled (each is compiled again when next needed)")
    what.add_argument("--build", nargs="*", metavar="SPEC",
                      help="compile ahead the libraries the first design of each SPEC (a spec file or an "
                           "example's name; default: the design page's templates) loads, so that it loads them "
                           "instead of solving with expanded functions while they compile (minutes; `cadcam app` "
                           "does it for its templates in the background as it starts)")
    p.set_defaults(run=cmd_cache)
    return parser


def main(argv=None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit code (module
    docstring): every input error as one line on stderr."""
    with signals_stop_the_run():  # handled inside: a signal during the messages is ignored
        return _run_command(argv)


def _run_command(argv) -> int:
    """:func:`main` with the signals already stopping the run."""
    try:
        args = _parser().parse_args(argv)
        return _run_interruptible(args)
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: temporary files are gone, no partial set is left
        STOP.finished = True  # first, and without a call: a later signal would raise in whatever runs next
        _say("cadcam: interrupted; no partial outputs were left", err=True)
        return INTERRUPTED
    except (SpecError, DesignError, ExpressionError, InputError, StudyError, SweepError,
            CompileError, FolderBusy, NotCadcams) as exc:
        _say(f"cadcam: error: {exc}", err=True)
        return 2
    except BrokenPipeError:  # the reader of our output went away (``| head``): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as exc:  # the environment failed after work began: disk full, permissions…
        _say(f"cadcam: error: {_os_error_words(exc)}", err=True)
        return 1


def _os_error_words(exc: OSError) -> str:
    """What failed as one line: the file, the system's reason, what is left and what to do."""
    where = f"{exc.filename}: " if exc.filename else ""
    fix = ("" if isinstance(exc, (IsADirectoryError, FileExistsError))
           else "; free space or fix the permissions and run again")
    return f"{where}{exc.strerror or exc} (nothing half-written is left{fix})"


def _run_interruptible(args) -> int:
    """Run the parsed command; an error raised after a signal arrived is the interrupt (CasADi
    turns a ``KeyboardInterrupt`` inside a function call into ``RuntimeError``)."""
    try:
        return args.run(args)
    except Exception as exc:
        if interrupt_arrived():
            raise KeyboardInterrupt from exc
        raise

