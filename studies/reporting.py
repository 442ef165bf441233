"""What the reproduction scripts share: provenance lines, figures and the written report."""
from __future__ import annotations

import platform
import subprocess
from pathlib import Path

import casadi

from cadcam import __version__
from cadcam.files import write_text
from cadcam.views.plots import plot_profiles, plot_springs, plot_torque

ROOT = Path(__file__).resolve().parents[1]


def provenance() -> str:
    """Versions, commit and machine that produced the report."""
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                                text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    return (f"cadcam {__version__} (commit {commit}), CasADi {casadi.__version__}, Python "
            f"{platform.python_version()}, {platform.machine()} {platform.system()}")


def figures(ev, directory: Path, stem: str, names=("profiles", "torque", "springs")) -> None:
    """The profile, torque and spring figures of an evaluation as ``{stem}_{name}.png``."""
    for name, plot in zip(names, (plot_profiles, plot_torque, plot_springs)):
        plot(ev, directory / f"{stem}_{name}.png")


def finish(lines: list[str], directory: Path) -> None:
    """Write ``report.md`` atomically and print it."""
    text = "\n".join(lines) + "\n"
    write_text(directory / "report.md", text)
    print(text)
