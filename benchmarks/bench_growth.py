"""How the cost of a design grows: NLP build, IPOPT solve and fine re-check time against the
grid, the profile's degree and the number of joints, in one table with growth exponents.

``python benchmarks/bench_growth.py [--runs 2]``. Measured, not asserted (issue 30, item 5).
Each row is :func:`cadcam.optimize.optimize` from the default start, functions expanded (the
first build of a structure on the default path), medians of ``runs``:

* grid: the 1-DOF spec at 12, 23, 46 and 91 angles (its re-check grid grows with it);
* degree: the 1-DOF spec with its cam's polynomial order 4, 5, 6, 8 and 10 (46 angles);
* joints: 1 to 4 joints at 20 angles per joint and a re-check 5 × finer — the 1-DOF spec,
  Johnston2023's RR arm (Sec. 10.4), the three-cam arm and ``bench_arms.py``'s four-cam arm.

The growth exponent is the slope of log(time) against log(size) by least squares over a
scan's rows: 1 is linear. Over the joints the size is the number of grid points, n^m (the
tensor grid the coupled objective and the re-check visit), not m.
"""
from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from cadcam.api import load_problem
from cadcam.optimize import optimize

from bench_arms import four_cam_arm

MODELS = Path(__file__).resolve().parents[1] / "models"
SPEC_1DOF = MODELS / "johnston2023_1dof.toml"
GRIDS = (12, 23, 46, 91)
ORDERS = (4, 5, 6, 8, 10)
#: Angles per joint and re-check factor of the joints scan.
JOINT_GRID, JOINT_RECHECK = 20, 5
PARTS = ("build", "solve", "recheck")


def _joints_problems():
    """(joints, problem) for 1 to 4 joints at :data:`JOINT_GRID` angles per joint."""
    def sized(problem):
        return replace(problem, options=replace(problem.options, grid=JOINT_GRID, recheck_factor=JOINT_RECHECK,
                                                functions="expanded"))
    return [(1, sized(load_problem(SPEC_1DOF))),
            (2, sized(load_problem(MODELS / "johnston2023_rr_arm.toml"))),
            (3, sized(load_problem(MODELS / "johnston2023_three_cam_arm.toml"))),
            (4, sized(load_problem(four_cam_arm())))]


def measure(problem, runs: int) -> dict:
    """Medians over ``runs`` designs of ``problem``: build, solve, re-check [s], iterations;
    and the statuses met."""
    rows = []
    for _ in range(runs):
        result = optimize(problem)
        rows.append({"build": result.build_time_s, "solve": result.solve.solve_time_s,
                     "recheck": result.recheck_time_s, "iterations": result.solve.iterations,
                     "status": result.status})
    out = {k: statistics.median(r[k] for r in rows) for k in (*PARTS, "iterations")}
    out["status"] = "/".join(sorted({r["status"] for r in rows}))
    return out


def exponent(sizes, times) -> float:
    """Least-squares slope of log(time) against log(size)."""
    return float(np.polyfit(np.log(sizes), np.log(times), 1)[0])


def scans(runs: int):
    """(scan, label, size, measurement) rows of the three scans."""
    base = load_problem(SPEC_1DOF, functions="expanded")
    for n in GRIDS:
        yield "grid", f"1-DOF, {n} angles", n, measure(replace(base, options=replace(base.options, grid=n)), runs)
    for order in ORDERS:
        yield "degree", f"1-DOF, order {order}", order + 1, measure(
            load_problem(SPEC_1DOF, overrides={"cams.1.order": order}, functions="expanded"), runs)
    for joints, problem in _joints_problems():
        yield "joints", f"{joints} joint{'s' * (joints > 1)}, {JOINT_GRID} angles each", JOINT_GRID**joints, \
            measure(problem, runs)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=2)
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    print(f"\nHow cost grows (medians of {args.runs} runs; functions expanded)\n")
    print("| scan | problem | size | build [s] | solve [s] | iterations | re-check [s] | status |")
    print("|---|---|---|---|---|---|---|---|")
    by_scan: dict[str, list] = {}
    for scan, label, size, m in scans(args.runs):
        by_scan.setdefault(scan, []).append((size, m))
        print(f"| {scan} | {label} | {size} | {m['build']:.3f} | {m['solve']:.3f} | {m['iterations']:.0f} "
              f"| {m['recheck']:.3f} | {m['status']} |", flush=True)
    print("\nGrowth exponents (slope of log time against log size; size: angles per joint, coefficients, "
          "grid points n^m)\n")
    print("| scan | build | solve | re-check |")
    print("|---|---|---|---|")
    for scan, rows in by_scan.items():
        sizes = [s for s, _ in rows]
        print(f"| {scan} | " + " | ".join(f"{exponent(sizes, [m[p] for _, m in rows]):.2f}" for p in PARTS) + " |")
    print(f"\nbench_growth.py: {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
