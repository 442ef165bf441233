"""Sweep throughput (``make bench``): cases per minute of a 1-DOF study, measured.

A 60-case study of models/johnston2023_1dof.toml (idler offset × spring-1 rate; ``--rates 12``
for 120 cases), run five ways on this machine: the naive loop (serially, building the NLP for
every case; its rate measured on every fifth case, half of those cases before the sweeps and
half after them, so that a drift of the machine's speed during the run weighs on both sides
of the ratios), cadcam's sweep on 2 worker processes (one
build per worker, reused), and on 2 workers with compiled functions
(``solver.functions = "compiled"``), first from an empty cache (the compile is counted), then
from the cache, without and with warm starts from the nearest solved case. Target (issue 12):
≥ 10× the naive loop's rate. (A serial sweep, and warm starts with functions expanded, are not
timed: ``make bench`` has five minutes.)
"""
from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from cadcam.optimize import optimize
from cadcam.sweep.study import Parameter, Study
from cadcam.sweep.runner import read_rows, run_sweep

from goals import print_goals

ROOT = Path(__file__).resolve().parents[1]
#: The naive loop's rate is measured on every NAIVE_STRIDE-th case (its time per case does not
#: depend on the others: each case is built and solved afresh). The spring rate varies fastest
#: in the case order over 6 (or ``--rates``) values: a stride of 5 samples every rate and every
#: idler offset, where 6 would take one rate only.
NAIVE_STRIDE = 5


def make_study(warm: bool, rates: int, functions: str = "expanded") -> Study:
    return Study(name="bench", base=ROOT / "models" / "johnston2023_1dof.toml", warm_start=warm,
                 parameters=[Parameter("cams.1.idler.offset", range=(0.010, 0.020), num=10),
                             Parameter("springs.1.rate", range=(900.0, 1300.0), num=rates),
                             Parameter("solver.functions", values=(functions,))])


def summary(db) -> tuple[float, int, dict]:
    _, rows = read_rows(db)
    its = [r["iterations"] for r in rows if r["iterations"] is not None]
    statuses = {}
    for r in rows:
        statuses[r["status"]] = statuses.get(r["status"], 0) + 1
    obj = {r["case_id"]: r["metrics"]["objective"] for r in rows if r["status"] == "success"}
    return statistics.median(its), statuses, obj


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rates", type=int, default=6, help="spring-1 rates (× 10 idler offsets = cases)")
    run(ap.parse_args().rates)


def run(rates: int) -> None:
    cold = make_study(False, rates)
    cases = cold.validate()
    sample = cases[::NAIVE_STRIDE]
    naive_s, its, statuses = 0.0, [], {}

    def naive_loop(part: list[dict]) -> None:
        nonlocal naive_s
        t0 = time.perf_counter()
        for case in part:  # what a hand-written loop does: a fresh NLP per case
            r = optimize(cold.problem(case))
            its.append(r.solve.iterations)
            statuses[r.status] = statuses.get(r.status, 0) + 1
        naive_s += time.perf_counter() - t0

    naive_loop(sample[::2])
    objectives, rows = {}, {}
    compiled = make_study(False, rates, "compiled")
    with tempfile.TemporaryDirectory() as tmp:
        # compiled functions: the first sweep finds an empty cache and compiles (counted), the
        # second finds the library
        os.environ["CADCAM_CACHE_DIR"] = str(Path(tmp) / "cache")
        for label, study, workers in (("cadcam sweep, 2 workers", cold, 2),
                                      ("cadcam sweep, 2 workers, compiled functions (compiling them)", compiled, 2),
                                      ("cadcam sweep, 2 workers, compiled functions (from the cache)", compiled, 2),
                                      ("cadcam sweep, 2 workers, compiled functions (from the cache), warm starts",
                                       make_study(True, rates, "compiled"), 2)):
            db = Path(tmp) / f"{len(objectives)}.db"
            rate = run_sweep(study, db, workers=workers, progress=False)["cases_per_min"]
            med, st, objectives[label] = summary(db)
            rows[label] = (rate, med, st)
    naive_loop(sample[1::2])
    naive = 60 * len(sample) / naive_s
    print(f"\n1-DOF sweep of {len(cases)} cases (this machine, wall time, including worker start-up)\n")
    print("| how | cases/min | median iterations | statuses | ratio to the naive loop |")
    print("|---|---|---|---|---|")
    print(f"| naive loop, rebuild per case (one case in {NAIVE_STRIDE}: {len(sample)}, half before the sweeps and "
          f"half after) | {naive:.0f} | {statistics.median(its):.0f} | {statuses} | 1.0× |")
    for label, (rate, med, st) in rows.items():
        print(f"| {label} | {rate:.0f} | {med:.0f} | {st} | {rate / naive:.1f}× |", flush=True)
    a = objectives["cadcam sweep, 2 workers, compiled functions (from the cache)"]
    b = objectives["cadcam sweep, 2 workers, compiled functions (from the cache), warm starts"]
    common = sorted(set(a) & set(b))
    rel = np.array([(b[k] - a[k]) / a[k] for k in common])
    print(f"\nwarm vs cold starts (compiled functions), objective (Eq. 46) over {len(common)} cases: median relative change "
          f"{np.median(rel):+.2e}, best {rel.min():+.2e}, worst {rel.max():+.2e} (negative: warm found better)")

    def way(label: str) -> str:
        return label.removeprefix("cadcam sweep, 2 workers").removeprefix(", ") or "functions expanded"

    print_goals([(f"a sweep of {len(cases)} 1-DOF cases on 2 workers ≥ 10× the naive loop (worker start-up counted)",
                  "; ".join(f"{way(label)} {rate / naive:.1f}×" for label, (rate, _, _) in rows.items()),
                  max(rate for rate, _, _ in rows.values()) >= 10 * naive)])


if __name__ == "__main__":
    main()
