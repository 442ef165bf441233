"""A radial cam pressing a translating roller follower against a spring (classic cam design,
Norton2009): a contact of a roller on the profile, not a wrapped cable.

* :mod:`.geometry` — the contact geometry, written once in CasADi: the profile point and its
  outward normal in the world frame, the roller centre (the pitch point), the pressure angle,
  the follower's velocity ratio and the pitch curve's radius of curvature;
* :mod:`.model` — the registered mechanism ``roller_follower``: its unknowns (contact angle α
  and follower position s), residuals, port ``follower``, limits, drawing hooks and spec keys.

Importing :mod:`.model` registers its source, Norton's handbook
(:func:`cadcam.citations.register_paper`).
"""
from .model import RollerFollower

__all__ = ["RollerFollower"]
