"""The figure of the tutorial's conventions (docs/images/conventions.png): docs/first_balancer.toml
designed and drawn as ``cadcam design`` draws it (:func:`cadcam.outputs.plots.pose_views`), the
whole arm beside a close-up of its pulley, each convention noted with the keys that set it.

    python docs/conventions_figure.py            (or: make docs-images)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.patches import FancyArrowPatch

import cadcam
from cadcam.outputs.plots import MM, pose_views, save_figure
from cadcam.physics.profile import profile_function

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "docs" / "first_balancer.toml"
OUT = ROOT / "docs" / "images" / "conventions.png"
#: The pose drawn: the middle of three joint angles spread over the range.
POSE, N_POSES = 1, 3
#: The two views [mm]: the whole arm with its spring, and the pulley close up.
WHOLE = ((-200.0, -215.0), (110.0, 240.0))
CLOSE = ((-45.0, -45.0), (55.0, 55.0))
#: How far outside the profile the winding's arrow runs [mm].
WINDING_GAP = 4.0
#: Radii [mm] of the arrows of θ (about the joint, in the whole view) and of the pulley's turn
#: (in the close-up), and the length of the weight's arrow [mm].
THETA_ARC, TURN_ARC, WEIGHT = 75.0, 17.0, 45.0
NOTE = dict(fontsize=9, color="0.1", va="top", bbox=dict(boxstyle="round,pad=0.35", fc="lightyellow", ec="0.6", lw=0.6))
POINTER = dict(arrowstyle="->", color="0.3", lw=0.9, shrinkA=0, shrinkB=3)


def note(ax, text, at, xytext) -> None:
    """A note at ``xytext`` (axes fraction, its top-left corner) pointing to ``at`` [mm]."""
    ax.annotate(text, at, xytext=xytext, textcoords="axes fraction", arrowprops=POINTER, **NOTE)


def polar(radius, degrees) -> np.ndarray:
    """The point [mm] at ``radius`` from the joint in the world direction ``degrees``."""
    return radius * np.array([np.cos(np.radians(degrees)), np.sin(np.radians(degrees))])


def turn_arrow(ax, radius, start_deg, end_deg, colour) -> None:
    """A counter-clockwise arrow [mm] about the joint from world angle ``start_deg`` to ``end_deg``."""
    bend = np.tan(np.radians(end_deg - start_deg) / 4)  # arc3's bend of a circular arc
    ax.add_patch(FancyArrowPatch(polar(radius, start_deg), polar(radius, end_deg), connectionstyle=f"arc3,rad={bend}",
                                 arrowstyle="-|>", mutation_scale=16, lw=1.6, color=colour, zorder=6))


def main() -> None:
    result = cadcam.design(SPEC)
    ev, design = result.evaluation, result.design
    mech, joint, unit = ev.problem.mechanisms[0], ev.problem.joints[0], ev.units[0]
    k = int(np.unique(np.linspace(0, unit.theta.size - 1, N_POSES).round().astype(int))[POSE])
    theta, alpha = float(unit.theta[k]), float(unit.z[0, k])
    deg = np.degrees(theta)

    def on_pulley(phi: float) -> np.ndarray:
        """The world point [mm] of the pulley's profile at φ, at this pose."""
        rho = float(profile_function(design.bases[0])(phi, design.coefficients[0])[0])
        return MM * np.array(mech.world_points(theta, phi, rho), dtype=float)

    fig = pose_views(ev, [WHOLE, CLOSE], pose=POSE, n_poses=N_POSES)
    fig.set_size_inches(13.0, 8.6)
    fig.suptitle(f"The conventions of a spec: docs/first_balancer.toml at θ = {deg:.0f}°, as cadcam draws it "
                 "(the pulley close up on the right)", fontsize=11)
    whole, close = fig.axes

    # -- the whole arm: θ = 0, θ, the target's sign, the spring end
    data = joint.target.data
    whole.plot([0, 0], [0, 0.9 * MM * data["length"]], color="0.3", lw=1.0, ls="--")
    note(whole, "θ = 0: the arm upright", (0, 0.9 * MM * data["length"]), (0.68, 0.80))
    turn_arrow(whole, THETA_ARC, 90.0, 90.0 + deg, "tab:green")
    low, high = np.degrees(joint.theta_range)
    note(whole, f"θ grows counter-clockwise\nfrom the upright (here {deg:.0f}°):\n"
                f"theta_range_deg = [{low:g}, {high:g}]", polar(THETA_ARC, 90 + deg / 2), (0.03, 0.55))
    mass = polar(MM * data["length"], 90 + deg)
    whole.annotate("", mass - [0, WEIGHT], xytext=mass, arrowprops=dict(arrowstyle="-|>", color="0.3", lw=1.6))
    whole.annotate("m g", mass - [0, WEIGHT], xytext=(5, 0), textcoords="offset points", fontsize=9, va="center")
    note(whole, f"target = {{ kind = \"pendulum\", mass = {data['mass']:g}, length = {data['length']:g} }}\n"
                "τ_d = m g l sin θ > 0: the weight turns the arm\ntowards larger θ; the spring stores that energy,\n"
                "its torque on the arm is −τ_d", mass, (0.03, 0.97))
    end = MM * np.array([mech.spring_end_x, mech.spring_end_y])
    note(whole, f"spring_end = [{mech.spring_end_x:g}, {mech.spring_end_y:g}]:\nthe spring's far end, (x, y) [m]\n"
                "at θ = 0 (fixed to the base here)", end, (0.03, 0.17))

    # -- the pulley close up: the anchor, the winding, turning and sense
    note(close, "anchor (■): the cable's end, fixed on the pulley\n(anchor_angle, optional: its world angle at θ = 0)", on_pulley(0.0), (0.03, 0.97))
    note(close, f"winding = \"{mech.winding}\": the cable is wound clockwise\nfrom the anchor to where it leaves (●);"
                "\nas θ grows, more winds on and the\nspring stretches", on_pulley(alpha / 2), (0.50, 0.80))
    wound = np.array([on_pulley(phi) * (1 + WINDING_GAP / np.hypot(*on_pulley(phi)))
                      for phi in np.linspace(0.1, 0.9, 20) * alpha])
    close.plot(*wound[:-1].T, color="tab:blue", lw=1.0)
    close.annotate("", wound[-1], xytext=wound[-2], arrowprops=dict(arrowstyle="-|>", color="tab:blue", lw=1.0))
    turn_arrow(close, TURN_ARC, 195.0, 300.0, "tab:red")
    note(close, f"turning = \"{mech.turning}\", sense = {mech.sense:g}:\nthe pulley is fixed to the arm and\n"
                "turns with it by sense·θ (+1: counter-\nclockwise, as θ)", polar(TURN_ARC, 215.0), (0.03, 0.21))
    save_figure(fig, OUT)


if __name__ == "__main__":
    main()
