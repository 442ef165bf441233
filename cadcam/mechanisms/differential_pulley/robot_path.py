"""The end-effector path that designed pulley pairs produce in Fedorov2018's cable robot
(Sec. 4.1): the check of a cable robot design against its pick-and-place path."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cable_robot import end_effector
from .output_laws import SHARED_PATH_KEYS, robot_position, slider_cable


@dataclass
class RobotPath:
    """The end effector over the joint angles ``theta`` [rad]: ``target`` (2, n) [m] on the
    pick-and-place path, ``designed`` (2, n) [m] where the designed pulleys put it (the
    idlers' positions from the rootfinder, through the amplification stage and both cables),
    and ``error`` (n,) [m] their distance at each angle."""

    theta: np.ndarray
    target: np.ndarray
    designed: np.ndarray

    @property
    def error(self) -> np.ndarray:
        return np.hypot(*(self.designed - self.target))


def robot_mechanisms(problem) -> list[int]:
    """Indices of the mechanisms whose output law is a ``cable_robot`` target."""
    return [u for u, m in enumerate(problem.mechanisms)
            if m.output_target is not None and m.output_target.kind == "cable_robot"]


def robot_path(evaluation) -> RobotPath | None:
    """The end-effector path of a two-cable robot, or None unless exactly two mechanisms on
    one joint carry ``cable_robot`` laws of the same path.

    Raises
    ------
    ValueError
        If the two cables' laws describe different paths.
    """
    p = evaluation.problem
    units = robot_mechanisms(p)
    if len(units) != 2 or len({p.mechanisms[u].joint for u in units}) != 1:
        return None
    laws = [p.mechanisms[u].output_target.data for u in units]
    if any(laws[0][k] != laws[1][k] for k in SHARED_PATH_KEYS):
        raise ValueError("the two cable_robot laws describe different paths: give both the same "
                         f"{', '.join(SHARED_PATH_KEYS)}")
    theta = evaluation.units[units[0]].theta
    lengths = [slider_cable(evaluation.units[u].z[p.mechanisms[u].unknowns.index("x")], d)
               for u, d in zip(units, laws)]
    designed = np.array(end_effector(*lengths, laws[0]["anchor"], laws[1]["anchor"]))
    return RobotPath(theta, np.array(robot_position(theta, laws[0])), designed)
