"""Mechanisms: compositions of the physics layer, one module per mechanism, registered by name
(:func:`cadcam.mechanisms.base.register`). Importing this package registers the built-in ones."""
from . import anchored_pulley, differential_pulley, wire_cam  # noqa: F401  (registers them)
