"""Does the Chebyshev basis lift Johnston2023's n ≤ 7 limit on the cam's polynomial order?

Johnston2023 (Sec. 6) keeps its monomial cams at n ≤ 7 because of the monomial basis's poor
conditioning at high powers. This study solves the 1-DOF problem (models/johnston2023_1dof.toml)
for n = 3 … 9 in the monomial and the Chebyshev basis (studies/basis_order.toml) and the same
grid for both cams of the RR arm (models/johnston2023_rr_arm.toml, Sec. 10.4 weights), and
reports RMSE, solve time, iterations and failures per basis and order, how far apart the two
bases' optima are, and the condition numbers of the two bases' Vandermonde-type matrices on the
design interval.

    .venv/bin/python studies/basis_order.py

Writes out/basis_order/study.db and rr_arm.db (resumable), report.md, summary.json and
basis_order.png; prints the report.
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.polynomial import chebyshev as C

from cadcam import Design
from cadcam.mechanisms.base import departure_solver
from cadcam.files import atomic_path, write_json, write_text
from cadcam.optimize import default_start, solve
from cadcam.sweep.study import Study, load_study
from cadcam.sweep.runner import read_rows, run_sweep
from cadcam.solve.transcription import Transcription

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies" / "basis_order.toml"
RR_SPEC = ROOT / "models" / "johnston2023_rr_arm.toml"
OUT = ROOT / "out" / "basis_order"
MM = 1e3
BASES = ("monomial", "chebyshev")
#: Samples of the design interval for the condition numbers (the spec's convexity_points).
COND_POINTS = 120


def rr_study(study: Study) -> Study:
    """The same grid for every cam of the RR arm (``cams.1.`` keys become ``cams.*.``)."""
    return dataclasses.replace(
        study, name=f"{study.name}_rr_arm", base=RR_SPEC, variant=None,
        origin=f"{study.origin} (RR arm)",
        parameters=[dataclasses.replace(p, key=p.key.replace("cams.1.", "cams.*.", 1)) for p in study.parameters])


def condition_numbers(domain, orders) -> dict:
    """cond₂ of V (COND_POINTS × (n+1)) on [0, φ_hi]: monomial φ^k and Chebyshev T_k(u)."""
    lo, hi = domain
    phi = np.linspace(lo, hi, COND_POINTS)
    u = (2 * phi - (lo + hi)) / (hi - lo)
    return {n: {"monomial": float(np.linalg.cond(np.vander(phi, n + 1, increasing=True))),
                "chebyshev": float(np.linalg.cond(C.chebvander(u, n)))} for n in orders}


def table(path, study):
    """Rows of one sweep keyed by (basis, order), with designs and the spread of ρ between bases."""
    study_dict, rows = read_rows(path)
    s = Study.from_dict(study_dict)
    out = {}
    for r in rows:
        basis = r["params"][next(k for k in r["params"] if k.endswith(".basis"))]
        order = int(r["params"][next(k for k in r["params"] if k.endswith(".order"))])
        ok = r["status"] == "success"
        m = r["metrics"] or {}
        out[(basis, order)] = {
            "status": r["status"], "ok": ok,
            "message": r["error"] or r["message"],
            "rmse": [MM * v for v in m.get("rmse", [])],
            "rmse_rms": MM * float(np.sqrt(np.mean(np.square(m["rmse"])))) if m.get("rmse") else np.nan,
            "objective": m.get("objective", np.nan),
            "iterations": r["iterations"], "solve_time_s": r["solve_time_s"],
            "build_time_s": r["build_time_s"], "wall_time_s": r["wall_time_s"],
            "design": Design.from_dict(r["design"], s.problem(r["params"])) if r["design"] else None,
            "domain": s.problem(r["params"]).profiles[0].basis.domain}
    # the largest |ρ_monomial − ρ_chebyshev| over the design interval of every cam [mm]
    for order in sorted({k[1] for k in out}):
        a, b = out.get(("monomial", order)), out.get(("chebyshev", order))
        if a and b and a["design"] and b["design"]:
            gap = 0.0
            for i in range(len(a["design"].bases)):
                phi = np.linspace(*a["domain"], 400)
                ra = np.polynomial.polynomial.polyval(phi, a["design"].monomial(i))
                rb = np.polynomial.polynomial.polyval(phi, b["design"].monomial(i))
                gap = max(gap, float(np.max(np.abs(ra - rb))))
            a["gap_mm"] = b["gap_mm"] = MM * gap
    return out


def diagnose(path, res) -> None:
    """Re-solve every failed case in this process to see what IPOPT itself returned (a case
    recorded as ``error`` keeps nothing of its solve) and how many design-grid angles the
    evaluation's tangency rootfinder cannot solve at that point (NaN)."""
    study_dict, rows = read_rows(path)
    s = Study.from_dict(study_dict)
    for r in rows:
        key = (r["params"][next(k for k in r["params"] if k.endswith(".basis"))],
               int(r["params"][next(k for k in r["params"] if k.endswith(".order"))]))
        if res[key]["ok"]:
            continue
        problem = s.problem(r["params"])
        sol = solve(Transcription(problem), problem, default_start(problem))
        nan = 0
        for mech, sl in zip(problem.mechanisms, problem.profile_slices()):
            structure = (type(mech), tuple(sol.design.bases[sl]))
            theta = np.concatenate([[mech.reference_angle], problem.joints[mech.joint].grid(problem.options.grid)])
            c = np.concatenate([np.asarray(v, dtype=float) for v in sol.design.coefficients[sl]])
            z, _ = departure_solver(structure).solve(theta, c, mech.parameter_values())
            nan += int(np.isnan(z).any(axis=0).sum())
        res[key]["ipopt"] = {"return_status": sol.return_status, "iterations": sol.iterations,
                             "objective": sol.objective, "nan_tangencies": nan}


def section(title, res, orders, n_cams):
    lines = [f"### {title}", "",
             "| n | basis | status | RMSE [N·mm]" + (" cam 1 / cam 2 (RMS)" if n_cams > 1 else "")
             + " | objective | iterations | solve [s] | build [s] | max \\|ρ_mono − ρ_cheb\\| [mm] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for n in orders:
        for b in BASES:
            c = res.get((b, n))
            if c is None:
                continue
            if c["ok"] or c["rmse"]:
                rm = " / ".join(f"{v:.3g}" for v in c["rmse"]) + (f" ({c['rmse_rms']:.3g})" if n_cams > 1 else "")
            else:
                rm = "—"
            status = c["status"] if c["ok"] else f"{c['status']}: {c['message']}"
            it = "—" if c["iterations"] is None else c["iterations"]
            st = "—" if c["solve_time_s"] is None else f"{c['solve_time_s']:.2f}"
            bt = "—" if c["build_time_s"] is None else f"{c['build_time_s']:.2f}"
            lines.append(f"| {n} | {b} | {status} | {rm} | "
                         f"{'—' if not np.isfinite(c['objective']) else format(c['objective'], '.4g')} | "
                         f"{it} | {st} | {bt} | {c.get('gap_mm', float('nan')):.2g} |")
    lines.append("")
    summary = []
    for b in BASES:
        cases = [res[(b, n)] for n in orders if (b, n) in res]
        fails = [n for n in orders if (b, n) in res and not res[(b, n)]["ok"]]
        summary.append(f"{b}: {len(fails)}/{len(cases)} failed" + (f" (n = {', '.join(map(str, fails))})" if fails else ""))
    lines += ["Failure rate (status ≠ success): " + "; ".join(summary) + ".", ""]
    return lines


def figure(results, conds, orders):
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5), constrained_layout=True)
    styles = {"monomial": {"marker": "o", "ls": "-"}, "chebyshev": {"marker": "s", "ls": "--"}}
    fail_style = {"monomial": ("x", 0.56), "chebyshev": ("+", 0.44)}
    for (label, res), colour in zip(results.items(), ("C0", "C1")):
        for b in BASES:
            bad = [n for n in orders if (b, n) in res and not res[(b, n)]["ok"]]
            kw = dict(color=colour, label=f"{label}, {b}", **styles[b])

            def series(q, res=res, b=b):  # NaN where the case failed: gaps, not lines across failures
                return [res[(b, n)][q] if res.get((b, n), {}).get("ok") else np.nan for n in orders]
            axes[0, 0].plot(orders, series("rmse_rms"), **kw)
            axes[0, 1].plot(orders, series("iterations"), **kw)
            axes[1, 0].plot(orders, series("solve_time_s"), **kw)
            marker, height = fail_style[b]
            for ax in (axes[0, 0], axes[0, 1], axes[1, 0]):
                ax.plot(bad, [height] * len(bad), ls="none", marker=marker, color=colour, ms=11, mew=2.2,
                        transform=ax.get_xaxis_transform(),
                        label=f"{label}, {b}: failed" if bad else None)
    axes[0, 0].set_yscale("log")
    axes[0, 0].set_ylabel("torque RMSE [N·mm] (RR arm: RMS over cams)")
    axes[0, 1].set_ylabel("IPOPT iterations")
    axes[1, 0].set_ylabel("IPOPT solve time [s]")
    for ax in (axes[0, 0], axes[0, 1], axes[1, 0]):
        ax.set_xlabel("polynomial order n")
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=7)
    ax = axes[1, 1]
    for label, cond in conds.items():
        for b in BASES:
            ax.semilogy(orders, [cond[n][b] for n in orders], label=f"{b}, {label}", **styles[b])
    ax.axvline(7, color="k", lw=0.8, ls=":")
    ax.text(7.05, 0.02, "Johnston2023's n ≤ 7", transform=ax.get_xaxis_transform(), fontsize=8)
    ax.set_xlabel("polynomial order n")
    ax.set_ylabel(f"cond₂ of the {COND_POINTS} × (n+1) basis matrix")
    ax.set_title("Vandermonde-type matrix on the design interval [0, θ_max + π/2]", fontsize=9)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)
    fig.suptitle("Polynomial order and basis (× monomial / + Chebyshev at mid-height: case failed)", fontsize=11)
    with atomic_path(OUT / "basis_order.png") as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)


def main() -> None:
    t0 = time.perf_counter()
    study = load_study(STUDY)
    rr = rr_study(study)
    OUT.mkdir(parents=True, exist_ok=True)
    sweeps = {"1-DOF": run_sweep(study, OUT / "study.db", workers=2),
              "RR arm": run_sweep(rr, OUT / "rr_arm.db", workers=2)}
    orders = sorted({int(c[next(k for k in c if k.endswith(".order"))]) for c in study.cases()})
    results = {"1-DOF": table(OUT / "study.db", study), "RR arm": table(OUT / "rr_arm.db", rr)}
    t_diag = time.perf_counter()
    diagnose(OUT / "study.db", results["1-DOF"])
    diagnose(OUT / "rr_arm.db", results["RR arm"])
    t_diag = time.perf_counter() - t_diag
    domains = {label: next(iter(res.values()))["domain"] for label, res in results.items()}
    conds = {f"[0, {domains[label][1]:.3f}] rad ({label})": condition_numbers(domains[label], orders)
             for label in results}
    # both models have θ ∈ [0°, 90°], hence the same interval: keep one curve per basis
    if len({tuple(d) for d in domains.values()}) == 1:
        conds = {f"[0, {domains['1-DOF'][1]:.3f}] rad": next(iter(conds.values()))}
    figure(results, conds, orders)

    cond = next(iter(conds.values()))
    lines = [
        "# Polynomial order and basis of the cam profile", "",
        "Generated by `.venv/bin/python studies/basis_order.py` from `studies/basis_order.toml`. "
        "Johnston2023 (Sec. 6) limits its cams to n ≤ 7 'since polynomial bases are known to suffer from "
        "poor numerical conditioning for large powers (n > 7)'. Both bases span the same polynomials, "
        "so at each order they have the same optima; what can differ is whether IPOPT finds them.", "",
        "Problems: **1-DOF** `models/johnston2023_1dof.toml` (Sec. 10.1 target, Table 2 springs, "
        "w1 = 10, w2 = w3 = 1, cam 1 varied: `cams.1.basis` × `cams.1.order`); **RR arm** "
        "`models/johnston2023_rr_arm.toml` (Sec. 10.4: w1 = w2 = 10, no sensitivity terms; both cams "
        "varied together: `cams.*.basis` × `cams.*.order`). The specs' energy torque model (τ = ∂V/∂θ), 46-point grid (46 × 46 "
        "for the arm), one start (the default circle), IPOPT max 500 iterations; every order and basis "
        "is its own NLP structure, so each case builds its NLP (build time in the tables).", ""]
    for label, sw in sweeps.items():
        lines.append(f"Sweep {label}: {sw['cases']} cases, {sw['ran']} solved now in {sw['wall_time_s']:.1f} s "
                     f"on 2 workers, {sw['skipped']} already recorded; statuses {sw['statuses']}.")
    lines += ["", "## Results", ""]
    lines += section("1-DOF", results["1-DOF"], orders, 1)
    lines += section("RR arm (2 cams, 3 springs)", results["RR arm"], orders, 2)
    lines += ["The last column is the largest difference between the two bases' optimal profiles over "
              "the design interval (every cam): ≈ 0 means both bases reached the same optimum.", "",
              "## Conditioning of the bases (numpy, not the NLP)", "",
              f"2-norm condition number of the {COND_POINTS} × (n + 1) matrix of basis functions sampled "
              f"uniformly on the design interval φ ∈ {next(iter(conds))} (θ_max + π/2, the Chebyshev "
              "domain cadcam uses): monomial columns φ^k, Chebyshev columns T_k(u) with u the affine "
              "image of φ on [−1, 1]. It measures how ill-posed fitting ρ(φ) by least squares in that "
              "basis is; it is *not* the condition number of IPOPT's KKT systems.", "",
              "| n | " + " | ".join(str(n) for n in orders) + " |", "|---" * (len(orders) + 1) + "|",
              "| monomial | " + " | ".join(f"{cond[n]['monomial']:.3g}" for n in orders) + " |",
              "| Chebyshev | " + " | ".join(f"{cond[n]['chebyshev']:.3g}" for n in orders) + " |", ""]

    fails = [(label, b, n, c) for label, res in results.items()
             for (b, n), c in sorted(res.items(), key=lambda kv: (kv[0][1], kv[0][0])) if not c["ok"]]
    if fails:
        lines += ["## What the failed cases are", "",
                  f"Each failed case re-solved in this process from the same default start ({t_diag:.1f} s), "
                  "to see IPOPT's own result (a case recorded as `error` keeps nothing of its solve) and "
                  "how many design-grid angles the evaluation's tangency rootfinder cannot solve at "
                  "that point. For comparison, the lowest objective of a successful case of the same "
                  "problem (any order, any basis).", "",
                  "| problem | n | basis | sweep status | IPOPT | iterations | objective | best successful objective | NaN tangencies |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for label, b, n, c in fails:
            best_ok = min((x["objective"] for x in results[label].values() if x["ok"]), default=float("nan"))
            d = c.get("ipopt", {})
            lines.append(f"| {label} | {n} | {b} | {c['status']} | {d.get('return_status', '?')} | "
                         f"{d.get('iterations', '?')} | {d.get('objective', float('nan')):.4g} | {best_ok:.4g} | "
                         f"{d.get('nan_tangencies', '?')} |")
        lines += ["", "`Solve_Succeeded` with an objective above the best one is a local optimum of this "
                  "non-convex NLP. NaN tangencies mean the independent rootfinder (circle-based initial "
                  "guess) cannot follow the wire on that profile at some angles, which makes "
                  "`cadcam.optimize` raise `ValueError: Optimization bounds must be finite scalars.` "
                  "(`scipy.optimize.minimize_scalar` given a NaN interval in "
                  "`cadcam.verify.evaluate._refine_min`) instead of returning a status such as "
                  "`recheck_failed`, so the sweep records `error` and loses the solve.", ""]

    lines += ["## Findings", ""]
    for label, res in results.items():
        for b in BASES:
            ok = [n for n in orders if res.get((b, n), {}).get("ok")]
            best = min(ok, key=lambda n: res[(b, n)]["objective"]) if ok else None
            lines.append(
                f"- {label}, {b}: success for n = {', '.join(map(str, ok)) or 'none'}"
                + (f"; lowest objective {res[(b, best)]['objective']:.4g} at n = {best} (RMSE "
                   f"{res[(b, best)]['rmse_rms']:.3g} N·mm{', RMS over cams' if label == 'RR arm' else ''})" if best else "")
                + (f"; iterations {min(res[(b, n)]['iterations'] for n in ok)} … "
                   f"{max(res[(b, n)]['iterations'] for n in ok)}, solve "
                   f"{min(res[(b, n)]['solve_time_s'] for n in ok):.2f} … {max(res[(b, n)]['solve_time_s'] for n in ok):.2f} s, "
                   f"build {min(res[(b, n)]['build_time_s'] for n in ok):.2f} … {max(res[(b, n)]['build_time_s'] for n in ok):.2f} s"
                   if ok else "") + ".")
        only = {b: [n for n in orders if not res[(b, n)]["ok"] and res[(o, n)]["ok"]]
                for b, o in (("monomial", "chebyshev"), ("chebyshev", "monomial"))}
        both = [n for n in orders if not res[("monomial", n)]["ok"] and not res[("chebyshev", n)]["ok"]]
        same = [n for n in orders if res[("monomial", n)].get("gap_mm", np.inf) < 0.01]
        not_conv = [f"{b} n = {n} ({c['ipopt']['return_status']})" for (b, n), c in sorted(res.items(), key=lambda kv: kv[0][1])
                    if not c["ok"] and c.get("ipopt", {}).get("return_status") != "Solve_Succeeded"]
        # order n contains every lower order, so a converged optimum above a lower order's
        # (either basis) is a local optimum
        local = []
        for (b, n), c in sorted(res.items(), key=lambda kv: (kv[0][1], kv[0][0])):
            lower = [x["objective"] for (bb, nn), x in res.items() if x["ok"] and nn < n]
            if c["ok"] and lower and c["objective"] > min(lower) * (1 + 1e-3):
                local.append(f"{b} n = {n} ({c['objective']:.4g} against {min(lower):.4g})")
        lines.append(f"- {label}: converged optima above the best of a lower order (local optima of the "
                     f"non-convex NLP: order n contains every lower order): {', '.join(local) or 'none'}.")
        if not only["monomial"] and not only["chebyshev"] and not both:
            lines.append(f"- {label}: no failures in either basis. Both bases reach the same profile (within "
                         f"0.01 mm) at n = {', '.join(map(str, same)) or 'none'}.")
            continue
        lines.append(
            f"- {label}: fails only in the monomial basis at n = {', '.join(map(str, only['monomial'])) or 'none'}, "
            f"only in the Chebyshev basis at n = {', '.join(map(str, only['chebyshev'])) or 'none'}, in both at "
            f"n = {', '.join(map(str, both)) or 'none'}. IPOPT itself did not converge in: "
            f"{', '.join(not_conv) or 'no case'}; every other failure converged to a local optimum. Both "
            f"bases reach the same profile (within 0.01 mm) at n = {', '.join(map(str, same)) or 'none'}.")
    lines += [f"- Conditioning: the monomial matrix grows from {cond[orders[0]]['monomial']:.3g} (n = {orders[0]}) "
              f"to {cond[orders[-1]]['monomial']:.3g} (n = {orders[-1]}), about ×8 per order; the Chebyshev "
              f"one stays at {min(cond[n]['chebyshev'] for n in orders):.3g} … {max(cond[n]['chebyshev'] for n in orders):.3g}.",
              "- Does the Chebyshev basis remove the n ≤ 7 limit? A failure the basis causes is one where "
              "IPOPT does not converge in the monomial basis while the Chebyshev basis solves the same "
              "order (see the lists above). Failures where IPOPT converges are local optima of the "
              "non-convex problem: they depend on the path IPOPT takes from the start (which differs "
              "between bases even for the same starting polynomial), not on conditioning. cadcam's NLP "
              "scaling (coefficients in mm, normalised objective) keeps the monomial basis usable "
              "beyond what its raw condition number suggests; the Chebyshev basis removes the "
              "conditioning argument altogether, at the price of a longer NLP build (the recurrence "
              "makes larger expressions: compare the build columns).", ""]
    lines += ["## Figures", "",
              "- `basis_order.png`: RMSE, iterations and solve time against n per basis and problem "
              "(× monomial, + Chebyshev at mid-height: failed cases), and the condition numbers.", "",
              f"Total script time {time.perf_counter() - t0:.1f} s."]
    text = "\n".join(lines) + "\n"
    write_text(OUT / "report.md", text)
    write_json(OUT / "summary.json", {
        "sweeps": sweeps, "condition_numbers": {str(n): cond[n] for n in orders},
        "cases": {label: [{"basis": b, "order": n, **{k: (None if isinstance(v, float) and not np.isfinite(v) else v)
                                                      for k, v in c.items() if k not in ("design", "domain")}}
                          for (b, n), c in sorted(res.items())] for label, res in results.items()}})
    print(text)
    print(f"report: {OUT / 'report.md'}")


if __name__ == "__main__":
    main()
