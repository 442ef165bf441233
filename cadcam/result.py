"""The result of a design run as plain data, and its JSON form (schema: result.schema.json)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .citations import cited
from .version import __version__
from .check.evaluate import Evaluation


@dataclass
class Result:
    """What :func:`cadcam.optimize.optimize` returns; see :meth:`to_dict` for the JSON.

    ``status`` is ``success`` for a converged optimum that passed the fine re-check, else one
    word (``infeasible``, ``max_iterations``, ``recheck_failed``, …); ``message`` says it in
    words a person can act on.
    """

    status: str
    message: str
    problem: object
    design: object
    evaluation: Evaluation
    recheck: Evaluation
    solve: object = None
    build_time_s: float = float("nan")

    @property
    def success(self) -> bool:
        return self.status == "success"

    def to_dict(self) -> dict:
        """JSON-ready dictionary (SI units throughout)."""
        ev, fine, sol = self.evaluation, self.recheck, self.solve
        out = {
            "cadcam_version": __version__,
            "status": self.status,
            "message": self.message,
            "torque_model": self.problem.torque_model,
            "friction_model": self.problem.torque_model,  # the field's old name, kept for readers
            "design": self.design.to_dict(),
            "metrics": ev.metrics,
            "recheck": fine.metrics,
            "violations": fine.violations if self.status != "success" else [],
            "target_samples": target_samples(ev),
            "problem": self.problem.to_dict(),
            "citations": citations(self.problem),
        }
        if sol is not None:
            out["solver"] = {
                "name": "envelope" if self.problem.options.method == "envelope" else "ipopt",
                "return_status": sol.return_status,
                "iterations": sol.iterations, "solve_time_s": sol.solve_time_s,
                "build_time_s": self.build_time_s, "objective": sol.objective,
                "start": sol.start, "trials": sol.trials,
                "tangency_nlp_vs_rootfinder_max": float(max(
                    np.abs(sol.z[u] - unit.z).max() for u, unit in enumerate(ev.units))),
            }
        return out


def target_samples(ev: Evaluation) -> list[list[list[float]]]:
    """Per joint, rows [θ₁ … θ_m [rad], τ_d [N·m]] on the evaluation grid."""
    return [np.column_stack([ev.theta.T, ev.tau_d[i]]).tolist() for i in range(len(ev.tau_d))]


def citations(problem) -> list[dict]:
    """The papers a result rests on: Johnston2023 (the objective, Eq. 46/47), each mechanism's
    own, and Endo2010 (Eq. 3–8) for an arm's (or its five-bar arm's) gravity torques by the
    transposed Jacobian."""
    tags = ["Johnston2023"] + [t for m in problem.mechanisms for t in m.citations()]
    if any(j.target.kind in ("arm", "five_bar") for j in problem.joints):
        tags.append("Endo2010")
    return cited(tags)
