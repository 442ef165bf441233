"""Does the design converge from anywhere? Every shipped spec designed by the NLP, at several
grids and profile orders, from the default start and from random starts (issue 30, item 4).

``python benchmarks/bench_convergence.py [--random 2] [--grids 21 46 91] [--budget 20]``.
Measured, not asserted. Each cell is :func:`cadcam.optimize.optimize` with ``multistart`` random starts after
the default one; the table gives, per cell, how each start ended (IPOPT's status) and what the
design returned ended as after the fine re-check (``success`` or a status that says why), its
objective against the default start's, its IPOPT iterations and its CPU time. A cell passes when
the design returned is verified (``success``) or its status names the failure, and when the
multistart answer is no worse than the default start's (within :func:`no_worse`'s tolerance).

Orders: each spec's own and twice it, at most its basis's cap (the row says where it held an
order back). Grids: the spec's grid is replaced by each of
``--grids``; specs with several joints solve on the tensor grid of all their joints, so they
run at the grids up to :data:`MAX_COUPLED_GRID` only (the larger cells are listed as not run).
A spec's variants that design by another method than the spec (``solver.method``: a
mechanism's own, such as the cable robot's ``envelope``, or the NLP where the spec designs by
one, as the generic torque's variant ``nlp``) are cells too, at the same grids and orders: a
method has no start to vary, so such a cell is one design, judged like the others by its fine
re-check. ``--specs`` runs only the rows of the specs (or variants) it names.

Budgets are CPU time, not wall time, so that the matrix judges the solver rather than how busy
the machine was: each start's IPOPT solve stops at ``--budget`` CPU seconds (times
:data:`BUDGET_FACTOR` for the specs listed there; IPOPT's ``max_cpu_time``, status
``max_time``), and each cell runs in a process of its own, on one thread, limited to twice that
budget per start (a kept design that fails its fine re-check between the check points is
solved again, :func:`cadcam.optimize.optimize`) plus :data:`BUILD_CPU_S` for its builds and
re-checks, and to :data:`MEMORY_BYTES` of memory; a cell beyond either is listed as such.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import resource
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

from cadcam.api import load_problem
from cadcam.optimize import optimize
from cadcam.spec import MAX_ORDER, read_spec_data

MODELS = Path(__file__).resolve().parents[1] / "models"
#: The largest grid a spec with several joints runs at (its tensor grid is grid^joints).
MAX_COUPLED_GRID = 46
#: Memory a cell may use [bytes].
MEMORY_BYTES = 4 * 2**30
#: Specs whose solve needs more than ``--budget`` from their default start, with the factor
#: their budget is multiplied by: the cable robot's two degree-30 pairs take about 45 s of CPU
#: from Fedorov's envelope pulleys (``make bench``'s bench_cable_robot.py).
BUDGET_FACTOR = {"fedorov2018_cable_robot": 4}
#: CPU time a cell may spend beyond its IPOPT budgets: the builds, the fine re-checks [s].
BUILD_CPU_S = 60
#: A cell's wall time as a multiple of its CPU limit before it is stopped: only a guard against
#: a cell that waits on something, as the CPU limit stops every cell that computes.
WALL_GUARD = 4
#: One thread for BLAS and OpenMP, so that a cell's CPU time is the work it did.
ONE_THREAD = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
#: Relative and absolute tolerances of "no worse". Without the absolute floor an objective that
#: is zero within IPOPT's tolerance, where two starts' answers differ in their last digits only
#: (a few 1e-17 at about -1e-11), would count as a worse answer.
NO_WORSE_RELATIVE = 1e-9
NO_WORSE_FLOOR = 1e-15


def no_worse(objective: float, default: float) -> bool:
    """Whether the multistart answer's ``objective`` is no worse than the default start's
    ``default``, within ``NO_WORSE_RELATIVE`` of it or ``NO_WORSE_FLOOR`` (in the objective's
    own units), whichever is larger."""
    return objective <= default + max(NO_WORSE_RELATIVE * abs(default), NO_WORSE_FLOOR)


def _with(data: dict, grid: int, factor: int) -> dict:
    """Spec ``data`` at ``grid`` angles with every profile's order times ``factor``, up to its
    basis's cap (:data:`cadcam.spec.MAX_ORDER`)."""
    out = copy.deepcopy(data)
    out.setdefault("solver", {})["grid"] = grid
    for key in ("cams", "mechanisms"):
        for item in out.get(key, []):
            if "order" in item:
                item["order"] = min(item["order"] * factor, MAX_ORDER[item.get("basis", "chebyshev")])
    return out


def _orders(data: dict, factor: int) -> str:
    """The matrix's "order ×" cell: ``factor``, and the orders its basis's cap held back."""
    capped = sorted({f"{item['order'] * factor} → {MAX_ORDER[basis]}, the {basis} cap"
                     for key in ("cams", "mechanisms") for item in data.get(key, [])
                     if "order" in item and item["order"] * factor > MAX_ORDER[basis := item.get("basis", "chebyshev")]})
    return f"{factor} (order {'; '.join(capped)})" if capped else str(factor)


def cases(spec: Path):
    """(name, data) of ``spec`` as it stands and of each of its variants that designs by
    another method than the spec."""
    data = read_spec_data(spec)
    yield spec.stem, data
    for name, variant in tomllib.loads(spec.read_text(encoding="utf-8")).get("variants", {}).items():
        if variant.get("solver.method", _method(data)) != _method(data):
            yield f"{spec.stem} --variant {name}", read_spec_data(spec, name)


def _method(data: dict) -> str:
    return data.get("solver", {}).get("method", "nlp")


def cell(data: dict, random: int, budget: float) -> dict:
    """One design of spec ``data`` from the default start and ``random`` random starts, each
    start's IPOPT solve within ``budget`` CPU seconds; by its own method, one design."""
    data = copy.deepcopy(data)
    nlp = _method(data) == "nlp"
    if nlp:
        data["solver"]["multistart"] = random
        data["solver"].setdefault("ipopt", {})["max_cpu_time"] = budget
    t0 = time.process_time()
    result = optimize(load_problem(data))
    cpu = time.process_time() - t0
    trials = result.solve.trials if nlp else []
    default = trials[0]["objective"] if trials and trials[0]["status"] == "converged" else None
    return {"status": result.status, "objective": result.fun, "default": default, "cpu_s": cpu,
            "starts": [t["status"] for t in trials] or [f"method {_method(data)}"],
            "iterations": sum(t["iterations"] for t in trials), "method": not nlp}


def _cell_cpu_s(random: int, budget: float) -> int:
    """The CPU seconds a cell of ``random`` random starts at ``budget`` per start may use: each
    start's solve and as much again for the kept design's solves with more check points."""
    return int(2 * (random + 1) * budget + BUILD_CPU_S)


def _limits(cpu_s: int):
    """The cell process's limits: :data:`MEMORY_BYTES` of memory and ``cpu_s`` of CPU time."""
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_BYTES, MEMORY_BYTES))
        resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s + 5))
    return apply


def cell_in_a_process(data: dict, random: int, budget: float) -> dict | str:
    """:func:`cell` in a process of its own, on one thread, within :func:`_cell_cpu_s` of CPU
    time and :data:`MEMORY_BYTES`; the reason it did not finish otherwise."""
    cpu_s = _cell_cpu_s(random, budget)
    try:
        run = subprocess.run([sys.executable, __file__, "--cell", str(random), "--budget", str(budget)],
                             input=json.dumps(data), capture_output=True, text=True, timeout=WALL_GUARD * cpu_s,
                             preexec_fn=_limits(cpu_s), env={**os.environ, **ONE_THREAD})
    except subprocess.TimeoutExpired:
        return f"stopped after {WALL_GUARD * cpu_s} s of wall time"
    if run.returncode in (-signal.SIGXCPU, -signal.SIGKILL):
        return f"over {cpu_s} s of CPU time"
    if run.returncode != 0:
        last = (run.stderr.strip().splitlines() or ["no message"])[-1]
        return f"failed: {last[:120]}" if "MemoryError" not in run.stderr and "bad_alloc" not in run.stderr \
            else f"over {MEMORY_BYTES / 2**30:g} GiB of memory"
    return json.loads(run.stdout)


def matrix_row(name: str, data: dict, grid: int, factor: int, args, counts: dict) -> str:
    """The matrix's row of spec ``data`` (named ``name``) at ``grid`` and ``factor`` times its
    orders, its cell run (unless over a cap) and counted in ``counts``."""
    joints = len(data.get("joints", data.get("cams", [])))
    why = f"{joints} joints: grid > {MAX_COUPLED_GRID}" if joints > 1 and grid > MAX_COUPLED_GRID else None
    if factor > 1 and _with(data, grid, factor) == _with(data, grid, 1):
        why = "its orders are at their basis's cap already"
    orders = _orders(data, factor)
    if why:
        c = f"not run: {why}"
    else:
        budget = args.budget * BUDGET_FACTOR.get(name.split()[0], 1)
        c = cell_in_a_process(_with(data, grid, factor), args.random, budget)
    if isinstance(c, str):
        counts["not run"] += 1
        return f"| {name} | {grid} | {orders} | {c} | | | | | | |"
    counts["cells"] += 1
    counts["verified"] += c["status"] == "success"
    if c["method"]:  # one design: no start to be worse than
        default, verdict = "–", "–"
    elif c["default"] is None:  # nothing to be worse than
        default, verdict = "did not converge", "–"
    else:
        better = no_worse(c["objective"], c["default"])
        counts["compared"] += 1
        counts["no worse"] += better
        default, verdict = f"{c['default']:.6g}", "yes" if better else "**no**"
    return (f"| {name} | {grid} | {orders} | {', '.join(c['starts'])} | {c['status']} | {c['objective']:.6g} | "
            f"{default} | {verdict} | {c['iterations']} | {c['cpu_s']:.1f} |")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=2, help="random starts after the default one")
    parser.add_argument("--grids", type=int, nargs="+", default=[21, 46, 91])
    parser.add_argument("--budget", type=float, default=20.0, help="CPU time of one start's IPOPT solve [s]")
    parser.add_argument("--specs", nargs="+", metavar="NAME",
                        help="only these rows' specs, named as the table names them ('ludovico2021_pendulum', "
                             "'ludovico2021_generic --variant nlp')")
    parser.add_argument("--cell", type=int, help=argparse.SUPPRESS)  # one cell: spec data on stdin
    args = parser.parse_args(argv)
    if args.cell is not None:
        print(json.dumps(cell(json.loads(sys.stdin.read()), args.cell, args.budget)))
        return
    t0 = time.perf_counter()
    print(f"\nConvergence matrix: each cell from the default start and {args.random} random starts "
          f"(functions as each spec states them), each start's IPOPT solve within {args.budget:g} s of CPU time; a cell "
          f"within {_cell_cpu_s(args.random, args.budget)} s of CPU time on one thread (budgets × "
          f"{BUDGET_FACTOR} for those specs)\n")
    print("| spec | grid | order × | starts (default first) | returned | objective | default start's | "
          "no worse | iterations | CPU time [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    counts = {"cells": 0, "verified": 0, "compared": 0, "no worse": 0, "not run": 0}
    for spec in sorted(MODELS.glob("*.toml")):
        for name, data in cases(spec):
            if args.specs and name not in args.specs:
                continue
            for grid in args.grids:
                for factor in (1, 2):
                    print(matrix_row(name, data, grid, factor, args, counts), flush=True)
    print(f"\n{counts['cells']} cells run ({counts['not run']} not run or not finished): {counts['verified']} verified "
          f"(success), the others ended with the status that says why; the multistart answer no worse "
          f"than the default start's in {counts['no worse']} of the {counts['compared']} where the default "
          "start converged")
    print(f"\nbench_convergence.py: {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
