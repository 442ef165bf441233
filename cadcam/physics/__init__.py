"""Physics layer: profiles, departure (tangency), wrapped length, capstan friction, springs.

Each model is written once, symbolically, in CasADi; function builders are cached per basis.
"""
