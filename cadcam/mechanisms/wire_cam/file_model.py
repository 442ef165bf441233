"""A wire cam's ports recomputed from its written file (the file model,
:meth:`cadcam.mechanisms.base.Mechanism.port_length_from_file`): the follower idler, a circle
pressed onto the outline read back along the platform (:func:`cadcam.physics.outline.follower_contact`).
"""
from __future__ import annotations

import numpy as np

from ...physics.outline import FileOutline, follower_contact


def wire_cam_port(outline: FileOutline, mech, port: str, theta) -> np.ndarray:
    """Length [m] of a wire cam's port at ``theta``: its follower idler rides the platform at
    height a₀, the cam turned by −θ (Johnston2023 Eq. 7); ``wire`` is the wrapped length plus the
    wire on the idler r γ, γ = φ_p + π the contact's angle on the idler (Eq. 6, 14);
    ``platform`` the idler centre's x (Eq. 15, 16)."""
    theta = np.asarray(theta, dtype=float)
    _, wrapped, qx, lean = follower_contact(outline, -theta, 0.0, mech.idler_offset, mech.idler_radius)
    return wrapped + mech.idler_radius * (lean + np.pi) if port == "wire" else qx
