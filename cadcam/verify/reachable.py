"""Targets no design can meet, told before any solve: lower bounds on the RMSE that every
design of a problem must keep, from its springs and its layout alone.

Under the energy torque model the torque is τ_i = ∂V/∂θ_i with V the springs' energy
(Johnston2023 Eq. 36), which gives two bounds a design cannot beat:

* **Energy budget.** Along joint i's range (the other joints held), V can change by at most
  E_i = Σ_j (½k_j t_j² + F0_j t_j) over the springs j on joint i, each kept in its travel
  0 ≤ x_j ≤ t_j (or less, where its force reaches its cable's working load:
  :meth:`cadcam.problem.Problem.extension_limit`). The target needs the swing
  S_i = max W − min W of W(θ) = ∫ τ_d dθ, so
  ∫|τ − τ_d| dθ ≥ S_i − E_i over the range, and by Cauchy–Schwarz the RMSE over a range of
  span L is at least (S_i − E_i)/L.
* **Torque sign.** A spring's force is k x + F0 ≥ 0; where every spring on a joint pulls
  through ports whose moment arm keeps one sign s whatever the profile
  (:attr:`cadcam.mechanisms.base.Mechanism.fixed_sign_ports`), τ_i·s ≥ 0 everywhere, and
  wherever the target has the other sign the error is at least |τ_d|.

:func:`unreachable` compares each bound with the joint's acceptance limits
(:attr:`cadcam.problem.Joint.limits`) and says, in one line, what to change; before them it
refuses a planar profile with no room round its hub, and a cable that no profile within its
limits can bend round or whose springs' initial tension alone passes its working load;
:func:`advice`
gathers what the mechanisms know they cannot do exactly (a note, not a refusal).
"""
from __future__ import annotations

from functools import cached_property

import numpy as np

from ..designs import default_start
from ..mechanisms.base import kinds_in
from ..physics.cables import shipped_cables
from ..problem import Problem
from ..spec import implausible_units
from .evaluate import evaluate

#: Angles along a joint's range on which the target's work W(θ) is integrated.
ENERGY_SAMPLES = 401
#: Angles per joint on which the other joints are held for the energy budget, and on which the
#: torque-sign bound evaluates the circular start (its arms' signs are the layout's).
HELD_SAMPLES = 9


def unreachable(problem: Problem) -> str | None:
    """Why no design of ``problem`` can be made or meet its targets, in one line with what to
    change: no room for a hub, a cable no design can carry (:func:`_cable_refusal`), or the
    first joint whose target no design can meet within its acceptance limits; None if nothing
    rules a design out (which does not promise that one meets its targets)."""
    if (no_room := _no_room_for_the_hub(problem)) is not None:
        return no_room
    if (no_cable := _cable_refusal(problem)) is not None:
        return no_cable
    if problem.torque_model != "energy":
        return None  # the bounds rest on τ = ∂V/∂θ
    start = _CircularStart(problem)
    for i, joint in enumerate(problem.joints):
        if not joint.limits:
            continue
        for bound in (_energy_bound(problem, i), _sign_bound(problem, i, start)):
            if bound is not None and (missed := _over_limit(problem, i, *bound[:2])):
                return f"joint {joint.name!r}: {bound[2]}, so no design comes within {missed}: {bound[3]}"
    return None


def _no_room_for_the_hub(problem: Problem) -> str | None:
    """The first planar profile whose ρ limit leaves no room for its anchor round the hub: the
    outline rows ask ρ(0) ≥ the anchor's radius and a cable's radius (:class:`cadcam.problem.Workshop`), which
    ρ ≤ rho_max rules out. None if every profile has room."""
    w = problem.workshop
    need = w.anchor_radius + w.cable_radius
    for mech in problem.mechanisms:
        if mech.planar():
            for prof in mech.profiles:
                if prof.rho_max <= need:
                    return (f"profile {prof.name!r}: rho_max = {prof.rho_max:g} m leaves no room for its outline "
                            f"round the hub: its anchor needs ρ ≥ {need:g} m (bore {w.bore_diameter:g} m, anchor hole "
                            f"{w.anchor_diameter:g} m, cable {w.cable_diameter:g} m and 1 mm walls): a larger rho_max "
                            "or a smaller workshop.bore_diameter, anchor_diameter or cable_diameter")
    return None


def _cable_refusal(problem: Problem) -> str | None:
    """Why the problem's cable (:attr:`cadcam.problem.Problem.cable`) rules every design out,
    in one line with what to change: a workshop diameter that is not the cable's (a
    ``--cable-diameter`` flag), a least profile radius above a profile's rho_max (a convex
    profile within rho_max bends tighter than rho_max somewhere on a turn), or a spring whose
    initial tension, or fixed pre-extension, already pulls beyond its working load. None if
    there is no cable or none of these."""
    cable = problem.cable
    if cable is None:
        return None
    if problem.workshop.cable_diameter != cable.diameter:
        return (f"workshop.cable_diameter = {problem.workshop.cable_diameter:g} m is not the diameter of the "
                f"cable {cable.label()} ({cable.diameter:g} m): drop --cable-diameter (the [cable] sets the "
                "diameter) or name another cable")
    need = cable.least_profile_radius
    for prof in problem.profiles:
        if need > prof.rho_max:
            others = _cables_that(lambda c: c.least_profile_radius < prof.rho_max
                                  and c.working_load >= cable.working_load)
            return (f"cable {cable.label()} bends round no less than {1e3 * cable.min_bend_radius:.3g} mm, so "
                    f"its centre line, the designed profile, no tighter than {1e3 * need:.3g} mm: above profile "
                    f"{prof.name!r}'s rho_max = {1e3 * prof.rho_max:.3g} mm, which no profile within rho_max can "
                    f"wrap: a rho_max above {1e3 * need:.3g} mm or a cable that bends tighter{others}")
    for s in problem.springs:
        pull = s.preload + s.rate * (s.preextension or 0.0)
        if pull >= cable.working_load:
            others = _cables_that(lambda c: c.working_load > pull and c.least_profile_radius <= need)
            what = ("its initial tension pulls" if not s.preextension
                    else f"its initial tension and fixed pre-extension {1e3 * s.preextension:.3g} mm pull")
            return (f"spring {s.name!r}: {what} {pull:.4g} N on cable {cable.label()}, whose working load "
                    f"is {cable.working_load:.4g} N ({cable.breaking_load:.4g} N breaking / "
                    f"{cable.safety_factor:g}): a spring of less initial tension or a stronger cable{others}")
    return None


def _cables_that(fits) -> str:
    """", e.g. …" naming up to two cables of the shipped table for which ``fits`` holds, the
    thinnest first, or "" if none does."""
    names = [c for c in sorted(shipped_cables().cables, key=lambda c: c.diameter) if fits(c)][:2]
    return ", e.g. " + " or ".join(f"'{c.name}'" for c in names) if names else ""


class _CircularStart:
    """The problem's circular start evaluated on :data:`HELD_SAMPLES` angles per joint, once,
    when a bound first asks for it."""

    def __init__(self, problem: Problem):
        self.problem = problem

    @cached_property
    def fine(self):
        # the moment arms and the target only: no profile scans
        return evaluate(self.problem, default_start(self.problem), grid=HELD_SAMPLES, profile=False)


def advice(problem: Problem) -> list[str]:
    """What the problem's mechanisms cannot do exactly, and angles plausible only in the other
    unit (:func:`cadcam.spec.implausible_units`), one line each with its fix, told before the
    solve without refusing it (:meth:`cadcam.mechanisms.base.Mechanism.advice`: Endo2010's
    convexity bound, for one)."""
    return [*implausible_units(problem),
            *(note for kind in kinds_in(problem.mechanisms) for note in kind.advice(problem))]


def _over_limit(problem: Problem, i: int, rmse_bound: float, target_rms: float) -> str | None:
    """The first acceptance limit of joint ``i`` that an RMSE of at least ``rmse_bound`` [N·m]
    breaks, its target's RMS being ``target_rms`` [N·m], in words (``relative_rmse`` against
    the joint's torque floor where the target's RMS is below it, as the verdict judges it)."""
    for key, limit in problem.joints[i].limits.items():
        if key == "relative_rmse":
            share = rmse_bound / target_rms if target_rms > 0 else None
            floor = problem.floor_acceptance(i, limit, rmse_bound, share)
            if floor is not None and rmse_bound > floor[0]:
                return (f"an RMSE of {1e3 * rmse_bound:.4g} N·mm (accepted: {1e3 * floor[0]:.4g} N·mm, {floor[1]}; "
                        "[joints.acceptance] relative_rmse)")
            if floor is None and share is not None and share > limit:
                return (f"{100 * share:.3g} % of the target's RMS (accepted: {100 * limit:.3g} %, "
                        "[joints.acceptance] relative_rmse)")
        if key in ("rmse", "max_abs_error") and rmse_bound > limit:
            return f"an RMSE of {rmse_bound:.4g} N·m (accepted: {key} = {limit:.4g} N·m)"
    return None


def _held_angles(problem: Problem, i: int) -> np.ndarray:
    """Angles (rows) of every joint on joint i's lines: joint i over :data:`ENERGY_SAMPLES`
    angles, each other joint at :data:`HELD_SAMPLES` angles of its range (all combinations)."""
    axes = [joint.grid(ENERGY_SAMPLES if c == i else HELD_SAMPLES) for c, joint in enumerate(problem.joints)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=0).reshape(len(axes), -1)


def _energy_bound(problem: Problem, i: int):
    """(RMSE bound [N·m], target RMS [N·m], why, fix) of joint ``i``'s energy budget, or None
    if its springs can store what its target needs."""
    joint, store = problem.joints[i], problem.spring_energy(i)
    theta = _held_angles(problem, i)
    tau_d = np.asarray(joint.target.function(len(problem.joints), i).map(theta.shape[1])(theta)).ravel()
    lines = np.moveaxis(tau_d.reshape([ENERGY_SAMPLES if c == i else HELD_SAMPLES
                                       for c in range(len(problem.joints))]), i, -1).reshape(-1, ENERGY_SAMPLES)
    angle = joint.grid(ENERGY_SAMPLES)
    work = np.concatenate([np.zeros((len(lines), 1)),
                           np.cumsum(0.5 * (lines[:, 1:] + lines[:, :-1]) * np.diff(angle), axis=1)], axis=1)
    swing = work.max(axis=1) - work.min(axis=1)
    span = joint.theta_range[1] - joint.theta_range[0]
    short = np.maximum(swing - store, 0.0)
    if not short.any():
        return None
    worst = int(np.argmax(swing))
    held = [s.name for j, s in enumerate(problem.springs) if problem.extension_limit(j) < s.travel]
    within = "their travel and their cable's working load" if held else "their travel"
    why = (f"its target needs {swing[worst]:.4g} J of spring energy over its range, and its springs store at most "
           f"{store:.4g} J within {within}")
    fix = "give stiffer springs, more travel or more preload, or balance a narrower range"
    if held:
        fix = (f"give a stronger cable (its working load {problem.cable.working_load:.4g} N stops "
               f"{', '.join(map(repr, held))} short of the travel), softer springs of longer travel (under a force "
               "limit, a spring stores more the further it stretches), or balance a narrower range")
    return float(np.sqrt(np.mean((short / span) ** 2))), float(np.sqrt(np.mean(lines**2))), why, fix


def _sign_bound(problem: Problem, i: int, start: _CircularStart):
    """(RMSE bound [N·m], target RMS [N·m], why, fix) where every spring on joint ``i`` pulls
    through fixed-sign ports one way and the target asks for the other sign, or None."""
    network, ports = problem.network(), problem.ports
    sign_keys: dict[int, tuple[str, ...]] = {}  # mechanism → the keys that reverse its pull
    for g in network.joint_ports[i]:
        u, name = ports[g]
        keys = problem.mechanisms[u].fixed_sign_ports.get(name)
        if keys is None and network.P[:, g].any():
            return None  # a port whose arm may take either sign
        if keys is not None:
            sign_keys[u] = keys
    springs = [j for j in range(network.S) if i in network.joints_of(j)]
    if not springs:
        return None
    fine = start.fine
    arms = np.vstack([fine.units[u].arm[problem.mechanisms[u].ports.index(name)]
                      for u, name in (ports[g] for g in network.joint_ports[i])])
    signs = np.sign([network.arm_term(j, i, arms) for j in springs])
    if not (np.all(signs == 1) or np.all(signs == -1)):
        return None
    s = signs.flat[0]
    tau_d = fine.tau_d[i]
    wrong = tau_d * s < 0
    if not wrong.any():
        return None
    why = (f"its springs can only give it a {'positive' if s > 0 else 'negative'} torque (τ = dV/dθ) with this "
           f"layout, and its target is {'negative' if s > 0 else 'positive'} over {100 * wrong.mean():.3g} % of "
           "the range")
    keys = [f"{' or '.join(ks)} of mechanism {problem.mechanisms[u].name!r}" for u, ks in sign_keys.items() if ks]
    fix = (f"reverse the pull: set the {'; or the '.join(keys)} the other way" if keys else
           "check the target's sign: cadcam's target is the torque the springs resist, dV/dθ")
    return float(np.sqrt(np.mean(np.where(wrong, tau_d, 0.0) ** 2))), float(np.sqrt(np.mean(tau_d**2))), why, fix
