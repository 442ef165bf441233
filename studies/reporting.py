"""What the reproduction scripts share: provenance, figures, limit checks and the written report."""
from __future__ import annotations

import datetime
import os
import platform
import re
import subprocess
from pathlib import Path

import casadi
import numpy as np
import scipy

from cadcam import __version__
from cadcam.verify.binding import RTOL, binding_constraints
from cadcam.files import write_text
from cadcam.outputs.plots import profile_figure, save_figure, springs_figure, torque_figure

ROOT = Path(__file__).resolve().parents[1]
#: The fields of :func:`provenance_info`, in the order the report lists them.
PROVENANCE_FIELDS = ("cadcam", "commit", "dirty", "python", "casadi", "ipopt", "numpy", "scipy",
                     "os", "cpu", "cores", "date")


def _git(*args) -> str | None:
    """``git args`` in the repository, its stdout stripped; None if git is absent or fails."""
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True,
                              timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


def ipopt_version() -> str:
    """The version of the IPOPT that CasADi loads: from its library's file name in CasADi's
    folder (``libipopt.so.3.14.19``), else from the version string inside the library;
    "unknown" if neither is there."""
    folder = Path(casadi.__file__).parent
    libraries = sorted(folder.glob("*ipopt*"))
    for lib in libraries:
        hit = re.search(r"libipopt[.\w-]*?\.(\d+\.\d+\.\d+)", lib.name)
        if hit:
            return hit.group(1)
    for lib in libraries:
        if lib.name.startswith("libipopt") and lib.is_file():
            hit = re.search(rb"Ipopt version (\d+\.\d+\.\d+)", lib.read_bytes())
            if hit:
                return hit.group(1).decode()
    return "unknown"


def cpu_model() -> str:
    """The processor's model name (``/proc/cpuinfo`` on Linux, ``sysctl`` on macOS, else what
    :func:`platform.processor` says); "unknown" if none says."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith(("model name", "hardware", "cpu model")):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    try:
        out = subprocess.run(["sysctl", "-n", "machdep.cpu.brand_string"], capture_output=True, text=True,
                             check=True, timeout=10).stdout.strip()
        if out:
            return out
    except (OSError, subprocess.SubprocessError):
        pass
    return platform.processor() or "unknown"


def provenance_info() -> dict:
    """Where a report came from: cadcam's version, the git commit (``"unknown"`` without git or
    outside a checkout) and whether the working tree had uncommitted changes (``True``,
    ``False`` or ``"unknown"``), the versions of Python, CasADi, IPOPT, NumPy and SciPy, the
    machine (OS, CPU model, logical cores) and the date and time (UTC, ISO 8601)."""
    commit = _git("rev-parse", "HEAD")
    status = _git("status", "--porcelain") if commit else None
    return {
        "cadcam": __version__,
        "commit": commit or "unknown",
        "dirty": "unknown" if status is None else bool(status),
        "python": platform.python_version(),
        "casadi": casadi.__version__,
        "ipopt": ipopt_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "os": platform.platform(),
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }


def provenance(info: dict | None = None) -> str:
    """One line: versions, commit and machine that produced the report."""
    info = info or provenance_info()
    dirty = {True: ", uncommitted changes", False: "", "unknown": ""}[info["dirty"]]
    return (f"cadcam {info['cadcam']} (commit {info['commit'][:10]}{dirty}), CasADi {info['casadi']}, "
            f"IPOPT {info['ipopt']}, Python {info['python']}, {info['os']}")


def provenance_section(info: dict | None = None) -> list[str]:
    """The report's provenance section (markdown lines): every field of
    :func:`provenance_info`."""
    info = info or provenance_info()
    dirty = {True: "yes (uncommitted changes: the numbers may not match the commit)", False: "no",
             "unknown": "unknown"}[info["dirty"]]
    rows = [("cadcam", info["cadcam"]), ("git commit", info["commit"]), ("working tree dirty", dirty),
            ("Python", info["python"]), ("CasADi", info["casadi"]), ("IPOPT", info["ipopt"]),
            ("NumPy", info["numpy"]), ("SciPy", info["scipy"]), ("OS", info["os"]),
            ("CPU", f"{info['cpu']}, {info['cores']} logical cores"), ("date (UTC)", info["date"])]
    return ["## Provenance", "", "| | |", "|---|---|"] + [f"| {k} | {v} |" for k, v in rows] + [""]


def limit_lines(label: str, ev) -> list[str]:
    """Markdown bullets: how an evaluated design stands against its own limits — the
    evaluation's violations, and the limits it sits at or beyond with their values
    (:func:`cadcam.verify.binding.binding_constraints`, relative tolerance RTOL)."""
    binding = binding_constraints(ev.metrics, ev.problem)
    exceeded = [b for b in binding if " beyond " in b or "compression" in b or "not convex" in b]
    at = [b for b in binding if b not in exceeded]

    def told(violation):  # "kind: item (margin …)", already stated with its numbers above
        item = violation.split(": ", 1)[-1].rsplit(" (margin", 1)[0]
        return any(e.startswith(item + " ") for e in exceeded)

    out = [f"- **{label}** ({ev.problem.torque_model} model, {ev.grid}-angle grid per joint): "
           + ("**violates its limits**" if ev.violations else "within its limits")]
    out += [f"  - beyond a limit: {b}" for b in exceeded]
    out += [f"  - violated: {v}" for v in ev.violations if not told(v)]
    out += [f"  - binding (within {100 * RTOL:g} % of the limit): {b}" for b in at]
    return out


def figures(ev, directory: Path, stem: str, names=("profiles", "torque", "springs")) -> None:
    """The profile, torque and spring figures of an evaluation as ``{stem}_{name}.png``."""
    for name, build in zip(names, (profile_figure, torque_figure, springs_figure)):
        save_figure(build(ev), directory / f"{stem}_{name}.png")


def finish(lines: list[str], directory: Path, info: dict | None = None) -> None:
    """Append the provenance section, write ``report.md`` atomically and print it."""
    text = "\n".join(lines + [""] + provenance_section(info)) + "\n"
    write_text(directory / "report.md", text)
    print(text)
