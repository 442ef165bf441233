"""The solids a workshop prints or machines, read back from what is written: ``camN.stl`` (a
binary mesh in millimetres, single precision) and ``camN.step`` (the extra ``step``: build123d
and its OpenCascade kernel), each measured for its check in :mod:`cadcam.outputs.file_checks`:
its volume, its thickness, and the outline and holes of its face on z = 0 (the groove, where
there is one, lies in the middle of the thickness: that face is the whole section).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..library_files import libraries_imported
from ..units import MM

#: A binary STL's record: the facet's normal, its three corners [mm] and an attribute word.
STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
#: Bytes of a binary STL's header before the facet count.
STL_HEADER = 80
#: How far [m] a length measured on an STL (a hole's centre and radii, its thickness) may be
#: off by the single precision of its coordinates, per metre of the part's size: four half
#: places (2⁻²⁴ each), a point's two coordinates rounded in each of two points measured apart.
FLOAT32_ROUNDING = 2.0**-22
#: Points along each edge of a STEP face's outer wire at which its outline is measured.
STEP_EDGE_SAMPLES = 5


@dataclass(frozen=True)
class Solid:
    """A solid read back from a file, in metres.

    Attributes
    ----------
    volume : float
        [m³].
    z_range : tuple of float
        Least and greatest z [m]: the part's faces.
    outline : ndarray (K, 2)
        Points [m] of the bottom face's outer boundary, counter-clockwise (an STL's polygon:
        its vertices; a STEP's curves: points along each edge).
    holes : list of (ndarray, float, float)
        Per inner boundary of the bottom face: its centre [m] and the radii [m] of the largest
        circle about it inside the hole and of the least that holds it (a true circle's
        radius twice; a polygon's inscribed and circumscribed radii).
    open_edges : int
        Edges of the mesh not shared by exactly two facets, once each way (0: a closed,
        consistently oriented surface; a STEP's kernel solid: 0).
    rounding : float
        How far [m] its coordinates may lie from where they were meant (single precision's
        half place at the part's farthest point for an STL, 0 for a STEP).
    surface : float
        Its surface's area [m²] (for the volume's rounding).
    """

    volume: float
    z_range: tuple[float, float]
    outline: np.ndarray
    holes: list
    open_edges: int
    rounding: float
    surface: float


def read_stl(path) -> Solid:
    """The mesh of a binary STL in millimetres, its coincident corners joined into vertices.

    Raises
    ------
    ValueError
        If the file's length is not that of its facet count.
    """
    data = Path(path).read_bytes()
    count = int(np.frombuffer(data, "<u4", 1, STL_HEADER)[0]) if len(data) >= STL_HEADER + 4 else -1
    if count < 0 or len(data) != STL_HEADER + 4 + STL_RECORD.itemsize * count:
        raise ValueError(f"{Path(path).name}: not a binary STL (its length is not that of its facet count)")
    corners = np.frombuffer(data, STL_RECORD, count, STL_HEADER + 4)["corners"].astype(float) / MM
    vertices, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    triangles = index.reshape(-1, 3)
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    z = vertices[:, 2]
    bottom = triangles[np.all(z[triangles] == z.min(), axis=1)]
    loops = [vertices[loop, :2] for loop in _boundary_loops(bottom)]
    areas = [_shoelace(loop) for loop in loops]
    outer = int(np.argmax(np.abs(areas))) if loops else None
    return Solid(volume=float(np.sum(np.linalg.det(corners)) / 6), z_range=(float(z.min()), float(z.max())),
                 outline=_counter_clockwise(loops[outer]) if loops else np.zeros((0, 2)),
                 holes=[_polygon_hole(loop) for k, loop in enumerate(loops) if k != outer],
                 open_edges=_open_edges(triangles, len(vertices)),
                 rounding=float(FLOAT32_ROUNDING * np.abs(vertices).max()),
                 surface=float(np.linalg.norm(cross, axis=1).sum() / 2))


def _open_edges(triangles: np.ndarray, vertices: int) -> int:
    """Directed edges of ``triangles`` used twice or without their opposite half."""
    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    key = directed[:, 0] * vertices + directed[:, 1]
    unique, times = np.unique(key, return_counts=True)
    reverse = np.isin(directed[:, 1] * vertices + directed[:, 0], unique)
    return int(np.sum(times > 1) + np.sum(~reverse))


def _boundary_loops(triangles: np.ndarray) -> list[np.ndarray]:
    """The closed loops (vertex indices) of the boundary of a set of consistently oriented
    triangles: its edges without their opposite half, followed end to end."""
    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    pairs = set(map(tuple, directed.tolist()))
    following = {a: b for a, b in pairs if (b, a) not in pairs}
    loops = []
    while following:
        start, loop = next(iter(following)), []
        vertex = start
        while vertex in following:
            loop.append(vertex)
            vertex = following.pop(vertex)
        loops.append(np.array(loop))
    return loops


def _shoelace(loop: np.ndarray) -> float:
    """Signed area [m²] of the polygon ``loop`` (K, 2), positive counter-clockwise."""
    x, y = loop.T
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _counter_clockwise(loop: np.ndarray) -> np.ndarray:
    """The polygon ``loop`` counter-clockwise."""
    return loop if _shoelace(loop) > 0 else loop[::-1]


def _polygon_hole(loop: np.ndarray) -> tuple[np.ndarray, float, float]:
    """A hole's polygon as its centre (the mean of its vertices: a regular polygon's centre),
    inscribed radius (least distance from the centre to its sides) and circumscribed radius."""
    centre = loop.mean(axis=0)
    a, b = loop - centre, np.roll(loop, -1, axis=0) - centre
    side = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) / np.linalg.norm(b - a, axis=1)
    return centre, float(side.min()), float(np.linalg.norm(a, axis=1).max())


def read_step(path) -> Solid:
    """The solid of a STEP file in millimetres (build123d's import): its volume, its box's z
    and its lowest face's outer wire (points along each edge) and inner wires (each a circle:
    its centre and radius; a wire of other edges is given as a hole of radius 0, which no
    hole's check passes)."""
    with libraries_imported():
        import build123d as bd

    shape = bd.import_step(str(path))
    box = shape.bounding_box()
    bottom = shape.faces().sort_by(bd.Axis.Z)[0]
    s = np.linspace(0.0, 1.0, STEP_EDGE_SAMPLES, endpoint=False)
    outline = np.array([[p.X, p.Y] for edge in bottom.outer_wire().edges() for p in edge.positions(s)]) / MM
    holes = []
    for wire in bottom.inner_wires():
        edges = wire.edges()
        if len(edges) == 1 and edges[0].geom_type == bd.GeomType.CIRCLE:
            centre, radius = np.array([edges[0].arc_center.X, edges[0].arc_center.Y]) / MM, edges[0].radius / MM
            holes.append((centre, radius, radius))
        else:
            holes.append((np.zeros(2), 0.0, 0.0))
    return Solid(volume=float(shape.volume) / MM**3, z_range=(box.min.Z / MM, box.max.Z / MM),
                 outline=_counter_clockwise(outline), holes=holes, open_edges=0, rounding=0.0,
                 surface=float(shape.area) / MM**2)
