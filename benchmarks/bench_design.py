"""Build and solve times of the design NLPs (``make bench``): medians of several runs.

Measured, not asserted: run on the machine at hand and read the table. Targets (issue 2, on a
2-core machine): 1-DOF solve ≤ 0.1 s, build ≤ 0.5 s.
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from cadcam import load_spec
from cadcam.evaluate import evaluate
from cadcam.optimize import default_start
from cadcam.transcription import Transcription

ROOT = Path(__file__).resolve().parents[1]
CASES = [("johnston2023_1dof", ROOT / "models" / "johnston2023_1dof.toml")]


def bench(problem, runs: int) -> dict:
    builds, solves, iters, rechecks = [], [], [], []
    for _ in range(runs):
        t0 = time.perf_counter()
        tr = Transcription(problem)
        builds.append(time.perf_counter() - t0)
        sol = tr.solve(problem, default_start(problem))
        solves.append(sol.solve_time_s)
        iters.append(sol.iterations)
        t0 = time.perf_counter()
        evaluate(problem, sol.design, grid=problem.options.recheck_factor * (problem.options.grid - 1) + 1)
        rechecks.append(time.perf_counter() - t0)
    return {"build": statistics.median(builds), "solve": statistics.median(solves),
            "iterations": statistics.median(iters), "recheck": statistics.median(rechecks),
            "status": sol.status, "n_var": tr.v.size, "n_con": tr.bounds(problem)[0].size}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    args = ap.parse_args()
    print(f"cadcam design NLPs, median of {args.runs} runs (wall time, this machine)\n")
    print("| case | variables | constraints | build [s] | solve [s] | iterations | fine re-check [s] | status |")
    print("|---|---|---|---|---|---|---|---|")
    for name, path in CASES:
        problem = load_spec(path)
        r = bench(problem, args.runs)
        print(f"| {name} | {r['n_var']} | {r['n_con']} | {r['build']:.3f} | {r['solve']:.3f} | "
              f"{r['iterations']:.0f} | {r['recheck']:.3f} | {r['status']} |")


if __name__ == "__main__":
    main()
