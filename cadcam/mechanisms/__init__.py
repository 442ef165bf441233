"""Mechanisms: compositions of the physics layer, one module per mechanism, registered by name
(:func:`cadcam.mechanisms.base.register`). Importing this package registers the built-in ones."""
from . import wire_cam  # noqa: F401  (registers "wire_cam")
