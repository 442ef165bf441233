"""Where should the idler of the 1-DOF cam go? Radius r and height a0 of the idler centre.

Sweeps the idler radius (cams.1.idler.radius) and vertical offset (cams.1.idler.offset) of
models/johnston2023_1dof.toml (Johnston2023's Sec. 10.1 target with Table 2's springs) on a
6 × 6 grid, five starts per case (studies/idler_placement.toml), and maps the achievable
torque RMSE and the worst convexity margin of each optimum on the fine re-check grid, with the
spec's own placement (r = 20 mm, a0 = 15 mm) marked. Cases that fail, or whose objective is
well above the typical one (a local optimum), are re-solved in this process from their good
neighbours' designs and from a circular start the wire can reach; the maps show the best
re-checked optimum, the report lists what the re-solves changed.

    .venv/bin/python studies/idler_placement.py

Writes out/idler_placement/study.db (resumable), report.md, summary.json and
idler_maps.png; prints the report.
"""
from __future__ import annotations

import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import Normalize

from cadcam import Design, evaluate, optimize
from cadcam.files import atomic_path, write_json, write_text
from cadcam.sweep.study import load_study
from cadcam.sweep.runner import sweep_and_read
from cadcam.solve.transcription import Transcription

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies" / "idler_placement.toml"
OUT = ROOT / "out" / "idler_placement"
MM = 1e3
R_KEY, A_KEY = "cams.1.idler.radius", "cams.1.idler.offset"
SPEC_PLACEMENT = (0.020, 0.015)
#: A limit counts as active on the re-check when its margin is below this [m].
ACTIVE_TOL = 1e-5
#: An optimum whose objective exceeds this multiple of the grid's median is re-solved.
LOCAL_FACTOR = 1.25


def circle_start(problem) -> Design:
    """A circular cam the wire can wrap around an idler at height a0:
    ρ₀ = max(1.2 ρ_min, |a0| − r + 5 mm), pre-extensions at 10 % of travel (as the default)."""
    mech, prof = problem.mechanisms[0], problem.profiles[0]
    rho0 = min(max(1.2 * prof.rho_min, abs(mech.idler_offset) - mech.idler_radius + 0.005), prof.rho_max)
    m = np.zeros(prof.basis.size)
    m[0] = rho0
    return Design([prof.basis], [prof.basis.from_monomial(m)],
                  np.array([0.1 * s.travel for s in problem.springs]))


def active_limits(recheck: dict, n_springs: int) -> list[str]:
    mg, out = recheck["margins"], []
    for j in range(n_springs):
        if mg["travel"][j] < ACTIVE_TOL:
            out.append(f"travel of spring {j + 1}")
        if mg["extension_lower"][j] < ACTIVE_TOL:
            out.append(f"x ≥ 0 of spring {j + 1}")
    for key, name in (("rho_min", "ρ_min"), ("rho_max", "ρ_max")):
        if mg[key][0] < ACTIVE_TOL:
            out.append(name)
    return out


def heat(ax, fig, radii, offsets, values, ok, marks, title, label, norm, fmt="{:.2g}"):
    """Cell map (rows: radius, columns: offset) with numbers and marks; no design: grey ×;
    above the colour range (the † cells): orange."""
    dr, da = np.diff(radii).mean(), np.diff(offsets).mean()
    edges_r = MM * np.r_[radii - dr / 2, radii[-1] + dr / 2]
    edges_a = MM * np.r_[offsets - da / 2, offsets[-1] + da / 2]
    cmap = plt.get_cmap("viridis").copy()
    cmap.set_bad("0.85")
    cmap.set_over("C1")
    im = ax.pcolormesh(edges_a, edges_r, np.ma.masked_where(~ok, values), cmap=cmap, norm=norm,
                       shading="flat")
    fig.colorbar(im, ax=ax, label=label, extend="max")
    for i, r in enumerate(radii):
        for k, a in enumerate(offsets):
            if ok[i, k]:
                shade = float(np.clip(norm(values[i, k]), 0, 1))
                ax.text(MM * a, MM * r, fmt.format(values[i, k]) + marks[i][k], ha="center",
                        va="center", fontsize=7, color="w" if shade < 0.6 else "k")
            else:
                ax.text(MM * a, MM * r, "×", ha="center", va="center", fontsize=14, color="C3")
    ax.plot(MM * SPEC_PLACEMENT[1], MM * SPEC_PLACEMENT[0], marker="s", ms=22, mfc="none", mec="r", mew=2)
    ax.set_xlabel("idler offset a0 [mm]")
    ax.set_ylabel("idler radius r [mm]")
    ax.set_title(title, fontsize=10)


def main() -> None:
    t0 = time.perf_counter()
    s = load_study(STUDY)
    sweep, rows = sweep_and_read(s, OUT / "study.db", workers=2)

    radii = np.array(sorted({r["params"][R_KEY] for r in rows}))
    offsets = np.array(sorted({r["params"][A_KEY] for r in rows}))
    shape = (radii.size, offsets.size)
    cells = {}
    for r in rows:
        ij = (int(np.searchsorted(radii, r["params"][R_KEY])), int(np.searchsorted(offsets, r["params"][A_KEY])))
        ok = r["status"] == "success"
        cells[ij] = {"row": r, "source": "sweep", "ok": ok,
                     "objective": r["metrics"]["objective"] if ok else np.inf,
                     "rmse": MM * r["metrics"]["rmse"][0] if ok else np.nan,
                     "conv": 1e6 * r["recheck"]["convexity_min"][0] if ok else np.nan,
                     "recheck": r["recheck"] if ok else None, "design": r["design"] if ok else None}
    sweep_obj = np.array([[cells[(i, k)]["objective"] for k in range(shape[1])] for i in range(shape[0])])
    median_obj = float(np.median(sweep_obj[np.isfinite(sweep_obj)]))
    sweep_ok = np.isfinite(sweep_obj)

    # re-solve failed and high-objective cells from their typical neighbours and a circle start
    t_re, resolves, tr, start_errors = time.perf_counter(), [], None, []
    for (i, k), c in sorted(cells.items()):
        if c["ok"] and c["objective"] <= LOCAL_FACTOR * median_obj:
            continue
        problem = s.problem(c["row"]["params"]).with_options(multistart=0)
        tr = tr or Transcription(problem)
        starts = [("circle", circle_start(problem))]
        for di, dk in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            nb = cells.get((i + di, k + dk))
            if nb and nb["row"]["status"] == "success" and nb["row"]["metrics"]["objective"] <= LOCAL_FACTOR * median_obj:
                starts.append((f"r = {MM * radii[i + di]:g}, a0 = {MM * offsets[k + dk]:g}",
                               Design.from_dict(nb["row"]["design"], problem)))
        before = (c["row"]["status"], c["objective"], c["rmse"])
        best = None
        for label, start in starts:
            try:
                res = optimize(problem, transcription=tr, start=start)
            except Exception as exc:  # noqa: BLE001 - a failing start is counted in the report
                start_errors.append(f"{type(exc).__name__}: {exc}")
                continue
            if res.status == "success" and (best is None or res.evaluation.metrics.objective < best[1].evaluation.metrics.objective):
                best = (label, res)
        if best and best[1].evaluation.metrics.objective < c["objective"] * (1 - 1e-6):
            label, res = best
            c.update(source=f"re-solve from {label}", ok=True, objective=res.evaluation.metrics.objective,
                     rmse=MM * res.evaluation.metrics.rmse[0],
                     conv=1e6 * res.recheck.metrics.convexity_min[0], recheck=res.recheck.metrics,
                     design=res.design.to_dict())
        resolves.append(((i, k), before, len(starts), c["source"], c["objective"], c["rmse"]))
    t_re = time.perf_counter() - t_re

    ok = np.array([[cells[(i, k)]["ok"] for k in range(shape[1])] for i in range(shape[0])])
    grid = {q: np.array([[cells[(i, k)][q] for k in range(shape[1])] for i in range(shape[0])], dtype=float)
            for q in ("objective", "rmse", "conv")}
    rmse, conv, objective = grid["rmse"], grid["conv"], grid["objective"]
    costly = ok & (objective > LOCAL_FACTOR * median_obj)
    marks = [["†" if costly[i, k] else ("*" if cells[(i, k)]["source"] != "sweep" else "")
              for k in range(shape[1])] for i in range(shape[0])]
    n_springs = len(s.problem(rows[0]["params"]).springs)
    active_count = {}
    for c in cells.values():
        if c["ok"]:
            for name in active_limits(c["recheck"], n_springs):
                active_count[name] = active_count.get(name, 0) + 1
    first = next(c for c in cells.values() if c["ok"])
    p0 = s.problem(first["row"]["params"])
    peak = MM * float(np.max(np.abs(evaluate(p0, Design.from_dict(first["design"], p0)).tau_d)))

    fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), constrained_layout=True)
    typical = ok & ~costly
    heat(axes[0], fig, radii, offsets, rmse, ok, marks,
         "achievable torque RMSE [N·mm]\n(colour range: cells without †; orange: above it)",
         "RMSE [N·mm]", Normalize(np.nanmin(rmse[typical]), np.nanmax(rmse[typical])), fmt="{:.2g}")
    heat(axes[1], fig, radii, offsets, conv, ok, marks,
         "worst convexity margin on the fine re-check [mm²]\n(Eq. 40; the NLP requires ≥ 1e-3·ρ_min² = 0.1 mm²)",
         "min(ρ² + 2ρ′² − ρρ″) [mm²]", Normalize(np.nanmin(conv[typical]), np.nanmax(conv[typical])),
         fmt="{:.0f}")
    fig.suptitle("1-DOF cam (Johnston2023 Sec. 10.1, Table 2 springs), idler placement. Red square: the spec's "
                 "r = 20 mm, a0 = 15 mm; *: improved by a re-solve; †: objective > "
                 f"{LOCAL_FACTOR:g}× median; ×: no design", fontsize=10)
    with atomic_path(OUT / "idler_maps.png") as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)

    def grid_table(values, fmt):
        out = ["| r \\ a0 [mm] | " + " | ".join(f"{MM * a:g}" for a in offsets) + " |",
               "|---" * (offsets.size + 1) + "|"]
        for i, r in enumerate(radii):
            row = []
            for k in range(offsets.size):
                txt = (fmt.format(values[i, k]) + marks[i][k]) if ok[i, k] else \
                    f"× ({cells[(i, k)]['row']['status']})"
                if abs(r - SPEC_PLACEMENT[0]) < 1e-12 and abs(offsets[k] - SPEC_PLACEMENT[1]) < 1e-12:
                    txt = f"**{txt}**"
                row.append(txt)
            out.append(f"| {MM * r:g} | " + " | ".join(row) + " |")
        return out

    n_ok, n_sweep_ok = int(ok.sum()), int(sweep_ok.sum())
    # share of the objective that is tracking: w1·∫(τ − τ_d)² ≈ w1·RMSE²·Δθ (trapezoid vs mean)
    joint = p0.joints[0]
    share = joint.tracking_weight * (rmse / MM) ** 2 * np.ptp(joint.theta_range) / objective
    i_best, k_best = np.unravel_index(np.nanargmin(rmse), shape)
    spec_cell = (int(np.argmin(abs(radii - SPEC_PLACEMENT[0]))), int(np.argmin(abs(offsets - SPEC_PLACEMENT[1]))))
    lines = [
        "# Idler placement for the 1-DOF cam", "",
        "Generated by `.venv/bin/python studies/idler_placement.py` from `studies/idler_placement.toml`. "
        "Problem: `models/johnston2023_1dof.toml` (Johnston2023 Sec. 10.1 target τ_d = 0.08θ² on [0°, 90°], "
        "Table 2's springs 1 on the wire and 2 on the idler platform, ρ ∈ [10, 100] mm, w1 = 10, "
        f"w2 = w3 = 1, the `{s.problem(rows[0]['params']).torque_model}` torque model, cubic Chebyshev cam, five starts per case) with the idler radius r "
        "(`cams.1.idler.radius`) and the height a0 of its centre (`cams.1.idler.offset`) varied on a "
        f"{radii.size} × {offsets.size} grid. The spec's placement (r = 20 mm, a0 = 15 mm) is in bold.", "",
        f"Sweep: {sweep['cases']} cases, {sweep['ran']} solved now in {sweep['wall_time_s']:.1f} s on 2 "
        f"workers, {sweep['skipped']} already in `study.db`; statuses {sweep['statuses']}. "
        f"Re-solves (below): {len(resolves)} cells, {t_re:.1f} s.", "",
        "Marks: `*` the value comes from a re-solve that beat the sweep's optimum (or replaced its failure); "
        f"`†` the best objective found stays above {LOCAL_FACTOR:g}× the sweep's median ({median_obj:.4g}), "
        "so this placement itself costs objective; `×` no design. Every map shows, per cell, the "
        "re-checked optimum with the lowest objective (Eq. 46), which is not always the lowest RMSE.", "",
        "## Achievable torque RMSE [N·mm] (design grid, 46 angles)", ""]
    lines += grid_table(rmse, "{:.3g}")
    lines += ["", "## Objective (Eq. 46: 10·∫(τ − τ_d)² + ∫|∂τ/∂k₁| + ∫|∂τ/∂k₂|, SI units)", ""]
    lines += grid_table(objective, "{:.4g}")
    lines += ["", "## Worst convexity margin on the fine re-check [mm²]", "",
              "The minimum over the whole wrapped range of ρ² + 2ρ′² − ρρ″ (Johnston2023 Eq. 40) on the "
              "451-angle re-check; the NLP requires at least ε·ρ_min² = 1e-3 × (10 mm)² = 0.1 mm², and a "
              "circle of radius ρ has ρ² (100 mm² at ρ_min).", ""]
    lines += grid_table(conv, "{:.0f}")
    lines += ["", "## Which limits hold the optima back", "",
              f"Limits with a re-check margin below {ACTIVE_TOL * MM:g} mm, counted over the {n_ok} "
              "designs in the maps: "
              + (", ".join(f"{k} ({v})" for k, v in sorted(active_count.items(), key=lambda kv: -kv[1]))
                 or "none") + ". Convexity is never active (smallest margin "
              f"{np.nanmin(conv):.0f} mm² against 0.1 mm² required).", ""]

    lines += ["## Failures and re-solves", ""]
    fails = [c for c in cells.values() if c["row"]["status"] != "success"]
    lines += [f"The sweep gave {n_sweep_ok} of {len(rows)} re-checked optima; "
              + (", ".join(f"r = {MM * c['row']['params'][R_KEY]:g} mm, a0 = {MM * c['row']['params'][A_KEY]:g} mm: "
                           f"{c['row']['status']} ({'; '.join((c['row']['recheck'] or {}).get('violations') or []) or c['row']['error'] or c['row']['message']})"
                           for c in fails)
                 or "no failures") + ".", ""]
    if resolves:
        lines += ["Each failed or high-objective cell was re-solved (one start each, same NLP) from a circle "
                  "ρ₀ = max(1.2 ρ_min, |a0| − r + 5 mm) and from the design of every 4-neighbour whose sweep "
                  "optimum is typical; the best re-checked optimum is kept if its objective is lower. "
                  f"{len(start_errors)} of these starts raised"
                  + (f" ({'; '.join(sorted(set(start_errors)))})" if start_errors else "") + ".", "",
                  "| r [mm] | a0 [mm] | sweep: status, objective, RMSE [N·mm] | starts | kept | objective | RMSE [N·mm] |",
                  "|---|---|---|---|---|---|---|"]
        for (i, k), (st, ob, rm), n, src, ob2, rm2 in resolves:
            lines.append(f"| {MM * radii[i]:g} | {MM * offsets[k]:g} | {st}, {ob:.4g}, {rm:.3g} | {n} | {src} | "
                         f"{ob2:.4g} | {rm2:.3g} |")
        lines.append("")
    if fails:
        why = []
        if any(c["row"]["status"] == "recheck_failed" for c in fails):
            why.append("`recheck_failed`: IPOPT converged, but on the 451-angle re-check the optimum breaks "
                       "the limit named above (between design-grid points, or through the NLP's coarser "
                       "quadrature)")
        if any(c["row"]["status"] == "error" for c in fails):
            why.append("`error`: the case raised (the message above) and kept nothing of its solve")
        if any(c["row"]["status"] not in ("recheck_failed", "error") for c in fails):
            why.append("any other status: IPOPT's own verdict on the best of the five starts")
        lines += ["What the failures are: " + "; ".join(why) + ". A successful re-solve from another start "
                  "(table above) shows the placement itself is feasible.", ""]

    lines += ["## Findings", "",
              f"- {n_ok} of {len(rows)} placements have a re-checked optimum ({n_sweep_ok} from the sweep alone). "
              f"Best RMSE {rmse[i_best, k_best]:.3g} N·mm at r = {MM * radii[i_best]:g} mm, "
              f"a0 = {MM * offsets[k_best]:g} mm; the spec's placement gives {rmse[spec_cell]:.3g} N·mm; "
              f"over the cells without † the RMSE spans {np.nanmin(rmse[typical]):.3g} … "
              f"{np.nanmax(rmse[typical]):.3g} N·mm, i.e. {100 * np.nanmin(rmse[typical]) / peak:.2f} … "
              f"{100 * np.nanmax(rmse[typical]) / peak:.2f} % of the target's {peak:.0f} N·mm peak.",
              "- RMSE against radius r = " + ", ".join(f"{MM * r:g}" for r in radii) + " mm at each offset "
              "(N·mm): " + "; ".join(f"a0 = {MM * a:g}: " + ", ".join(
                  (f"{rmse[i, k]:.2g}{marks[i][k]}" if ok[i, k] else "×") for i in range(radii.size))
                  for k, a in enumerate(offsets)) + ".",
              f"- Without † the objective hardly moves ({np.nanmin(objective[typical]):.4g} … "
              f"{np.nanmax(objective[typical]):.4g}): it is dominated by the spec's sensitivity terms "
              "(w2 = w3 = 1), so within this window the placement changes the tracking RMSE only at the "
              "level of a few tenths of a percent of the target; the active limits (above) are the "
              "springs and ρ_min, and convexity has a wide margin everywhere."
              + (f" {int(costly.sum())} placement(s) cost objective even after the re-solves (†)."
                 if costly.any() else ""),
              f"- The tracking term 10·∫(τ − τ_d)² is at most {100 * np.nanmax(share[typical]):.1f} % of the "
              "objective in the cells without †: the optima are set by the sensitivity terms, and which "
              "of their nearly equal local optima IPOPT lands in moves the RMSE as much as the "
              "placement does (compare the re-solves above). Read the RMSE map as what the spec's "
              "weights happen to give, not as the best tracking a placement allows.",
              "", "## Figures", "",
              "- `idler_maps.png`: RMSE and worst convexity margin, cell = grid point, "
              "red square = the spec's placement, marks as above; the colour range covers the cells "
              "without †, orange cells lie above it.", "",
              f"Total script time {time.perf_counter() - t0:.1f} s."]
    text = "\n".join(lines) + "\n"
    write_text(OUT / "report.md", text)

    def clean(a):
        return [[float(v) if ok[i, k] and np.isfinite(v) else None for k, v in enumerate(row)]
                for i, row in enumerate(a)]

    write_json(OUT / "summary.json", {
        "sweep": sweep, "radius_m": radii.tolist(), "offset_m": offsets.tolist(),
        "rmse_Nmm": clean(rmse), "objective": clean(objective), "convexity_min_mm2": clean(conv),
        "source": [[cells[(i, k)]["source"] for k in range(shape[1])] for i in range(shape[0])],
        "median_sweep_objective": median_obj})
    print(text)
    print(f"report: {OUT / 'report.md'}")


if __name__ == "__main__":
    main()
