"""Case files (TOML) → :class:`fsci.problem.Problem`.

Reading a case has three stages, all before anything runs or is written:

1. :func:`load_toml` reads the file (UTF-8 TOML, bounded nesting); ``--set KEY=VALUE``
   overrides (:func:`apply_override`) and the selected variant (:func:`apply_variant`) are
   applied to the dictionary;
2. :func:`fsci.schema.validate` checks every key against the schema (types, ranges, unknown
   keys with the closest valid name) and returns the normalised dictionary;
3. the checks that relate tables to each other or need sizes and geometry: the step and
   unknown limits (estimated before any mesh is built), the bodies' outlines against the fluid
   box and each other, boundary and quantity names, references that name a result; then the
   meshes and the :class:`Problem` are built.

Every problem raises :class:`fsci.errors.InputError` naming the dotted key.
"""

from __future__ import annotations

import copy
import math
import re
import tomllib
import warnings
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import shapely

from fsci.errors import FsciWarning, InputError, MeshError
from fsci.mesh import generate
from fsci.mesh.gmsh_io import mesh_outline, read_msh
from fsci.mesh.grid import Grid
from fsci.mesh.quadmesh import QuadMesh
from fsci.problem import (
    Body, ContactSettings, Dirichlet, Fluid, InterfaceSettings, Material, Neumann, Output, Problem, Quantity, Reference,
    SolverSettings, Stabilization, TimeGrid, Verification,
)
from fsci.schema import result_names, suggest, validate
from fsci.timefunc import time_function

MAX_NESTING = 64  # tables/lists inside each other in a case file (a real case needs < 10)
MAX_CASE_BYTES = 10_000_000

# --------------------------------------------------------------------------- reading
def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a case file: UTF-8 TOML; unreadable, non-UTF-8, malformed or absurdly nested
    files are reported with one line."""
    p = Path(path)
    try:
        if p.is_dir():
            raise InputError("case", str(path), "a TOML case file, not a directory")
        if p.stat().st_size > MAX_CASE_BYTES:
            raise InputError("case", str(path), f"a case file smaller than {MAX_CASE_BYTES // 1_000_000} MB")
        data = p.read_bytes()
    except OSError as exc:
        raise InputError("case", str(path), f"a readable TOML file ({exc.strerror})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError("case", str(path), f"a UTF-8 text file (byte {exc.start} is not UTF-8)") from None
    _check_nesting(text, str(path))
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError("case", str(path), f"valid TOML ({exc})") from None
    except RecursionError:
        raise InputError("case", str(path), f"TOML nested at most {MAX_NESTING} levels deep") from None


def _check_nesting(text: str, where: str) -> None:
    """Reject inline arrays/tables nested deeper than :data:`MAX_NESTING` before parsing
    (the parser and every later walk over the data recurse once per level)."""
    depth = 0
    in_str: str | None = None
    for ch in text:
        if in_str:
            if ch == in_str or ch == "\n":
                in_str = None
        elif ch in "\"'":
            in_str = ch
        elif ch in "[{":
            depth += 1
            if depth > MAX_NESTING:
                raise InputError("case", where, f"TOML nested at most {MAX_NESTING} levels deep")
        elif ch in "]}":
            depth = max(depth - 1, 0)
        elif ch == "\n" and depth <= 2:  # a table header [a] / [[a]] closes on its own line
            depth = 0


# --------------------------------------------------------------------------- overrides
_PATH_RE = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


def _split_path(key: str) -> list[str | int]:
    parts: list[str | int] = []
    for name, index in _PATH_RE.findall(key):
        parts.append(int(index) if index else (int(name) if name.isdigit() else name))
    return parts


def _parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, RecursionError):
        return text


def apply_override(case: dict[str, Any], assignment: str) -> None:
    """Apply one ``KEY=VALUE`` override in place (validation happens in :func:`problem_from_dict`).

    ``KEY`` is a dotted path (``fluid.mu``, ``bodies[0].material.E`` or ``bodies.flag.material.E``);
    a bare name that is a case parameter (``re``) sets ``parameters.re``. ``VALUE`` is read as a
    TOML value (numbers, booleans, strings, lists, inline tables); anything else is a string.
    """
    if "=" not in assignment:
        raise InputError("--set", assignment, "KEY=VALUE")
    key, text = assignment.split("=", 1)
    set_value(case, key.strip(), _parse_value(text.strip()), "--set")


def apply_overrides(case: dict[str, Any], assignments: list[str]) -> dict[str, Any]:
    """Apply ``--set`` overrides in order (:func:`apply_override`); returns those that changed
    the case dictionary outside its parameters (key -> value as given), which leave a case's
    verified setting just as a changed parameter does. (An override that restates the case
    file's own value changes nothing; one that sets an absent key to its default is counted.)"""
    changed: dict[str, Any] = {}
    for a in assignments:
        rest = {k: v for k, v in case.items() if k != "parameters"}
        before = copy.deepcopy(rest)
        apply_override(case, a)
        if {k: v for k, v in case.items() if k != "parameters"} != before:
            key, text = a.split("=", 1)
            changed[key.strip()] = _parse_value(text.strip())
    return changed


def set_value(case: dict[str, Any], key: str, value: Any, source: str) -> None:
    """Set the dotted ``key`` of a case dictionary (see :func:`apply_override`); ``source``
    names where the assignment came from in error messages."""
    parts = _split_path(key)
    if not parts:
        raise InputError(source, f"{key}={value!r}", "KEY=VALUE with a non-empty key")
    params = case.get("parameters", {})
    if len(parts) == 1 and parts[0] not in case and isinstance(params, Mapping) and parts[0] in params:
        parts = ["parameters", parts[0]]
    node: Any = case
    for i, p in enumerate(parts[:-1]):
        where = ".".join(str(x) for x in parts[: i + 1])
        if isinstance(node, list):
            if isinstance(p, str):
                match = [x for x in node if isinstance(x, dict) and x.get("name") == p]
                if not match:
                    names = [str(x.get("name")) for x in node if isinstance(x, dict)]
                    raise InputError(key, value, f"unknown key: no entry named '{p}' in {where.rsplit('.', 1)[0]}"
                                     + suggest(p, names))
                node = match[0]
            elif 0 <= p < len(node):
                node = node[p]
            else:
                raise InputError(key, value, f"unknown key: index {p} out of range (0..{len(node) - 1})")
        elif isinstance(node, dict):
            if p not in node:
                node[p] = {}  # an optional table left at its defaults; the schema checks the key
            node = node[p]
        else:
            raise InputError(key, value, f"unknown key: '{where}' is not a table")
    last = parts[-1]
    if isinstance(node, dict):
        node[last] = value  # unknown keys are reported by the schema (problem_from_dict)
    elif isinstance(node, list) and isinstance(last, int) and 0 <= last < len(node):
        node[last] = value
    else:
        raise InputError(key, value, "unknown key")


def apply_variant(case: dict[str, Any]) -> None:
    """Apply the selected variant in place: ``variant = "name"`` picks the table
    ``[variants.name]``, whose entries are ``--set``-style overrides (``"bodies.stamp.slip_length"
    = "gap_law"``) applied before validation. One mechanism for every family of variants."""
    variants = case.pop("variants", None)
    name = case.pop("variant", None)
    if variants is None:
        if name is not None:
            raise InputError("variant", name, "a [variants] table to choose from")
        return
    if not isinstance(variants, Mapping) or not variants:
        raise InputError("variants", variants, "a table of named tables of overrides")
    if name is None:
        name = next(iter(variants))
    if not isinstance(name, str) or name not in variants:
        raise InputError("variant", name, "one of " + ", ".join(variants) + suggest(name, list(variants)))
    overrides = variants[name]
    if not isinstance(overrides, Mapping):
        raise InputError(f"variants.{name}", overrides, "a table of KEY = VALUE overrides")
    for key, value in overrides.items():
        set_value(case, str(key), value, f"variants.{name}")


# --------------------------------------------------------------------------- meshes
def axis_coordinates(a: Any) -> np.ndarray:
    """Coordinates of a validated grid axis (a list, ``{start, end, cells, ratio}`` or
    ``{breaks, cells, ratios}``)."""
    if isinstance(a, list):
        return np.asarray(a, dtype=float)
    if "breaks" in a:
        b, n, r = a["breaks"], a["cells"], a["ratios"]
        return np.concatenate([generate.graded(b[i], b[i + 1], n[i], r[i])[(1 if i else 0):] for i in range(len(n))])
    return generate.graded(a["start"], a["end"], a["cells"], a["ratio"])


def _axis_cells(a: Any) -> int:
    if isinstance(a, list):
        return len(a) - 1
    return sum(a["cells"]) if "breaks" in a else a["cells"]


def curve(side: Mapping[str, Any]) -> Callable[[np.ndarray], np.ndarray]:
    """A validated side of a mapped mesh (``line`` or ``arc``) as a map ``s ∈ [0, 1] → points``."""
    if side.get("line") is not None:
        p0, p1 = np.asarray(side["line"], dtype=float)
        return lambda s: p0[None, :] + np.asarray(s)[:, None] * (p1 - p0)[None, :]
    arc = side["arc"]
    s0, c, s1 = (np.asarray(arc[k], dtype=float) for k in ("start", "center", "end"))
    r = np.linalg.norm(s0 - c)
    t0 = math.atan2(*(s0 - c)[::-1])
    t1 = math.atan2(*(s1 - c)[::-1])
    dt = (t1 - t0 + math.pi) % (2 * math.pi) - math.pi  # shorter arc
    return lambda s: c[None, :] + r * np.column_stack([np.cos(t0 + dt * np.asarray(s)), np.sin(t0 + dt * np.asarray(s))])


def _disk_loop(m: Mapping[str, Any]) -> list[dict[str, Any]]:
    c, r = np.asarray(m["center"]), m["radius"]
    pts = [c + r * np.array([math.cos(a), math.sin(a)]) for a in (0, math.pi / 2, math.pi, 3 * math.pi / 2)]
    return [{"arc": {"start": pts[i].tolist(), "center": c.tolist(), "end": pts[(i + 1) % 4].tolist()}, "name": m["name"]}
            for i in range(4)]


def _outline_loops(m: Mapping[str, Any]) -> list[list[dict[str, Any]]]:
    """Loops of an ``outline`` or ``disk`` mesh in the form :func:`mesh_outline` takes."""
    if m["type"] == "disk":
        return [_disk_loop(m)]
    return [[{k: v for k, v in piece.items() if v is not None} for piece in loop] for loop in m["loops"]]


def _sample(piece: Mapping[str, Any], n: int = 16) -> np.ndarray:
    """Points along a line or arc piece (without its last point)."""
    f = curve(piece)
    return f(np.linspace(0.0, 1.0, n + 1)[:-1])


def planned_outline(m: Mapping[str, Any]) -> shapely.Geometry | None:
    """The region a validated mesh specification will cover (from its outline, before meshing);
    ``None`` for a mesh file."""
    kind = m["type"]
    if kind == "rectangle":
        return shapely.box(m["x0"], m["y0"], m["x1"], m["y1"])
    if kind == "rectilinear":
        x, y = axis_coordinates(m["x"]), axis_coordinates(m["y"])
        return shapely.box(x[0], y[0], x[-1], y[-1])
    if kind == "mapped":
        s = m["sides"]
        u = np.linspace(0.0, 1.0, 33)
        ring = np.vstack([curve(s["bottom"])(u), curve(s["right"])(u), curve(s["top"])(u)[::-1], curve(s["left"])(u)[::-1]])
        return shapely.Polygon(ring).buffer(0)
    if kind in ("outline", "disk"):
        rings = [shapely.Polygon(np.vstack([_sample(p) for p in loop])) for loop in _outline_loops(m)]
        for k, r in enumerate(rings):
            if not r.is_valid:  # gmsh may abort the process on a crossing outline
                raise InputError(f"loops[{k}]", f"{len(m['loops'][k]) if 'loops' in m else 4} pieces",
                                 "a closed loop that does not cross itself")
        return rings[0].difference(shapely.union_all(rings[1:])) if rings[1:] else rings[0]
    return None


MAX_COORDINATE = 1e12  # |x|, |y| of any point: beyond, areas and squared lengths lose all precision


def region_of(m: Mapping[str, Any], where: str) -> shapely.Geometry | None:
    """:func:`planned_outline` with its failures and absurd sizes reported as input errors."""
    try:
        with np.errstate(all="ignore"):  # absurd sizes are reported below, not as numpy warnings
            r = planned_outline(m)
    except InputError as exc:
        raise InputError(f"{where}.{exc.field}", exc.value, exc.allowed) from None
    except (shapely.errors.GEOSException, ValueError, FloatingPointError) as exc:
        raise InputError(where, m["type"], f"a geometry that can be built ({exc})") from None
    if r is not None and (r.is_empty or not np.all(np.abs(r.bounds) <= MAX_COORDINATE)):
        raise InputError(where, m["type"], f"a region of positive area with coordinates within ±{MAX_COORDINATE:g}")
    return r


def estimated_nodes(m: Mapping[str, Any], region: shapely.Geometry | None) -> float:
    """Nodes of a validated mesh specification, estimated before meshing (order of magnitude:
    it guards against sizes no run can afford)."""
    kind = m["type"]
    if kind in ("rectangle", "mapped"):
        return (m["nx"] + 1.0) * (m["ny"] + 1.0)
    if kind == "rectilinear":
        return (_axis_cells(m["x"]) + 1.0) * (_axis_cells(m["y"]) + 1.0)
    if kind in ("outline", "disk") and region is not None:
        h = m["h"]
        cells = region.area / h**2
        if m.get("h_max") is not None and m["h_max"] > h:  # a band of width ~4 h_max at size h, coarser inside
            cells = min(cells, region.length * 4.0 * m["h_max"] / h**2 + region.area / m["h_max"] ** 2)
        for ref in m.get("refine") or []:
            cells += math.pi * (4.0 * ref["radius"]) ** 2 / ref["h"] ** 2
        return cells
    return 0.0


def read_mesh(m: Mapping[str, Any], where: str, base_dir: Path | None) -> QuadMesh:
    """Build the mesh of a validated mesh specification."""
    kind = m["type"]
    if kind == "rectangle":
        mesh = generate.rectangle(m["x0"], m["x1"], m["y0"], m["y1"], m["nx"], m["ny"])
    elif kind == "rectilinear":
        mesh = generate.rectilinear(axis_coordinates(m["x"]), axis_coordinates(m["y"]))
    elif kind == "mapped":
        s = m["sides"]
        mesh = generate.mapped(curve(s["bottom"]), curve(s["right"]), curve(s["top"]), curve(s["left"]), m["nx"], m["ny"])
    elif kind in ("outline", "disk"):
        try:
            mesh = mesh_outline(_outline_loops(m), m["h"], h_max=m["h_max"], refine=m.get("refine") or [])
        except InputError as exc:
            raise InputError(f"{where}.{exc.field}", exc.value, exc.allowed) from None
    else:
        path = Path(m["path"])
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        if not path.is_file():
            raise InputError(f"{where}.path", m["path"], f"an existing gmsh .msh file (no file {path})")
        try:
            mesh = read_msh(str(path))
        except (InputError, MeshError) as exc:
            raise InputError(f"{where}.path", m["path"], getattr(exc, "allowed", str(exc))) from None
    try:
        mesh.check(where)
    except MeshError as exc:
        raise InputError(where, kind, str(exc)) from None
    return mesh


# --------------------------------------------------------------------------- bodies and fluid
def _node_set(mesh: QuadMesh, name: str) -> np.ndarray:
    if name == "body":
        return np.arange(mesh.n_nodes)
    if name in mesh.node_sets:
        return np.asarray(mesh.node_sets[name])
    return np.unique(mesh.edge_sets[name])


def _dirichlet(d: Mapping[str, Any]) -> Dirichlet:
    return Dirichlet(d["boundary"], d["value"], time_function(d["function"]))


def _neumann(n: Mapping[str, Any]) -> Neumann:
    return Neumann(n["boundary"], n["type"], n["value"], time_function(n["function"]))


def _known(where: str, name: str, known: set[str], what: str) -> None:
    if name not in known:
        raise InputError(where, name, f"{what} (known: " + ", ".join(sorted(known)) + ")" + suggest(name, sorted(known)))


def read_body(b: Mapping[str, Any], where: str, base_dir: Path | None) -> Body:
    """Build a body from its validated table (its mesh included) and check its set names."""
    mesh = read_mesh(b["mesh"], f"{where}.mesh", base_dir)
    if not np.all(np.abs(mesh.nodes) <= MAX_COORDINATE):
        raise InputError(f"{where}.mesh", b["mesh"]["type"], f"a mesh with coordinates within ±{MAX_COORDINATE:g}")
    edge_names = set(mesh.edge_sets)
    node_names = set(mesh.node_sets) | edge_names | {"body"}
    for i, d in enumerate(b["dirichlet"]):
        _known(f"{where}.dirichlet[{i}].boundary", d["boundary"], node_names, "a node or edge set of the body's mesh")
    for i, n in enumerate(b["neumann"]):
        _known(f"{where}.neumann[{i}].boundary", n["boundary"], edge_names, "an edge set of the body's mesh")
    for key in ("interface", "contact"):
        for s in b[key] or []:
            _known(f"{where}.{key}", s, edge_names, "edge sets of the body's mesh")
    mat = b["material"]
    return Body(b["name"], mesh, Material(mat["law"], mat["E"], mat["nu"], mat["rho"]), b["body_force"],
                time_function(b["body_force_function"]), [_dirichlet(d) for d in b["dirichlet"]],
                [_neumann(n) for n in b["neumann"]], b["interface"], b["contact"], b["rigid"], b["slip_length"],
                b["interface_velocity"], b["extends_outside"], b["dry_cavities"])


def read_fluid(f: Mapping[str, Any]) -> Fluid:
    """Build the fluid from its validated table."""
    s, i = f["stabilization"], f["interface"]
    pref = None if f["pressure_reference"] is None else np.asarray(f["pressure_reference"])
    grid = Grid(axis_coordinates(f["grid"]["x"]), axis_coordinates(f["grid"]["y"]))
    return Fluid(grid, f["rho"], f["mu"], f["viscous_form"], f["body_force"], time_function(f["body_force_function"]),
                 [_dirichlet(d) for d in f["dirichlet"]], [_neumann(n) for n in f["neumann"]], pref,
                 Stabilization(**s), InterfaceSettings(**i))


# --------------------------------------------------------------------------- cross checks
def _check_limits(v: Mapping[str, Any], regions: list[shapely.Geometry | None]) -> None:
    """Step count and (estimated) unknowns against ``[limits]``, before any mesh is built."""
    lim = v["limits"]
    steps, last = 0.0, v["time"]["t_start"]
    for i, s in enumerate(v["time"]["segments"]):
        steps += math.ceil((s["until"] - last) / s["dt"] - 1e-9)
        last = s["until"]
        if steps > lim["max_steps"]:
            key = "time.dt" if v["time"]["dt"] is not None else f"time.segments[{i}].dt"
            raise InputError(key, s["dt"], f"at most limits.max_steps = {lim['max_steps']} steps (this grid has "
                             f"{steps:.3g} or more; raise limits.max_steps to run it)")
    parts: dict[str, float] = {}
    if v["fluid"] is not None:
        g = v["fluid"]["grid"]
        parts["fluid.grid"] = 3.0 * (_axis_cells(g["x"]) + 1.0) * (_axis_cells(g["y"]) + 1.0)
    for i, b in enumerate(v["bodies"]):
        parts[f"bodies[{i}].mesh"] = 2.0 * estimated_nodes(b["mesh"], regions[i])
    total = sum(parts.values())
    if total > lim["max_unknowns"]:
        key = max(parts, key=parts.get)
        raise InputError(key, f"about {parts[key]:.3g} unknowns",
                         f"at most limits.max_unknowns = {lim['max_unknowns']} unknowns in all (estimated "
                         f"{total:.3g}; raise limits.max_unknowns to run it)")


def _check_box(v: Mapping[str, Any], regions: list[shapely.Geometry | None]) -> None:
    """Bodies inside the fluid box (unless ``extends_outside``) and not covering it."""
    grid = v["fluid"]["grid"]
    x, y = axis_coordinates(grid["x"]), axis_coordinates(grid["y"])
    box = shapely.box(x[0], y[0], x[-1], y[-1])
    tol = 1e-9 * max(x[-1] - x[0], y[-1] - y[0])
    for i, (b, r) in enumerate(zip(v["bodies"], regions)):
        if r is not None and not b["extends_outside"] and not box.buffer(tol).covers(r):
            raise InputError(f"bodies[{i}].mesh", b["mesh"]["type"],
                             f"a body inside the fluid box, but its outline leaves the fluid box [{x[0]:g}, {x[-1]:g}]"
                             f" × [{y[0]:g}, {y[-1]:g}] (set bodies[{i}].extends_outside = true for a body meant to "
                             f"cross it)")
    known = [r for r in regions if r is not None]
    if known and box.difference(shapely.union_all(known)).area <= 1e-9 * box.area:
        raise InputError("bodies", [b["name"] for b in v["bodies"]], "bodies that leave fluid in the box "
                         "(they cover the whole fluid box)")


def _check_overlap(v: Mapping[str, Any], bodies: list[Body]) -> list[shapely.Geometry]:
    """Bodies do not overlap at the start unless ``contact.allow_overlap``; returns their regions."""
    from fsci.geometry.outlines import body_polygon

    regions = []
    for i, b in enumerate(bodies):
        try:
            regions.append(body_polygon(b.mesh.nodes, b.mesh.boundary_loops(), b.name))
        except Exception as exc:  # GeometryError, MeshError: an unusable outline is bad input
            raise InputError(f"bodies[{i}].mesh", b.mesh.n_cells, f"a mesh with a valid outline ({exc})") from None
    if v["contact"]["allow_overlap"]:
        return regions
    for j in range(len(bodies)):
        for i in range(j):
            area = regions[i].intersection(regions[j]).area
            if area > 1e-3 * min(regions[i].area, regions[j].area):
                raise InputError(f"bodies[{j}].mesh", bodies[j].name,
                                 f"a body not overlapping body '{bodies[i].name}' at the start (overlap area "
                                 f"{area:.3g}; set contact.allow_overlap = true for pre-penetration)")
    return regions


def _check_probes(v: Mapping[str, Any], regions: list[shapely.Geometry]) -> None:
    """Pressure probes lie in the fluid at the start (inside the box, outside every body)."""
    grid = v["fluid"]["grid"] if v["fluid"] is not None else None
    for i, q in enumerate(v["quantities"]):
        if q["type"] != "pressure_difference" or grid is None:
            continue
        x, y = axis_coordinates(grid["x"]), axis_coordinates(grid["y"])
        for k, p in enumerate(q["points"]):
            pt = shapely.Point(p)
            inside = x[0] <= p[0] <= x[-1] and y[0] <= p[1] <= y[-1]
            if not inside or any(r.contains(pt) for r in regions):
                raise InputError(f"quantities[{i}].points[{k}]", p, "a point in the fluid (inside the box, outside "
                                 "every body)")


def _check_dirichlet(owner: str, conds: list[Dirichlet], nodes_of: Callable[[str], np.ndarray], X: np.ndarray,
                     times: tuple[float, ...]) -> None:
    """Conditions that prescribe the same component twice on one boundary are an input error;
    where two conditions on different boundaries give different values at shared nodes, warn
    once which one wins (the one listed last)."""
    conflicts = []
    for j, dj in enumerate(conds):
        for i in range(j):
            di = conds[i]
            comps = [c for c in (0, 1) if di.values[c] is not None and dj.values[c] is not None]
            if not comps:
                continue
            if di.boundary == dj.boundary:
                raise InputError(f"{owner}.dirichlet[{j}].boundary", dj.boundary,
                                 f"a boundary whose components are prescribed once (also in dirichlet[{i}])")
            shared = np.intersect1d(nodes_of(di.boundary), nodes_of(dj.boundary))
            differ = [c for c in comps if len(shared) and any(
                not np.allclose(di.values[c](X[shared, 0], X[shared, 1], t) * di.function(t),
                                dj.values[c](X[shared, 0], X[shared, 1], t) * dj.function(t), rtol=1e-12, atol=1e-14)
                for t in times)]
            if differ:
                conflicts.append(f"'{dj.boundary}' over '{di.boundary}' ({', '.join('xy'[c] for c in differ)} at "
                                 f"{len(shared)} node{'s' if len(shared) > 1 else ''})")
    if conflicts:
        warnings.warn(f"{owner}.dirichlet: conditions differ at shared nodes, the one listed last wins: "
                      + "; ".join(conflicts), FsciWarning, stacklevel=3)


def _quantity(q: Mapping[str, Any]) -> Quantity:
    params = {k: v for k, v in q.items() if k not in ("name", "type") and v is not None}
    return Quantity(q["name"], q["type"], params)


def _check_references(v: Mapping[str, Any]) -> None:
    names: set[str] = set()
    prefixes: list[str] = []
    for q in v["quantities"]:
        exact, pre = result_names(q)
        names |= exact
        prefixes += pre
    contact = any(b["contact"] for b in v["bodies"])
    for i, r in enumerate(v["reference"]):
        n = r["name"]
        if not (n in names or any(n.startswith(p) for p in prefixes) or (contact and n.startswith("case_"))):
            raise InputError(f"reference[{i}].name", n, "the name of a result of the case's quantities"
                             + suggest(n, sorted(names)))


def _check_quantities(v: Mapping[str, Any]) -> None:
    """Unique quantity names; quantities that use other quantities name existing ones."""
    every = [q["name"] for q in v["quantities"]]
    for i, q in enumerate(v["quantities"]):
        earlier = every[:i]
        if q["name"] in earlier:
            raise InputError(f"quantities[{i}].name", q["name"], f"a name not used by another quantity "
                             f"(quantities[{earlier.index(q['name'])}])")
        refs = {"oscillation": [("of", every)],
                "hertz_exact": [("contact", earlier)] + ([("P", earlier)] if isinstance(q.get("P"), str) else [])}
        for key, known in refs.get(q["type"], []):
            if q[key] is not None and q[key] not in known:
                raise InputError(f"quantities[{i}].{key}", q[key], "the name of " + ("another" if known is every else
                                 "an earlier") + " quantity" + suggest(q[key], known))


# --------------------------------------------------------------------------- the problem
def problem_from_dict(case: Mapping[str, Any], base_dir: Path | None = None) -> Problem:
    """Validate a case dictionary and build the :class:`Problem` (see the module docstring)."""
    case = copy.deepcopy(dict(case))
    apply_variant(case)
    v = validate(case)
    params = v["parameters"]
    regions = [region_of(b["mesh"], f"bodies[{i}].mesh") for i, b in enumerate(v["bodies"])]
    if v["fluid"] is not None:
        for a in ("x", "y"):
            if _axis_cells(v["fluid"]["grid"][a]) < 2:  # one cell has no interior node: nothing to solve
                raise InputError(f"fluid.grid.{a}", _axis_cells(v["fluid"]["grid"][a]), "an axis of at least 2 cells")
            c = axis_coordinates(v["fluid"]["grid"][a]) if _axis_cells(v["fluid"]["grid"][a]) < 1e7 else np.zeros(1)
            if not np.all(np.abs(c[[0, -1]]) <= MAX_COORDINATE):
                raise InputError(f"fluid.grid.{a}", [float(c[0]), float(c[-1])], f"coordinates within ±{MAX_COORDINATE:g}")
    _check_limits(v, regions)
    names = [b["name"] for b in v["bodies"]]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise InputError(f"bodies[{i}].name", n, "a name not used by another body")
    if not v["bodies"] and v["fluid"] is None:
        raise InputError("bodies", [], "at least one body or a [fluid] table")
    for i, b in enumerate(v["bodies"]):
        if b["slip_length"] == "gap_law" and (v["fluid"] is None or not b["contact"]):
            raise InputError(f"bodies[{i}].slip_length", "gap_law",
                             "the gap law (40) needs a [fluid] and 'contact' surfaces on the body")
    if v["fluid"] is not None and v["bodies"]:
        _check_box(v, regions)
    _check_quantities(v)
    _check_references(v)
    bodies = [read_body(b, f"bodies[{i}]", base_dir) for i, b in enumerate(v["bodies"])]
    fluid = read_fluid(v["fluid"]) if v["fluid"] is not None else None
    _check_probes(v, _check_overlap(v, bodies))
    t = v["time"]
    times = (t["t_start"], t["segments"][-1]["until"])
    for b in bodies:
        _check_dirichlet(f"bodies.{b.name}", b.dirichlet, lambda s, m=b.mesh: _node_set(m, s), b.mesh.nodes, times)
    if fluid is not None:
        _check_dirichlet("fluid", fluid.dirichlet, fluid.grid.side_nodes, fluid.grid.nodes, times)
    time = TimeGrid(t["type"], t["theta"], t["t_start"], [(s["until"], s["dt"]) for s in t["segments"]])
    verification = None
    if v["verified_at"] is not None:
        verification = _verification(v["verified_at"], params)
    c, o = v["contact"], v["output"]
    return Problem(
        v["name"], v["description"], bodies, fluid, time, SolverSettings(**v["solver"]),
        [_quantity(q) for q in v["quantities"]],
        [Reference(r["name"], r["value"], r["rtol"], r["source"]) for r in v["reference"]],
        Output(o["every"], o["figures"], o["fields"], o["checkpoint_every"], o["checkpoint_minutes"]), case,
        ContactSettings(c["gamma0"], c["weighting"], c["search_radius"], c["n_gauss"], c["split"], c["n_fixed"],
                        c["self_contact"]),
        verification,
    )


def _verification(verified_at: Mapping[str, float], params: Mapping[str, float]) -> Verification:
    """``verified_at = { n = 40, ... }``: the parameter values at which the case's reference
    checks are verified (a test runs exactly these). A run whose parameters differ gets a
    one-line note (printed and recorded in results.json) instead of a silent pass or fail."""
    if not verified_at:
        raise InputError("verified_at", {}, "a table of case parameters and the values they are verified at")
    for k, x in verified_at.items():
        if k not in params:
            raise InputError(f"verified_at.{k}", x, "a name from [parameters] (known: " + ", ".join(params) + ")")
    return Verification(dict(verified_at), {k: params[k] for k in verified_at if params[k] != verified_at[k]})
