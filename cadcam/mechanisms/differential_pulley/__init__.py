"""The differential pair of noncircular pulleys (Fedorov2018): its model, Fedorov's envelope
synthesis, and the cable robot of Sec. 4.1 (its geometry and the check of its path)."""
from . import output_laws  # noqa: F401  (registers the spring_balance and cable_robot laws)
from .model import DifferentialPulley

__all__ = ["DifferentialPulley"]
