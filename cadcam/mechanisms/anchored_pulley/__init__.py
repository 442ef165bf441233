"""The anchored-spring pulley (Ludovico2021, Endo2010) and its direct syntheses outside the NLP.

* :mod:`.model` — the pulley, its cable and its in-line spring;
* :mod:`.kim_deshpande` — Kim & Deshpande's closed form as restated by Ludovico2021 Sec. II
  (with a preloaded spring as in Endo2010): the moment arm from the energy balance, the pulley
  as the envelope of its cable lines, and where it stops being feasible (curvature zeros,
  non-regular points);
* :mod:`.moment_arm` — the pulleys of one joint designed in the coefficients of their moment
  arms r_m(θ) (Ludovico2021 Sec. III's parametrisation) for the largest torque error, under the
  profile NLP's limits read through the envelope; its pulleys are envelopes, not profiles;
* :mod:`.ludovico_qcqp` — Ludovico2021's convex QCQP for a polynomial moment arm (Sec. III),
  the paper's baseline; needs the optional ``cvxpy`` (``cadcam[convex]``).
"""
from .model import AnchoredPulley

__all__ = ["AnchoredPulley"]
