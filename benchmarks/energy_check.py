"""How far the torque models are from τ = ∂V/∂θ, measured (the tests assert the limits).

    python benchmarks/energy_check.py        # or: make check-energy

Prints, for `make demo`'s design (re-solved here), the largest difference over the fine re-check
grid between the reported torque and dV/dθ of tests/mechanisms/wire_cam/independent_wire_cam.py (a model sharing no
code with cadcam), under the energy and the force model, and the same for the force model's own optimum; and, on Johnston2023's Table 3 design
over the 46 × 46 grid, the largest energy − force torque difference per joint, the torque range
and the largest difference of the two models' port arms.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cadcam import Design, evaluate, load_spec, optimize  # noqa: E402
from tests.mechanisms.wire_cam import independent_wire_cam as independent  # noqa: E402

MM = 1e3


def main() -> None:
    problem = load_spec(ROOT / "models" / "johnston2023_1dof.toml")
    result = optimize(problem)
    fine = result.recheck
    ref = independent.energy_torque(independent.load_design(json.loads(json.dumps(result.to_dict()))),
                                    fine.theta[0])
    force = evaluate(problem.with_torque_model("force"), result.design, grid=fine.grid, profile=False)
    print(f"1-DOF demo design ({result.status}, RMSE {MM * result.evaluation.metrics.rmse[0]:.3f} N·mm), "
          f"{fine.grid} re-check angles, max |τ − dV/dθ (independent)| [N·mm]: "
          f"energy {MM * np.abs(fine.tau[0] - ref).max():.2g}, force {MM * np.abs(force.tau[0] - ref).max():.3g}")

    forced = optimize(problem.with_torque_model("force"))
    ref = independent.energy_torque(independent.load_design(json.loads(json.dumps(forced.to_dict()))),
                                    forced.recheck.theta[0])
    print(f"1-DOF optimum of the force model (RMSE {MM * forced.evaluation.metrics.rmse[0]:.3f} N·mm "
          f"under that model): its torque against the independent dV/dθ, max "
          f"{MM * np.abs(forced.recheck.tau[0] - ref).max():.2f}, RMS "
          f"{MM * np.sqrt(np.mean((forced.recheck.tau[0] - ref) ** 2)):.2f} N·mm")

    rr = load_spec(ROOT / "models" / "johnston2023_rr_arm.toml")
    table3 = Design.from_dict(json.loads((ROOT / "models" / "johnston2023_table3_design.json").read_text()), rr)
    e = evaluate(rr, table3, grid=46, profile=False)
    f = evaluate(rr.with_torque_model("force"), table3, grid=46, profile=False)
    diff = MM * np.abs(e.tau - f.tau).max(axis=1)
    arms = MM * np.abs(e.units[0].arm - f.units[0].arm).max(axis=1)
    print(f"Table 3, 46 × 46 grid: max |τ_energy − τ_force| per joint [N·mm]: {diff[0]:.1f} / {diff[1]:.1f}; "
          f"joint 1 torque {e.tau[0].min():.2f} … {e.tau[0].max():.2f} N·m; cam 1 arm differences "
          f"[mm]: wire {arms[0]:.2f}, platform {arms[1]:.2f}")


if __name__ == "__main__":
    main()
