"""The cam as a STEP solid: the DXF's biarc outline extruded, the bore and the anchor hole
through it, the cable groove cut round it; with the optional extra ``step`` (build123d and its
OpenCascade kernel), imported only here.
"""
from __future__ import annotations

import numpy as np

from ..files import atomic_path
from ..library_files import libraries_imported
from .biarc import ArcChain, arc_points
from ..units import MM


def available() -> bool:
    """True where build123d (the extra ``step``) is installed."""
    try:
        with libraries_imported():  # it imports ezdxf; OpenCascade's message files
            import build123d  # noqa: F401
    except ImportError:
        return False
    return True


def _profile_face(chain: ArcChain):
    """The chain's closed outline [mm] as a build123d Face: a line or a three-point arc per segment."""
    with libraries_imported():
        import build123d as bd

    ends = np.roll(chain.vertices, -1, axis=0)
    edges = []
    for a, b, bulge in zip(chain.vertices * MM, ends * MM, chain.bulges):
        if bulge == 0:
            edges.append(bd.Edge.make_line((*a, 0.0), (*b, 0.0)))
        else:
            mid = arc_points(a, b, bulge, [0.5])[0]
            edges.append(bd.Edge.make_three_point_arc((*a, 0.0), (*mid, 0.0), (*b, 0.0)))
    return bd.Face(bd.Wire(edges))


def write_step(path, chain: ArcChain, holes, thickness: float, groove_depth: float = 0.0,
               groove_width: float = 0.0) -> float:
    """Write the cam as a STEP solid in millimetres, atomically; returns its volume [m³].

    The outline ``chain`` extruded along z by ``thickness`` [m], each of ``holes`` ((centre [m],
    diameter [m]) pairs: the bore and the anchor hole) a cylinder through it, and with a groove
    the band ``groove_width`` wide, centred in the thickness, cut ``groove_depth`` deep all round
    (the outline offset inwards). Sizes are checked by :func:`cadcam.make.workshop.write_stl`'s
    rules before this is called.
    """
    with libraries_imported():
        import build123d as bd

    face = _profile_face(chain)
    t = thickness * MM
    solid = bd.Solid.extrude(face, bd.Vector(0, 0, t))
    for centre, diameter in holes:
        solid = solid - bd.Solid.make_cylinder(diameter * MM / 2, t, bd.Plane((*(centre * MM), 0.0)))
    if groove_depth > 0:
        ring = face - bd.offset(face, -groove_depth * MM)
        z0 = (thickness - groove_width) / 2 * MM
        band = bd.extrude(ring, groove_width * MM).moved(bd.Location((0, 0, z0)))
        solid = solid - band
    with atomic_path(path) as tmp:
        bd.export_step(solid, str(tmp))
    return float(solid.volume) / MM**3
