"""What lifting a profile's convexity rows costs and saves: the NLP's build time, its size and
its Lagrangian Hessian's nonzeros with the convexity, ρ-bound and curvature rows written on
lifted ρ, ρ′, ρ″ (:func:`cadcam.solve.rows._lifted_profile`) and written directly on
the coefficients, at a shipped spec's degree and at degree 30 (issue 30, item 1).

``python benchmarks/bench_lifting.py [--solve] [--cable-robot]``. Measured, not asserted; builds
only unless ``--solve`` (then also IPOPT's iterations and objective from the default start).
Each build's wall and CPU time are printed with the machine's load average beside them (wall
times are only comparable at a similar load; CPU times less so). ``--cable-robot`` adds
Fedorov2018's cable robot (two pairs at degree 30: minutes and several GB per build).
"""
from __future__ import annotations

import argparse
import os
import time
from dataclasses import replace
from pathlib import Path

from cadcam.api import load_problem
from cadcam.optimize import solve, start_design
from cadcam.solve import rows
from cadcam.solve.transcription import Transcription

MODELS = Path(__file__).resolve().parents[1] / "models"
#: (label, spec, overrides) of the problems measured.
CASES = (("1-DOF cam, order 3", "johnston2023_1dof.toml", {}),
         ("1-DOF cam, order 30", "johnston2023_1dof.toml", {"cams.1.order": 30}),
         ("balancer pair, order 15", "fedorov2018_balancer.toml", {}),
         ("balancer pair, order 30", "fedorov2018_balancer.toml", {"mechanisms.1.order": 30}))
CABLE_ROBOT = ("cable robot, two pairs, order 30", "fedorov2018_cable_robot.toml", {})


def measure(spec: str, overrides: dict, lifted: bool, run_solver: bool) -> dict:
    """Build (and with ``run_solver`` solve) the NLP of ``spec`` with every profile's rows lifted
    or none."""
    problem = load_problem(MODELS / spec, overrides=overrides, functions="expanded")
    problem, start = start_design(replace(problem, options=replace(problem.options, method="nlp")))
    saved = rows.LIFTED_PROFILE_SIZE
    rows.LIFTED_PROFILE_SIZE = 0 if lifted else 10**9
    cpu = time.process_time()
    try:
        tr = Transcription(problem)
    finally:
        cpu = time.process_time() - cpu
        rows.LIFTED_PROFILE_SIZE = saved
    row = {"build": tr.build_time_s, "cpu": cpu, "load": os.getloadavg()[0], "nx": tr.v.size,
           "ng": tr.nlp["g"].shape[0],
           "hessian": tr.solver.get_function("nlp_hess_l").sparsity_out(0).nnz()}
    if run_solver:
        s = solve(tr, problem, start)
        row.update(iterations=s.iterations, objective=s.objective, status=s.status)
    return row


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--solve", action="store_true", help="also solve from the default start")
    parser.add_argument("--cable-robot", action="store_true", help="add the cable robot (slow)")
    args = parser.parse_args(argv)
    cases = CASES + ((CABLE_ROBOT,) if args.cable_robot else ())
    print("\nConvexity rows on lifted ρ, ρ′, ρ″ against rows on the coefficients (functions expanded)\n")
    print("| problem | rows | build [s] | build CPU [s] | load | variables | rows of g | Hessian nonzeros | iterations "
          "| objective | status |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, spec, overrides in cases:
        for lifted in (False, True):
            r = measure(spec, overrides, lifted, args.solve)
            solved = (f"{r['iterations']} | {r['objective']:.10g} | {r['status']}" if args.solve
                      else "– | – | –")
            print(f"| {label} | {'lifted' if lifted else 'on coefficients'} | {r['build']:.2f} | {r['cpu']:.2f} | {r['load']:.1f} "
                  f"| {r['nx']} | {r['ng']} | {r['hessian']} | {solved} |", flush=True)


if __name__ == "__main__":
    main()
