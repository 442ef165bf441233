"""How much tracking does robustness to spring-rate error cost on Johnston2023's RR arm?

Solves the RR arm of Johnston2023 (models/johnston2023_rr_arm.toml, tracking weights 1) for one
sensitivity weight w on all springs at a time (w = 0 and log-spaced from 1 to 1e4; see
studies/sensitivity_pareto.toml), then plots the front of torque RMSE against

* the deviation of Johnston2023's Table 5: RMSE between nominal torques and torques with every
  spring rate +10 % — which is exactly 10 % of the RMS torque, since τ is linear in the rates;
* the deviation when one spring at a time is 10 % stiffer (the worst of the three), which does
  measure robustness,

with the published designs of Tables 3 and 4 placed on both fronts, evaluated under the torque
model the paper used (``force-as-printed``: Eq. 19–21 with Eq. 33 as printed) and under the
model the front is solved in (``energy``, τ = ∂V/∂θ, the spec's default). Per-cam values are
combined as the RMS over both cams.

    .venv/bin/python studies/sensitivity_pareto.py

Writes out/sensitivity_pareto/study.db (resumable: a re-run only solves missing cases),
report.md, summary.json and pareto_fronts.png, deviation_vs_weight.png; prints the report.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from cadcam import Design, evaluate, load_spec
from cadcam.verify.evaluate import rate_deviation
from cadcam.files import atomic_path, write_json, write_text
from cadcam.outputs.plots import pareto_front
from cadcam.sweep.study import load_study
from cadcam.sweep.runner import sweep_and_read

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies" / "sensitivity_pareto.toml"
OUT = ROOT / "out" / "sensitivity_pareto"
MM = 1e3
FACTOR = 1.10
#: Torque models the published designs are evaluated under: the paper's, then the front's.
PAPER_MODEL, FRONT_MODEL = "force-as-printed", "energy"
PUBLISHED = [("Table 3", "johnston2023_table3_design.json", (351.38, 102.34)),
             ("Table 4", "johnston2023_table4_design.json", (323.52, 71.92))]


def rms(values) -> float:
    """RMS over cams of per-cam RMS values (= RMS over every torque sample of both cams)."""
    return float(np.sqrt(np.mean(np.square(values))))


def score(problem, design) -> dict:
    """Tracking and +10 % rate deviations [N·m] of ``design`` (per cam and RMS over cams)."""
    nominal = evaluate(problem, design)
    all_rates = rate_deviation(problem, design, FACTOR)
    single = [rate_deviation(problem, design, FACTOR, {j}) for j in range(len(problem.springs))]
    single_rms = [rms(s) for s in single]
    return {"rmse": nominal.metrics.rmse, "rmse_rms": rms(nominal.metrics.rmse),
            "max_abs_error": nominal.metrics.max_abs_error,
            "all_rates": all_rates.tolist(), "all_rates_rms": rms(all_rates),
            "single": [s.tolist() for s in single], "single_rms": single_rms,
            "worst_single_rms": max(single_rms), "worst_spring": int(np.argmax(single_rms)) + 1,
            # τ is linear in k: the all-rates deviation is (FACTOR − 1) × the RMS torque
            "linearity": float(rms(all_rates) / ((FACTOR - 1) * rms(np.sqrt(np.mean(nominal.tau ** 2, axis=1))))),
            "extension_max": nominal.metrics.extension_max}


def weight_of(params) -> float:
    return float(params["cams.*.sensitivity_weights"][0])


def front_labels(points: np.ndarray) -> set[int]:
    return {int(k) for k in pareto_front(points)}


def _annotate_sparse(ax, cases, pts):
    """Label points with their w, skipping those too close (in log space) to a labelled one."""
    done = []
    for c, (x, y) in zip(cases, pts):
        if all(abs(np.log10(x / a)) > 0.04 or abs(np.log10(y / b)) > 0.04 for a, b in done):
            ax.annotate(f"w={c['w']:g}", (x, y), textcoords="offset points", xytext=(5, 4), fontsize=7)
            done.append((x, y))


def figures(cases, published):
    from matplotlib.ticker import FuncFormatter, NullFormatter

    fig, axes = plt.subplots(1, 2, figsize=(13, 5.4), constrained_layout=True)
    ws = np.array([c["w"] for c in cases])
    colour = {"Table 3": "C3", "Table 4": "C4"}
    for ax, key, label in ((axes[0], "all_rates_rms", "all rates +10 % (Table 5)"),
                           (axes[1], "worst_single_rms", "worst single spring +10 %")):
        pts = np.array([[MM * c["rmse_rms"], MM * c[key]] for c in cases])
        sc = ax.scatter(pts[:, 0], pts[:, 1], c=np.log10(np.where(ws > 0, ws, 0.1)), cmap="viridis",
                        vmin=-1, vmax=4, zorder=3)
        _annotate_sparse(ax, cases, pts)
        front = pts[pareto_front(pts)]
        front = front[np.argsort(front[:, 0])]
        ax.plot(front[:, 0], front[:, 1], "r-", lw=1, label=f"cadcam Pareto front ({FRONT_MODEL} model)", zorder=2)
        for name, model, s in published:
            ax.scatter(MM * s["rmse_rms"], MM * s[key], marker="s" if model == PAPER_MODEL else "D",
                       s=70, facecolors="none", edgecolors=colour[name], linewidths=1.8, zorder=4,
                       label=f"published {name}, {model} model")
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xticks([200, 300, 500, 1000, 2000])
        ax.set_xlabel("torque RMSE, RMS over both cams [N·mm]")
        ax.set_ylabel(f"deviation, {label} [N·mm]")
        ax.set_title(f"tracking vs {label}", fontsize=10)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=7, loc="lower left")
    cb = fig.colorbar(sc, ax=axes, shrink=0.85)
    cb.set_label("log10 w (w = 0 drawn at −1)")
    fig.suptitle("Johnston2023 RR arm: one cadcam optimum per sensitivity weight w (RMS over both cams)",
                 fontsize=11)
    with atomic_path(OUT / "pareto_fronts.png") as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7.5, 5))
    order = np.argsort(ws)
    x = ws[order]
    ax.plot(x, [MM * cases[k]["rmse_rms"] for k in order], "k-o", label="torque RMSE")
    ax.plot(x, [MM * cases[k]["all_rates_rms"] for k in order], "C0--s", label="all rates +10 %")
    for j in range(len(cases[0]["single_rms"])):
        ax.plot(x, [max(MM * cases[k]["single_rms"][j], 1e-3) for k in order], f"C{j + 1}-^", lw=1,
                label=f"spring {j + 1} alone +10 %")
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_yscale("log")
    ax.set_ylim(bottom=10)
    ax.set_xlabel("sensitivity weight w (all springs, both cams; symlog axis)")
    ax.set_ylabel("RMS over both cams [N·mm] (values < 10 clipped)")
    ax.set_title(f"RR arm (Johnston2023), tracking weight 1, {FRONT_MODEL} torque model")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    with atomic_path(OUT / "deviation_vs_weight.png") as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)


def pair(v, digits=1):
    return " / ".join(f"{MM * x:.{digits}f}" for x in v)


def main() -> None:
    t0 = time.perf_counter()
    s = load_study(STUDY)
    sweep, rows = sweep_and_read(s, OUT / "study.db", workers=2)

    cases, failed = [], []
    for r in rows:
        w = weight_of(r["params"])
        if r["status"] != "success":
            failed.append((w, r["status"], r["error"] or r["message"]))
            continue
        problem = s.problem(r["params"])
        sc = score(problem, Design.from_dict(r["design"], problem))
        cases.append({"w": w, "iterations": r["iterations"], "solve_time_s": r["solve_time_s"], **sc})
    cases.sort(key=lambda c: c["w"])

    base = load_spec(s.base)
    published = []
    for name, file, _ in PUBLISHED:
        data = json.loads((ROOT / "models" / file).read_text())
        for model in (PAPER_MODEL, FRONT_MODEL):
            p = base.with_torque_model(model)
            published.append((name, model, score(p, Design.from_dict(data, p))))

    figures(cases, published)

    pts_all = np.array([[c["rmse_rms"], c["all_rates_rms"]] for c in cases])
    pts_one = np.array([[c["rmse_rms"], c["worst_single_rms"]] for c in cases])
    on_all, on_one = front_labels(pts_all), front_labels(pts_one)

    def dominated_by(sc, key):
        """Weights of the cadcam optima at least as good in both coordinates as ``sc``."""
        return [f"{c['w']:g}" for c in cases if c["rmse_rms"] <= sc["rmse_rms"] and c[key] <= sc[key]]

    lines = [
        "# Sensitivity weight vs tracking: the Pareto front of Johnston2023's RR arm", "",
        "Generated by `.venv/bin/python studies/sensitivity_pareto.py` from "
        "`studies/sensitivity_pareto.toml`. Problem: `models/johnston2023_rr_arm.toml` (Johnston2023, "
        "Sec. 10, Tables 1–2) with tracking weights w1 = w2 = 1 and one sensitivity weight w on "
        "all three springs of both cams (w3 … w8 of Eq. 47); the spec's torque model "
        f"(`{s.problem(rows[0]['params']).torque_model}`, τ = ∂V/∂θ), cubic "
        "Chebyshev cams, 46 × 46 grid. Torques in N·mm. **Per-cam values are combined as the RMS "
        "over both cams**, sqrt((v₁² + v₂²)/2), i.e. the RMS over all 2 × 46² torque samples.", "",
        f"Sweep: {sweep['cases']} cases, {sweep['ran']} solved now in {sweep['wall_time_s']:.1f} s "
        f"on 2 workers, {sweep['skipped']} already in `study.db`; statuses {sweep['statuses']}.", "",
        "## What the two deviations measure", "",
        f"*All rates +10 %* (Johnston2023, Table 5): τ_i = Σ_j (k_j x_j + F0_j) a_ij with no preloads "
        f"(F0 = {max(sp.preload for sp in base.springs):g} N here) is linear in the rates, so "
        f"raising every rate by 10 % scales every torque by 1.1 and the deviation is exactly 10 % "
        f"of the design's RMS torque (checked: deviation / (0.1 × RMS τ) = "
        f"{min(c['linearity'] for c in cases + [p[2] for p in published]):.6f} … "
        f"{max(c['linearity'] for c in cases + [p[2] for p in published]):.6f} over every design "
        "below, both torque models). It therefore rewards designs that produce *less torque*, "
        "i.e. that track the target worse, and cannot tell a robust design from one that cancels "
        "springs against each other. *One spring at a time +10 %* can: the table gives each "
        "spring's deviation and the front uses the worst of the three.", "",
        "## cadcam's optima, one per weight", "",
        "| w | RMSE cam 1 / cam 2 | RMSE (RMS) | all +10 % cam 1 / cam 2 | all +10 % (RMS) | "
        "spring 1 / 2 / 3 alone +10 % (RMS) | worst single | on front (all / single) | spring max [mm] | iterations | solve [s] |",
        "|---|---|---|---|---|---|---|---|---|---|---|"]
    for k, c in enumerate(cases):
        lines.append(
            f"| {c['w']:g} | {pair(c['rmse'])} | {MM * c['rmse_rms']:.1f} | {pair(c['all_rates'])} | "
            f"{MM * c['all_rates_rms']:.1f} | {' / '.join(f'{MM * v:.1f}' for v in c['single_rms'])} | "
            f"{MM * c['worst_single_rms']:.1f} (spring {c['worst_spring']}) | "
            f"{'yes' if k in on_all else 'no'} / {'yes' if k in on_one else 'no'} | "
            f"{pair(c['extension_max'], 1)} | {c['iterations']} | {c['solve_time_s']:.2f} |")
    if failed:
        lines += ["", "Failed cases: " + "; ".join(f"w = {w:g}: {st} ({msg})" for w, st, msg in failed)]
    else:
        lines += ["", "Every case converged and passed the fine (451 × 451) re-check."]

    lines += ["", "## The published designs on the same axes", "",
              "Tables 3 (Sec. 10.4, no sensitivity terms) and 4 (Sec. 10.5, w = 1000 with w1 = w2 = 1) "
              "evaluated on the same problem under the torque model the paper used (`force-as-printed`: "
              "Eq. 19–21 with Eq. 33 as printed; what its Table 5 reports, in parentheses) and under "
              "`energy` (τ = ∂V/∂θ, the model of cadcam's front, so the like-for-like comparison). The last column lists the "
              "weights whose cadcam optimum is at least as good in both coordinates, for the "
              "all-rates and for the worst-single-spring front.", "",
              "| design | torque model | RMSE cam 1 / cam 2 | RMSE (RMS) | all +10 % cam 1 / cam 2 (paper's Table 5) | "
              "all +10 % (RMS) | spring 1 / 2 / 3 alone +10 % (RMS) | worst single | dominated by cadcam w (all / single) |",
              "|---|---|---|---|---|---|---|---|---|"]
    paper5 = {name: t5 for name, _, t5 in PUBLISHED}
    for name, model, sc in published:
        dom = [", ".join(dominated_by(sc, key)) or "none" for key in ("all_rates_rms", "worst_single_rms")]
        lines.append(
            f"| {name} | {model} | {pair(sc['rmse'])} | {MM * sc['rmse_rms']:.1f} | "
            f"{pair(sc['all_rates'])} ({paper5[name][0]} / {paper5[name][1]}) | {MM * sc['all_rates_rms']:.1f} | "
            f"{' / '.join(f'{MM * v:.1f}' for v in sc['single_rms'])} | "
            f"{MM * sc['worst_single_rms']:.1f} (spring {sc['worst_spring']}) | {dom[0]} / {dom[1]} |")

    best = min(c["rmse_rms"] for c in cases)
    near = [f"{c['w']:g}" for c in cases if c["rmse_rms"] <= best + 0.5e-3]
    robust = min(cases, key=lambda c: c["worst_single_rms"])
    c1000 = next((c for c in cases if c["w"] == 1000.0), None)
    first, penult = cases[0], cases[-2] if len(cases) > 1 else cases[0]
    k = [sp.rate for sp in base.springs]
    lines += ["", "## Findings", "",
              f"- Best tracking: RMSE {MM * best:.1f} N·mm (RMS over cams) for w in {{{', '.join(near)}}} "
              f"(within 0.5 N·mm): up to w = {near[-1]} the sensitivity terms cost no tracking.",
              f"- Over w = {cases[0]['w']:g} … {cases[-1]['w']:g} the torque RMSE goes "
              f"{MM * cases[0]['rmse_rms']:.1f} → {MM * cases[-1]['rmse_rms']:.1f} N·mm, the all-rates "
              f"deviation {MM * cases[0]['all_rates_rms']:.1f} → {MM * cases[-1]['all_rates_rms']:.1f} N·mm and "
              f"the worst single spring {MM * cases[0]['worst_single_rms']:.1f} → "
              f"{MM * cases[-1]['worst_single_rms']:.1f} N·mm (smallest: w = {robust['w']:g}).",
              f"- Per spring, w = {first['w']:g} → {penult['w']:g}: "
              + "; ".join(f"spring {j + 1} (k = {k[j]:g} N/m) {MM * first['single_rms'][j]:.1f} → "
                          f"{MM * penult['single_rms'][j]:.1f} N·mm" for j in range(len(k)))
              + ". Eq. 47 weighs ∫|∂τ/∂k_j| [m²], while a 10 % rate error moves τ by 0.1·k_j·∂τ/∂k_j, "
              "so one weight for all springs penalises a newton-metre of deviation caused by the stiff "
              f"spring 2 {k[1] / k[0]:.1f}× and {k[1] / k[2]:.1f}× less than one caused by springs 1 and 3: "
              f"the worst single spring (spring {first['worst_spring']}) improves only "
              f"{MM * first['worst_single_rms']:.1f} → {MM * penult['worst_single_rms']:.1f} N·mm up to "
              f"w = {penult['w']:g}"
              + (f"; at w = {cases[-1]['w']:g} the optimum gives up spring 2 (largest extension "
                 f"{MM * cases[-1]['extension_max'][1]:.3f} mm) and the RMSE explodes"
                 if cases[-1]["extension_max"][1] < 1e-4 else "")
              + ". Weights proportional to k_j would target relative rate errors evenly."]
    if c1000:
        lines.append(f"- Johnston2023's Sec. 10.5 weight (w = 1000): RMSE {MM * c1000['rmse_rms']:.1f} N·mm, "
                     f"all-rates {MM * c1000['all_rates_rms']:.1f} N·mm, worst single "
                     f"{MM * c1000['worst_single_rms']:.1f} N·mm.")
    for name, model, sc in published:
        if model != FRONT_MODEL:
            continue
        doms = [bool(dominated_by(sc, key)) for key in ("all_rates_rms", "worst_single_rms")]
        lines.append(f"- Published {name} under the {FRONT_MODEL} model (RMSE {MM * sc['rmse_rms']:.1f}, all-rates "
                     f"{MM * sc['all_rates_rms']:.1f}, worst single {MM * sc['worst_single_rms']:.1f} N·mm): "
                     + ("dominated by a cadcam optimum on " + " and ".join(
                         n for n, d in zip(("the all-rates front", "the single-spring front"), doms) if d)
                        if any(doms) else "dominated by none of cadcam's optima")
                     + ". The swept optima minimise Eq. 47 (∫err² + w Σ∫|∂τ/∂k_j|), not the plotted "
                     "deviations, so a design can lie beyond this front.")
    for name, _, _ in PUBLISHED:
        by_model = {m: sc for n, m, sc in published if n == name}
        paper, front = by_model[PAPER_MODEL], by_model[FRONT_MODEL]
        lines.append(f"- Published {name}: RMSE {MM * paper['rmse_rms']:.1f} N·mm under {PAPER_MODEL} (the "
                     f"model it was optimised in) against {MM * front['rmse_rms']:.1f} N·mm under "
                     f"{FRONT_MODEL}, the torque the mechanism really produces.")
    lines += [f"- cadcam's front is computed under the {FRONT_MODEL} model only.",
              "", "## Figures", "",
              "- `pareto_fronts.png`: torque RMSE against the all-rates deviation (left) and against the "
              "worst single-spring deviation (right); cadcam's optima coloured by log10 w with their "
              "Pareto front, the published designs as squares (force-as-printed) and diamonds (energy).",
              "- `deviation_vs_weight.png`: RMSE and each deviation against w.", "",
              f"Total script time {time.perf_counter() - t0:.1f} s."]
    text = "\n".join(lines) + "\n"
    write_text(OUT / "report.md", text)
    write_json(OUT / "summary.json", {"sweep": sweep, "cases": cases,
                                      "published": [{"design": n, "torque_model": m, **sc}
                                                    for n, m, sc in published]})
    print(text)
    print(f"report: {OUT / 'report.md'}")


if __name__ == "__main__":
    main()
