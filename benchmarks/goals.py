"""The goals (issues 12 and 30, and those of later issues) as ``make bench`` reports them: one row per goal with the value this
run measured and whether it met the goal (each benchmark script prints the goals it measures,
after its tables)."""
from __future__ import annotations


def print_goals(rows: list[tuple[str, str, bool]], issues: str = "issues 12 and 30") -> None:
    """Print ``rows`` (goal, measured value, met) as a table headed "goals" of ``issues``."""
    print(f"\nGoals ({issues}), this run on this machine\n")
    print("| goal | measured | verdict |")
    print("|---|---|---|")
    for goal, measured, met in rows:
        print(f"| {goal} | {measured} | {'met' if met else '**missed**'} |", flush=True)


def spec_label(spec: str, variant: str | None) -> str:
    """A spec's name as a table shows it, with the variant as ``cadcam design`` takes it."""
    return spec + (f" --variant {variant}" if variant else "")
