"""Why the 1-DOF spec weighs sensitivity: tracking-only optima cancel springs against each other.

Solves models/johnston2023_1dof.toml under its own torque model (energy, τ = ∂V/∂θ) for several
sensitivity weights w2 = w3 and reports the tracking RMSE, the largest torque of the wire
spring, and the torque change (RMS over the grid) when one spring's rate is 5 % higher than
nominal, and when all are (Johnston2023, Table 5's perturbation).

    python studies/weights_1dof.py            # writes out/weights_1dof/report.md
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cadcam import load_spec, optimize
from cadcam.verify.evaluate import rate_deviation
from cadcam.files import write_text

ROOT = Path(__file__).resolve().parents[1]


def wire_torque(problem, ev) -> float:
    """Largest torque [N·m] of spring 1 on the joint through the cam's wire port:
    (k₁x₁ + F0₁)·a_wire, a_wire the wire port's arm under the problem's torque model."""
    s = problem.springs[0]
    return float(np.max((s.rate * ev.x[0] + s.preload) * ev.units[0].arm[0]))


def main() -> None:
    base = load_spec(ROOT / "models" / "johnston2023_1dof.toml").with_options(multistart=4)
    rows = ["| w2 = w3 | status | objective (Eq. 46) | best start | RMSE [N·mm] | max wire torque [N·m] | "
            "+5 % k1 [N·mm] | +5 % k2 [N·mm] | +5 % all [N·mm] |",
            "|---|---|---|---|---|---|---|---|---|"]
    weights = (0.0, 0.1, 1.0, 10.0)
    first = {w: optimize(base.with_weights(sensitivity=(w, w))) for w in weights}
    for w in weights:
        p = base.with_weights(sensitivity=(w, w))
        # the problem has distinct local optima: also start from every other weight's optimum
        # and keep the re-checked optimum with the lowest objective
        r, source = first[w], "own starts"
        for other, ro in first.items():
            if other == w or ro.status != "success":
                continue
            rs = optimize(p.with_options(multistart=0), start=ro.design)
            if rs.status == "success" and (r.status != "success" or rs.evaluation.metrics.objective
                                           < r.evaluation.metrics.objective * (1 - 1e-6)):
                r, source = rs, f"from the w = {other:g} optimum"
        ev = r.evaluation
        d = [1e3 * rate_deviation(p, r.design, 1.05, {j})[0] for j in range(2)]
        d.append(1e3 * rate_deviation(p, r.design, 1.05)[0])
        rows.append(f"| {w:g} | {r.status} | {ev.metrics.objective:.4g} | {source} | "
                    f"{1e3 * ev.metrics.rmse[0]:.3f} | {wire_torque(p, ev):.3f} | "
                    + " | ".join(f"{v:.2f}" for v in d) + " |")
    intro = (f"Torque model: `{base.torque_model}`. Per weight: the default start and four random "
             "ones, then one start from each other weight's optimum (the problem has distinct local "
             "optima, and five starts do not always find the best); the re-checked optimum with the "
             "lowest objective is kept (`best start`). τ is linear in the rates (no preloads here), "
             "so a −5 % error moves the torque by the same amounts as +5 %.")
    text = ("# 1-DOF weights study\n\n" + __doc__.split("\n\n")[1] + "\n\n" + intro + "\n\n"
            + "\n".join(rows) + "\n")
    write_text(ROOT / "out" / "weights_1dof" / "report.md", text)
    print(text)


if __name__ == "__main__":
    main()
