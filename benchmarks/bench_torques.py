"""How closely Ludovico2021's pulleys meet their torques: issue 30's accuracy goals.

``python benchmarks/bench_torques.py``. Each design is made once, in this process, from the spec
(no files written), and judged on its fine re-check grid: the largest |τ − τ_d| there [N·m] is
the number the goals ask for, with the spec's spring and limits.

* ``models/ludovico2021_pendulum.toml`` by cadcam's profile NLP (the spec as shipped);
* ``models/ludovico2021_generic.toml`` (the spec as shipped): the moment arms r_m(θ) designed
  and each pulley fitted as a profile (``solver.method = "moment_arm"``). The same spec by the
  profile NLP (its variant ``nlp``) is the convergence matrix's (``make convergence``).

Columns: spec and variant, how it was designed, status, iterations (0: no NLP), the largest
torque error on the fine re-check [N·m], end to end [s] (:func:`cadcam.optimize.optimize`).
"""
from __future__ import annotations

import os
import time
from pathlib import Path

from cadcam.api import load_problem
from cadcam.optimize import optimize

from goals import print_goals, spec_label

MODELS = Path(__file__).resolve().parents[1] / "models"
#: (spec, variant, goal [N·m]): issue 30's goals for the largest torque error on the fine re-check.
CASES = [("ludovico2021_pendulum", None, 1e-3), ("ludovico2021_generic", None, 5e-3)]


def main() -> None:
    print(f"load average at start: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (1, 5, 15 min; "
          f"{os.cpu_count()} cores); one design each")
    print("| spec | designed by | status | iterations | largest torque error, fine re-check [N·m] | end to end [s] |")
    print("|---|---|---|---|---|---|")
    goals = []
    for name, variant, goal in CASES:
        problem = load_problem(MODELS / f"{name}.toml", variant=variant)
        t0 = time.perf_counter()
        result = optimize(problem)
        seconds = time.perf_counter() - t0
        error = max(result.recheck.metrics.max_abs_error)
        shown = spec_label(name, variant)
        print(f"| {shown} | {problem.options.method} | {result.status} | {result.solve.iterations} "
              f"| {error:.3g} | {seconds:.2f} |", flush=True)
        goals.append((f"{shown}: largest torque error on the fine re-check ≤ {goal:g} N·m, the spec's spring "
                      f"and limits", f"{error:.3g} N·m ({result.status})", result.success and error <= goal))
    print_goals(goals)


if __name__ == "__main__":
    main()
