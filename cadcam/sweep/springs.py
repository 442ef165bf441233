"""A spec's spring slot screened against a whole spring catalogue: what the slot asks of a spring
(:func:`slot_need`) and the catalogue's screen for it (:func:`screen_slot`), before any solve.
"""
from __future__ import annotations

import numpy as np

from ..physics.catalogue import Catalogue, Need, Screen, screen
from ..problem import Problem

#: The (mechanism kind, port) pairs whose moment arm on their joint is at most the mechanism's
#: profiles' ``rho_max``: the cable of an anchored pulley leaves its profile tangentially, so its length
#: changes by the perpendicular distance of that line from the pivot, at most the largest
#: radius, per radian. Springs on other ports get no force or stroke test.
ARM_BOUNDED = {("anchored_pulley", "cable")}

#: Points of the joint's range the target's work and peak torque are taken on.
NEED_POINTS = 2001


def slot_need(problem: Problem, j: int) -> Need:
    """What spring ``j`` (0-based) of ``problem`` must at least do, for :func:`screen`.

    The tests apply to a spring on one joint that no other spring works on (its energy must
    then supply the target's whole work); a spring that shares its joint, or spans several,
    gets no test and every catalogue spring passes the screen.
    """
    spring = problem.springs[j]
    joints = {problem.mechanisms[p.mechanism].joint for p in spring.ports}
    if len(joints) != 1:
        return Need()
    (i,) = joints
    shared = [s for s in problem.springs if s is not spring
              and any(problem.mechanisms[p.mechanism].joint == i for p in s.ports)]
    if shared or len(problem.joints) != 1:
        return Need()
    joint = problem.joints[i]
    theta = np.linspace(*joint.theta_range, NEED_POINTS)
    tau = np.asarray(joint.target.function(1, 0).map(theta.size)(theta[None, :])).ravel()
    work = np.concatenate([[0.0], np.cumsum(0.5 * (tau[1:] + tau[:-1]) * np.diff(theta))])
    arms = [max(f.rho_max for f in problem.mechanisms[p.mechanism].profiles) for p in spring.ports
            if (problem.mechanisms[p.mechanism].kind, p.name) in ARM_BOUNDED]
    bounded = len(arms) == len(spring.ports) == 1
    return Need(energy=float(work.max() - work.min()), torque=float(np.abs(tau).max()),
                arm=float(arms[0]) if bounded else None,
                angle=float(np.ptp(theta)) if bounded else None)


def screen_slot(problem: Problem, j: int, catalogue: Catalogue) -> Screen:
    """``catalogue`` screened for spring ``j`` of ``problem`` (:func:`slot_need`, :func:`screen`)."""
    return screen(catalogue, slot_need(problem, j))
