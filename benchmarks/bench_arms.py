"""Design and re-check planar arms balanced by 3 and 4 wire cams: how the NLP and the
streamed fine re-check grow with the number of joints.

``python benchmarks/bench_arms.py [--runs 3] [--two]``. Measured, not asserted: medians of
``runs`` designs per arm, with the machine's load average printed beside them (the times are
only comparable at a similar load).

* 2 cams, with ``--two`` only: ``models/johnston2023_rr_arm.toml`` (Johnston2023 Sec. 10.4: 46
  angles per joint, re-check on 451² points). ``make bench`` leaves it out: it is the Sec. 10.4
  problem that ``bench_design.py`` times (its first table), and the benchmark has five minutes;
* 3 cams: ``models/johnston2023_three_cam_arm.toml`` (26 angles per joint over 60°, re-check
  on 251³ ≈ 1.6·10⁷ points);
* 4 cams: the three-cam spec with a fourth link (0.15 kg, 0.15 m, centre of mass at
  mid-length), a fourth cam and two more springs (Table 2's spring 3 between the platforms of
  cams 3 and 4 and on wire 4), every joint over 0–45° (the last link stays above the
  horizontal-down line) at 20 angles (2.4° apart, as above), and ``recheck_factor = 5``: at
  the default 10 the re-check grid would be 191⁴ ≈ 1.3·10⁹ points, beyond the cap
  ``recheck_points`` (10⁹); at 5 it is 96⁴ ≈ 8.5·10⁷.

Columns: NLP build [s], IPOPT solve [s], iterations, the fine re-check alone [s] (the
result's ``recheck_time_s``: the optimum evaluated on the fine grid), end to end [s]
(:func:`cadcam.optimize.optimize`: build, solve and both evaluations; no files written),
status and RMSE per joint on the fine re-check [N·mm].
"""
from __future__ import annotations

import argparse
import copy
import os
import statistics
import time
from pathlib import Path

from cadcam.api import load_problem
from cadcam.optimize import optimize
from cadcam.spec import read_spec_data

from goals import print_goals

MODELS = Path(__file__).resolve().parents[1] / "models"
#: Link 4 of the four-cam arm: mass [kg], length [m], centre of mass from its joint [m].
LINK4 = (0.15, 0.15, 0.075)
#: The four-cam arm's joint range [deg], grid and re-check factor (see the module docstring).
RANGE4_DEG, GRID4, RECHECK_FACTOR4 = [0.0, 45.0], 20, 5


def four_cam_arm() -> dict:
    """The spec data of the four-cam arm, from the three-cam spec."""
    data = copy.deepcopy(read_spec_data(MODELS / "johnston2023_three_cam_arm.toml"))
    data["name"] = "four_cam_arm (bench_arms.py)"
    for key, value in zip(("masses", "lengths", "com"), LINK4):
        data["arm"][key] = data["arm"][key] + [value]
    cam4 = copy.deepcopy(data["cams"][2])
    cam4["name"], cam4["target"]["joint"] = "cam 4", 4
    data["cams"].append(cam4)
    spring = next(s for s in data["springs"] if s["ports"] == ["wire:3"])
    data["springs"] += [{**spring, "name": "spring 6 (McMaster-Carr 1942N653)", "ports": ["platform:3", "platform:4"]},
                        {**spring, "name": "spring 7 (McMaster-Carr 1942N653)", "ports": ["wire:4"]}]
    for cam in data["cams"]:
        cam["theta_range_deg"] = RANGE4_DEG
        cam["sensitivity_weights"] = [0.0] * len(data["springs"])
    data["solver"].update(grid=GRID4, recheck_factor=RECHECK_FACTOR4)
    return data


ARMS = [(2, lambda: load_problem(MODELS / "johnston2023_rr_arm.toml")),
        (3, lambda: load_problem(MODELS / "johnston2023_three_cam_arm.toml")),
        (4, lambda: load_problem(four_cam_arm()))]


def bench(problem, runs: int) -> dict:
    """Medians over ``runs`` designs of ``problem`` from its default start."""
    rows = []
    for _ in range(runs):
        t0 = time.perf_counter()
        result = optimize(problem)
        total = time.perf_counter() - t0
        rows.append({"build": result.build_time_s, "solve": result.solve.solve_time_s,
                     "iterations": result.solve.iterations, "recheck": result.recheck_time_s,
                     "total": total, "status": result.status, "rmse": result.recheck.metrics.rmse})
    out = {k: statistics.median(r[k] for r in rows) for k in ("build", "solve", "iterations", "recheck", "total")}
    out["status"] = "/".join(sorted({r["status"] for r in rows}))
    out["rmse"] = [statistics.median(r["rmse"][i] for r in rows) for i in range(len(rows[0]["rmse"]))]
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--two", action="store_true", help="also the 2-cam arm (Sec. 10.4)")
    args = parser.parse_args(argv)
    print(f"load average at start: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (1, 5, 15 min; "
          f"{os.cpu_count()} cores); medians of {args.runs} runs"
          + ("" if args.two else "; 2 cams: the Sec. 10.4 rows of bench_design.py (or --two)"))
    print("| joints | grid | re-check grid | NLP build [s] | solve [s] | iterations | re-check [s] "
          "| end to end [s] | status | RMSE per joint [N·mm] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    totals = {}
    for joints, make in ARMS:
        if joints == 2 and not args.two:
            continue
        problem = make()
        r = bench(problem, args.runs)
        totals[joints] = r["total"]
        n, fine = problem.options.grid, problem.options.recheck_grid
        print(f"| {joints} | {n}^{joints} | {fine}^{joints} = {fine**joints:.3g} | {r['build']:.2f} | {r['solve']:.2f} "
              f"| {r['iterations']:.0f} | {r['recheck']:.2f} | {r['total']:.2f} | {r['status']} "
              f"| {', '.join(f'{1e3 * v:.1f}' for v in r['rmse'])} |", flush=True)
    print(f"load average at end: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print_goals([("the three-cam arm ≤ 15 s end to end (`models/johnston2023_three_cam_arm.toml`)",
                  f"{totals[3]:.2f} s (four cams: {totals[4]:.2f} s, reported, no goal)", totals[3] <= 15.0)])


if __name__ == "__main__":
    main()
