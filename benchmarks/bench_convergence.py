"""Does the design converge from anywhere? Every shipped spec designed by the NLP, at several
grids and profile orders, from the default start and from random starts (issue 30, item 4).

``python benchmarks/bench_convergence.py [--random 2] [--grids 21 46 91] [--budget 60]``.
Measured, not asserted. Each cell is :func:`cadcam.optimize.optimize` with ``multistart`` random starts after
the default one; the table gives, per cell, how each start ended (IPOPT's status) and what the
design returned ended as after the fine re-check (``success`` or a status that says why), its
objective against the default start's, and the time. A cell passes when the design returned
is verified (``success``) or its status names the failure, and when the multistart answer is
no worse than the default start's.

Orders: each spec's own and twice it. Grids: the spec's grid is replaced by each of
``--grids``; specs with several joints solve on the tensor grid of all their joints, so they
run at the grids up to :data:`MAX_COUPLED_GRID` only (the larger cells are listed as not run).
Specs designed by a method of their own (``method = "envelope"``) have no NLP and are listed
as not run. Each cell runs in a process of its own with ``--budget`` seconds of wall time and
:data:`MEMORY_BYTES` of memory; a cell beyond either is listed as such (Fedorov2018's balancer
at twice its degree, 30, builds dense convexity rows: issue 30 measured 114 s to build).
"""
from __future__ import annotations

import argparse
import copy
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

from cadcam.api import load_problem
from cadcam.optimize import optimize
from cadcam.spec import MAX_ORDER, read_spec_data

MODELS = Path(__file__).resolve().parents[1] / "models"
#: The largest grid a spec with several joints runs at (its tensor grid is grid^joints).
MAX_COUPLED_GRID = 46
#: Memory a cell may use [bytes].
MEMORY_BYTES = 4 * 2**30


def _with(data: dict, grid: int, factor: int) -> dict:
    """Spec ``data`` at ``grid`` angles with every profile's order times ``factor``."""
    out = copy.deepcopy(data)
    out.setdefault("solver", {})["grid"] = grid
    for key in ("cams", "mechanisms"):
        for item in out.get(key, []):
            if "order" in item:
                item["order"] = item["order"] * factor
    return out


def _over_cap(data: dict, factor: int) -> str | None:
    """Why spec ``data`` at ``factor`` times its orders cannot be a spec: a profile's order over
    its basis's cap (:data:`cadcam.spec.MAX_ORDER`), else None."""
    for key in ("cams", "mechanisms"):
        for item in data.get(key, []):
            basis = item.get("basis", "chebyshev")
            if "order" in item and item["order"] * factor > MAX_ORDER[basis]:
                return f"order {item['order'] * factor} > the {basis} cap {MAX_ORDER[basis]}"
    return None


def cell(data: dict, random: int) -> dict:
    """One design of spec ``data`` from the default start and ``random`` random starts."""
    data = copy.deepcopy(data)
    data["solver"]["multistart"] = random
    t0 = time.perf_counter()
    result = optimize(load_problem(data))
    seconds = time.perf_counter() - t0
    trials = result.solve.trials or []
    default = trials[0]["objective"] if trials and trials[0]["status"] == "converged" else None
    return {"status": result.status, "objective": result.fun, "default": default, "seconds": seconds,
            "starts": [t["status"] for t in trials]}


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_BYTES, MEMORY_BYTES))


def cell_in_a_process(data: dict, random: int, budget: float) -> dict | str:
    """:func:`cell` in a process of its own within ``budget`` seconds and :data:`MEMORY_BYTES`;
    the reason it did not finish otherwise."""
    try:
        run = subprocess.run([sys.executable, __file__, "--cell", str(random)], input=json.dumps(data),
                             capture_output=True, text=True, timeout=budget, preexec_fn=_limit_memory)
    except subprocess.TimeoutExpired:
        return f"not finished within {budget:g} s"
    if run.returncode != 0:
        last = (run.stderr.strip().splitlines() or ["no message"])[-1]
        return f"failed: {last[:120]}" if "MemoryError" not in run.stderr and "bad_alloc" not in run.stderr \
            else f"over {MEMORY_BYTES / 2**30:g} GiB of memory"
    return json.loads(run.stdout)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=2, help="random starts after the default one")
    parser.add_argument("--grids", type=int, nargs="+", default=[21, 46, 91])
    parser.add_argument("--budget", type=float, default=60.0, help="wall time of one cell [s]")
    parser.add_argument("--cell", type=int, help=argparse.SUPPRESS)  # one cell: spec data on stdin
    args = parser.parse_args(argv)
    if args.cell is not None:
        print(json.dumps(cell(json.loads(sys.stdin.read()), args.cell)))
        return
    t0 = time.perf_counter()
    print(f"\nConvergence matrix: each cell from the default start and {args.random} random starts "
          "(functions expanded)\n")
    print("| spec | grid | order × | starts (default first) | returned | objective | default start's | "
          "no worse | time [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    counts = {"cells": 0, "verified": 0, "compared": 0, "no worse": 0, "not run": 0}
    for spec in sorted(MODELS.glob("*.toml")):
        data = read_spec_data(spec)
        joints = len(data.get("joints", data.get("cams", [])))
        for grid in args.grids:
            for factor in (1, 2):
                why = ("its own method, no NLP" if data.get("solver", {}).get("method", "nlp") != "nlp" else
                       f"{joints} joints: grid > {MAX_COUPLED_GRID}" if joints > 1 and grid > MAX_COUPLED_GRID
                       else _over_cap(data, factor))
                if why:
                    counts["not run"] += 1
                    print(f"| {spec.stem} | {grid} | {factor} | not run: {why} | | | | | |")
                    continue
                c = cell_in_a_process(_with(data, grid, factor), args.random, args.budget)
                if isinstance(c, str):
                    counts["not run"] += 1
                    print(f"| {spec.stem} | {grid} | {factor} | {c} | | | | | |", flush=True)
                    continue
                counts["cells"] += 1
                counts["verified"] += c["status"] == "success"
                if c["default"] is None:  # nothing to be worse than
                    default, no_worse = "did not converge", "–"
                else:
                    better = c["objective"] <= c["default"] + 1e-9 * abs(c["default"])
                    counts["compared"] += 1
                    counts["no worse"] += better
                    default, no_worse = f"{c['default']:.6g}", "yes" if better else "**no**"
                print(f"| {spec.stem} | {grid} | {factor} | {', '.join(c['starts'])} | {c['status']} | "
                      f"{c['objective']:.6g} | {default} | {no_worse} | {c['seconds']:.1f} |", flush=True)
    print(f"\n{counts['cells']} cells run ({counts['not run']} not run or not finished): {counts['verified']} verified "
          f"(success), the others ended with the status that says why; the multistart answer no worse "
          f"than the default start's in {counts['no worse']} of the {counts['compared']} where the default "
          "start converged")
    print(f"\nbench_convergence.py: {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
