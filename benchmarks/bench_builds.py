"""The built device (issue 52, items 2–4): the tutorial's balancer built 10 000 times under its
spec's tolerances, set back by its adjustment, and carrying 0.3–0.8 kg.

``python benchmarks/bench_builds.py``. Measured, not asserted. The spec is
``docs/first_balancer.toml`` (its tolerances are the defaults: rate and preload ± 10 %, placement
± 0.5 mm, profile ± 0.05 mm, the pin's friction coefficient ± 30 %) with the cable's anchor turned back (``anchor_angle = 0.35``: 44° of
cable wound at the range's start, so that the spring end may turn back along its slot), a
pendulum ``mass_range = [0.3, 0.8]``, the ``[adjustment]`` of :data:`ADJUSTMENT`: a tensioning
screw (± 10.5 mm of pre-extension) and a slot along the arc around the joint through the spring
end (``chi0``, ± 120 mm), and the cable over a fixed steel pin (:data:`FRICTION`, the friction
band's centre tracked): docs/tutorial.md's "Build it, and set it back". It is designed once, in
this process; the builds are then simulated (:func:`cadcam.verify.builds.simulate_builds`) with
the screw alone, with both, under each distribution.

Columns: the adjustment, the distribution, and the P50 / P95 of the largest |τ − τ_d| over the
range as built, as set by the adjustment table (the slot from the spring's measured rate, then
the screw until the arm holds still at the stated pose) and at each build's best settings (least
squares within the ranges), each as a share of the target's peak; the wall and CPU time of the
builds [s] (the model, 10 000 builds, their settings and the table; with the payload range, its
exact re-evaluations too; CPU over wall above 1 is NumPy's threads, below it the machine's other
load). A last row draws the friction coefficient exactly (its tolerance 0): its share of the
rest. Then each tolerance alone (the others 0), screw and slot, uniform: what is left after
adjusting and where it comes from. Then each payload's RMS error after its setting — the screw and the slot, and the screw
alone (one adjustment; the slot is the second) — the build model's error against 30 builds
evaluated exactly, and the goals.
"""
from __future__ import annotations

import copy
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import cadcam
from cadcam.problem import TOLERANCES
from cadcam.spec import parse_spec, read_spec_data
from cadcam.verify import builds as B
from cadcam.verify.evaluate import evaluate
from cadcam.verify.tolerance import sensitivity

from goals import print_goals

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "docs" / "first_balancer.toml"
#: The adjustment designed in: the screw's and the slot's travel [m].
ADJUSTMENT = {"preload_travel": 0.0105, "slot": "chi0", "slot_travel": 0.12}
#: The cable over a fixed steel pin turning it 30° (μ = 0.16, docs/physics.md), the band's centre tracked.
FRICTION = {"centre": True, "guides": [{"spring": 1, "mu": 0.16, "wrap_deg": 30.0}]}
#: Issue 52's goals: P95 after one adjustment [share of the target's peak], each payload's RMS
#: error [share of its target's RMS], the time of 10 000 builds [s].
P95_GOAL, PAYLOAD_GOAL, TIME_GOAL = 0.02, 0.05, 10.0
#: Builds evaluated exactly against the model.
EXACT_BUILDS = 30


def spec() -> dict:
    data = read_spec_data(SPEC)
    data["mechanisms"][0]["anchor_angle"] = 0.35
    data["joints"][0]["target"]["mass_range"] = [0.3, 0.8]
    data["adjustment"] = dict(ADJUSTMENT)
    data["friction"] = dict(FRICTION)
    return data


def posed(ev, **changes):
    """The evaluation ``ev`` with its problem changed (its metrics kept), without its payload
    range (the builds alone are timed)."""
    joint = ev.problem.joints[0]
    fixed = replace(joint, target=replace(joint.target, data={k: v for k, v in joint.target.data.items()
                                                               if k != "mass_range"}))
    out = copy.copy(ev)
    out.problem = replace(ev.problem, joints=(fixed,), **changes)
    return out


def main() -> None:
    print(f"load average at start: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (1, 5, 15 min; "
          f"{os.cpu_count()} cores)")
    result = cadcam.design(parse_spec(spec(), str(SPEC)))
    ev, sens = result.evaluation, result.band.sensitivity
    peak = float(np.abs(ev.tau_d).max())
    print(f"\n{SPEC.relative_to(ROOT)} with anchor_angle = 0.35, mass_range = [0.3, 0.8] kg and [adjustment] "
          f"{ADJUSTMENT}, the cable over a pin ({FRICTION}): {result.status}; the target's peak {1e3 * peak:.4g} "
          f"N·mm; the first-order band ± {1e3 * result.band.half_width.max():.4g} N·mm; the friction band "
          f"{1e3 * result.friction.width.max():.4g} N·mm wide at its widest\n")
    print("| adjustment | distribution | as built P50 / P95 | as set P50 / P95 | at best P50 / P95 | stated pose "
          "| builds: wall / CPU [s] |")
    print("|---|---|---|---|---|---|---|")
    screw_only = (("preload_travel", ADJUSTMENT["preload_travel"]),)
    rows, cpu = {}, {}
    cases = [(name, adjustment, distribution, ()) for name, adjustment in (
        ("none", ()), ("screw", screw_only), ("screw and slot", tuple(ADJUSTMENT.items())))
        for distribution in ("uniform", "normal")]
    cases.append(("screw and slot, μ exact", tuple(ADJUSTMENT.items()), "uniform", (("friction", 0.0),)))
    for name, adjustment, distribution, tolerances in cases:
        start = time.process_time()
        builds = B.simulate_builds(posed(ev, adjustments=adjustment, builds=(("distribution", distribution),),
                                         tolerances=tolerances), sens)
        cpu[name, distribution] = time.process_time() - start
        rows[name, distribution] = builds

        def share(stage):
            if stage != "before" and not builds.chosen:
                return "–"
            p50, p95 = builds.percentiles(stage)[:, 0] / peak
            return f"{100 * p50:.2f} / {100 * p95:.2f} %"
        pose = "–" if builds.pose is None else f"{np.degrees(builds.pose[0]):.1f}°"
        print(f"| {name} | {distribution} | {share('before')} | {share('set')} | {share('best')} | {pose} "
              f"| {builds.seconds:.2f} / {cpu[name, distribution]:.2f} |", flush=True)
    alone_rows(ev, sens, peak)
    payloads = result.builds.payloads
    screw_alone = B.payload_settings(ev, sens, [s for s in result.builds.chosen if s.screw])
    print(f"\nPayloads 0.3–0.8 kg, the screw and the slot set for each from exact re-evaluations "
          f"({result.builds.seconds:.1f} s with the 10 000 builds), and the screw alone:\n")
    print("| mass [kg] | screw [mm] | slot [mm] | RMS error / target RMS | largest error / target peak | at a range end "
          "| the screw alone: screw [mm], RMS error |")
    print("|---|---|---|---|---|---|---|")
    slot = next(s for s in result.builds.chosen if not s.screw)
    for p, alone in zip(payloads, screw_alone):
        print(f"| {p['mass']:.2f} | {1e3 * p['settings']['screw 1']:.2f} | {1e3 * p['settings']['slot 1'] / slot.per_metre:.1f} "
              f"| {100 * p['relative_rmse']:.2f} % | {100 * p['max_abs_error'] / (peak * p['mass'] / p['design_mass']):.2f} % "
              f"| {'yes' if p['at_range_end'] else 'no'} | {1e3 * alone['settings']['screw 1']:.2f}, "
              f"{100 * alone['relative_rmse']:.2f} % |", flush=True)
    model_error = exact_check(result)
    print(f"\nThe build model against {EXACT_BUILDS} builds evaluated exactly (cadcam.verify.evaluate), largest "
          f"|τ_model − τ_exact| over the range as a share of the target's peak: as built {100 * model_error[0]:.2g} %, "
          f"at their best settings {100 * model_error[1]:.2g} % (first order alone: {100 * model_error[2]:.2g} % and "
          f"{100 * model_error[3]:.2g} %)")
    builds = rows["screw and slot", "uniform"]
    set95 = builds.percentiles("set")[1, 0] / peak
    screw95 = rows["screw", "uniform"].percentiles("set")[1, 0] / peak
    worst = max(p["relative_rmse"] for p in payloads)
    worst_alone = max(p["relative_rmse"] for p in screw_alone)
    plain = rows["none", "uniform"]
    print_goals([
        ("the tutorial's balancer, its spec's tolerances, each part uniform: P95 of the largest torque error after "
         f"one adjustment ≤ {100 * P95_GOAL:g} % of the target's peak",
         f"{100 * set95:.2f} % (screw and slot, as set by the table; the screw alone {100 * screw95:.2f} %; as built "
         f"{100 * plain.percentiles('before')[1, 0] / peak:.2f} %)", set95 <= P95_GOAL),
        (f"0.3–0.8 kg: every payload within {100 * PAYLOAD_GOAL:g} % RMS of its target after adjusting",
         f"{100 * worst:.2f} % at worst (the screw and the slot; the screw alone {100 * worst_alone:.2f} %)",
         worst <= PAYLOAD_GOAL),
        (f"10 000 builds in ≤ {TIME_GOAL:g} s (wall)", f"{plain.seconds:.2f} s as built, {builds.seconds:.2f} s with "
         f"the screw and the slot (CPU {cpu['none', 'uniform']:.2f} s and {cpu['screw and slot', 'uniform']:.2f} s)",
         builds.seconds <= TIME_GOAL),
    ], "issue 52")


def alone_rows(ev, sens, peak: float) -> None:
    """Print the table of each tolerance alone, the others 0 (its builds' steps made again for
    its tolerances), with the screw and the slot, each part uniform."""
    print("\n| tolerance alone | as built P50 / P95 | as set P50 / P95 | at best P50 / P95 |")
    print("|---|---|---|---|")
    names = list(ev.problem.tolerance)
    for name in names:
        alone = posed(ev, tolerances=tuple((other, 0.0) for other in names if other != name))
        builds = B.simulate_builds(alone, sensitivity(alone, sens.model))
        cells = [" / ".join(f"{100 * v / peak:.2f}" for v in builds.percentiles(stage)[:, 0]) + " %"
                 for stage in ("before", "set", "best")]
        value = ev.problem.tolerance[name]
        amount = f"{100 * value:g} %" if TOLERANCES[name].unit == "ratio" else f"{1e3 * value:g} mm"
        print(f"| {name} ± {amount} | {' | '.join(cells)} |", flush=True)


def exact_check(result) -> tuple[float, float, float, float]:
    """The build model's largest error against :data:`EXACT_BUILDS` builds evaluated exactly, as
    built and at their best settings, and the first-order model's, each a share of the peak."""
    ev, sens = result.evaluation, result.band.sensitivity
    chosen = B.settings(ev.problem, sens.layout)
    model = B.build_model(ev, sens, B.mixed_function(sens.model), [s for s in chosen if not s.screw])[0]
    D = np.concatenate(list(sens.directions.values()), axis=1)
    step = D @ B.draws(1, EXACT_BUILDS, D.shape[1], "uniform")
    adjusted = B.with_settings(step, chosen, B.best_settings(model, step, chosen))
    peak = np.abs(ev.tau_d).max()
    out = []
    for steps in (step, adjusted):
        exact = np.column_stack([(evaluate(*B.built(ev.problem, ev.design, sens.layout, s), grid=ev.grid,
                                           profile=False).tau - ev.tau_d).ravel() for s in steps.T])
        out.append((np.abs(exact - model.error(steps)).max() / peak,
                    np.abs(exact - model.error0[:, None] - model.J @ steps).max() / peak))
    return out[0][0], out[1][0], out[0][1], out[1][1]


if __name__ == "__main__":
    main()
