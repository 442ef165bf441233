"""An anchored pulley's cable length recomputed from its written file (the file model,
:meth:`cadcam.mechanisms.base.Mechanism.port_length_from_file`): the cable runs from the anchor
round the outline read back (:class:`cadcam.physics.outline.FileOutline`) and leaves it along
the tangent through the spring end, the root of n·S − h(ψ) = 0 in [χ − π, χ], χ the spring
end's polar angle unwrapped from the anchor; its length is the wrapped length plus that free
span.
"""
from __future__ import annotations

import numpy as np

from ...physics.outline import FileOutline, rotate


def spring_end_in_outline_frame(mech, theta) -> np.ndarray:
    """An anchored pulley's spring end at joint angles ``theta`` in its outline's frame [m]:
    the world turned back by the anchor's angle (and the pulley's turn when the pulley turns),
    mirrored for a clockwise winding."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    turn = mech.sense * theta
    still = np.zeros_like(theta)
    end = np.tile([mech.spring_end_x, mech.spring_end_y], (theta.size, 1))
    world = rotate(turn if mech.turning == "spring_end" else still, end)
    own = rotate(-(mech.anchor_angle + (turn if mech.turning == "pulley" else still)), world)
    own[:, 1] *= mech.windings[0]
    return own



def spring_end_turns(mech, theta) -> np.ndarray:
    """The spring end's polar angle in the outline's frame [rad], unwrapped from the anchor:
    its world angle at θ = 0 less the anchor's, plus the turn of the body that turns (the
    spring end's, or less the pulley's), mirrored for a clockwise winding."""
    turn = mech.sense * np.atleast_1d(np.asarray(theta, dtype=float))
    turn = turn if mech.turning == "spring_end" else -turn
    return mech.windings[0] * (np.arctan2(mech.spring_end_y, mech.spring_end_x) - mech.anchor_angle + turn)


def anchored_span(outline: FileOutline, mech, theta):
    """The free span of an anchored pulley's cable at ``theta`` (n,) in its outline's frame:
    where it leaves the outline and the spring end (both (n, 2) [m]), and the length wrapped
    from the anchor (n,) [m]."""
    end = spring_end_in_outline_frame(mech, theta)
    _, point, wrapped = outline.tangent(end, spring_end_turns(mech, theta))
    return point, end, wrapped


def anchored_path(outline: FileOutline, mech, theta) -> np.ndarray:
    """Length [m] of the cable from the anchor round the outline to the spring end at ``theta``."""
    point, end, wrapped = anchored_span(outline, mech, theta)
    return wrapped + np.hypot(*(end - point).T)
