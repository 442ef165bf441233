"""The output laws a differential pair brings (Fedorov2018): the idler position that balances a
pendulum by a spring on the slider (``spring_balance``, Sec. 3), and the idler position that
gives one cable of the two-cable robot the length to its end effector on a pick-and-place path
(``cable_robot``, Sec. 4.1). Registered as target kinds (:func:`cadcam.targets.register_target_kind`)
for a mechanism's ``output_target``.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ...keys import GRAVITY, MASS, PART_SIZE, REACH, Key, KeyTable
from ...physics.springs import CATALOGUE_PRELOADS, CATALOGUE_RATES
from ...targets import TargetKind, register_target_kind
from .cable_robot import cable_length, pick_and_place


def spring_elongation(phi, mass, length, g, rate, preload):
    """The elongation e(φ) [m] of a spring (rate k [N/m], initial tension F0 [N]) that balances
    a pendulum (m g l) by energy, zero at the unstable equilibrium φ = ±π (Fedorov2018 Eq. 18):
    m g l (1 − cos φ) + F0 e + ½ k e² = 2 m g l (Eq. 17)."""
    mgl = mass * g * length
    return (-preload + ca.sqrt(preload**2 + 2 * rate * mgl * (ca.cos(phi) + 1))) / rate  # Fedorov2018 Eq. 18


#: The path keys of a ``cable_robot`` target (:func:`cadcam.mechanisms.differential_pulley.cable_robot.pick_and_place`).
PATH_KEYS = ("start", "lift", "span", "lift_share", "overlap")
#: The keys both cables of one robot share: its path and the input range it runs over.
SHARED_PATH_KEYS = PATH_KEYS + ("theta_range",)
#: Input shares at which the shortest cable of a path is sought.
PATH_SAMPLES = 20001


def robot_position(theta, d: dict):
    """The end effector's target position (x, y) [m] at joint angle θ: the path's input share
    is τ = (θ − θ₀)/(θ₁ − θ₀) over ``d["theta_range"]`` [rad] (Fedorov2018 Sec. 4.1)."""
    lo, hi = d["theta_range"]
    return pick_and_place((theta - lo) / (hi - lo), *(d[k] for k in PATH_KEYS))


def robot_cable(theta, d: dict):
    """The cable length [m] from anchor ``d["anchor"]`` to the end effector's target position
    at joint angle θ (:func:`robot_position`)."""
    return cable_length(*robot_position(theta, d), d["anchor"])


def shortest_cable(d: dict) -> float:
    """ℓ_min [m]: the least :func:`robot_cable` along the path, sampled at
    :data:`PATH_SAMPLES` angles and refined between the best sample's neighbours."""
    theta = np.linspace(*d["theta_range"], PATH_SAMPLES)
    k = int(np.argmin(robot_cable(theta, d)))
    bracket = (theta[max(k - 1, 0)], theta[min(k + 1, theta.size - 1)])
    from scipy.optimize import minimize_scalar  # imported here: scipy.optimize is slow to import

    best = minimize_scalar(lambda t: robot_cable(t, d), bounds=bracket, method="bounded",
                           options={"xatol": 1e-12})
    return float(min(best.fun, robot_cable(theta[k], d)))


def cable_robot_slider(theta, d: dict):
    """The idler position x(θ) [m] of one cable of Fedorov2018's cable robot (Sec. 4.1).

    The amplification stage (two coaxial pulleys of diameter ratio G = ``amplification``)
    turns the idler's travel into G times as much cable to the end effector, so that
    x = ``slider_at_shortest`` + (ℓ(θ) − ℓ_min)/G with ℓ(θ) :func:`robot_cable` and ℓ_min
    :func:`shortest_cable`: the idler moves away from the shaft as the cable pays out.
    """
    return d["slider_at_shortest"] + (robot_cable(theta, d) - shortest_cable(d)) / d["amplification"]


def slider_cable(x, d: dict):
    """The inverse of :func:`cable_robot_slider`: the cable length [m] to the end effector
    that an idler at ``x`` [m] gives, ℓ = ℓ_min + G (x − ``slider_at_shortest``)."""
    return shortest_cable(d) + d["amplification"] * (x - d["slider_at_shortest"])


SPRING_BALANCE_KEYS = KeyTable('kind = "spring_balance"', "x_d = slider_zero − e(θ + phase) with e the elongation at which a spring (rate, preload) balances a pendulum (mass, length, g) by energy, zero at the unstable equilibrium (Fedorov2018 Eq. 16–18).", (
    Key("mass", "kg", "the pendulum's mass", low=0, open_low=True, plausible=MASS),
    Key("length", "m", "the distance from the joint to the pendulum's centre of mass", low=0, open_low=True,
        plausible=REACH),
    Key("g", "m/s²", "the gravity", low=0, open_low=True, default=9.81, plausible=GRAVITY),
    Key("rate", "N/m", "the slider spring's rate", low=0, open_low=True, plausible=CATALOGUE_RATES),
    Key("preload", "N", "the slider spring's initial tension", low=0, plausible=CATALOGUE_PRELOADS),
    Key("slider_zero", "m", "the idler's distance from the shaft where the spring's elongation is zero",
        low=0, open_low=True, plausible=PART_SIZE),
    Key("phase", "rad", "the joint angle minus the pendulum angle from its stable equilibrium", default=0.0),
))
CABLE_ROBOT_KEYS = KeyTable('kind = "cable_robot"', "x_d = slider_at_shortest + (ℓ(θ) − ℓ_min)/amplification: the idler position that gives one cable of a two-cable robot its length ℓ from anchor to the end effector on a pick-and-place path (cadcam.mechanisms.differential_pulley.cable_robot.pick_and_place at input share (θ − theta_range[0])/(theta_range[1] − theta_range[0])), ℓ_min its least value along the path (Fedorov2018 Sec. 4.1).", (
    Key("anchor", "m", "[x, y]: this cable's attachment on the frame", "numbers", length=2, plausible=REACH),
    Key("start", "m", "[x, y]: the path's pick point", "numbers", length=2, plausible=REACH),
    Key("lift", "m", "the height of the vertical moves", low=0, open_low=True, plausible=REACH),
    Key("span", "m", "the horizontal move, signed", plausible=REACH),
    Key("lift_share", "-", "the share of the input rotation each vertical move takes", low=0, high=0.5,
        open_low=True, open_high=True),
    Key("amplification", "-", "the ratio G of cable to idler travel of the amplification stage (6 for 6:1)",
        low=0, open_low=True),
    Key("slider_at_shortest", "m", "the idler's distance from the shaft where the cable is shortest",
        low=0, open_low=True, plausible=PART_SIZE),
    Key("overlap", "-", "the share of the input during which the horizontal move overlaps a vertical one, "
        "below lift_share", low=0, default=0.0),
    Key("theta_range", "rad", "[start, end]: the joint angles over which the path runs, end > start",
        "numbers", length=2, default=None, default_text="the joint's range",
        check=lambda v: v[1] > v[0], words="end > start"),
))


def read_cable_robot(r, theta_range) -> dict:
    """A ``cable_robot`` output law (Fedorov2018 Sec. 4.1): this cable's frame anchor, the
    pick-and-place path, the amplification and the idler's position at the shortest cable;
    ``overlap`` below its ``lift_share``, ``theta_range`` by default its joint's."""
    data = {k.name: r.read(k) for k in CABLE_ROBOT_KEYS.keys if k.name not in ("overlap", "theta_range")}
    overlap = CABLE_ROBOT_KEYS["overlap"].within(high=data["lift_share"], open_high=True)
    data["overlap"] = r.read(overlap)
    data["theta_range"] = r.read(CABLE_ROBOT_KEYS["theta_range"], list(theta_range))
    return {k: ([float(x) for x in v] if isinstance(v, list) else float(v)) for k, v in data.items()}


def _spring_balance_law(d, thetas, cam):
    """x = slider_zero − e(θ + phase) [m] (Fedorov2018 Eq. 16–18)."""
    return d["slider_zero"] - spring_elongation(thetas[cam] + d["phase"], d["mass"], d["length"],
                                                d["g"], d["rate"], d["preload"])


register_target_kind(TargetKind("spring_balance", _spring_balance_law, torque=False, output=True,
                                keys=SPRING_BALANCE_KEYS))
def one_path(datas) -> str | None:
    """The cables of one cable robot follow one path: the first path key two laws differ in."""
    for key in SHARED_PATH_KEYS:
        if len({repr(d[key]) for d in datas}) > 1:
            return (f"{key}: the cables of one cable robot follow one path; give every cable_robot "
                    f"law the same {key}")
    return None


register_target_kind(TargetKind("cable_robot", lambda d, thetas, cam: cable_robot_slider(thetas[cam], d),
                                torque=False, output=True, read=read_cable_robot, check=one_path,
                                keys=CABLE_ROBOT_KEYS))
