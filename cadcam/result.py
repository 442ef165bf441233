"""The result of a design run as plain data, and its JSON form (schema: result.schema.json)."""
from __future__ import annotations

import html

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from .citations import cited
from .verify.binding import binding_constraints
from .verify.reachable import advice
from .mechanisms.base import kinds_in
from .verify.evaluate import Evaluation, cable_report
from .verify.installation import installation_lines, spring_installation
from .verify.friction import FrictionBand, friction_band
from .verify.builds import Builds, simulate_builds
from .verify.tolerance import Band, tolerance_band
from .files import printable, staged_folder
from .version import __version__
from .outputs.forked import Drawer
from .solve.messages import count
from .outputs.run_files import (ADJUSTMENT_FILE, WorkshopError, figure_drawings, run_file_names, torque_table,
                                 write_outputs, write_workshop_files)

if TYPE_CHECKING:
    from .designs import Design
    from .solve.ipopt import Solve
    from .problem import Problem, Workshop


def _rmse_text(problem, i: int, rmse: float, share: float | None) -> str:
    """Joint ``i``'s RMSE [N·mm] and its relative acceptance, as the summary shows them: its
    share of the target's RMS and the limit on it, or where the target's RMS is below the
    joint's torque floor (:meth:`~cadcam.problem.Problem.floor_acceptance`), the RMSE that
    floor accepts."""
    limit = problem.joints[i].limits.get("relative_rmse")
    floor = None if limit is None else problem.floor_acceptance(i, limit, rmse, share)
    if floor is None:
        accepted = "" if limit is None else f", accepted up to {100 * limit:.3g} %"
        return f"{1e3 * rmse:.4g}" + ("" if share is None else f" ({100 * share:.3g} % of the target's RMS{accepted})")
    relative = "" if share is None else f"{100 * share:.3g} % of the target's RMS; "
    return f"{1e3 * rmse:.4g} ({relative}accepted up to {1e3 * floor[0]:.4g} N·mm, {floor[1]})"


def _band_line(band: Band, ev: Evaluation) -> str:
    """The summary's line on the tolerance band: each joint's widest half-width, as a share of
    its target's peak (where that peak is not below the joint's torque floor, which a vanishing
    target is), and how far the worst corner, re-checked, moves the torque."""
    floors = [ev.problem.torque_floor(i) for i in range(len(ev.problem.joints))]
    per_joint = [f"± {1e3 * h.max():.3g} N·mm ({100 * h.max() / peak:.2g} % of the target's peak; worst corner "
                 f"re-checked {1e3 * c['recomputed']:.3g})" if peak > 0 and peak >= floor else f"± {1e3 * h.max():.3g} N·mm"
                 for h, c, peak, floor in zip(band.half_width, band.corners, np.abs(ev.tau_d).max(axis=1), floors)]
    return f"  tolerance band ({band.label()}) per joint: {'; '.join(per_joint)}"


def _errors_text(values: np.ndarray, scales: np.ndarray, floors: list, peaks: np.ndarray) -> str:
    """P50 / P95 per joint [N·mm] (``values`` (2, m) [N·m]) and, where the target's peak is not
    below the joint's torque floor, as shares of it; a joint without a torque goal left out."""
    out = []
    for (p50, p95), scale, floor, peak in zip(values.T, scales, floors, peaks):
        if np.isfinite(scale):
            share = f" ({100 * p50 / peak:.2g} / {100 * p95 / peak:.2g} % of the target's peak)" \
                if peak > 0 and peak >= floor else ""
            out.append(f"{1e3 * p50:.3g} / {1e3 * p95:.3g} N·mm{share}")
    return "; ".join(out)


def _builds_lines(builds: Builds, ev: Evaluation) -> list[str]:
    """The summary's lines on the builds: P50 / P95 of each joint's largest torque error as
    built and, with an adjustment, as set by the table and at best, the ranges' violations
    and each payload's error."""
    options, problem = builds.options, ev.problem
    floors = [problem.torque_floor(i) for i in range(len(problem.joints))]
    peaks = np.abs(ev.tau_d).max(axis=1)

    def text(stage: str) -> str:
        return _errors_text(builds.percentiles(stage), builds.scales, floors, peaks)
    rubbing = sum(source["tolerance"] == "friction" for source in builds.sources)
    among = f"; {rubbing} friction coefficients among them" if rubbing > 1 else \
        "; a friction coefficient among them" if rubbing else ""
    lines = [f"  builds: {options['count']} (seed {options['seed']}, each part {options['distribution']} within ± its "
             f"tolerance{among}), largest torque error P50 / P95 per joint: {text('before')}"]
    if builds.chosen:
        how = [f"{s.name} ± {1e3 * s.travel:g} mm" for s in builds.chosen]
        hold = "" if builds.pose is None else (
            f"; then the screw{'s' * (sum(s.screw for s in builds.chosen) > 1)} until the arm holds still at "
            + ", ".join(f"{np.degrees(t):.3g}°" for t in builds.pose))
        lines.append(f"  adjusted ({', '.join(how)}) as {ADJUSTMENT_FILE} says{hold}: {text('set')}; at best "
                     f"{text('best')}; builds at an end of a range: {100 * builds.at_end['set']:.2g} % as set, "
                     f"{100 * builds.at_end['best']:.2g} % at best")
    lines += [f"  adjustment's range violated: {v}" for v in builds.limits]
    if builds.payloads:
        per = ", ".join(f"{p['mass']:.3g} kg {100 * p['relative_rmse']:.2g} %" + (" (range end)" * p["at_range_end"])
                        + (f" (violates {len(p['violations'])} limits)" if p["violations"] else "")
                        for p in builds.payloads)
        lines.append(f"  payloads, each adjusted: RMS error as a share of its target's RMS: {per}")
    return lines


def _cable_line(report: dict) -> str:
    """The summary's line on the cable: its least radius of curvature against the one its
    bend asks, and its peak tension against its working load."""
    least, need = min(report["curvature_radius_min"], default=float("nan")), report["least_profile_radius"]
    return (f"  cable {report.get('name') or 'given in full'} (Ø{1e3 * report['diameter']:.3g} mm "
            f"{report['kind']}): least radius of curvature {1e3 * least:.2f} mm, its bend asks ≥ {1e3 * need:.2f} "
            f"mm ({1e3 * report['min_bend_radius']:.3g} mm to the cut outline); peak tension "
            f"{report['peak_tension']:.4g} N, working load {report['working_load']:.4g} N "
            f"({report['breaking_load']:.4g} N breaking / {report['safety_factor']:g})")


def _warnings_line(warnings: list[dict]) -> str:
    """The summary's line on CasADi's warnings during the solves: how many, and the first."""
    n, first = count(warnings), warnings[0]["message"]
    distinct = f", {len(warnings)} distinct" if len(warnings) > 1 else ""
    return f"  CasADi warned {n} time{'s' * (n > 1)} during the solve{distinct} (kept in solver.warnings), first: {first}"


@dataclass(repr=False)
class Result:
    """What :func:`cadcam.design` (and :func:`cadcam.optimize.optimize`) returns; see
    :meth:`to_dict` for the JSON.

    ``status`` is ``success`` for a converged optimum that passed the fine re-check, else one
    word (``infeasible``, ``max_iterations``, ``recheck_failed``, …); ``message`` says it in
    words a person can act on. Like scipy's ``OptimizeResult`` it has ``success``, ``nit``,
    ``fun`` and ``x`` (``status`` is a word here, not a number). Its repr is
    :meth:`summary`.

    Attributes
    ----------
    problem : Problem
        The problem that was solved (fully resolved).
    design : Design
        The profiles' coefficients [m] and the springs' pre-extensions [m].
    evaluation, recheck : Evaluation
        The design on the design grid, and on the grid ``recheck_factor`` times finer by the
        rootfinder and independent quadrature (what ``success`` is judged on).
    solve : Solve
        What IPOPT did for the kept start (``history``: its iterates).
    build_time_s : float
        Wall time to build the NLP [s].
    recheck_time_s : float
        Wall time of the fine re-check [s].
    functions : str
        How the NLP's build evaluated IPOPT's functions
        (:attr:`cadcam.solve.transcription.Transcription.functions_used`; ``none`` without an NLP).
    provisional : bool
        True for a design judged on the design grid alone, not yet re-checked on the fine grid
        (:func:`cadcam.optimize.optimize` with ``recheck=False``: a design page's while a
        slider moves): its ``recheck`` is its ``evaluation``.
    """

    status: str
    message: str
    problem: Problem
    design: Design
    evaluation: Evaluation
    recheck: Evaluation
    solve: Solve | None = None
    build_time_s: float = float("nan")
    recheck_time_s: float = float("nan")
    functions: str = "none"
    provisional: bool = False

    @property
    def success(self) -> bool:
        """True only for a converged optimum that passed the fine re-check and met every
        acceptance limit."""
        return self.status == "success"

    @property
    def nit(self) -> int:
        """IPOPT iterations of the kept start (0 without an NLP)."""
        return self.solve.iterations if self.solve is not None else 0

    @property
    def fun(self) -> float:
        """The objective reached: Johnston2023 Eq. 46/47 on the design grid (SI units), with
        the tolerance band's term of any joint's ``band_weight``."""
        return self.solve.objective if self.solve is not None else float("nan")

    @property
    def x(self) -> np.ndarray:
        """The design as one vector: every profile's coefficients in its basis [m], in
        mechanism order, then one pre-extension per spring [m]."""
        return np.concatenate([*self.design.coefficients, self.design.preextension])

    @property
    def history(self) -> dict:
        """IPOPT's iterates of the kept start (see :func:`cadcam.solve.ipopt.iteration_history`)."""
        return self.solve.history if self.solve is not None else {}

    @property
    def warnings(self) -> list[dict]:
        """What CasADi warned during the solves of every start (a NaN in an evaluation at a trial
        point, …), kept here instead of printed: ``{"message", "count"}`` per distinct message
        (:func:`cadcam.solve.messages.kept_warnings`); empty without an NLP."""
        return self.solve.warnings if self.solve is not None else []

    @cached_property
    def spec_warnings(self) -> list[str]:
        """What the spec asks that is implausible or cannot be met exactly, told, not refused:
        values plausible only in another unit or outside every catalogue, and the bounds the
        mechanisms know (:func:`cadcam.verify.reachable.advice`), one line each with its fix;
        ``result.json``'s ``warnings`` and the summary's ``warning:`` lines."""
        return advice(self.problem)

    @cached_property
    def band(self) -> Band | None:
        """The torque band a built part falls in under the problem's tolerances
        (:func:`cadcam.verify.tolerance.tolerance_band`, on the design grid); None without
        springs, and for a design whose torque is not finite there (a failed solve's design
        where no pose was found: its band would be NaN, and its least squares fail)."""
        finite = bool(np.all(np.isfinite(self.evaluation.tau)))
        return tolerance_band(self.evaluation) if self.problem.springs and finite else None

    @cached_property
    def friction(self) -> FrictionBand | None:
        """The band of torques the built device holds still in under the spec's ``[friction]``
        (:func:`cadcam.verify.friction.friction_band`, on the design grid, as :attr:`band`);
        None without friction, without springs, or where the torque is not finite."""
        finite = bool(np.all(np.isfinite(self.evaluation.tau)))
        return friction_band(self.evaluation) if self.problem.friction and self.problem.springs and finite else None

    @cached_property
    def builds(self) -> Builds | None:
        """The simulated builds under the problem's tolerances and their adjustment
        (:func:`cadcam.verify.builds.simulate_builds`, on the design grid); None where there is
        no band, or ``[builds] count`` is 0."""
        if self.band is None or self.band.sensitivity is None:
            return None
        return simulate_builds(self.evaluation, self.band.sensitivity)

    @cached_property
    def installation(self) -> list[dict]:
        """How each spring is installed, from the fine re-check: force and length ranges, and
        for a spring hung from a mount on its cable the mount and the cable's cut length
        (:func:`cadcam.verify.installation.spring_installation`; SI units)."""
        finite = bool(np.all(np.isfinite(self.recheck.units[0].d))) if self.recheck.units else False
        return spring_installation(self.recheck) if finite else []

    @property
    def binding(self) -> list[str]:
        """Constraints that bind on the fine re-check, one sentence each
        (:func:`cadcam.verify.binding.binding_constraints`)."""
        return binding_constraints(self.recheck.metrics, self.problem)

    def to_frame(self):
        """The fine re-check as a :class:`pandas.DataFrame`: θ [rad], τ, τ_d and τ − τ_d [N·m] per
        joint and the spring extensions [m], one row per grid point (the columns and rows of
        ``torque_recheck.csv``, :func:`cadcam.outputs.run_files.torque_table`)."""
        import pandas as pd

        header, rows = torque_table(self.recheck)
        return pd.DataFrame(rows, columns=header)

    def _repr_html_(self) -> str:
        """The summary, for a notebook's output cell."""
        return f"<pre>{html.escape(self.summary())}</pre>"

    def summary(self) -> str:
        """A few lines: status and message, RMSE per joint, iterations and times, the spec's
        warnings, output and path errors, violated and binding constraints."""
        metrics, fine = self.evaluation.metrics, self.recheck.metrics
        rmse = [_rmse_text(self.problem, i, v, r) for i, (v, r) in enumerate(zip(metrics.rmse, metrics.relative_rmse))]
        lines = [f"{self.status}: {self.message}",
                 f"  {self.problem.name}: RMSE per joint [N·mm]: {', '.join(rmse) or 'none (no torque goal)'}; "
                 f"iterations {self.nit}, build {self.build_time_s:.3f} s (functions {self.functions}), "
                 f"solve {self.solve.solve_time_s if self.solve is not None else float('nan'):.3f} s, "
                 f"fine re-check {self.recheck_time_s:.3f} s"]
        lines += [f"  warning: {w}" for w in self.spec_warnings]
        outs = [f"{1e3 * v:.3g}" for v in fine.output_max_abs_error if v is not None]
        if outs:
            lines.append(f"  output max |x − x_d| on the re-check grid [mm]: {', '.join(outs)}")
        for kind in kinds_in(self.problem.mechanisms):
            lines += kind.summary_lines(self.recheck)
        if self.band is not None:
            lines.append(_band_line(self.band, self.evaluation))
        if self.friction is not None:
            lines.append(self.friction.summary_line([j.name for j in self.problem.joints]))
        if self.builds is not None:
            lines += _builds_lines(self.builds, self.evaluation)
        lines += installation_lines(self.installation)
        if (cable := cable_report(self.problem, fine)) is not None:
            lines.append(_cable_line(cable))
        lines += [f"  violated: {v}" for v in (self.recheck.violations if not self.success else [])]
        if self.warnings:
            lines.append(_warnings_line(self.warnings))
        lines += [f"  binding: {b}" for b in self.binding]
        return "\n".join(map(printable, lines))  # a name's line break or escape code stays in its line

    def __repr__(self) -> str:
        return self.summary()

    def plot(self, which: str | None = None):
        """The figures of this design as matplotlib Figures (no backend is chosen: show them,
        or save them with ``fig.savefig``).

        Parameters
        ----------
        which : str, optional
            One of ``profile``, ``torque``, ``springs`` (with springs), ``output`` (with an
            output law) or ``convergence``; default all of them.

        Returns
        -------
        dict of str to matplotlib.figure.Figure, or one Figure if ``which`` is given.
        """
        from .outputs.plots import figures
        figs = figures(self.evaluation, self.history or None, self.band, self.recheck, self.friction)
        if which is None:
            return figs
        if which not in figs:
            raise ValueError(f"which = {which!r}: this result has the figures {sorted(figs)}")
        return figs[which]

    def save(self, directory, workshop: Workshop | None | Literal["spec"] = "spec",
             figures: bool = True, workers: int = 1, drawer: Drawer | None = None) -> list[str]:
        """Write what ``cadcam design`` writes into ``directory``, the set whole or not at all
        (:func:`cadcam.files.staged_folder`). It replaces or removes only the files of the set
        cadcam recorded writing there that are unchanged since (a file of the earlier set this one
        does not write is removed); other files are left alone, and before any drawing a file
        where it writes that is not one of those refuses it.

        Parameters
        ----------
        directory : str or Path
        workshop : Workshop, None or "spec"
            Sizes of the workshop files [m]: ``"spec"``, the problem's (its spec's ``[workshop]``
            table); a :class:`cadcam.problem.Workshop`, those; None writes no workshop files.
        figures : bool
            False writes none of the files matplotlib draws — the PNG figures and the drawing
            sheets, most of a small design's time; the tables, outlines and result.json are
            written all the same.
        workers : int
            Processes that draw the figures and sheets side by side (forked from this one; see
            :class:`cadcam.outputs.forked.Drawer`, which draws here where forking is unsafe).
            ``cadcam design`` uses one per core.
        drawer : Drawer, optional
            The processes to draw them (:class:`cadcam.outputs.forked.Drawer`), forked before
            the design was made, so that they imported matplotlib meanwhile (``workers`` is
            then theirs); waited for (or, on an error, ended) before this returns.

        Returns
        -------
        list of str
            One line per workshop file set.

        Raises
        ------
        WorkshopError
            A cam's workshop files cannot be made (its outline cannot be closed, or a hole
            leaves too little material); every other file is written.
        cadcam.files.NotCadcams
            Something stands where a file goes, or where a file of the earlier set is removed,
            that is not a file cadcam recorded writing there (nothing is written).
        OSError
            The set could not be written or swapped in (the earlier one is left whole).
        """
        notes, failure = [], None
        sizes = self.problem.workshop if workshop == "spec" else workshop
        with staged_folder(Path(directory), "result.json", run_file_names(self.problem, figures, sizes)) as stage:
            outcome = None  # the workshop step's, recorded in result.json beside the design's status
            # the figures need only the design: drawn while this process makes the workshop
            # files, whose sheets are sent as soon as the outlines are fitted; the drawing
            # processes end before the staging folder is swapped in or removed
            with drawer or Drawer(workers if figures else 1) as drawing:
                drawing.send(figure_drawings(self, stage) if figures else [])
                if sizes is not None:
                    try:
                        notes = write_workshop_files(self, stage, sizes, figures, drawing.send)
                        outcome = {"status": "written", "files": notes}
                    except WorkshopError as exc:
                        failure = exc
                        outcome = {"status": "failed", "message": str(exc)}
                write_outputs(self, stage, False, None, outcome)
                drawing.wait()
        if failure is not None:
            raise failure
        return notes

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
            "metrics": ev.metrics.to_dict(),
            "recheck": fine.metrics.to_dict(),
            "violations": fine.violations if self.status != "success" else [],
            "warnings": self.spec_warnings,
            "target_samples": target_samples(ev),
            "target_samples_grid": target_samples_grid(ev),
            "problem": self.problem.to_dict(),
            "citations": citations(self.problem),
        }
        bodies = [s.body_report(x) for s, x in zip(self.problem.springs, fine.metrics.extension_max)]
        if any(bodies):
            out["spring_bodies"] = [b for b in bodies if b is not None]
        if self.installation:
            out["spring_installation"] = self.installation
        if (cable := cable_report(self.problem, fine.metrics)) is not None:
            out["cable"] = cable
        if self.band is not None:
            out["tolerance_band"] = self.band.to_dict()
        if self.friction is not None:
            out["friction_band"] = self.friction.to_dict(target_samples_grid(ev)["indices"])
        if self.builds is not None:
            out["builds"] = self.builds.to_dict()
        if sol is not None:
            out["solver"] = {
                "name": "ipopt" if self.problem.options.method == "nlp" else self.problem.options.method,
                "return_status": sol.return_status,
                "iterations": sol.iterations, "solve_time_s": sol.solve_time_s,
                "build_time_s": self.build_time_s, "recheck_time_s": self.recheck_time_s,
                "functions": self.functions, "objective": sol.objective,
                "start": sol.start, "trials": sol.trials, "history": sol.history, "warnings": sol.warnings,
                "tangency_nlp_vs_rootfinder_max": float(max(
                    np.abs(sol.z[u] - unit.z).max() for u, unit in enumerate(ev.units))),
            }
        return out


#: Largest count of numbers in ``target_samples``: m joints × (m + 1) numbers a row × the
#: rows. Written with an indent of 2, a number takes at most 34 bytes and a row 17 more, so
#: these stay under 2.2 MB of result.json, well below the 10 MB a reader accepts
#: (:data:`cadcam.files.MAX_INPUT_BYTES`). The whole tensor grid is kept up to 25 000 angles
#: per joint for one joint, 91 for two, 16 for three; beyond, :func:`target_sample_stride`.
TARGET_SAMPLE_NUMBERS = 50_000


def target_sample_stride(grid: int, n_joints: int) -> int:
    """The smallest stride k ≥ 1 at which every k-th angle of a ``grid``-angle design grid per
    joint, both ends included, keeps at most :data:`TARGET_SAMPLE_NUMBERS` numbers in
    ``target_samples`` (1: the whole grid); grid − 1 (the ends alone) if none does."""
    for k in range(1, grid - 1):
        kept = len(target_sample_indices(grid, k))
        if n_joints * (n_joints + 1) * kept**n_joints <= TARGET_SAMPLE_NUMBERS:
            return k
    return max(grid - 1, 1)


def target_sample_indices(grid: int, stride: int) -> list[int]:
    """The design-grid indices kept per joint at ``stride``: 0, k, 2k, … and the last one,
    grid − 1."""
    return sorted(set(range(0, grid, stride)) | {grid - 1})


def target_samples_grid(ev: Evaluation) -> dict:
    """Which design-grid angles ``target_samples`` keeps (the same for every joint):
    ``sampled`` (False: the whole tensor grid), ``stride`` (every stride-th angle, both ends
    included) and ``indices`` (0-based indices into each joint's ``grid`` angles)."""
    stride = target_sample_stride(ev.grid, len(ev.problem.joints))
    return {"sampled": stride > 1, "stride": stride, "indices": target_sample_indices(ev.grid, stride)}


def target_samples(ev: Evaluation) -> list[list[list[float]]]:
    """Per joint, rows [θ₁ … θ_m [rad], τ_d [N·m]] at the points of the tensor grid of the
    design-grid angles :func:`target_samples_grid` keeps, in C order of the joints' angles
    (the whole design grid's tensor grid while it fits :data:`TARGET_SAMPLE_NUMBERS`). Only
    these points are evaluated."""
    m = len(ev.problem.joints)
    index = target_samples_grid(ev)["indices"]
    axes = [a[index].reshape([-1 if c == k else 1 for k in range(m)]) for c, a in enumerate(ev.tensor.axes)]
    shape = (len(index),) * m
    theta = np.vstack([np.broadcast_to(a, shape).ravel() for a in axes])
    return [np.column_stack([theta.T, np.broadcast_to(f(axes).value(), shape).ravel()]).tolist()
            for f in ev.tensor.targets]


def citations(problem) -> list[dict]:
    """The papers a result rests on: Johnston2023 (the objective, Eq. 46/47), each mechanism's
    own, and Endo2010 (Eq. 3–8) for an arm's (or its five-bar arm's) gravity torques by the
    transposed Jacobian."""
    tags = ["Johnston2023"] + [t for m in problem.mechanisms for t in m.citations()]
    if any(j.target.kind in ("arm", "five_bar") for j in problem.joints):
        tags.append("Endo2010")
    return cited(tags)
