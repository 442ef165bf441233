"""Fedorov2018's cable robot designed by cadcam's NLP against Fedorov's envelope synthesis alone
(issue 30, item 3): time, memory and accuracy of ``cadcam design`` end to end.

``python benchmarks/bench_cable_robot.py [--runs 2]``. Measured, not asserted. Each design is
``cadcam design models/fedorov2018_cable_robot.toml -o DIR --no-figures`` (with
``--variant envelope`` for the envelope) in a new process: its wall time is the process's,
from start to exit (Python's start and cadcam's import, reading the spec, the envelope start,
the NLP's build and solve, the fine re-check, the workshop files and ``verification.md``), its
peak memory the process's own peak resident set (``os.wait4``'s ``ru_maxrss``). The NLP runs
``runs`` times, a row each (its goals take their median time and their largest peak), the
envelope once.
The machine's load average is printed beside each run: the times are only comparable at a
similar load.

Columns: build, solve and fine re-check [s] and the iterations from ``result.json``'s
``solver``; the rest of the wall time [s] (starting Python, importing cadcam, reading the spec,
the envelope start, the design-grid evaluation, the workshop files and their verification); the
largest |x − x_d| of each pair's idler on the fine re-check grid [mm]
(``recheck.output_max_abs_error``); the end effector's largest distance from its pick-and-place
path on that grid [mm] (the summary's ``cable robot:`` line,
:func:`cadcam.mechanisms.differential_pulley.robot_path.robot_path`); ``verification.md``'s
verdict. Goals (issue 30): the NLP's design ≤ 90 s end to end and ≤ 2 GB, the end effector within
0.35 mm of its path (the envelope's own deviation, rounded up), and the NLP at least as accurate
as the envelope on both measures.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from goals import print_goals

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "models" / "fedorov2018_cable_robot.toml"
#: Goals: end to end [s], peak resident memory [GB], the end effector's largest deviation from
#: its path [mm].
WALL_S, PEAK_GB, PATH_MM = 90.0, 2.0, 0.35
#: The summary line that gives the end effector's deviation from its path (mm).
PATH_LINE = re.compile(r"deviates from its path by (\S+) mm on average, (\S+) mm at most")


def _load() -> str:
    return f"{os.getloadavg()[0]:.2f}"


def design(variant: str | None, out: Path) -> dict:
    """Run ``cadcam design`` of the cable robot (its ``variant``) into ``out`` in a new process;
    return its wall time [s], peak resident memory [GB], the load average before and after it,
    and what its result.json and summary report."""
    command = [sys.executable, "-m", "cadcam", "design", str(SPEC), "-o", str(out), "--no-figures"]
    command += ["--variant", variant] if variant else []
    load = _load()
    t0 = time.perf_counter()
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT)
    assert proc.stdout is not None
    text = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)  # this child's own rusage, not the running maximum of all
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    path = PATH_LINE.search(text)
    if not (out / "result.json").is_file() or path is None:
        raise RuntimeError(f"`{' '.join(command)}` exited {proc.returncode} without a result.json and a cable "
                           f"robot line; its output:\n{text}")
    result = json.loads((out / "result.json").read_text())
    solver = result["solver"]
    verified = json.loads((out / "verification.json").read_text())["passed"] if (out / "verification.json").is_file() \
        else None
    return {"wall": wall, "peak": usage.ru_maxrss * 1024 / 1e9, "load": f"{load}→{_load()}",
            "status": result["status"], "iterations": solver["iterations"], "build": solver["build_time_s"],
            "solve": solver["solve_time_s"], "recheck": solver["recheck_time_s"],
            "x_mm": [1e3 * e for e in result["recheck"]["output_max_abs_error"]],
            "path_mm": float(path.group(2)), "verified": verified}


def _row(label: str, r: dict) -> str:
    verified = {True: "PASSED", False: "FAILED", None: "not written"}[r["verified"]]
    return (f"| {label} | {r['load']} | {r['wall']:.1f} | {r['peak']:.2f} | {r['build']:.1f} | {r['solve']:.1f} "
            f"| {r['recheck']:.1f} | {r['wall'] - r['build'] - r['solve'] - r['recheck']:.1f} | {r['iterations']} "
            f"| {r['status']} "
            f"| {', '.join(f'{v:.4f}' for v in r['x_mm'])} | {r['path_mm']:.3g} | {verified} |")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=2, help="designs by the NLP (the envelope's: one)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    print(f"`cadcam design {SPEC.relative_to(ROOT)} -o DIR --no-figures` (a new process each run; the NLP "
          f"{args.runs} times, `--variant envelope` once); load average (1 min) before→after each run, "
          f"{os.cpu_count()} cores\n")
    print("| design | load | wall [s] | peak memory [GB] | build [s] | solve [s] | fine re-check [s] | the rest [s] "
          "| iterations | status | max \\|x − x_d\\| per pair [mm] | end effector's max deviation from its path [mm] "
          "| verification.md |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as root:
        nlp = []
        for i in range(args.runs):
            nlp.append(design(None, Path(root) / f"nlp{i}"))
            print(_row(f"NLP, run {i + 1}", nlp[-1]), flush=True)
        envelope = design("envelope", Path(root) / "envelope")
        print(_row("envelope", envelope), flush=True)
    wall = statistics.median(r["wall"] for r in nlp)
    peak = max(r["peak"] for r in nlp)
    path = max(r["path_mm"] for r in nlp)
    x = [max(r["x_mm"][k] for r in nlp) for k in range(len(nlp[0]["x_mm"]))]
    ok = all(r["status"] == "success" and r["verified"] for r in nlp)
    print(f"\nbench_cable_robot.py: {time.perf_counter() - start:.0f} s")
    print_goals([
        (f"the cable robot by the NLP ≤ {WALL_S:.0f} s end to end (`cadcam design`, median of {args.runs})",
         f"{wall:.1f} s (load {', '.join(r['load'] for r in nlp)})", wall <= WALL_S),
        (f"the cable robot by the NLP ≤ {PEAK_GB:.0f} GB peak memory", f"{peak:.2f} GB (largest of {args.runs})",
         peak <= PEAK_GB),
        (f"the NLP's end effector within {PATH_MM} mm of its path (fine re-check), every run `success` and verified",
         f"{path:.3g} mm; {'/'.join(sorted({r['status'] for r in nlp}))}", path <= PATH_MM and ok),
        ("the NLP at least as accurate as the envelope (end effector's path; each pair's x)",
         f"path {path:.3g} mm against {envelope['path_mm']:.3g} mm; x {', '.join(f'{v:.4f}' for v in x)} mm against "
         f"{', '.join(f'{v:.4f}' for v in envelope['x_mm'])} mm",
         path <= envelope["path_mm"] and all(a <= b for a, b in zip(x, envelope["x_mm"]))),
    ])


if __name__ == "__main__":
    main()
