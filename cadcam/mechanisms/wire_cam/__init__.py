"""The wire-wrapped cam on a follower idler (Johnston2023): its model, the tangency of the
wire on cam and idler (departure) and the paper's capstan force model."""
from .model import WireCam

__all__ = ["WireCam"]
