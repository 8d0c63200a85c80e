"""Case files (TOML) → :class:`fsci.problem.Problem`, with validation and clear errors.

Every key is checked; a bad or unknown key raises :class:`fsci.errors.InputError` naming the
dotted key, the value and what is allowed. ``--set KEY=VALUE`` overrides are applied to the
dictionary before validation (:func:`apply_override`).

A string value starting with ``=`` is a constant expression in the case's ``[parameters]``,
e.g. ``mu = "=1/re"``; boundary values and loads may be expressions in ``x, y, t`` too.
"""

from __future__ import annotations

import copy
import math
import re
import tomllib
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from fsci.errors import InputError, MeshError
from fsci.expressions import Expression, evaluate_parameter, make_scalar
from fsci.mesh import generate
from fsci.mesh.gmsh_io import mesh_outline, read_msh
from fsci.mesh.grid import SIDES, Grid
from fsci.mesh.quadmesh import QuadMesh
from fsci.physics.materials import LAW_NAMES
from fsci.problem import (
    Body, ContactSettings, Dirichlet, Fluid, InterfaceSettings, Material, Neumann, Output, Problem, Quantity, Reference,
    SolverSettings, Stabilization, TimeGrid, Verification,
)
from fsci.timefunc import make_time_function

QUANTITY_KINDS = (
    "point_displacement", "body_force", "pressure_difference", "flow_rate", "oscillation",
    "centerline_profiles", "vortex_center", "mass_balance", "body_moment", "contact_profile", "hertz_exact", "reaction",
    "interface_summary", "fluid_pieces", "event", "value",
)


class Table:
    """Typed access to one TOML table that remembers which keys were read."""

    def __init__(self, data: Any, path: str, params: Mapping[str, float]) -> None:
        if not isinstance(data, Mapping):
            raise InputError(path or "<case>", data, "a table")
        self.data = data
        self.path = path
        self.params = params
        self.used: set[str] = set()

    def key(self, k: str) -> str:
        return f"{self.path}.{k}" if self.path else k

    def has(self, k: str) -> bool:
        return k in self.data

    def raw(self, k: str, default: Any = None) -> Any:
        self.used.add(k)
        return _evaluate_nested(self.data.get(k, default), self.params, self.key(k))

    def num(self, k: str, default: float | None = None, *, lo: float | None = None, hi: float | None = None,
            lo_open: bool = False, hi_open: bool = False, allowed: str | None = None) -> float:
        v = self.raw(k, default)
        if v is None:
            raise InputError(self.key(k), None, "required number is missing")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(self.key(k), v, "a finite number")
        ok = True
        if lo is not None:
            ok &= v > lo if lo_open else v >= lo
        if hi is not None:
            ok &= v < hi if hi_open else v <= hi
        if not ok:
            if allowed is None:
                left = "(" if lo_open else "["
                right = ")" if hi_open else "]"
                allowed = f"a number in {left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{right}"
            raise InputError(self.key(k), v, allowed)
        return float(v)

    def int(self, k: str, default: int | None = None, *, lo: int | None = None) -> int:
        v = self.raw(k, default)
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        if isinstance(v, bool) or not isinstance(v, int):
            raise InputError(self.key(k), v, "an integer")
        if lo is not None and v < lo:
            raise InputError(self.key(k), v, f"an integer ≥ {lo}")
        return v

    def str(self, k: str, default: str | None = None, choices: Iterable[str] | None = None) -> str:
        v = self.raw(k, default)
        if not isinstance(v, str):
            raise InputError(self.key(k), v, "a string" if choices is None else "one of " + ", ".join(choices))
        if choices is not None and v not in choices:
            raise InputError(self.key(k), v, "one of " + ", ".join(choices))
        return v

    def bool(self, k: str, default: bool) -> bool:
        v = self.raw(k, default)
        if not isinstance(v, bool):
            raise InputError(self.key(k), v, "true or false")
        return v

    def vec(self, k: str, default: Any = None, n: int = 2) -> np.ndarray:
        v = self.raw(k, default)
        if not isinstance(v, (list, tuple)) or len(v) != n:
            raise InputError(self.key(k), v, f"a list of {n} numbers")
        out = []
        for i, x in enumerate(v):
            x = evaluate_parameter(x, self.params, f"{self.key(k)}[{i}]")
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise InputError(f"{self.key(k)}[{i}]", x, "a finite number")
            out.append(float(x))
        return np.array(out)

    def table(self, k: str, default: Any = None) -> "Table":
        v = self.raw(k, {} if default is None else default)
        return Table(v, self.key(k), self.params)

    def tables(self, k: str) -> list["Table"]:
        v = self.raw(k, [])
        if not isinstance(v, list):
            raise InputError(self.key(k), v, "a list of tables")
        return [Table(x, f"{self.key(k)}[{i}]", self.params) for i, x in enumerate(v)]

    def done(self) -> None:
        extra = sorted(set(self.data) - self.used)
        if extra:
            raise InputError(self.key(extra[0]), self.data[extra[0]],
                             "unknown key (allowed here: " + ", ".join(sorted(self.used)) + ")")


def _evaluate_nested(value: Any, params: Mapping[str, float], field: str) -> Any:
    """Evaluate ``"=expr"`` strings anywhere inside lists and inline tables."""
    if isinstance(value, list):
        return [_evaluate_nested(v, params, f"{field}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, Mapping) and not isinstance(value, Table):
        return {k: _evaluate_nested(v, params, f"{field}.{k}") for k, v in value.items()}
    return evaluate_parameter(value, params, field)


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
    except tomllib.TOMLDecodeError:
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


def set_value(case: dict[str, Any], key: str, value: Any, source: str) -> None:
    """Set the dotted ``key`` of a case dictionary (see :func:`apply_override`); ``source``
    names where the assignment came from in error messages."""
    parts = _split_path(key)
    if not parts:
        raise InputError(source, f"{key}={value!r}", "KEY=VALUE with a non-empty key")
    if len(parts) == 1 and parts[0] not in case and parts[0] in case.get("parameters", {}):
        parts = ["parameters", parts[0]]
    node: Any = case
    for i, p in enumerate(parts[:-1]):
        where = ".".join(str(x) for x in parts[: i + 1])
        if isinstance(node, list):
            if isinstance(p, str):
                match = [x for x in node if isinstance(x, dict) and x.get("name") == p]
                if not match:
                    raise InputError(key, value, f"unknown key: no entry named '{p}' in {where.rsplit('.', 1)[0]}")
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


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a case file; malformed TOML is reported with line and column."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise InputError("case", str(path), f"a readable TOML file ({exc.strerror})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError("case", str(path), f"valid TOML ({exc})") from None


# --------------------------------------------------------------------------- pieces
def read_time_function(t: Table, key: str = "function") -> Any:
    return make_time_function(t.raw(key, None), t.key(key))


def read_axis(t: Table, key: str) -> np.ndarray:
    """A grid axis: ``{start, end, cells[, ratio]}``, ``{breaks, cells[, ratios]}`` or a list."""
    v = t.raw(key)
    if isinstance(v, list):
        arr = np.array([float(evaluate_parameter(x, t.params, t.key(key))) for x in v])
        if len(arr) < 2 or np.any(np.diff(arr) <= 0):
            raise InputError(t.key(key), v, "strictly increasing coordinates")
        return arr
    a = Table(v, t.key(key), t.params)
    if a.has("breaks"):
        breaks = a.raw("breaks")
        cells = a.raw("cells")
        ratios = a.raw("ratios", [1.0] * (len(cells) if isinstance(cells, list) else 0))
        if not (isinstance(breaks, list) and isinstance(cells, list) and len(breaks) == len(cells) + 1 == len(ratios) + 1):
            raise InputError(a.key("breaks"), breaks, "'breaks' (k+1 values) with 'cells' and 'ratios' (k values)")
        pieces = []
        for i in range(len(cells)):
            b0 = float(evaluate_parameter(breaks[i], t.params, a.key("breaks")))
            b1 = float(evaluate_parameter(breaks[i + 1], t.params, a.key("breaks")))
            n = evaluate_parameter(cells[i], t.params, a.key("cells"))
            if isinstance(n, float) and n.is_integer():
                n = int(n)
            if isinstance(n, bool) or not isinstance(n, int) or n < 1 or b1 <= b0:
                raise InputError(a.key("cells"), cells, "positive integers between increasing breaks")
            pieces.append(generate.graded(b0, b1, n, float(ratios[i]))[(1 if i else 0):])
        a.done()
        return np.concatenate(pieces)
    start = a.num("start")
    end = a.num("end")
    if end <= start:
        raise InputError(a.key("end"), end, f"greater than start = {start}")
    n = a.int("cells", lo=1)
    ratio = a.num("ratio", 1.0, lo=0, lo_open=True)
    a.done()
    return generate.graded(start, end, n, ratio)


def _curve(spec: Table):
    """A side of a mapped mesh: ``{line = [[..],[..]]}`` or ``{arc = {start, center, end}}``."""
    if spec.has("line"):
        p = spec.raw("line")
        try:
            p0, p1 = np.asarray(p, float)
        except (ValueError, TypeError):
            raise InputError(spec.key("line"), p, "two points [[x0, y0], [x1, y1]]") from None
        spec.done()
        return lambda s: p0[None, :] + np.asarray(s)[:, None] * (p1 - p0)[None, :]
    if spec.has("arc"):
        a = spec.table("arc")
        s0, c, s1 = a.vec("start"), a.vec("center"), a.vec("end")
        a.done()
        spec.done()
        r = np.linalg.norm(s0 - c)
        t0 = math.atan2(*(s0 - c)[::-1])
        t1 = math.atan2(*(s1 - c)[::-1])
        dt = (t1 - t0 + math.pi) % (2 * math.pi) - math.pi  # shorter arc
        return lambda s: c[None, :] + r * np.column_stack([np.cos(t0 + dt * np.asarray(s)), np.sin(t0 + dt * np.asarray(s))])
    raise InputError(spec.path, dict(spec.data), "a side needs 'line' or 'arc'")


def read_mesh(t: Table, base_dir: Path | None) -> QuadMesh:
    kind = t.str("type", choices=("rectangle", "rectilinear", "mapped", "outline", "disk", "file"))
    if kind == "rectangle":
        m = generate.rectangle(t.num("x0"), t.num("x1"), t.num("y0"), t.num("y1"), t.int("nx", lo=1), t.int("ny", lo=1))
    elif kind == "rectilinear":
        m = generate.rectilinear(read_axis(t, "x"), read_axis(t, "y"))
    elif kind == "mapped":
        sides = t.table("sides")
        curves = {k: _curve(sides.table(k)) for k in ("bottom", "right", "top", "left")}
        sides.done()
        m = generate.mapped(curves["bottom"], curves["right"], curves["top"], curves["left"],
                            t.int("nx", lo=1), t.int("ny", lo=1))
    elif kind == "outline":
        loops = t.raw("loops")
        if not isinstance(loops, list) or not loops:
            raise InputError(t.key("loops"), loops, "a list of closed loops of line/arc pieces")
        hmax = t.num("h_max", 0.0, lo=0) if t.has("h_max") else None
        refine = t.raw("refine", [])
        if not isinstance(refine, list):
            raise InputError(t.key("refine"), refine, "a list of {point, h, radius} tables")
        m = mesh_outline(loops, t.num("h", lo=0, lo_open=True), h_max=hmax, refine=refine)
    elif kind == "disk":
        c = t.vec("center")
        r = t.num("radius", lo=0, lo_open=True)
        name = t.str("name", "surface")
        pts = [c + r * np.array([math.cos(a), math.sin(a)]) for a in (0, math.pi / 2, math.pi, 3 * math.pi / 2)]
        loop = [{"arc": {"start": pts[i].tolist(), "center": c.tolist(), "end": pts[(i + 1) % 4].tolist()}, "name": name}
                for i in range(4)]
        hmax = t.num("h_max", 0.0, lo=0) if t.has("h_max") else None
        m = mesh_outline([loop], t.num("h", lo=0, lo_open=True), h_max=hmax)
    else:
        path = Path(t.str("path"))
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        m = read_msh(str(path))
    t.done()
    try:
        m.check(t.path)
    except MeshError as exc:
        raise InputError(t.path, kind, str(exc)) from None
    return m


def read_material(t: Table) -> Material:
    law = t.str("law", "neo_hooke", choices=tuple(LAW_NAMES))
    E = t.num("E", lo=0.0, lo_open=True, allowed="E > 0")
    nu = t.num("nu", 0.0, lo=0.0, hi=0.5, hi_open=True, allowed="0 ≤ nu < 0.5")
    rho = t.num("rho", 0.0, lo=0.0, allowed="rho ≥ 0")
    t.done()
    return Material(law, E, nu, rho)


def _value_list(t: Table, key: str, n: int | None, allow_free: bool) -> list[Expression | None]:
    v = t.raw(key)
    items = v if isinstance(v, list) else [v]
    if n is not None and len(items) != n:
        free = ", or 'free'" if allow_free else ""
        raise InputError(t.key(key), v, f"a list of {n} values (numbers or expressions{free})")
    out: list[Expression | None] = []
    for i, x in enumerate(items):
        if allow_free and x == "free":
            out.append(None)
        else:
            out.append(make_scalar(evaluate_parameter(x, t.params, f"{t.key(key)}[{i}]"), t.params, f"{t.key(key)}[{i}]"))
    return out


def read_dirichlet(t: Table, known: Iterable[str]) -> Dirichlet:
    b = t.str("boundary")
    if b not in known:
        raise InputError(t.key("boundary"), b, "a boundary that exists (known: " + ", ".join(sorted(known)) + ")")
    vals = _value_list(t, "value", 2, allow_free=True)
    fn = read_time_function(t)
    t.done()
    return Dirichlet(b, vals, fn)


def read_neumann(t: Table, known: Iterable[str]) -> Neumann:
    b = t.str("boundary")
    if b not in known:
        raise InputError(t.key("boundary"), b, "a boundary that exists (known: " + ", ".join(sorted(known)) + ")")
    kind = t.str("type", "traction", choices=("traction", "pressure"))
    vals = _value_list(t, "value", 2 if kind == "traction" else 1, allow_free=False)
    fn = read_time_function(t)
    t.done()
    return Neumann(b, kind, [v for v in vals if v is not None], fn)


def read_body(t: Table, base_dir: Path | None) -> Body:
    name = t.str("name")
    mesh = read_mesh(t.table("mesh"), base_dir)
    material = read_material(t.table("material"))
    bf = _value_list(t, "body_force", 2, allow_free=False) if t.has("body_force") else None
    bff = read_time_function(t, "body_force_function")
    edge_names = set(mesh.edge_sets)
    node_names = set(mesh.node_sets) | edge_names | {"body"}  # "body": every node
    dirichlet = [read_dirichlet(d, node_names) for d in t.tables("dirichlet")]
    neumann = [read_neumann(d, edge_names) for d in t.tables("neumann")]
    rigid = t.bool("rigid", False)
    slip = read_slip_length(t)
    iv = _value_list(t, "interface_velocity", 2, allow_free=False) if t.has("interface_velocity") else None
    outside = t.bool("extends_outside", False)
    interface = t.raw("interface", None)
    contact = t.raw("contact", None)
    for key, val in (("interface", interface), ("contact", contact)):
        if val is None:
            continue
        if not isinstance(val, list) or any(v not in edge_names for v in val):
            raise InputError(t.key(key), val, "a list of edge sets of the body's mesh (known: " + ", ".join(sorted(edge_names)) + ")")
    t.done()
    return Body(name, mesh, material, bf, bff, dirichlet, neumann, interface, contact, rigid, slip, iv, outside)


def read_slip_length(t: Table) -> float | Expression | str:
    """Navier slip length: a number ≥ 0, "inf" (free slip), "gap_law" (the contact-gap law (40)
    with ``fluid.interface.kappa0`` and ``slip_h``) or an expression in x, y, t."""
    v = t.raw("slip_length", 0.0)
    if isinstance(v, str) and v.strip().lower() in ("inf", "infinity"):
        return math.inf
    if isinstance(v, str) and v.strip() == "gap_law":
        return "gap_law"
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        raise InputError(t.key("slip_length"), v,
                         "a slip length ≥ 0, \"inf\", \"gap_law\" or an expression in x, y, t")
    if isinstance(v, str):
        return make_scalar(v, t.params, t.key("slip_length"))
    if not (v >= 0.0):
        raise InputError(t.key("slip_length"), v, "a slip length κ ≥ 0 (0 = no slip, \"inf\" = free slip)")
    return float(v)


def read_fluid(t: Table) -> Fluid:
    g = t.table("grid")
    grid = Grid(read_axis(g, "x"), read_axis(g, "y"))
    g.done()
    rho = t.num("rho", lo=0, lo_open=True, allowed="rho > 0")
    mu = t.num("mu", lo=0, lo_open=True, allowed="mu > 0")
    form = t.str("viscous_form", "symmetric", choices=("symmetric", "laplace"))
    bf = _value_list(t, "body_force", 2, allow_free=False) if t.has("body_force") else None
    bff = read_time_function(t, "body_force_function")
    dirichlet = [read_dirichlet(d, SIDES) for d in t.tables("dirichlet")]
    neumann = [read_neumann(d, SIDES) for d in t.tables("neumann")]
    pref = t.raw("pressure_reference", None)
    pref_arr = None if pref is None else t.vec("pressure_reference")
    s = t.table("stabilization")
    st = Stabilization(
        gamma_p=s.num("gamma_p", 0.25, lo=0), gamma_u=s.num("gamma_u", 0.25, lo=0),
        gamma_div=s.num("gamma_div", 0.00025, lo=0), gamma_gp=s.num("gamma_gp", 0.5, lo=0),
        gamma_gp_t=s.num("gamma_gp_t", 0.001, lo=0),
        ghost_penalty=s.bool("ghost_penalty", True),
    )
    s.done()
    it = t.table("interface")
    iset = InterfaceSettings(
        gamma_n=it.num("gamma_n", 35.0, lo=0, lo_open=True), gamma_t=it.num("gamma_t", 35.0, lo=0, lo_open=True),
        trace_constant=it.num("trace_constant", 1.43426, lo=0, lo_open=True),
        adjoint=it.str("adjoint", "skew", choices=("skew", "symmetric")),
        island_factor=it.num("island_factor", 2.0, lo=0),
        eps_geom=it.num("eps_geom", 1e-9, lo=0),
        grow_only_after=it.int("grow_only_after", 5, lo=1),
        freeze_cut_after=it.int("freeze_cut_after", 8, lo=1),
        max_layout_changes=it.int("max_layout_changes", 5, lo=0),
        kappa0=it.num("kappa0", 0.1, lo=0, allowed="κ0 ≥ 0"),
        slip_h=it.num("slip_h", 0.0, lo=0, allowed="h ≥ 0 (0: the largest fluid cell side)"),
        case_iii=it.str("case_iii", "remark6", choices=("remark6", "original")),
        film_closure=it.num("film_closure", 1e-6, lo=0, hi=0.5),
        extension=it.bool("extension", True),
        shape_derivative=it.bool("shape_derivative", True),
    )
    it.done()
    t.done()
    return Fluid(grid, rho, mu, form, bf, bff, dirichlet, neumann, pref_arr, st, iset)


def read_time(t: Table) -> TimeGrid:
    kind = t.str("type", "transient", choices=("static", "transient"))
    # θ = 0.5 (Crank-Nicolson) is second order but undamped: docs/validation.md "Time accuracy"
    theta = t.num("theta", 1.0, lo=0.5, hi=1.0, allowed="theta in [0.5, 1]")
    t0 = t.num("t_start", 0.0)
    segs = []
    if t.has("segments"):
        for s in t.tables("segments"):
            end = s.num("until")
            dt = s.num("dt", lo=0, lo_open=True, allowed="dt > 0")
            s.done()
            if end <= (segs[-1][0] if segs else t0):
                raise InputError(s.key("until"), end, "segment end times must increase beyond t_start")
            segs.append((end, dt))
    else:
        end = t.num("t_end")
        dt = t.num("dt", lo=0, lo_open=True, allowed="dt > 0")
        if end <= t0:
            raise InputError(t.key("t_end"), end, f"greater than t_start = {t0}")
        segs.append((end, dt))
    t.done()
    return TimeGrid(kind, theta, t0, segs)


def read_solver(t: Table) -> SolverSettings:
    s = SolverSettings(
        max_iterations=t.int("max_iterations", 25, lo=1),
        min_iterations=t.int("min_iterations", 1, lo=1),
        tol_residual=t.num("tol_residual", 1e-8, lo=0, lo_open=True),
        tol_increment=t.num("tol_increment", 1e-8, lo=0, lo_open=True),
        rtol_residual=t.num("rtol_residual", 1e-10, lo=0),
        damping=t.bool("damping", True),
        linear=t.str("linear", "auto", choices=("auto", "pardiso", "superlu")),
        max_step_cuts=t.int("max_step_cuts", 6, lo=0),
        step_cut_factor=t.num("step_cut_factor", 0.5, lo=0, hi=1, lo_open=True, hi_open=True),
        dt_min=t.num("dt_min", 0.0, lo=0),
        outer_tol=t.num("outer_tol", 1e-4, lo=0, lo_open=True),
    )
    t.done()
    return s


def read_quantity(t: Table) -> Quantity:
    name = t.str("name")
    kind = t.str("type", choices=QUANTITY_KINDS)
    params = {k: evaluate_parameter(v, t.params, t.key(k)) for k, v in t.data.items() if k not in ("name", "type")}
    if kind == "event" and "value" in params:  # the value reported at the event: an expression in t
        params["value"] = make_scalar(params["value"], t.params, t.key("value"))
    t.used |= set(t.data)
    return Quantity(name, kind, params)


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
    if name not in variants:
        raise InputError("variant", name, "one of " + ", ".join(variants))
    overrides = variants[name]
    if not isinstance(overrides, Mapping):
        raise InputError(f"variants.{name}", overrides, "a table of KEY = VALUE overrides")
    for key, value in overrides.items():
        set_value(case, str(key), value, f"variants.{name}")


def problem_from_dict(case: Mapping[str, Any], base_dir: Path | None = None) -> Problem:
    """Validate a case dictionary and build the :class:`Problem`."""
    case = copy.deepcopy(dict(case))
    apply_variant(case)
    params_raw = case.get("parameters", {})
    if not isinstance(params_raw, Mapping):
        raise InputError("parameters", params_raw, "a table of numbers")
    params: dict[str, float] = {}
    for k, v in params_raw.items():
        v = evaluate_parameter(v, params, f"parameters.{k}")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"parameters.{k}", v, "a number")
        params[k] = v
    top = Table(case, "", params)
    top.used.add("parameters")
    name = top.str("name")
    description = top.str("description", "")
    top.str("kind", "generic")  # informational: which built-in case family produced it
    bodies = [read_body(b, base_dir) for b in top.tables("bodies")]
    names = [b.name for b in bodies]
    if len(set(names)) != len(names):
        raise InputError("bodies.name", names, "unique body names")
    fluid = read_fluid(top.table("fluid")) if top.has("fluid") else None
    for i, b in enumerate(bodies):
        if b.slip_length == "gap_law" and (fluid is None or not b.contact):
            raise InputError(f"bodies[{i}].slip_length", "gap_law",
                             "the gap law (40) needs a [fluid] and 'contact' surfaces on the body")
    if not bodies and fluid is None:
        raise InputError("bodies", [], "at least one body or a [fluid] table")
    time = read_time(top.table("time"))
    solver = read_solver(top.table("solver"))
    quantities = [read_quantity(q) for q in top.tables("quantities")]
    refs = []
    for r in top.tables("reference"):
        refs.append(Reference(r.str("name"), r.num("value"), r.num("rtol", 0.01, lo=0), r.str("source", "")))
        r.done()
    c = top.table("contact")
    contact = ContactSettings(
        gamma0=c.num("gamma0", 1.0, lo=0, lo_open=True),
        weighting=c.str("weighting", "harmonic", choices=("harmonic", "half")),
        search_radius=c.num("search_radius", 0.0, lo=0),
        n_gauss=c.int("n_gauss", 3, lo=1),
        split=c.bool("split", True),
        n_fixed=c.int("n_fixed", 10, lo=1),
        self_contact=c.bool("self_contact", False),
    )
    c.done()
    verification = read_verified_at(top, params) if top.has("verified_at") else None
    o = top.table("output")
    output = Output(every=o.int("every", 1, lo=0), figures=o.bool("figures", True), fields=o.bool("fields", True),
                    checkpoint_every=o.int("checkpoint_every", 0, lo=0))
    o.done()
    top.done()
    return Problem(name, description, bodies, fluid, time, solver, quantities, refs, output, case, contact,
                   verification)


def read_verified_at(top: Table, params: Mapping[str, float]) -> Verification:
    """``verified_at = { n = 40, ... }``: the parameter values at which the case's reference
    checks are verified (a test runs exactly these). A run whose parameters differ gets a
    one-line note (printed and recorded in results.json) instead of a silent pass or fail."""
    v = top.raw("verified_at")
    if not isinstance(v, Mapping) or not v:
        raise InputError("verified_at", v, "a table of case parameters and the values they are verified at")
    verified: dict[str, float] = {}
    for k, x in v.items():
        if k not in params:
            raise InputError(f"verified_at.{k}", x, "a name from [parameters] (known: " + ", ".join(params) + ")")
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise InputError(f"verified_at.{k}", x, "a number")
        verified[k] = x
    return Verification(verified, {k: params[k] for k in verified if params[k] != verified[k]})
