"""Solid outlines in the current configuration.

For every body: its boundary loops as a shapely polygon (outer loops counter-clockwise, holes
clockwise), its coupling-interface edges Γ (paper Sec. 2) with their outward normals, and
the checks the cut relies on: no self-intersection, no escape from the fluid box (unless the
body is declared to cross it), and a warning for bodies thinner than a fluid cell.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.validation import explain_validity

from fsci.errors import FsciWarning, GeometryError


@dataclass
class Outline:
    """One body's boundary in the current configuration."""

    body: int
    name: str
    x: np.ndarray  # current node coordinates (n, 2)
    edges: np.ndarray  # coupling-interface edges Γ (k, 2), cell on the left
    polygon: shapely.Geometry  # the region the body takes from the fluid (with dry cavities: included)
    all_edges: np.ndarray  # every boundary edge (for events between bodies)
    _normals: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)

    def normals(self) -> np.ndarray:
        """Outward unit normals of the interface edges, ``(k, 2)`` (computed once: an outline
        is the geometry of one iterate and is not changed)."""
        if self._normals is None:
            d = self.x[self.edges[:, 1]] - self.x[self.edges[:, 0]]
            L = np.linalg.norm(d, axis=1)
            self._normals = np.column_stack([d[:, 1], -d[:, 0]]) / L[:, None]
        return self._normals


def body_polygon(x: np.ndarray, loops: list[np.ndarray], name: str, dry_cavities: bool = False) -> shapely.Geometry:
    """Polygon of a body from its boundary loops; raises :class:`GeometryError` if invalid.
    With ``dry_cavities`` the enclosed cavities belong to the body's region (not fluid)."""
    shells, holes = [], []
    for loop in loops:
        p = x[loop]
        # twice the signed area (shoelace): counter-clockwise loops are shells
        area = p[:-1, 0] @ p[1:, 1] - p[1:, 0] @ p[:-1, 1] + p[-1, 0] * p[0, 1] - p[0, 0] * p[-1, 1]
        (shells if area > 0 else holes).append(p)
    polys = []
    for s in shells:
        if not holes:
            polys.append(shapely.Polygon(s))
            continue
        ring = shapely.Polygon(s)
        mine = [h for h in holes if ring.contains(shapely.Point(h[0])) or ring.covers(shapely.Point(h[0]))]
        polys.append(shapely.Polygon(s, mine))
    geom = polys[0] if len(polys) == 1 else shapely.MultiPolygon(polys)
    if not geom.is_valid:
        raise GeometryError(f"body '{name}': outline self-intersects ({explain_validity(geom)})")
    if not dry_cavities:
        return geom
    filled = [shapely.Polygon(p.exterior) for p in polys]
    return filled[0] if len(filled) == 1 else shapely.MultiPolygon(filled)


def check_in_box(outline: Outline, box: tuple[float, float, float, float], tol: float) -> None:
    """Raise if an interface edge of a body leaves the fluid box."""
    x0, x1, y0, y1 = box
    pts = outline.x[np.unique(outline.edges)]
    out = (pts[:, 0] < x0 - tol) | (pts[:, 0] > x1 + tol) | (pts[:, 1] < y0 - tol) | (pts[:, 1] > y1 + tol)
    if np.any(out):
        p = pts[np.argmax(out)]
        raise GeometryError(
            f"body '{outline.name}': outline leaves the fluid box [{x0:g}, {x1:g}] × [{y0:g}, {y1:g}] at "
            f"({p[0]:.6g}, {p[1]:.6g}); set 'extends_outside = true' for a body meant to cross the box boundary"
        )


THIN_AREA = 0.25  # area (in cells) of a part thinner than a cell that is worth a warning


def _thin_parts(region, h: float, within=None) -> list:
    """Parts of ``region`` (inside ``within``) thinner than ``h``: what an opening by h/2
    removes, beyond the rounding of corners (a right angle loses 0.05 h²)."""
    thin = shapely.difference(region, region.buffer(-0.5 * h).buffer(0.5 * h))
    if within is not None:
        thin = shapely.intersection(thin, within)
    return [g for g in getattr(thin, "geoms", [thin]) if g.area > THIN_AREA * h * h]


def warn_if_thin(outline: Outline, h: float, box: tuple[float, float, float, float] | None = None,
                 local_h=None) -> float:
    """Warn if the body, or a part of it inside the fluid ``box`` (x0, x1, y0, y1), is thinner
    than the fluid cell size ``h`` (the largest near the body); with ``local_h(x, y)`` a part is
    measured against the cells where it is (a grid refined there is enough). Returns the
    thickness estimate of the body (diameter of the largest inscribed circle)."""
    radius = shapely.maximum_inscribed_circle(outline.polygon, tolerance=0.01 * h).length
    thickness = 2.0 * radius
    if thickness < h:
        warnings.warn(
            f"body '{outline.name}' is {thickness:.4g} thick (largest inscribed circle) but fluid cells are "
            f"{h:.4g} wide: fluid on both sides shares nodes (one dof set per node); refine the fluid grid "
            "or set fluid.interface.unknowns = 'per_fluid_part'",
            FsciWarning, stacklevel=2)
        return thickness
    # parts thinner than a cell: a fin, the wedge of a valve flap
    region = outline.polygon
    if box is not None:  # no fluid outside the box: a body along its side has fluid on one side only
        inside = shapely.box(box[0], box[2], box[1], box[3])
        region = shapely.union(region, shapely.difference(inside.buffer(2.0 * h, join_style="mitre"), inside))
    parts = [(g, h) for g in _thin_parts(region, h, inside if box is not None else None)]
    if local_h is not None:  # measured again against the cells where each part is
        parts = [(g, hl) for g, hl in ((g, float(local_h(g.centroid.x, g.centroid.y))) for g, _ in parts)
                 if _thin_parts(shapely.intersection(region, g.buffer(4.0 * h)), hl, g.buffer(h))]
    if parts:
        big, hb = max(parts, key=lambda p: p[0].area)
        c = big.centroid
        warnings.warn(
            f"body '{outline.name}' has {len(parts)} part(s) thinner than the fluid cells there ({hb:.4g}), the "
            f"largest near ({c.x:.4g}, {c.y:.4g}): fluid on both sides of it shares nodes (one dof set per node); "
            "refine the fluid grid there (the tip of a sharp wedge stays thinner than its cell on any grid) or set "
            "fluid.interface.unknowns = 'per_fluid_part'",
            FsciWarning, stacklevel=2)
    return thickness
