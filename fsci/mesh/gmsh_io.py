"""Quad meshes from gmsh: meshing 2D outlines and importing ``.msh`` files.

* :func:`mesh_outline` meshes a region bounded by closed loops of lines and circular arcs
  with quadrilaterals (gmsh recombination + subdivision, so every cell is a quad); each piece
  of the outline may carry a name, which becomes an edge set and a node set.
* :func:`read_msh` imports a gmsh file through meshio; physical groups of dimension 1 become
  edge and node sets, physical groups of dimension 2 are ignored except that all quads are
  kept.

gmsh runs in a child process of its own (:func:`_in_clean_process`). Inside a process that has
loaded numba, scipy and MKL it did not always give the same mesh for the same input (the pump's
upper body at ``r = 2``: 3182 instead of 3198 nodes in about one run in eight, with fixed input,
one thread, and even with address-space randomisation off; always the same with a fixed
``PYTHONHASHSEED`` in a small process), so its result depends on the state of the heap it
meshes in. A fresh interpreter with a fixed hash seed that imports only gmsh gives the same mesh
every time, and costs about 0.2 s per mesh.
"""

from __future__ import annotations

import math
import os
import pickle
import signal
import subprocess
import sys
import threading
from collections import defaultdict
from typing import Any, Mapping, Sequence

import numpy as np

from fsci.errors import InputError, MeshError
from fsci.mesh.quadmesh import QuadMesh


def _orient_edge_sets(mesh: QuadMesh, raw: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Orient named edges like the mesh boundary (cell on the left); drop interior edges."""
    bnd = mesh.boundary.edges
    lookup = {(int(a), int(b)) for a, b in bnd}
    out = {}
    for name, edges in raw.items():
        oriented = []
        for a, b in np.asarray(edges).reshape(-1, 2):
            a, b = int(a), int(b)
            if (a, b) in lookup:
                oriented.append((a, b))
            elif (b, a) in lookup:
                oriented.append((b, a))
        if oriented:
            out[name] = np.array(oriented, dtype=np.int64)
    return out


def _compact(nodes: np.ndarray, cells: np.ndarray, edge_sets: dict[str, np.ndarray]) -> QuadMesh:
    """Drop nodes not used by any cell and renumber."""
    used = np.unique(cells)
    new = -np.ones(len(nodes), dtype=np.int64)
    new[used] = np.arange(len(used))
    mesh = QuadMesh(nodes[used], new[cells]).oriented()
    sets = {k: new[v] for k, v in edge_sets.items() if np.all(new[v] >= 0)}
    mesh.edge_sets = _orient_edge_sets(mesh, sets)
    mesh.edge_sets["all"] = mesh.boundary.edges.copy()
    mesh.node_sets = {k: np.unique(v) for k, v in mesh.edge_sets.items()}
    mesh.check("gmsh mesh")
    return mesh


def _loop_polygon(loop: Sequence[Mapping[str, Any]], field: str):
    """The loop as a shapely polygon (arcs sampled every 5°)."""
    import shapely

    pts: list[np.ndarray] = []
    for pi, piece in enumerate(loop):
        if "line" in piece:
            pts.append(np.asarray(piece["line"], float).reshape(2, 2))
        elif "arc" in piece:
            arc = piece["arc"]
            s, c, e = (np.asarray(arc[k], float) for k in ("start", "center", "end"))
            a0 = math.atan2(*(s - c)[::-1])
            da = (math.atan2(*(e - c)[::-1]) - a0 + math.pi) % (2 * math.pi) - math.pi  # the shorter arc
            a = a0 + da * np.linspace(0.0, 1.0, max(2, math.ceil(abs(da) / math.radians(5)) + 1))
            pts.append(c + np.linalg.norm(s - c) * np.column_stack([np.cos(a), np.sin(a)]))
        else:
            raise InputError(f"{field}[{pi}]", dict(piece), "a piece needs 'line' or 'arc'")
    # pieces may run either way (gmsh reorients them): chain them
    if len(pts) > 1 and min(np.linalg.norm(pts[0][0] - q) for q in (pts[1][0], pts[1][-1])) < \
            min(np.linalg.norm(pts[0][-1] - q) for q in (pts[1][0], pts[1][-1])):
        pts[0] = pts[0][::-1]
    for k in range(1, len(pts)):
        if np.linalg.norm(pts[k][0] - pts[k - 1][-1]) > np.linalg.norm(pts[k][-1] - pts[k - 1][-1]):
            pts[k] = pts[k][::-1]
    # each piece starts where the previous ended: drop the repeated (possibly rounded) point
    return shapely.Polygon(np.vstack([pts[0]] + [q[1:] for q in pts[1:]]))


def _check_loops(loops: Sequence[Sequence[Mapping[str, Any]]]) -> None:
    """Every loop a simple closed curve, every hole strictly inside the outer loop and apart from
    the other holes (gmsh may hang or abort on such input instead of reporting it)."""
    polys = [_loop_polygon(loop, f"loops[{i}]") for i, loop in enumerate(loops)]
    for i, p in enumerate(polys):
        if not p.is_valid or p.area <= 0.0:
            raise InputError(f"loops[{i}]", f"a loop of {len(loops[i])} pieces", "a closed loop that does not cross itself")
    for i, p in enumerate(polys[1:], 1):
        if not polys[0].contains(p) or polys[0].exterior.intersects(p.exterior):
            raise InputError(f"loops[{i}]", f"a hole with bounds {tuple(round(v, 6) for v in p.bounds)}",
                             f"a hole strictly inside the outer loop (bounds "
                             f"{tuple(round(v, 6) for v in polys[0].bounds)})")
        for j in range(1, i):
            if p.intersects(polys[j]):
                raise InputError(f"loops[{i}]", f"a hole touching loops[{j}]", "holes apart from each other")


def initialize_gmsh() -> None:
    """Start gmsh without letting it change how the process treats SIGPIPE.

    gmsh's C++ initialisation resets SIGPIPE to its default action (terminate), which Python
    ignores so that a write to a closed pipe or socket raises ``BrokenPipeError``. Left reset,
    any later write to a closed socket kills the whole process without a word (seen: a Dask
    client's socket closing after a mesh was made killed the test run, exit 141).
    """
    import gmsh

    sigpipe = getattr(signal, "SIGPIPE", None)  # not on Windows
    before = signal.getsignal(sigpipe) if sigpipe is not None else None
    gmsh.initialize(interruptible=False)
    if before is not None and threading.current_thread() is threading.main_thread():
        signal.signal(sigpipe, before)  # only the main thread may set a handler


def mesh_outline(loops: Sequence[Sequence[Mapping[str, Any]]], h: float, *, h_max: float | None = None,
                 refine: Sequence[Mapping[str, Any]] = (), algorithm: int = 8) -> QuadMesh:
    """Mesh a 2D region bounded by closed loops of lines and arcs with quads.

    Parameters
    ----------
    loops
        First loop is the outer boundary, further loops are holes. Each loop is a list of
        pieces, consecutive pieces sharing end points:
        ``{"line": [[x0, y0], [x1, y1]], "name": "top"}`` or
        ``{"arc": {"start": [..], "center": [..], "end": [..]}, "name": "round"}``
        (arcs spanning less than 180°; the shorter arc is taken).
    h
        Target element size on the outline.
    h_max
        Optional larger size in the interior (the size grows linearly with the distance from
        the outline); useful for rigid bodies whose interior does not matter.
    refine
        Local refinement: ``{"point": [x, y], "h": size, "radius": r}`` — size ``h`` within
        ``r`` of the point, growing linearly to the global size at ``4 r``.
    algorithm
        gmsh 2D algorithm (8 = Frontal-Delaunay for quads).

    Returns
    -------
    QuadMesh
        With edge/node sets for every named piece and ``all``.
    """
    if not (h > 0 and math.isfinite(h)):
        raise InputError("h", h, "a positive element size")
    if not loops:
        raise InputError("loops", loops, "at least one closed loop")
    _check_loops(loops)
    nodes_all, cells, edge_sets = _in_clean_process(loops, h, h_max, refine, algorithm)
    return _compact(nodes_all, cells, edge_sets)


def _in_clean_process(*args):
    """:func:`_generate` of ``args`` in a fresh Python interpreter with ``PYTHONHASHSEED=0`` (see
    the module docstring: gmsh's result depended on the heap of the calling process). Arguments
    and result travel pickled through the child's standard streams; an exception raised in the
    child is raised here."""
    job = pickle.dumps(args)
    env = dict(os.environ, PYTHONHASHSEED="0")
    code = "from fsci.mesh.gmsh_io import _child_main; _child_main()"
    done = subprocess.run([sys.executable, "-c", code], input=job, capture_output=True, env=env)
    try:
        ok, value = pickle.loads(done.stdout)
    except Exception:  # the child died before it could answer (killed, out of memory, gmsh aborted)
        tail = done.stderr.decode(errors="replace").strip().splitlines()[-3:]
        raise MeshError(f"the gmsh process ended with status {done.returncode} without a mesh"
                        + (": " + " / ".join(tail) if tail else "")) from None
    if not ok:
        raise value
    return value


def _child_main() -> None:
    """Entry point of the child of :func:`_in_clean_process`: read the job from stdin, write
    ``(True, result)`` or ``(False, exception)`` to stdout."""
    args = pickle.loads(sys.stdin.buffer.read())
    try:
        answer = (True, _generate(*args))
    except Exception as exc:  # handed to the parent, which raises it
        answer = (False, exc)
    sys.stdout.buffer.write(pickle.dumps(answer))
    sys.stdout.buffer.flush()


def _generate(loops: Sequence[Sequence[Mapping[str, Any]]], h: float, h_max: float | None,
              refine: Sequence[Mapping[str, Any]], algorithm: int
              ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """gmsh's mesh of checked ``loops`` (arguments as :func:`mesh_outline`): all nodes, the quads
    and the edges of every named piece, before unused nodes are dropped."""
    import gmsh

    initialized_here = not gmsh.isInitialized()
    if initialized_here:
        initialize_gmsh()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("fsci_outline")
        geo = gmsh.model.geo
        point_tags: dict[tuple[float, float], int] = {}

        def point(p) -> int:
            key = (round(float(p[0]), 12), round(float(p[1]), 12))
            if key not in point_tags:
                point_tags[key] = geo.addPoint(float(p[0]), float(p[1]), 0.0, h)
            return point_tags[key]

        names: dict[str, list[int]] = defaultdict(list)
        lengths: list[float] = []  # of every piece
        loop_tags = []
        for li, loop in enumerate(loops):
            curve_tags = []
            for pi, piece in enumerate(loop):
                field = f"loops[{li}][{pi}]"
                if "line" in piece:
                    p0, p1 = piece["line"]
                    tag = geo.addLine(point(p0), point(p1))
                    lengths.append(math.dist(p0, p1))
                elif "arc" in piece:
                    arc = piece["arc"]
                    s, c, e = (np.asarray(arc[k], float) for k in ("start", "center", "end"))
                    r0, r1 = np.linalg.norm(s - c), np.linalg.norm(e - c)
                    if abs(r0 - r1) > 1e-9 * max(r0, 1.0):
                        raise InputError(field + ".arc", arc, "start and end must be equidistant from center")
                    tag = geo.addCircleArc(point(s), point(c), point(e))
                    angle = math.acos(max(-1.0, min(1.0, float(np.dot(s - c, e - c)) / (r0 * r1))))
                    lengths.append(r0 * angle)
                else:
                    raise InputError(field, dict(piece), "a piece needs 'line' or 'arc'")
                curve_tags.append(tag)
                if "name" in piece:
                    names[str(piece["name"])].append(tag)
            loop_tags.append(geo.addCurveLoop(curve_tags, reorient=True))
        surf = geo.addPlaneSurface(loop_tags)
        geo.synchronize()
        for name, tags in names.items():
            gmsh.model.addPhysicalGroup(1, tags, name=name)
        gmsh.model.addPhysicalGroup(2, [surf], name="domain")
        gmsh.option.setNumber("Mesh.Algorithm", algorithm)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)
        gmsh.option.setNumber("Mesh.MeshSizeFactor", 1.0)
        # subdivision halves the size; compensate so the final size is about h
        gmsh.option.setNumber("Mesh.MeshSizeMin", 2 * h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 2 * (h if h_max is None else max(h, h_max)))
        fields = gmsh.model.mesh.field
        size_fields = []
        for k, ref in enumerate(refine):
            field = f"refine[{k}]"
            p = np.asarray(ref.get("point"), float)
            hr, rr = float(ref.get("h", 0.0)), float(ref.get("radius", 0.0))
            if p.shape != (2,) or not (hr > 0 and rr > 0):
                raise InputError(field, dict(ref), "{point = [x, y], h > 0, radius > 0}")
            pt = gmsh.model.geo.addPoint(p[0], p[1], 0.0, hr)
            gmsh.model.geo.synchronize()
            dist = fields.add("Distance")
            fields.setNumbers(dist, "PointsList", [pt])
            thr = fields.add("Threshold")
            fields.setNumber(thr, "InField", dist)
            fields.setNumber(thr, "SizeMin", 2 * hr)
            fields.setNumber(thr, "SizeMax", 2 * h)
            fields.setNumber(thr, "DistMin", rr)
            fields.setNumber(thr, "DistMax", 4 * rr)
            size_fields.append(thr)
        if size_fields:
            gmsh.option.setNumber("Mesh.MeshSizeMin", 2 * min(float(r["h"]) for r in refine))
        if h_max is not None and h_max > h:
            dist = fields.add("Distance")
            curves = [c[1] for c in gmsh.model.getEntities(1)]
            fields.setNumbers(dist, "CurvesList", curves)
            # the distance is measured to sample points: closer than h apart, or the size at the
            # outline grows between them (edges of 1.3 h observed with the default 20 per curve)
            fields.setNumber(dist, "Sampling", max(20, math.ceil(2.0 * max(lengths) / h)))
            thr = fields.add("Threshold")
            fields.setNumber(thr, "InField", dist)
            fields.setNumber(thr, "SizeMin", 2 * h)
            fields.setNumber(thr, "SizeMax", 2 * h_max)
            fields.setNumber(thr, "DistMin", 0.0)
            fields.setNumber(thr, "DistMax", 4 * h_max)
            size_fields.append(thr)
        if size_fields:
            fmin = fields.add("Min")
            fields.setNumbers(fmin, "FieldsList", size_fields)
            fields.setAsBackgroundMesh(fmin)
            gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        nodes_all = coords.reshape(-1, 3)[:, :2]
        index = -np.ones(int(tags.max()) + 1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        etypes, _, enodes = gmsh.model.mesh.getElements(2)
        quads = [np.asarray(n, dtype=np.int64).reshape(-1, 4) for t, n in zip(etypes, enodes) if t == 3]
        if not quads or any(t != 3 for t in etypes):
            raise MeshError("gmsh did not produce an all-quad mesh")
        cells = index[np.vstack(quads)]
        edge_sets = {}
        for name, ctags in names.items():
            edges = []
            for ct in ctags:
                lt, _, ln = gmsh.model.mesh.getElements(1, ct)
                for t, n in zip(lt, ln):
                    if t == 1:
                        edges.append(index[np.asarray(n, dtype=np.int64).reshape(-1, 2)])
            edge_sets[name] = np.vstack(edges)
    finally:
        gmsh.model.remove()
        if initialized_here:
            gmsh.finalize()
    return nodes_all, cells, edge_sets


def read_msh(path: str) -> QuadMesh:
    """Import a quad mesh from a gmsh ``.msh`` file via meshio.

    Physical groups of lines become edge/node sets named after the group (or ``group<tag>``
    when unnamed); all quad cells form the mesh.
    """
    import meshio

    try:
        m = meshio.read(path)
    except Exception as exc:  # meshio raises a variety of errors for bad files
        raise InputError("mesh.file", str(path), f"a readable gmsh .msh file ({exc})") from exc
    names_by_tag = {int(v[0]): k for k, v in (m.field_data or {}).items() if len(v) > 1 and int(v[1]) == 1}
    quads, edges = [], defaultdict(list)
    phys = m.cell_data.get("gmsh:physical")
    for bi, block in enumerate(m.cells):
        if block.type == "quad":
            quads.append(block.data)
        elif block.type == "line" and phys is not None:
            for tag in np.unique(phys[bi]):
                name = names_by_tag.get(int(tag), f"group{int(tag)}")
                edges[name].append(block.data[phys[bi] == tag])
        elif block.type not in ("vertex", "line", "quad"):
            raise InputError("mesh.file", str(path), f"only quad cells are supported, found {block.type}")
    if not quads:
        raise InputError("mesh.file", str(path), "the file contains no quad cells")
    return _compact(np.asarray(m.points)[:, :2], np.vstack(quads), {k: np.vstack(v) for k, v in edges.items()})
