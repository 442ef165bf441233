"""Direct synthesis of anchored-spring pulleys from a target torque, outside the NLP.

* :mod:`~cadcam.synthesis.kim_deshpande` — Kim & Deshpande's closed form as restated by
  Ludovico2021 Sec. II (with a preloaded spring as in Endo2010): the moment arm from the energy
  balance, the pulley as the envelope of its cable lines, and where it stops being feasible
  (curvature zeros, non-regular points). It also fits a profile basis to the result, a start
  point for the design NLP.
* :mod:`~cadcam.synthesis.ludovico_qcqp` — Ludovico2021's convex QCQP for a polynomial moment
  arm (Sec. III), the paper's baseline; needs the optional ``cvxpy`` (``cadcam[convex]``).
"""
