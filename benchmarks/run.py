"""``make bench`` and ``make convergence``: run benchmark scripts, show their tables as they
come, and write them all to one results file stamped with the machine, the date and the commit
they were measured on.

``python benchmarks/run.py [--results benchmarks/results.md] [--scripts NAME ...]``. The file is
written at the end, whole (a run stopped midway leaves the previous file as it was); the README
links it. With the default scripts (``make bench``) the last section lists each script's wall
time and the benchmark's own time against its goal of 5 minutes.
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SCRIPTS = ("bench_design.py", "bench_solver.py", "bench_page.py", "bench_speed.py", "bench_sweep.py", "bench_arms.py",
           "bench_growth.py", "bench_cable_robot.py", "bench_torques.py", "bench_friction.py", "bench_builds.py",
           "bench_robust.py", "bench_springs.py")
#: The goal for the whole benchmark [s] (issue 12).
GOAL_S = 300


def machine_stamp() -> str:
    """Markdown lines naming where and when the numbers below were measured."""
    import casadi
    import numpy

    cpu = next((line.split(":", 1)[1].strip() for line in _lines("/proc/cpuinfo") if line.startswith("model name")),
               platform.processor() or "unknown CPU")
    mem = next((f"{int(line.split()[1]) / 2**20:.1f} GiB" for line in _lines("/proc/meminfo")
                if line.startswith("MemTotal")), "unknown memory")
    commit = subprocess.run(["git", "describe", "--always", "--dirty"], capture_output=True, text=True,
                            cwd=ROOT).stdout.strip() or "not a git checkout"
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (f"# `make bench` results\n\n"
            f"- measured: {now}, commit {commit}\n"
            f"- machine: {socket.gethostname()}, {cpu}, {os.cpu_count()} cores, {mem}, "
            f"{platform.system()} {platform.release()}\n"
            f"- software: Python {platform.python_version()}, CasADi {casadi.__version__}, NumPy {numpy.__version__}\n"
            f"- load average at start: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (1, 5, 15 min)\n"
            "- Python's bytecode of cadcam cached, as an installed cadcam has it (see `run_script`)\n")


def _lines(path: str) -> list[str]:
    try:
        return Path(path).read_text().splitlines()
    except OSError:
        return []


def run_script(name: str) -> tuple[str, int]:
    """Run one benchmark script, echoing its output; return the output and exit code. It runs
    with an empty cache of compiled libraries of its own and no background compiles (which
    would load the machine while it measures): ``functions = "auto"`` expands what the script
    has not compiled itself, whatever this machine has cached. Python caches the bytecode of
    cadcam's sources as an installed cadcam has it, also where this machine's environment
    turns that off (``PYTHONDONTWRITEBYTECODE``): otherwise each new process the scripts time
    (``cadcam design``, a sweep's workers) would compile cadcam again, which a user's does not."""
    from cadcam.solve.compiled import BACKGROUND_ENV
    with tempfile.TemporaryDirectory(prefix="cadcam-bench-cache-") as cache:
        env = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
        env.update({"CADCAM_CACHE_DIR": cache, BACKGROUND_ENV: "0"})
        proc = subprocess.Popen([sys.executable, str(HERE / name)], stdout=subprocess.PIPE, text=True, cwd=ROOT,
                                env=env)
        return _echoed(proc)


def _echoed(proc: subprocess.Popen) -> tuple[str, int]:
    """``proc``'s output, echoed line by line as it comes, and its exit code."""
    out = []
    assert proc.stdout is not None
    for line in proc.stdout:
        sys.stdout.write(line)
        sys.stdout.flush()
        out.append(line)
    return "".join(out), proc.wait()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=HERE / "results.md")
    parser.add_argument("--scripts", nargs="+", default=list(SCRIPTS), help="benchmark scripts to run, in order")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    parts = [machine_stamp()]
    print(parts[0], flush=True)
    walls = {}
    for name in args.scripts:
        script_start = time.perf_counter()
        out, code = run_script(name)
        walls[name] = time.perf_counter() - script_start
        parts.append(f"\n## {name}\n\n{out}")
        if code != 0:
            print(f"{name} failed (exit {code}); {args.results} is left as it was", file=sys.stderr)
            return code
    took = time.perf_counter() - start
    if args.scripts == list(SCRIPTS):
        parts.append(_whole_benchmark(walls, took))
        print(parts[-1])
    tmp = args.results.with_name(f".{args.results.name}.tmp")
    tmp.write_text("".join(parts))
    os.replace(tmp, args.results)
    print(f"tables written to {args.results}")
    return 0


def _whole_benchmark(walls: dict[str, float], took: float) -> str:
    """The closing section: each script's wall time (where the benchmark's time goes) and the
    whole benchmark's against :data:`GOAL_S`."""
    rows = "".join(f"| {name} | {wall:.0f} |\n" for name, wall in walls.items())
    verdict = f"| `make bench` ≤ {GOAL_S // 60} min | {took:.0f} s | {'met' if took <= GOAL_S else '**missed**'} |"
    return (f"\n## the whole benchmark\n\n| script | wall [s] |\n|---|---|\n{rows}\n"
            f"| goal | measured | verdict |\n|---|---|---|\n{verdict}\n")


if __name__ == "__main__":
    sys.exit(main())
