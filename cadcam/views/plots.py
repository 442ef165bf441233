"""Figures of an evaluated design (PNG, written atomically). Views only: no physics here."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..check.evaluate import Evaluation, output_error, output_law  # noqa: E402
from ..physics.profile import profile_function  # noqa: E402
from ..files import atomic_path  # noqa: E402

MM = 1e3


def _save(fig, path):
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def plot_profiles(ev: Evaluation, path, n_poses: int = 4) -> None:
    """Each mechanism in the world frame at a few joint angles: its profiles (thick where the
    cable is wrapped, the anchor marked) and what it asks to draw (idlers, points, free cable
    spans) [mm]."""
    problem = ev.problem
    m = len(problem.mechanisms)
    fig, axes = plt.subplots(1, m, figsize=(5.5 * m, 5.2), squeeze=False)
    for ax, mech, unit, sl in zip(axes[0], problem.mechanisms, ev.units, problem.profile_slices()):
        c = np.concatenate(ev.design.coefficients[sl])
        poses = np.unique(np.linspace(0, unit.theta.size - 1, n_poses).round().astype(int))
        colors = plt.cm.viridis(np.linspace(0, 0.85, poses.size))
        for col, k in zip(colors, poses):
            th = unit.theta[k]
            for p in range(sl.start, sl.stop):
                ps = ev.profiles[p]
                phi = np.linspace(0, ps.phi[-1], 400)
                rho = np.asarray(profile_function(ev.design.bases[p]).map(phi.size)(
                    phi, ev.design.coefficients[p])[0]).ravel()
                x, y = mech.world_points(th, phi, rho, p - sl.start)
                ax.plot(MM * x, MM * y, color=col,
                        label=f"θ = {np.degrees(th):.0f}°" if p == sl.start else None)
                mask = phi <= ps.alpha[k]
                ax.plot(MM * x[mask], MM * y[mask], color=col, lw=2.5, alpha=0.5)
                ax.plot(*(MM * np.array(mech.world_points(th, 0.0, rho[0], p - sl.start))), "s",
                        color=col, ms=4)
            for start, end in mech.segments(th, unit.z[:, k], c):
                ax.plot(MM * np.array([start[0], end[0]]), MM * np.array([start[1], end[1]]),
                        color=col, lw=1.0)
            t = np.linspace(0, 2 * np.pi, 100)
            for centre, radius in mech.circles(th, unit.z[:, k], c):
                if radius > 0:
                    ax.plot(MM * (centre[0] + radius * np.cos(t)), MM * (centre[1] + radius * np.sin(t)),
                            color=col, lw=0.8, ls="--")
                else:  # a point (zero-radius idler): mark it
                    ax.plot(*(MM * np.asarray(centre)), "o", color=col, ms=5, mfc="none")
        ax.plot(0, 0, "k+")
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.set_title(f"{mech.name}\nthick: wrapped cable, ■ anchor, ○ point idler, dashed: idler",
                     fontsize=8)
        ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    _save(fig, path)


def plot_torque(ev: Evaluation, path) -> None:
    """Torque against target and the error [N·mm]: lines for one joint, heat maps for two."""
    m = len(ev.tau)
    if m == 1:
        th = np.degrees(ev.theta[0])
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        a1.plot(th, MM * ev.tau_d[0], "k--", label="target τ_d")
        a1.plot(th, MM * ev.tau[0], label=f"τ ({ev.problem.torque_model} model)")
        a1.set_ylabel("torque [N·mm]")
        a1.legend()
        a2.plot(th, MM * (ev.tau[0] - ev.tau_d[0]), color="C3")
        a2.set_ylabel("τ − τ_d [N·mm]")
        a2.set_xlabel("θ [deg]")
        a1.set_title(f"RMSE {MM * ev.metrics['rmse'][0]:.3g} N·mm, "
                     f"max {MM * ev.metrics['max_abs_error'][0]:.3g} N·mm")
    else:
        n = ev.grid
        fig, axes = plt.subplots(1, m, figsize=(5.5 * m, 4.5), squeeze=False)
        ext = [np.degrees(ev.theta[1].min()), np.degrees(ev.theta[1].max()),
               np.degrees(ev.theta[0].min()), np.degrees(ev.theta[0].max())]
        for i, ax in enumerate(axes[0]):
            err = MM * (ev.tau[i] - ev.tau_d[i]).reshape((n,) * m)
            im = ax.imshow(err if m == 2 else err.reshape(n, -1), origin="lower", extent=ext,
                           aspect="auto", cmap="RdBu_r", vmin=-np.abs(err).max(), vmax=np.abs(err).max())
            fig.colorbar(im, ax=ax, label="τ − τ_d [N·mm]")
            ax.set_xlabel("θ₂ [deg]")
            ax.set_ylabel("θ₁ [deg]")
            ax.set_title(f"{ev.problem.joints[i].name}: RMSE {MM * ev.metrics['rmse'][i]:.3g} N·mm")
    fig.tight_layout()
    _save(fig, path)


def plot_outputs(ev: Evaluation, path) -> None:
    """Each mechanism's output x(θ) against its law x_d(θ) and the error [mm]."""
    rows = [(mech, unit) for mech, unit in zip(ev.problem.mechanisms, ev.units)
            if mech.output_target is not None]
    fig, axes = plt.subplots(2, len(rows), figsize=(6.5 * len(rows), 6), sharex="col", squeeze=False)
    for k, (mech, unit) in enumerate(rows):
        th = np.degrees(unit.theta)
        x = unit.z[mech.unknowns.index(mech.output)]
        xd, err = output_law(mech, unit.theta), output_error(mech, unit)
        a1, a2 = axes[0][k], axes[1][k]
        a1.plot(th, MM * xd, "k--", label=f"target {mech.output}_d")
        a1.plot(th, MM * x, label=f"{mech.output} (rootfinder)")
        a1.set_ylabel(f"{mech.output} [mm]")
        a1.legend(fontsize=8)
        a1.set_title(f"{mech.name}: max |{mech.output} − {mech.output}_d| "
                     f"{MM * np.abs(err).max():.3g} mm", fontsize=9)
        a2.plot(th, 1e6 * err, color="C3")
        a2.set_ylabel(f"{mech.output} − {mech.output}_d [µm]")
        a2.set_xlabel("θ [deg]")
    fig.tight_layout()
    _save(fig, path)


def plot_springs(ev: Evaluation, path) -> None:
    """Spring extensions against their travel limits [mm].

    A spring on one cam is a line over that cam's angle; a spring joining two cams (Johnston2023's
    spring 2) is a map over both angles with its travel limit drawn as a contour.
    """
    springs, m, n = ev.problem.springs, len(ev.tau), ev.grid
    net = ev.problem.network()
    grids = [j.grid(n) for j in ev.problem.joints]
    fig, axes = plt.subplots(1, len(springs) if m > 1 else 1, figsize=(5 * max(len(springs), 1) if m > 1 else 7, 4.5),
                             squeeze=False)
    for j, s in enumerate(springs):
        ax = axes[0][j if m > 1 else 0]
        cams = net.joints_of(j)
        x = MM * ev.x[j].reshape((n,) * m)
        if len(cams) == 1:
            c = cams[0]
            line = x[tuple(slice(None) if a == c else 0 for a in range(m))]
            ax.plot(np.degrees(grids[c]), line, color=f"C{j}", label=s.name)
            ax.axhline(MM * s.travel, color=f"C{j}", ls=":", lw=1)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_xlabel(f"θ{c + 1 if m > 1 else ''} [deg]")
            ax.set_ylabel("extension [mm] (dotted: travel)")
            ax.legend(fontsize=8)
        else:
            a, b = cams[:2]
            sl = x[tuple(slice(None) if k in (a, b) else 0 for k in range(m))]
            ext = [np.degrees(grids[b][0]), np.degrees(grids[b][-1]),
                   np.degrees(grids[a][0]), np.degrees(grids[a][-1])]
            im = ax.imshow(sl, origin="lower", extent=ext, aspect="auto", cmap="viridis")
            fig.colorbar(im, ax=ax, label="extension [mm]")
            if sl.max() >= 0.98 * MM * s.travel:
                ax.contour(np.degrees(grids[b]), np.degrees(grids[a]), sl,
                           levels=[0.98 * MM * s.travel], colors="r", linewidths=1)
            ax.set_xlabel(f"θ{b + 1} [deg]")
            ax.set_ylabel(f"θ{a + 1} [deg]")
        ax.set_title(f"{s.name}\nmax {x.max():.2f} of {MM * s.travel:.2f} mm", fontsize=9)
    fig.tight_layout()
    _save(fig, path)


def pareto_front(points: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both coordinates (minimising both)."""
    order = np.lexsort((points[:, 1], points[:, 0]))
    front, best = [], np.inf
    for k in order:
        if points[k, 1] < best:
            front.append(k)
            best = points[k, 1]
    return np.array(front, dtype=int)


def plot_study(table: list[dict], x: str, y: str, color: str | None, pareto: bool, path,
               title: str) -> None:
    """Scatter of column ``y`` against ``x`` over a study's successful cases, optionally
    coloured by ``color`` and with the Pareto front (both minimised) drawn."""
    rows = [r for r in table if r.get("status") == "success"
            and isinstance(r.get(x), (int, float)) and isinstance(r.get(y), (int, float))]
    pts = np.array([[r[x], r[y]] for r in rows], dtype=float).reshape(-1, 2)
    fig, ax = plt.subplots(figsize=(7, 5))
    if color:
        c = [r.get(color) for r in rows]
        numeric = all(isinstance(v, (int, float)) for v in c)
        if numeric:
            sc = ax.scatter(pts[:, 0], pts[:, 1], c=c, cmap="viridis")
            fig.colorbar(sc, ax=ax, label=color)
        else:
            for k, level in enumerate(dict.fromkeys(c)):
                mask = np.array([v == level for v in c])
                ax.scatter(pts[mask, 0], pts[mask, 1], color=f"C{k}", label=str(level))
            ax.legend(fontsize=8, title=color)
    else:
        ax.scatter(pts[:, 0], pts[:, 1])
    if pareto and len(pts):
        front = pts[pareto_front(pts)]
        ax.plot(front[:, 0], front[:, 1], "r-o", mfc="none", label="Pareto front")
        ax.legend(fontsize=8)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(f"{title}: {len(rows)} successful cases of {len(table)}")
    fig.tight_layout()
    _save(fig, path)
