"""A roller follower's port recomputed from its written file (the file model,
:meth:`cadcam.mechanisms.base.Mechanism.port_length_from_file`): the roller, a circle pressed
onto the outline read back along its stem (:func:`cadcam.physics.outline.follower_contact`).
"""
from __future__ import annotations

import numpy as np

from ...physics.outline import FileOutline, follower_contact


def roller_follower_port(outline: FileOutline, mech, theta) -> np.ndarray:
    """Position s [m] of a roller follower's centre along its line at ``theta``, the cam turned
    by γ₀ − θ (Norton2009; :mod:`cadcam.mechanisms.roller_follower`)."""
    rotation = mech.axis_angle - np.asarray(theta, dtype=float)
    return follower_contact(outline, rotation, mech.follower_angle, mech.offset, mech.roller_radius)[2]
