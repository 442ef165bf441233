"""How each spring of a design is installed: its force and length over the joint range, and for a
spring that hangs from a mount on its cable (:meth:`cadcam.problem.Problem.mounted_springs`)
where that mount is and how long to cut the cable from its anchor on the profile to the hook.

The cable's length is constant: the path from the anchor to the mount, wound length plus room
(:meth:`cadcam.mechanisms.base.Mechanism.spring_room`), less the spring's length L0 + x, is the
same at every pose because the spring's extension x grows by exactly the path's change
(Johnston2023 Eq. 14). It is taken at the reference pose, where x is the design's pre-extension.
"""
from __future__ import annotations

import numpy as np

from .evaluate import Evaluation, free_cable


def _ranges(ev: Evaluation, j: int) -> dict:
    """Spring ``j``'s extension [m], force [N] and (with a free length) installed length [m],
    each as [least, largest] over the grid."""
    spring = ev.problem.springs[j]
    lo, hi = ev.tensor.extension_range(j)
    out = {"name": spring.name, "part": spring.part, "extension": [float(lo), float(hi)],
           "force": [float(spring.preload + spring.rate * lo), float(spring.preload + spring.rate * hi)]}
    if spring.free_length is not None:
        out["installed_length"] = [float(spring.free_length + lo), float(spring.free_length + hi)]
    return out


def _mount(ev: Evaluation, j: int, u: int, port: str, joint: int) -> dict:
    """Mounted spring ``j``'s mount (its fixed end, a world point [m] at the reference angle),
    the cable's cut length from its anchor on the mechanism's first profile to the hook [m], and
    the least free cable between the profile and the hook over the grid [m]."""
    problem, design = ev.problem, ev.design
    mech, unit, spring = problem.mechanisms[u], ev.units[u], problem.springs[j]
    sl = problem.profile_slices()[u]
    c = np.concatenate([np.asarray(v, dtype=float) for v in design.coefficients[sl]])
    sign = spring.ports[0].sign
    mount, _, _ = mech.spring_line(mech.reference_angle, unit.z_ref, c, port, sign)
    room_ref = unit.rooms[port][-1]
    cable = unit.wound_ref[0] + room_ref - spring.free_length - float(design.preextension[j])
    return {"mount": [float(v) for v in mount], "mount_angle": float(mech.reference_angle),
            "cable_length": float(cable),
            "least_free_cable": float(np.min(free_cable(ev, j, u, port, joint)))}


def spring_installation(ev: Evaluation) -> list[dict]:
    """Every spring's installation (SI units): name, part, ``extension``, ``force`` and
    ``installed_length`` ranges; a mounted spring adds ``mount``, ``mount_angle``,
    ``cable_length`` and ``least_free_cable`` (:func:`_mount`)."""
    out = [_ranges(ev, j) for j in range(len(ev.problem.springs))]
    for j, u, port, joint in ev.problem.mounted_springs():
        out[j].update(_mount(ev, j, u, port, joint))
    return out


def installation_lines(rows: list[dict]) -> list[str]:
    """One summary line per spring: its force and length ranges, and where a mounted one is
    mounted and how long its cable is cut (mm and N)."""
    lines = []
    for row in rows:
        name = row["name"] + (f" ({row['part']})" if row["part"] else "")
        text = f"  {name}: force {row['force'][0]:.4g}–{row['force'][1]:.4g} N"
        if "installed_length" in row:
            text += f", length {1e3 * row['installed_length'][0]:.1f}–{1e3 * row['installed_length'][1]:.1f} mm"
        if "mount" in row:
            x, y = (1e3 * v for v in row["mount"])
            text += (f"; mount at ({x:.1f}, {y:.1f}) mm (joint at {np.degrees(row['mount_angle']):.4g}°), "
                     f"cable {1e3 * row['cable_length']:.1f} mm from its anchor to the hook")
        lines.append(text)
    return lines
