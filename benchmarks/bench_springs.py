"""The whole-catalogue spring search (``make bench``): issue 50's command,
``cadcam springs docs/first_balancer.toml -o DIR``, over the shipped catalogue of 1,284
McMaster-Carr extension springs, timed end to end in a new process as a user runs it on a fresh
clone: start-up, the screen, the compile of the NLP's functions into the empty cache ``make
bench`` gives each script, every survivor's design on the machine's cores, the table and the
best design's folder with its figures.

The table is read back: how many springs are feasible, near, undecided and infeasible, the best
and its rmse against the tutorial's acceptance, and the feasible rows whose peak force or largest
length passes its part's limit (none may; the wire's stress, the third limit, is in each design's
result.json, not in the table). The search's CPU time (its workers' and compiles' included) is
stated beside its wall time: on a shared machine the wall time measures the load as much as the
search. The screen alone is timed in this process, the best of :data:`SCREEN_REPEATS`. Goals
(issue 50): the whole search within 60 s on 2 workers, at least 10 feasible springs, the best
within the default acceptance; the screen of the whole catalogue within 0.1 s.
"""
from __future__ import annotations

import csv
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cadcam.physics.catalogue import load_catalogue
from cadcam.spec import parse_spec, read_spec_data
from cadcam.sweep.springs import screen_slot

sys.path.insert(0, str(Path(__file__).resolve().parent))
from goals import print_goals  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "docs" / "first_balancer.toml"
#: Goals (issue 50): the whole search's wall time [s] on :data:`WORKERS` workers, the least
#: number of feasible springs, and the screen's time [s] for the whole catalogue.
SEARCH_S, FEASIBLE, SCREEN_S = 60.0, 10, 0.1
#: The worker processes the search runs on: the goal's 2-core machine.
WORKERS = 2
#: How many times the screen is timed (the best counts: the least disturbed by other load).
SCREEN_REPEATS = 20


def searched(out: Path) -> tuple[float, float, int, list[dict]]:
    """Run the search into ``out``; its wall time and CPU time [s] (its own and its
    children's: the workers, the compiles), exit code and table rows (ranked)."""
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "cadcam", "springs", str(SPEC.relative_to(ROOT)), "-o", str(out),
                          "--workers", str(WORKERS)], cwd=ROOT, capture_output=True, text=True)
    took = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - used.ru_utime) + (after.ru_stime - used.ru_stime)
    if run.returncode not in (0, 1):
        sys.exit(f"cadcam springs failed (exit {run.returncode}): {run.stderr.strip().splitlines()[-1:]}")
    with open(out / "springs.csv", newline="") as f:
        return took, cpu, run.returncode, list(csv.DictReader(f))


def screen_time() -> tuple[float, float, int]:
    """The screen of the whole shipped catalogue for the tutorial's spring: its least wall time
    and CPU time [s] over :data:`SCREEN_REPEATS` runs (the spec parsed and the catalogue read
    before, as the page has them), and how many springs pass."""
    problem, catalogue = parse_spec(read_spec_data(SPEC), str(SPEC), SPEC.parent), load_catalogue(None)
    walls, cpus = [], []
    for _ in range(SCREEN_REPEATS):
        w0, c0 = time.perf_counter(), time.process_time()
        screened = screen_slot(problem, 0, catalogue)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return min(walls), min(cpus), int(screened.passed.sum())


def past_limits(rows: list[dict]) -> int:
    """How many of the feasible ``rows`` pass their part's largest load or largest length."""
    cat = load_catalogue(None)
    bodies = [cat.spring_body(cat.index(r["part_number"])) for r in rows]
    return sum(float(r["peak_force"]) > b.load_max or float(r["max_length"]) > b.length_max
               for r, b in zip(rows, bodies))


def main() -> None:
    limit = parse_spec(read_spec_data(SPEC), str(SPEC), SPEC.parent).joints[0].limits["relative_rmse"]
    screen_s, screen_cpu, passed = screen_time()
    with tempfile.TemporaryDirectory() as tmp:
        took, cpu, code, rows = searched(Path(tmp) / "springs")
    words = [r["verdict"] for r in rows]
    feasible = [r for r in rows if r["verdict"] == "feasible"]
    best = feasible[0] if feasible else None
    print(f"\n`cadcam springs docs/first_balancer.toml -o DIR --workers {WORKERS}` over the shipped catalogue "
          f"({len(rows)} springs, {passed} pass the screen) on a machine of {os.cpu_count()} cores, from an empty "
          "cache (the compile counted), end to end; CPU time: the search's processes together\n")
    print("| wall [s] | CPU [s] | exit | feasible | near | undecided | infeasible (screened out or unusable) | best "
          "| its rmse [N·m] | rmse / target RMS | feasible rows past a limit |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print(f"| {took:.1f} | {cpu:.1f} | {code} | {len(feasible)} | {words.count('near')} | {words.count('undecided')} | "
          f"{words.count('infeasible')} | "
          + (f"{best['part_number']} | {float(best['rmse']):.4g} | {100 * float(best['relative_rmse']):.3g} % "
             f"(limit {100 * limit:g} %)" if best else "– | – | –") + f" | {past_limits(feasible)} |", flush=True)
    print_goals([
        (f"the tutorial's whole {len(rows)}-spring search ≤ {SEARCH_S:g} s on {WORKERS} workers",
         f"{took:.1f} s ({cpu:.1f} s of CPU)", took <= SEARCH_S),
        (f"≥ {FEASIBLE} feasible springs, the best within the default acceptance",
         f"{len(feasible)}; best {best['part_number']}" if best else "none",
         len(feasible) >= FEASIBLE and best is not None and float(best["relative_rmse"]) <= limit),
        ("every feasible row within its part's largest load and length", f"{past_limits(feasible)} past one",
         past_limits(feasible) == 0),
        (f"the screen of the whole catalogue ≤ {SCREEN_S:g} s", f"{1e3 * screen_s:.1f} ms ({1e3 * screen_cpu:.1f} ms "
         f"of CPU), the best of {SCREEN_REPEATS}", screen_s <= SCREEN_S),
    ], "issue 50")


if __name__ == "__main__":
    main()
