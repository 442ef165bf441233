"""The differential pair of noncircular pulleys (Fedorov2018): its model, Fedorov's envelope
synthesis, and the cable robot of Sec. 4.1 (its geometry and the check of its path)."""
from .model import DifferentialPulley

__all__ = ["DifferentialPulley"]
