"""Why the 1-DOF spec weighs sensitivity: tracking-only optima cancel springs against each other.

Solves models/johnston2023_1dof.toml for several sensitivity weights w2 = w3 and reports the
tracking RMSE, the largest wire torque, and the torque change (RMS over the grid) when one
spring's rate is 5 % higher than nominal, and when all are (Johnston2023, Table 5's perturbation).

    python studies/weights_1dof.py            # writes out/weights_1dof/report.md
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cadcam import load_spec, optimize
from cadcam.check.evaluate import rate_deviation
from cadcam.files import write_text

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    base = load_spec(ROOT / "models" / "johnston2023_1dof.toml").with_options(multistart=4)
    rows = ["| w2 = w3 | status | RMSE [N·mm] | max wire torque [N·m] | +5 % k1 [N·mm] | +5 % k2 [N·mm] | +5 % all [N·mm] |",
            "|---|---|---|---|---|---|---|"]
    for w in (0.0, 0.1, 1.0, 10.0):
        p = base.with_weights(sensitivity=(w, w))
        r = optimize(p)
        ev = r.evaluation
        wire = float(np.max(p.springs[0].rate * ev.x[0] * ev.cams[0].arm[0]))
        d = [1e3 * rate_deviation(p, r.design, 1.05, {j})[0] for j in range(2)]
        d.append(1e3 * rate_deviation(p, r.design, 1.05)[0])
        rows.append(f"| {w:g} | {r.status} | {1e3 * ev.metrics['rmse'][0]:.3f} | {wire:.3f} | "
                    + " | ".join(f"{v:.2f}" for v in d) + " |")
    text = "# 1-DOF weights study\n\n" + __doc__.split("\n\n")[1] + "\n\n" + "\n".join(rows) + "\n"
    write_text(ROOT / "out" / "weights_1dof" / "report.md", text)
    print(text)


if __name__ == "__main__":
    main()
