"""Mechanisms: compositions of the physics layer, one module per mechanism."""
