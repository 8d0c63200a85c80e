"""The case-file schema: every key defined once, with its type, default, unit, allowed values
and a one-line meaning.

One definition, three uses:

* **validation** — :func:`validate` checks a case dictionary against :data:`CASE` and returns
  it normalised (defaults filled in, ``"=..."`` parameter expressions evaluated, expressions
  in ``x, y, t`` compiled); an unknown key or table at any depth is named with the closest
  valid name, a bad value with what is allowed (:class:`fsci.errors.InputError`);
* ``fsci show --schema`` prints :func:`markdown`;
* ``docs/case-format.md`` is :func:`markdown` written to a file (``tests/test_schema.py``
  regenerates it and compares).

Checks that relate keys to each other across tables or to a mesh (boundary names, bodies
inside the box, size limits) are made by :mod:`fsci.config` right after this validation,
before anything is built or written.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Mapping, Sequence

from fsci.errors import InputError
from fsci.expressions import CONSTANTS, FUNCTIONS, Expression, evaluate_parameter, make_scalar
from fsci.mesh.grid import SIDES
from fsci.physics.materials import LAW_NAMES


class _Required:
    def __repr__(self) -> str:
        return "required"


REQUIRED: Any = _Required()  # default of a key that must be given

Rule = Callable[[dict[str, Any], str], None]  # relates the normalised keys of one table


@dataclass
class Context:
    """What validation needs besides the value: the case parameters (for ``"=..."``)."""

    params: dict[str, float] = field(default_factory=dict)


def suggest(word: Any, candidates: Sequence[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest candidate, or ``""``."""
    close = difflib.get_close_matches(str(word), [str(c) for c in candidates], n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ""


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _join(where: str, key: Any) -> str:
    return f"{where}.{key}" if where else str(key)


def _anchor(title: str) -> str:
    """The anchor GitHub gives a heading: lower case, punctuation dropped, spaces → hyphens."""
    return "".join(c for c in title.lower() if c.isalnum() or c in " -_").replace(" ", "-")


# --------------------------------------------------------------------------- value types
class Spec:
    """A value type: checks and normalises a value, and describes itself for the reference."""

    def check(self, value: Any, where: str, ctx: Context) -> Any:
        raise NotImplementedError

    def describe(self) -> str:
        """Allowed values in a few words (a cell of the reference table)."""
        raise NotImplementedError

    def sections(self) -> Iterator["Section"]:
        """Tables nested in this type, for the reference."""
        return iter(())


@dataclass(frozen=True)
class Num(Spec):
    """A finite number, optionally bounded; ``"=expr"`` is evaluated with the parameters."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False

    def check(self, value: Any, where: str, ctx: Context) -> float:
        v = evaluate_parameter(value, ctx.params, where)
        if not _is_number(v) or not math.isfinite(v):
            raise InputError(where, v, "a finite " + self.describe())
        ok = (self.lo is None or (v > self.lo if self.lo_open else v >= self.lo)) and \
             (self.hi is None or (v < self.hi if self.hi_open else v <= self.hi))
        if not ok:
            raise InputError(where, v, "a " + self.describe())
        return float(v)

    def describe(self) -> str:
        lo, hi = self.lo, self.hi
        if lo is None and hi is None:
            return "number"
        if hi is None:
            return f"number {'>' if self.lo_open else '≥'} {lo:g}"
        if lo is None:
            return f"number {'<' if self.hi_open else '≤'} {hi:g}"
        return f"number in {'(' if self.lo_open else '['}{lo:g}, {hi:g}{')' if self.hi_open else ']'}"


@dataclass(frozen=True)
class Int(Spec):
    """An integer (a float with an integer value counts, e.g. from ``"=n/2"``)."""

    lo: int | None = None
    hi: int | None = None

    def check(self, value: Any, where: str, ctx: Context) -> int:
        v = evaluate_parameter(value, ctx.params, where)
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        if isinstance(v, bool) or not isinstance(v, int) or \
                (self.lo is not None and v < self.lo) or (self.hi is not None and v > self.hi):
            raise InputError(where, v, "an " + self.describe())
        return v

    def describe(self) -> str:
        if self.lo is not None and self.hi is not None:
            return f"integer in {self.lo}..{self.hi}"
        return f"integer ≥ {self.lo}" if self.lo is not None else "integer"


@dataclass(frozen=True)
class Str(Spec):
    """A string, optionally one of ``choices``."""

    choices: tuple[str, ...] | None = None

    def check(self, value: Any, where: str, ctx: Context) -> str:
        if not isinstance(value, str) or (self.choices is not None and value not in self.choices):
            hint = suggest(value, self.choices) if isinstance(value, str) and self.choices else ""
            raise InputError(where, value, ("one of " + ", ".join(self.choices) if self.choices else "a string") + hint)
        return value

    def describe(self) -> str:
        return " \\| ".join(f'"{c}"' for c in self.choices) if self.choices else "string"


@dataclass(frozen=True)
class Bool(Spec):
    """``true`` or ``false``."""

    def check(self, value: Any, where: str, ctx: Context) -> bool:
        if not isinstance(value, bool):
            raise InputError(where, value, "true or false")
        return value

    def describe(self) -> str:
        return "true \\| false"


@dataclass(frozen=True)
class Vec(Spec):
    """A list of ``n`` finite numbers (a point or a vector)."""

    n: int = 2

    def check(self, value: Any, where: str, ctx: Context) -> list[float]:
        if not isinstance(value, (list, tuple)) or len(value) != self.n:
            raise InputError(where, value, f"a list of {self.n} numbers")
        return [Num().check(x, f"{where}[{i}]", ctx) for i, x in enumerate(value)]

    def describe(self) -> str:
        return "[x, y]" if self.n == 2 else f"list of {self.n} numbers"


@dataclass(frozen=True)
class Points(Spec):
    """A list of exactly ``n`` points ``[x, y]``."""

    n: int = 2

    def check(self, value: Any, where: str, ctx: Context) -> list[list[float]]:
        if not isinstance(value, (list, tuple)) or len(value) != self.n:
            raise InputError(where, value, self.describe())
        return [Vec().check(p, f"{where}[{i}]", ctx) for i, p in enumerate(value)]

    def describe(self) -> str:
        return f"{self.n} points [[x, y], ...]"


@dataclass(frozen=True)
class NumList(Spec):
    """A list of finite numbers (at least ``min_len``, at most ``max_len``; strictly increasing
    if ``increasing``)."""

    min_len: int = 1
    increasing: bool = False
    item: Spec = Num()
    max_len: int | None = None

    def check(self, value: Any, where: str, ctx: Context) -> list[Any]:
        if (not isinstance(value, list) or len(value) < self.min_len
                or (self.max_len is not None and len(value) > self.max_len)):
            raise InputError(where, value, self.describe())
        out = [self.item.check(x, f"{where}[{i}]", ctx) for i, x in enumerate(value)]
        if self.increasing and any(b <= a for a, b in zip(out, out[1:])):
            raise InputError(where, value, self.describe())
        return out

    def describe(self) -> str:
        what = "strictly increasing " if self.increasing else ""
        count = (f"{self.min_len}" if self.max_len == self.min_len else
                 f"≥ {self.min_len}" if self.max_len is None else f"{self.min_len} to {self.max_len}")
        return f"list of {count} {what}{self.item.describe()}s"


@dataclass(frozen=True)
class StrList(Spec):
    """A list of names."""

    def check(self, value: Any, where: str, ctx: Context) -> list[str]:
        if not isinstance(value, list) or not all(isinstance(x, str) for x in value):
            raise InputError(where, value, "a list of names")
        return list(value)

    def describe(self) -> str:
        return "list of names"


@dataclass(frozen=True)
class Expr(Spec):
    """A number or an expression in ``x, y, t`` and the parameters (→ :class:`Expression`)."""

    def check(self, value: Any, where: str, ctx: Context) -> Expression:
        return make_scalar(evaluate_parameter(value, ctx.params, where), ctx.params, where)

    def describe(self) -> str:
        return "number or expression in x, y, t"


@dataclass(frozen=True)
class Values(Spec):
    """``n`` values, each a number or an expression (``"free"``: not prescribed, if allowed);
    ``n = 1`` also accepts the bare value."""

    n: int = 2
    free: bool = False

    def check(self, value: Any, where: str, ctx: Context) -> list[Expression | None]:
        items = [value] if self.n == 1 and not isinstance(value, list) else value
        if not isinstance(items, list) or len(items) != self.n:
            raise InputError(where, value, "a " + self.describe())
        return [None if self.free and x == "free" else Expr().check(x, f"{where}[{i}]", ctx) for i, x in enumerate(items)]

    def describe(self) -> str:
        if self.n == 1:
            return "number or expression in x, y, t"
        return f"list of {self.n} numbers or expressions in x, y, t" + (' or "free"' if self.free else "")


@dataclass(frozen=True)
class SlipLength(Spec):
    """Navier slip length: a number ≥ 0, ``"inf"``, ``"gap_law"`` or an expression."""

    def check(self, value: Any, where: str, ctx: Context) -> float | str | Expression:
        if isinstance(value, str) and value.strip().lower() in ("inf", "infinity"):
            return math.inf
        if isinstance(value, str) and value.strip() == "gap_law":
            return "gap_law"
        if _is_number(value):
            if not value >= 0.0 or not math.isfinite(value):
                raise InputError(where, value, 'a slip length κ ≥ 0 (0 = no slip, "inf" = free slip)')
            return float(value)
        if isinstance(value, str):
            return Expr().check(value, where, ctx)
        raise InputError(where, value, "a " + self.describe())

    def describe(self) -> str:
        return 'number ≥ 0, "inf", "gap_law" or expression in x, y, t'


@dataclass(frozen=True)
class Anything(Spec):
    """Any value (documented only: the key is consumed before validation)."""

    text: str

    def check(self, value: Any, where: str, ctx: Context) -> Any:
        return value

    def describe(self) -> str:
        return self.text


@dataclass(frozen=True)
class Key:
    """One key of a table: name, type, default (:data:`REQUIRED`, ``None`` = optional without
    a default), unit and one-line meaning."""

    name: str
    type: Spec
    default: Any = REQUIRED
    doc: str = ""
    unit: str = ""


@dataclass
class Section:
    """A table of the reference: title, prose, keys."""

    title: str
    doc: str
    keys: Sequence[Key]


@dataclass(eq=False)
class Table(Spec):
    """A table with fixed keys; ``rule`` (optional) relates its normalised keys to each other.

    ``title`` is how the reference names the table (``[fluid.grid]``)."""

    keys: Sequence[Key]
    title: str
    doc: str = ""
    rule: Rule | None = None

    def key_names(self) -> list[str]:
        return [k.name for k in self.keys]

    def check(self, value: Any, where: str, ctx: Context) -> dict[str, Any]:
        if not isinstance(value, Mapping):
            raise InputError(where or "case", value, f"a table ({self.title})")
        names = self.key_names()
        for k in value:  # unknown keys first: a misspelt key is named, not the required one it hides
            if k not in names:
                raise InputError(_join(where, k), value[k], "unknown key" + suggest(k, names)
                                 + " (allowed here: " + ", ".join(names) + ")")
        out: dict[str, Any] = {}
        for key in self.keys:
            w = _join(where, key.name)
            if key.name in value:
                out[key.name] = key.type.check(value[key.name], w, ctx)
            elif key.default is REQUIRED:
                raise InputError(w, None, "required (" + key.type.describe().replace("\\", "") + ") is missing")
            else:
                out[key.name] = None if key.default is None else key.type.check(key.default, w, ctx)
        if self.rule is not None:
            self.rule(out, where)
        return out

    def describe(self) -> str:
        return f"table, see [{self.title}](#{_anchor(self.title)})"

    def sections(self) -> Iterator[Section]:
        yield Section(self.title, self.doc, self.keys)
        for k in self.keys:
            yield from k.type.sections()


@dataclass(frozen=True)
class Form:
    """One variant of a :class:`Variants` table: meaning, keys, rule."""

    doc: str
    keys: Sequence[Key]
    rule: Rule | None = None


@dataclass(eq=False)
class Variants(Spec):
    """A table whose keys depend on its ``type`` key: one :class:`Form` per value; ``common``
    keys (first) belong to every form."""

    forms: Mapping[str, Form]
    title: str
    doc: str = ""
    default: str | None = None
    common: Sequence[Key] = ()

    def table(self, kind: str) -> Table:
        f = self.forms[kind]
        tag = Key("type", Str(tuple(self.forms)), REQUIRED if self.default is None else self.default,
                  "the kind of " + self.title.strip("[]"))
        return Table([*self.common, tag, *f.keys], f'{self.title} type = "{kind}"', f.doc, f.rule)

    def check(self, value: Any, where: str, ctx: Context) -> dict[str, Any]:
        if not isinstance(value, Mapping):
            raise InputError(where, value, f"a table with 'type' one of " + ", ".join(self.forms))
        kind = value.get("type", self.default)
        if kind is None:
            raise InputError(_join(where, "type"), None, "required (one of " + ", ".join(self.forms) + ") is missing")
        Str(tuple(self.forms)).check(kind, _join(where, "type"), ctx)
        return self.table(kind).check(value, where, ctx)

    def describe(self) -> str:
        return f"table, see [{self.title}](#{_anchor(self.title)})"

    def sections(self) -> Iterator[Section]:
        kinds = "\n".join(f'* [`type = "{k}"`](#{_anchor(self.table(k).title)}): {f.doc}' for k, f in self.forms.items())
        default = f' (default `"{self.default}"`)' if self.default else ""
        yield Section(self.title, (self.doc + "\n\n" if self.doc else "") + f"`type`{default} selects the form:\n\n"
                      + kinds, [])
        for k in self.forms:
            t = self.table(k)
            yield Section(t.title, "", t.keys)
            for key in t.keys:
                yield from key.type.sections()


@dataclass(eq=False)
class ListOf(Spec):
    """A list of values of one type (``[[array of tables]]`` for tables)."""

    item: Spec
    min_len: int = 0

    def check(self, value: Any, where: str, ctx: Context) -> list[Any]:
        if not isinstance(value, list) or len(value) < self.min_len:
            raise InputError(where, value, self.describe())
        return [self.item.check(x, f"{where}[{i}]", ctx) for i, x in enumerate(value)]

    def describe(self) -> str:
        least = f"≥ {self.min_len} " if self.min_len else ""
        return f"list of {least}({self.item.describe()})"

    def sections(self) -> Iterator[Section]:
        return self.item.sections()


@dataclass(eq=False)
class OneOf(Spec):
    """One of several forms, chosen by the shape of the value (the first matching test)."""

    forms: Sequence[tuple[Callable[[Any], bool], Spec]]
    text: str

    def check(self, value: Any, where: str, ctx: Context) -> Any:
        for test, spec in self.forms:
            if test(value):
                return spec.check(value, where, ctx)
        raise InputError(where, value, self.text.split(", see")[0])

    def describe(self) -> str:
        return self.text

    def sections(self) -> Iterator[Section]:
        for _, s in self.forms:
            yield from s.sections()


@dataclass(frozen=True)
class MapOf(Spec):
    """A table with free key names; values of one type."""

    value: Spec

    def check(self, value: Any, where: str, ctx: Context) -> dict[str, Any]:
        if not isinstance(value, Mapping):
            raise InputError(where, value, "a table of name = " + self.value.describe())
        return {k: self.value.check(v, _join(where, k), ctx) for k, v in value.items()}

    def describe(self) -> str:
        return "table of name = " + self.value.describe()


@dataclass(frozen=True)
class Parameters(Spec):
    """``parameters``: numbers, each may use the ones before it; they become the context of
    every ``"=..."`` and expression."""

    def check(self, value: Any, where: str, ctx: Context) -> dict[str, float]:
        if not isinstance(value, Mapping):
            raise InputError(where, value, "a table of numbers")
        for k, v in value.items():
            if not k.isidentifier() or k in ("x", "y", "t") or k in CONSTANTS or k in FUNCTIONS:
                raise InputError(_join(where, k), v, "a name usable in expressions (not x, y, t or a function)")
            x = Num().check(v, _join(where, k), ctx)
            ctx.params[k] = int(x) if isinstance(v, int) and x.is_integer() else x  # n = 16 stays an integer
        return dict(ctx.params)

    def describe(self) -> str:
        return "table of name = number"


def _is_table(v: Any) -> bool:
    return isinstance(v, Mapping)


def _has(key: str) -> Callable[[Any], bool]:
    return lambda v: isinstance(v, Mapping) and key in v


# --------------------------------------------------------------------------- time functions
def _after_t0(v: dict[str, Any], where: str) -> None:
    if v.get("t1") is not None and v["t1"] <= v["t0"]:
        raise InputError(_join(where, "t1"), v["t1"], f"greater than t0 = {v['t0']:g}")


def _one_minus_cos(v: dict[str, Any], where: str) -> None:
    if (v["t1"] is None) == (v["period"] is None):
        raise InputError(_join(where, "t1"), v["t1"], "exactly one of 't1' (a ramp) and 'period' (periodic)")
    _after_t0(v, where)


def _table_lengths(v: dict[str, Any], where: str) -> None:
    if len(v["times"]) != len(v["values"]):
        raise InputError(_join(where, "values"), v["values"], f"as many values as times ({len(v['times'])})")


TIME_FUNCTION_TABLE = Variants(
    {
        "constant": Form("f(t) = value.", [Key("value", Num(), 1.0, "the factor")]),
        "ramp": Form("linear from 0 at t0 to 1 at t1; 0 before, 1 after.",
                     [Key("t0", Num(), 0.0, "start of the ramp", "time"),
                      Key("t1", Num(), REQUIRED, "end of the ramp", "time")], _after_t0),
        "table": Form("piecewise linear through (times, values); constant outside.",
                      [Key("times", NumList(1, increasing=True), REQUIRED, "sample times", "time"),
                       Key("values", NumList(1), REQUIRED, "the factor at each time")], _table_lengths),
        "one_minus_cos": Form(
            "amplitude · ½(1 − cos(π(t − t0)/(t1 − t0))) on [t0, t1], amplitude after (the Turek-Hron inflow "
            "ramp); with `period` instead of `t1` periodic: amplitude · (1 − cos(2π(t − t0)/period)); 0 before t0.",
            [Key("t0", Num(), 0.0, "start", "time"), Key("t1", Num(), None, "end of the ramp", "time"),
             Key("period", Num(0.0, lo_open=True), None, "period of the periodic form", "time"),
             Key("amplitude", Num(), 1.0, "value reached at the end of the ramp")], _one_minus_cos),
        "linear": Form("slope · (t − t0) for t > t0, 0 before.",
                       [Key("slope", Num(), 1.0, "growth per unit time", "1/time"),
                        Key("t0", Num(), 0.0, "start", "time")]),
    },
    "time function",
    "A time function multiplies the values of a load or boundary condition: a number (a constant "
    "factor) or a table. Without one the factor is 1.",
)
TIME_FUNCTION = OneOf([(_is_number, Num()), (_is_table, TIME_FUNCTION_TABLE)],
                      "number or table, see [time function](#time-function)")

# --------------------------------------------------------------------------- geometry
def _ends_increase(v: dict[str, Any], where: str) -> None:
    if v["end"] <= v["start"]:
        raise InputError(_join(where, "end"), v["end"], f"greater than start = {v['start']:g}")


def _breaks_cells(v: dict[str, Any], where: str) -> None:
    k = len(v["breaks"]) - 1
    if len(v["cells"]) != k:
        raise InputError(_join(where, "cells"), v["cells"], f"{k} cell counts (one per interval between breaks)")
    if v["ratios"] is None:
        v["ratios"] = [1.0] * k
    elif len(v["ratios"]) != k:
        raise InputError(_join(where, "ratios"), v["ratios"], f"{k} grading ratios (one per interval)")


AXIS = OneOf(
    [
        (lambda v: isinstance(v, list), NumList(2, increasing=True)),
        (_has("breaks"), Table([
            Key("breaks", NumList(2, increasing=True), REQUIRED, "interval ends", "length"),
            Key("cells", NumList(1, item=Int(1)), REQUIRED, "cells in each interval"),
            Key("ratios", NumList(1, item=Num(0.0, lo_open=True)), None,
                "last/first cell size in each interval (default 1: uniform)"),
        ], "graded axis", "Piecewise graded axis: intervals between `breaks`, each with its own cell count and "
           "grading.", _breaks_cells)),
        (_is_table, Table([
            Key("start", Num(), REQUIRED, "first coordinate", "length"),
            Key("end", Num(), REQUIRED, "last coordinate", "length"),
            Key("cells", Int(1), REQUIRED, "number of cells"),
            Key("ratio", Num(0.0, lo_open=True), 1.0, "last/first cell size (geometric grading; 1: uniform)"),
        ], "axis", "An axis of a rectilinear grid: `{start, end, cells[, ratio]}`, a graded axis "
           "`{breaks, cells, ratios}`, or a list of increasing coordinates.", _ends_increase)),
    ],
    "list of coordinates or table, see [axis](#axis)",
)


def _arc_radii(v: dict[str, Any], where: str) -> None:
    r0 = math.dist(v["start"], v["center"])
    r1 = math.dist(v["end"], v["center"])
    if r0 == 0.0 or abs(r0 - r1) > 1e-9 * max(r0, 1.0):
        raise InputError(_join(where, "end"), v["end"], "a point as far from center as start (a circular arc)")


ARC = Table([Key("start", Vec(), REQUIRED, "first point", "length"),
             Key("center", Vec(), REQUIRED, "centre of the circle", "length"),
             Key("end", Vec(), REQUIRED, "last point (same distance from center)", "length")],
            "arc", "A circular arc from `start` to `end` about `center`, the shorter way (less than 180°).",
            _arc_radii)


def _line_or_arc(v: dict[str, Any], where: str) -> None:
    if (v["line"] is None) == (v["arc"] is None):
        raise InputError(where, {k: x for k, x in v.items() if x is not None}, "exactly one of 'line' and 'arc'")


PIECE = Table([Key("line", Points(2), None, "a straight piece [[x0, y0], [x1, y1]]", "length"),
               Key("arc", ARC, None, "a circular arc"),
               Key("name", Str(), None, "edge/node set of this piece (pieces may share a name)")],
              "outline piece", "One piece of an outline loop: `line` or `arc`; consecutive pieces share end points.",
              _line_or_arc)
CURVE = Table([Key("line", Points(2), None, "a straight side [[x0, y0], [x1, y1]]", "length"),
               Key("arc", ARC, None, "a circular side")],
              "side", "A side of a mapped mesh: `line` or `arc`.", _line_or_arc)


def _rectangle(v: dict[str, Any], where: str) -> None:
    for a, b in (("x0", "x1"), ("y0", "y1")):
        if v[b] <= v[a]:
            raise InputError(_join(where, b), v[b], f"greater than {a} = {v[a]:g}")


BOUNDARY_SIZE = ("target edge length along the outline (the gmsh meshes honour it within 20 %)")
MESH = Variants(
    {
        "rectangle": Form("structured mesh of an axis-parallel rectangle; edge sets `bottom`, `right`, `top`, "
                          "`left`, `all`.",
                          [Key("x0", Num(), REQUIRED, "left", "length"), Key("x1", Num(), REQUIRED, "right", "length"),
                           Key("y0", Num(), REQUIRED, "bottom", "length"), Key("y1", Num(), REQUIRED, "top", "length"),
                           Key("nx", Int(1), REQUIRED, "cells in x"), Key("ny", Int(1), REQUIRED, "cells in y")],
                          _rectangle),
        "rectilinear": Form("tensor-product mesh of two (graded) axes; edge sets as `rectangle`.",
                            [Key("x", AXIS, REQUIRED, "x axis"), Key("y", AXIS, REQUIRED, "y axis")]),
        "mapped": Form("transfinite map of the unit square onto four sides (lines or arcs); edge sets as "
                       "`rectangle`.",
                       [Key("sides", Table([Key(s, CURVE, REQUIRED, f"{s} side") for s in ("bottom", "right", "top", "left")],
                                           "mapped sides", "The four sides of a mapped mesh, counter-clockwise; "
                                           "`top` and `left` run from their left/bottom end like `bottom` and `right`."),
                            REQUIRED, "the four sides"),
                        Key("nx", Int(1), REQUIRED, "cells along bottom/top"),
                        Key("ny", Int(1), REQUIRED, "cells along left/right")]),
        "outline": Form("gmsh quad mesh of a region bounded by closed loops of lines and arcs; every named piece "
                        "becomes an edge set, plus `all`.",
                        [Key("loops", ListOf(ListOf(PIECE, 1), 1), REQUIRED,
                             "closed loops (the first is the outer boundary, others are holes)"),
                         Key("h", Num(0.0, lo_open=True), REQUIRED, BOUNDARY_SIZE, "length"),
                         Key("h_max", Num(0.0, lo_open=True), None,
                             "larger size in the interior (grows with the distance from the outline)", "length"),
                         Key("refine", ListOf(Table([
                             Key("point", Vec(), REQUIRED, "centre of the refinement", "length"),
                             Key("h", Num(0.0, lo_open=True), REQUIRED, "size near the point", "length"),
                             Key("radius", Num(0.0, lo_open=True), REQUIRED,
                                 "size h within this distance, growing to the global size at 4 radius", "length"),
                         ], "refinement", "Local refinement of an `outline` mesh around a point.")), [],
                             "local refinements")]),
        "disk": Form("gmsh quad mesh of a disk; its boundary is the edge set `name` (and `all`).",
                     [Key("center", Vec(), REQUIRED, "centre", "length"),
                      Key("radius", Num(0.0, lo_open=True), REQUIRED, "radius", "length"),
                      Key("h", Num(0.0, lo_open=True), REQUIRED, BOUNDARY_SIZE, "length"),
                      Key("h_max", Num(0.0, lo_open=True), None, "larger size in the interior", "length"),
                      Key("name", Str(), "surface", "name of the boundary edge set")]),
        "file": Form("a gmsh `.msh` file (read with meshio): all quad cells; physical line groups become edge sets.",
                     [Key("path", Str(), REQUIRED, "file name, relative to the case file")]),
    },
    "[bodies.mesh]", "The body's mesh in its reference configuration. Every mesh has the edge set `all` (the whole "
            "boundary); node sets have the names of the edge sets, plus `body` (every node).",
)

# --------------------------------------------------------------------------- boundary conditions
BODY_DIRICHLET = Table(
    [Key("boundary", Str(), REQUIRED, "a node or edge set of the body's mesh, or `body` (every node)"),
     Key("value", Values(2, free=True), REQUIRED, 'prescribed displacement (x, y); "free": not prescribed', "length"),
     Key("function", TIME_FUNCTION, None, "time factor of the values")],
    "[[bodies.dirichlet]]",
    "Prescribed displacement on a node set; values are expressions in the reference coordinates x, y and t.\n\n"
    "**Precedence.** Where two conditions prescribe the same component at a node, the one listed *last* wins; "
    "the run warns once when their values differ there.",
)
BODY_NEUMANN = Variants(
    {"traction": Form("dead load per reference length (x, y).",
                      [Key("value", Values(2), REQUIRED, "traction (x, y)", "force/length"),
                       Key("function", TIME_FUNCTION, None, "time factor")]),
     "pressure": Form("follower pressure on the current boundary, acting against the outward normal.",
                      [Key("value", Values(1), REQUIRED, "pressure", "force/length"),
                       Key("function", TIME_FUNCTION, None, "time factor")])},
    "[[bodies.neumann]]", "A load on an edge set of the body's mesh.", default="traction",
    common=[Key("boundary", Str(), REQUIRED, "an edge set of the body's mesh")],
)
FLUID_DIRICHLET = Table(
    [Key("boundary", Str(SIDES), REQUIRED, "a side of the fluid box"),
     Key("value", Values(2, free=True), REQUIRED, 'prescribed velocity (x, y); "free": not prescribed', "velocity"),
     Key("function", TIME_FUNCTION, None, "time factor of the values")],
    "[[fluid.dirichlet]]",
    "Prescribed velocity on a side of the box (its nodes, including the corners); values are expressions in "
    "x, y, t.\n\n**Precedence.** Where two conditions prescribe the same component at a node (a lid and a wall "
    "share the corner nodes), the one listed *last* wins; the run warns once when their values differ there. "
    "List the condition that should hold at the corners last.",
)
FLUID_NEUMANN = Variants(
    {"traction": Form("traction σn on the side (x, y).",
                      [Key("value", Values(2), REQUIRED, "traction (x, y)", "force/length"),
                       Key("function", TIME_FUNCTION, None, "time factor")]),
     "pressure": Form("pressure p0: traction −p0 n (n the outward normal); with `viscous_form = \"laplace\"` "
                      "the do-nothing condition ν∂v/∂n − pn = −p0 n.",
                      [Key("value", Values(1), REQUIRED, "pressure", "force/length"),
                       Key("function", TIME_FUNCTION, None, "time factor")])},
    "[[fluid.neumann]]", "A load on a side of the fluid box (its PHYSICAL part, outside the bodies). A side "
                         "without any condition is traction free (do nothing).", default="traction",
    common=[Key("boundary", Str(SIDES), REQUIRED, "a side of the fluid box")],
)

SLIP_NOTE = (
    "**Navier slip.** `slip_length` κ is the Navier slip length: the tangential slip velocity of the fluid "
    "relative to the body is v_t = (κ/μ) σ_nt, i.e. κ ∂v_t/∂n at a flat wall. κ = 0 is no slip, `\"inf\"` free "
    "slip. It is imposed weakly by Nitsche's method with the penalty length a = h_K/(γ0^t C_T) (h_K the fluid "
    "cell size, `fluid.interface.gamma_t`, `trace_constant`): the tangential traction is "
    "σ_t = μ/(κ + a) v_t + a/(κ + a) (σn)_t, which tends to the no-slip penalty for κ → 0 and to zero shear "
    "for κ → ∞ (paper eqs. (37)-(39)). `\"gap_law\"` uses the contact gap g of the point: "
    "κ = κ0 h (h/g − 1) for 0 < g < h, κ = 0 for g ≥ h, free slip for g ≤ 0 (paper eq. (40); κ0 and h are "
    "`fluid.interface.kappa0` and `slip_h`).\n\n"
    "**Polygonal outlines.** The body's boundary is the polygon of its mesh edges. A rigid rotation of a round "
    "body has, on each chord, a normal velocity component of order ω h (the chord is not tangential to the "
    "circle); with slip the fluid cannot follow it tangentially and the torque has an O(h) error that does not "
    "exist for the exact circle. Resolve the outline finely (`h`) when torques on rotating slipping bodies matter."
)

MATERIAL = Table([
    Key("law", Str(tuple(LAW_NAMES)), "neo_hooke", "hyperelastic law: Neo-Hooke (paper eq. (43)) or St. Venant-Kirchhoff"),
    Key("E", Num(0.0, lo_open=True), REQUIRED, "Young's modulus", "stress"),
    Key("nu", Num(0.0, 0.5, hi_open=True), 0.0, "Poisson's ratio (plane strain)"),
    Key("rho", Num(0.0), 0.0, "density in the reference configuration (0: no inertia)", "mass/volume"),
], "[bodies.material]", "Solid material, plane strain.")

BODY = Table([
    Key("name", Str(), REQUIRED, "unique body name (used by --set bodies.<name>..., quantities)"),
    Key("material", MATERIAL, REQUIRED, "material"),
    Key("mesh", MESH, REQUIRED, "mesh in the reference configuration"),
    Key("body_force", Values(2), None, "body force per unit mass (x, y)", "force/mass"),
    Key("body_force_function", TIME_FUNCTION, None, "time factor of the body force"),
    Key("dirichlet", ListOf(BODY_DIRICHLET), [], "prescribed displacements"),
    Key("neumann", ListOf(BODY_NEUMANN), [], "loads on edge sets"),
    Key("rigid", Bool(), False, "every node prescribed (needs a Dirichlet condition on `body`)"),
    Key("slip_length", SlipLength(), 0.0, "Navier slip length κ of the fluid on this body (see below)", "length"),
    Key("interface_velocity", Values(2), None,
        "prescribed interface velocity (x, y) replacing ∂u/∂t (moving walls, manufactured solutions)", "velocity"),
    Key("extends_outside", Bool(), False, "the body may reach outside the fluid box"),
    Key("dry_cavities", Bool(), False, "cavities enclosed by the body are not fluid (e.g. a pressurised cavity "
        "that loads the body); by default the fluid fills them"),
    Key("interface", StrList(), None,
        "edge sets coupled to the fluid (default: the whole boundary except loaded or fixed parts)"),
    Key("contact", StrList(), None, "edge sets that may touch other bodies (default: none)"),
], "[[bodies]]", "An elastic (or fully prescribed, `rigid`) solid body.\n\n" + SLIP_NOTE)

# --------------------------------------------------------------------------- fluid
STABILIZATION = Table([
    Key("gamma_p", Num(0.0), 0.25, "pressure CIP constant γ_p"),
    Key("gamma_u", Num(0.0), 0.25, "velocity (streamline) CIP constant γ_u"),
    Key("gamma_div", Num(0.0), 0.00025, "divergence CIP constant"),
    Key("gamma_gp", Num(0.0), 0.5, "viscous ghost-penalty constant"),
    Key("gamma_gp_t", Num(0.0), 0.001, "transient ghost-penalty constant"),
    Key("ghost_penalty", Bool(), True, "face terms on faces of cut cells (false: studies only)"),
    Key("ghost_ramp", Num(0.0, hi=1.0), 0.0,
        "solid fraction of a cut cell from which its faces carry the whole ghost penalty; below it the "
        "penalty grows linearly from zero, so that it does not switch on when a body's edge grazes a cell "
        "(0: the paper's switch, full penalty on every face of a cut cell)"),
    Key("scheme", Str(("cip", "residual")), "cip",
        "bulk stabilisation: `cip`, the paper's face terms (25) on every face; `residual`, SUPG/PSPG/grad-div "
        "in the cells with the face terms only on faces of cut cells (about 3× cheaper factorisation, "
        "docs/performance.md)"),
], "[fluid.stabilization]", "Continuous-interior-penalty and ghost-penalty constants (paper eqs. (25), (26); "
                            "defaults: the 2D values of Schott et al. 2015 as used by 4C).")

INTERFACE = Table([
    Key("gamma_n", Num(0.0, lo_open=True), 35.0, "Nitsche normal penalty constant γ0^F (paper Remark 8)"),
    Key("gamma_t", Num(0.0, lo_open=True), 35.0, "Nitsche tangential penalty constant γ0^t (paper eq. (37))"),
    Key("trace_constant", Num(0.0, lo_open=True), 1.43426, "trace-inequality constant C_T of Q1 cells"),
    Key("adjoint", Str(("skew", "symmetric")), "skew", "viscous adjoint consistency term"),
    Key("island_factor", Num(0.0), 2.0, "fluid islands smaller than this × cell diagonal are dropped"),
    Key("trapped_film", Num(0.0), 0.1, "enclosed fluid pieces (not reaching the box boundary) whose mean "
        "thickness 2 area / perimeter is below this × cell diagonal are dropped as islands"),
    Key("eps_geom", Num(0.0), 1e-9, "re-cut when bodies moved more than this × smallest cell"),
    Key("grow_only_after", Int(1), 5, "Newton iterations after which the active set may only grow"),
    Key("freeze_cut_after", Int(1), 8, "Newton iterations after which the cut is kept (paper §3.4.2)"),
    Key("own_cut_tol", Num(0.0), 1e-6, "a state converged on a frozen cut is accepted if the bodies moved less "
        "than this × smallest cell since the cut; else the cut follows again"),
    Key("max_layout_changes", Int(0), 5, "active-set changes in a step before it may only grow"),
    Key("kappa0", Num(0.0), 0.1, "κ0 of the slip-length gap law (paper eq. (40))"),
    Key("slip_h", Num(0.0), 0.0, "h of the gap law (0: the largest fluid cell side)", "length"),
    Key("case_iii", Str(("remark6", "original")), "remark6",
        "fluid in contact (case III): paper Remark 6 variant (35) or the original (33)"),
    Key("film_closure", Num(0.0, 0.5), 1e-6, "films between bodies thinner than 2 × this × h are closed"),
    Key("unknowns", Str(("per_node", "per_fluid_part")), "per_node",
        "sets of fluid unknowns of a background node: one (the paper's; fluid on both sides of a body thinner than "
        "a cell or of a shut valve shares it) or one per connected fluid part of the node's cells (those sides "
        "are not coupled; where a gap closes, Newton may alternate between the two, docs/architecture.md)"),
    Key("extension", Bool(), True, "extend the fluid traction into the contact zone (paper §4.6)"),
    Key("shape_derivative", Bool(), True, "linearise the motion of the cut in Newton"),
], "[fluid.interface]", "Fluid-structure coupling by Nitsche's method and the cut.")

FLUID = Table([
    Key("rho", Num(0.0, lo_open=True), REQUIRED, "density", "mass/volume"),
    Key("mu", Num(0.0, lo_open=True), REQUIRED, "dynamic viscosity", "stress·time"),
    Key("grid", Table([Key("x", AXIS, REQUIRED, "x axis"), Key("y", AXIS, REQUIRED, "y axis")], "[fluid.grid]",
                      "The rectilinear background grid; its box is the fluid domain."), REQUIRED, "background grid"),
    Key("viscous_form", Str(("symmetric", "laplace")), "symmetric",
        "2μ ε(v) (paper eq. (22)) or μ∇v (the DFG/Turek do-nothing outflow)"),
    Key("body_force", Values(2), None, "body force per unit mass (x, y)", "force/mass"),
    Key("body_force_function", TIME_FUNCTION, None, "time factor of the body force"),
    Key("dirichlet", ListOf(FLUID_DIRICHLET), [], "prescribed velocities on box sides"),
    Key("neumann", ListOf(FLUID_NEUMANN), [], "tractions or pressures on box sides"),
    Key("pressure_reference", Vec(), None, "point where p = 0 is imposed (default: automatic pin if needed)", "length"),
    Key("stabilization", STABILIZATION, {}, "stabilisation constants"),
    Key("interface", INTERFACE, {}, "coupling and cut settings"),
], "[fluid]", "Incompressible Newtonian fluid on a rectilinear background grid (Q1/Q1 with CIP); the bodies cut it.")

# --------------------------------------------------------------------------- time, solver, output
def _time_rule(v: dict[str, Any], where: str) -> None:
    t0 = v["t_start"]
    if v["segments"] is not None:
        if v["t_end"] is not None or v["dt"] is not None:
            raise InputError(_join(where, "segments"), "...", "either 'segments' or 't_end' and 'dt', not both")
        last = t0
        for i, s in enumerate(v["segments"]):
            if s["until"] <= last:
                raise InputError(f"{_join(where, 'segments')}[{i}].until", s["until"], f"greater than {last:g}")
            last = s["until"]
        return
    for k in ("t_end", "dt"):
        if v[k] is None:
            raise InputError(_join(where, k), None, "required (or 'segments') is missing")
    if v["t_end"] <= t0:
        raise InputError(_join(where, "t_end"), v["t_end"], f"greater than t_start = {t0:g}")
    v["segments"] = [{"until": v["t_end"], "dt": v["dt"]}]


TIME = Table([
    Key("type", Str(("static", "transient")), "transient", "static: no inertia, steady flow (t is a load parameter)"),
    Key("theta", Num(0.5, 1.0), 1.0, "one-step-θ parameter (1: backward Euler; 0.5: Crank-Nicolson, undamped)"),
    Key("t_start", Num(), 0.0, "start time", "time"),
    Key("t_end", Num(), None, "end time (with dt; or give segments)", "time"),
    Key("dt", Num(0.0, lo_open=True), None, "time step (static: load increment)", "time"),
    Key("segments", ListOf(Table([Key("until", Num(), REQUIRED, "end of the segment", "time"),
                                  Key("dt", Num(0.0, lo_open=True), REQUIRED, "step in the segment", "time")],
                                 "[[time.segments]]", "A part of the time grid with its own step."), 1), None,
        "time grid in parts, instead of t_end and dt"),
], "[time]", "The time grid: `t_end` and `dt`, or `segments`. A failed step is retried with a smaller step "
             "(`solver.step_cut_factor`) and grows back afterwards.", _time_rule)

SOLVER = Table([
    Key("max_iterations", Int(1), 25, "Newton iterations before the step is cut"),
    Key("min_iterations", Int(1), 1, "Newton iterations at least"),
    Key("tol_residual", Num(0.0, lo_open=True), 1e-8, "converged when every field's residual norm is below this"),
    Key("tol_increment", Num(0.0, lo_open=True), 1e-8, "… and every field's increment (max norm) is below this"),
    Key("rtol_residual", Num(0.0), 1e-10, "… or the residual fell by this factor from the first iteration"),
    Key("damping", Bool(), True, "damped Newton (step length rule of paper §3.4.1)"),
    Key("relaxation", Bool(), True, "Aitken relaxation of the Newton update while the cut follows the "
        "iterates, where the Jacobian lacks part of the cut's motion (contact) and Newton can overshoot "
        "back and forth (docs/architecture.md, decision 34)"),
    Key("predictor", Str(("constant_velocity", "constant_acceleration")), "constant_velocity",
        "Newton's start in a time step: the last step's velocities (and the displacement they give), or "
        "the velocities and the fluid pressure extrapolated linearly in time from the last two steps; the "
        "latter where bodies move smoothly (a step then needs about one Newton iteration fewer), the former "
        "where they hit or let go often (docs/architecture.md, decision 50)"),
    Key("linear", Str(("auto", "pardiso", "superlu")), "auto", "linear solver (auto: PARDISO if installed)"),
    Key("forcing", Num(0.0, 1.0, hi_open=True), 0.9, "largest relative residual of a linear solve that "
        "reuses factors (inexact Newton, forcing term of Eisenstat and Walker); 0: every solve exact"),
    Key("max_step_cuts", Int(0), 6, "step-size cuts of one step before the run stops"),
    Key("step_cut_factor", Num(0.0, 1.0, lo_open=True, hi_open=True), 0.5, "factor of a step-size cut"),
    Key("dt_min", Num(0.0), 0.0, "smallest step size", "time"),
    Key("steps_before_growth", Int(1), 1, "after a step-size cut, converged steps at the reduced size before it "
        "grows back by 1/step_cut_factor (1: after every step; more keeps a step that had to be cut from being "
        "tried again at the size that failed in the next step)"),
], "[solver]", "Newton, linear solver and step control.")

CONTACT = Table([
    Key("gamma0", Num(0.0, lo_open=True), 1.0, "Nitsche contact penalty constant γ0^S"),
    Key("weighting", Str(("harmonic", "half")), "harmonic", "weights of the two bodies' stresses"),
    Key("search_radius", Num(0.0), 0.0, "contact search distance (0: twice the longest contact edge)", "length"),
    Key("n_gauss", Int(1), 3, "Gauss points per integration piece"),
    Key("split", Bool(), True, "split pieces at projected opposite nodes (paper Remark 9)"),
    Key("n_fixed", Int(1), 10, "sub-intervals per edge when split = false"),
    Key("self_contact", Bool(), False, "a body may touch itself"),
    Key("allow_overlap", Bool(), False, "bodies may overlap at the start (pre-penetration)"),
], "[contact]", "Nitsche contact between bodies (surfaces listed in each body's `contact`).")

OUTPUT = Table([
    Key("every", Int(0), 1, "VTU output every this many steps (0: only the last)"),
    Key("figures", Bool(), True, "PNG figures at the end"),
    Key("fields", Bool(), True, "VTU/PVD field output"),
    Key("checkpoint_every", Int(0), 0, "also checkpoint every this many steps (0: by wall time only)"),
    Key("checkpoint_minutes", Num(0.0), 5.0, "checkpoint when this much wall time passed since the last (0: off)",
        "minutes"),
], "[output]", "What is written into the output folder (docs/output.md). A checkpoint is also written at every "
               "step-size cut, on SIGINT/SIGTERM, on failure and at the end.")

LIMITS = Table([
    Key("max_steps", Int(1), 200_000, "largest number of time steps of the time grid"),
    Key("max_unknowns", Int(1), 2_000_000, "largest (estimated) number of unknowns"),
], "[limits]", "Sanity limits checked before anything runs; raise them for a larger run.")

# --------------------------------------------------------------------------- quantities
COMPONENT = Int(0, 1)
BODY_NAME = Key("body", Str(), REQUIRED, "a body")


def _q(doc: str, *keys: Key, rule: Rule | None = None) -> Form:
    return Form(doc, list(keys), rule)


def _force_bodies() -> Key:
    return Key("body", OneOf([(lambda v: isinstance(v, str), Str()), (lambda v: isinstance(v, list), StrList())],
                             "a body name or a list of names"), REQUIRED, "body or bodies summed")


FORCE_KEYS = (Key("method", Str(("volume", "traction")), "volume",
                  "volume form (residual-based, includes inertia) or integrated traction"),
              Key("scale", Num(), 1.0, "factor applied to the value (e.g. to a drag coefficient)"))

QUANTITY = Variants(
    {
        "point_displacement": _q("displacement of a material point; column `<name>`.", BODY_NAME,
                                 Key("point", Vec(), REQUIRED, "the point in reference coordinates", "length"),
                                 Key("component", COMPONENT, 0, "0: x, 1: y")),
        "body_force": _q("fluid force on the body (or bodies); column `<name>`.", _force_bodies(),
                         Key("component", COMPONENT, 0, "0: x, 1: y"), *FORCE_KEYS),
        "body_moment": _q("fluid moment about `about`, counter-clockwise positive; column `<name>`.",
                          _force_bodies(), Key("about", Vec(), [0.0, 0.0], "moment point", "length"), *FORCE_KEYS),
        "pressure_difference": _q("p(first point) − p(second point); column `<name>`; NaN while a moving body "
                                  "covers a point.",
                                  Key("points", Points(2), REQUIRED, "two points in the fluid", "length")),
        "flow_rate": _q("∫ v·n over the physical part of a box side (paper eq. (44)); column `<name>`.",
                        Key("boundary", Str(SIDES), REQUIRED, "a side of the fluid box")),
        "mass_balance": _q("flow rates Φ through the box and Γ^FS and the errors of paper eq. (45); columns "
                           "`<name>_phi_box`, `_phi_fluid`, `_phi_solid`, `_err1`, `_err2`, and `_err1_pieces`, the largest "
                           "`_err1` of a single connected fluid piece (flow between pieces the bodies separate); result "
                           "`<name>_err1_max`."),
        "oscillation": _q("mean, amplitude, period and frequency of another quantity over its last period; results "
                          "`<name>_mean`, `_amplitude`, `_period`, `_frequency`.",
                          Key("of", Str(), REQUIRED, "name of an earlier quantity")),
        "centerline_profiles": _q("u along x = x and v along y = y written to profiles.csv (cavity).",
                                  Key("x", Num(), None, "vertical line (default: box centre)", "length"),
                                  Key("y", Num(), None, "horizontal line (default: box centre)", "length")),
        "vortex_center": _q("location and value of the stream-function extremum; results `<name>_x`, `_y`, `_psi`."),
        "contact_profile": _q("contact zone of a body: columns `<prefix>half_width`, `peak_pressure`, `penetration`, "
                              "`contact_force_x`, `contact_force_y`; contact_<body>.csv at the end.", BODY_NAME,
                              Key("axis", Num(), 0.0, "half-widths are measured from x = axis", "length"),
                              Key("prefix", Str(), "", "prefix of the column names")),
        "reaction": _q("force a prescribed boundary exerts on the body; column `<name>`.", BODY_NAME,
                       Key("boundary", Str(), REQUIRED, "a node or edge set of the body, or `body`"),
                       Key("component", COMPONENT, 0, "0: x, 1: y")),
        "hertz_exact": _q("plane-strain Hertz half-width and peak pressure for the load factor·|P|; columns "
                          "`hertz_load`, `half_width_exact`, `peak_pressure_exact`, with `contact` also "
                          "`half_width_ratio`, `peak_pressure_ratio`, `load_balance`.",
                          Key("P", OneOf([(_is_number, Num(0.0, lo_open=True)), (lambda v: isinstance(v, str), Str())],
                                         "a load > 0 or the name of an earlier reaction quantity"),
                              REQUIRED, "load per unit length", "force/length"),
                          Key("factor", Num(0.0, lo_open=True), 1.0, "load factor (2 for a half model)"),
                          Key("R", Num(0.0, lo_open=True), REQUIRED, "cylinder radius", "length"),
                          Key("E", Num(0.0, lo_open=True), REQUIRED, "Young's modulus", "stress"),
                          Key("nu", Num(0.0, 0.5, hi_open=True), REQUIRED, "Poisson's ratio"),
                          Key("contact", Str(), None, "an earlier contact_profile quantity to compare with")),
        "interface_summary": _q("per-step interface data of a body (lengths in contact and wetted, forces); "
                                "columns `<name>_*`.", BODY_NAME,
                                Key("x_range", NumList(2, increasing=True, max_len=2), None,
                                    "[x0, x1]: only interface points whose current x lies in it (e.g. one valve); "
                                    "default: the whole interface", "length")),
        "fluid_pieces": _q("number of connected fluid regions; column `<name>`."),
        "body_centroid": _q("centre of mass of a body in its current configuration (mean of the current positions "
                            "over the reference area) and its current area; columns `<name>_x`, `_y`, `_area`.",
                            BODY_NAME),
        "elastic_energy": _q("strain energy ∫ ψ dA0 stored in a body (or bodies, summed) by its hyperelastic law; "
                             "column `<name>`.", _force_bodies()),
        "event": _q("first time the history column `of` falls to zero, rises from zero, or falls below half of its "
                    "largest value so far; results `<name>_time` and `<name>` (= `value` at that time).",
                    Key("of", Str(), REQUIRED, "a history column of an earlier quantity (or case_I..case_IV)"),
                    Key("when", Str(("falls_to_zero", "rises_from_zero", "halves")), REQUIRED, "which event"),
                    Key("value", Expr(), None, "value reported at the event, an expression in t (default: t)"),
                    Key("after", Num(), None, "only steps at t ≥ this count (default: all)")),
        "value": _q("a constant (e.g. a derived input) reported in results.json; result `<name>`.",
                    Key("value", Num(), REQUIRED, "the value")),
    },
    "[[quantities]]",
    "Reported quantities: one or more columns of history.csv per quantity (evaluated after every step) or "
    "results at the end. With contact surfaces, history.csv also has the counts `case_I` … `case_IV` of "
    "interface points in each case of paper eqs. (31)-(35).",
    common=[Key("name", Str(), REQUIRED, "unique name (column / result name)")],
)

# result columns a quantity produces: exact names, and prefixes ending in "_" or "*" patterns
FIXED_COLUMNS = {
    "hertz_exact": ("hertz_load", "half_width_exact", "peak_pressure_exact", "half_width_ratio",
                    "peak_pressure_ratio", "load_balance"),
    "contact_profile": ("half_width", "peak_pressure", "penetration", "contact_force_x", "contact_force_y"),
}
SUFFIXES = {
    "mass_balance": ("phi_box", "phi_fluid", "phi_solid", "err1", "err2", "err1_pieces", "err1_max"),
    "oscillation": ("mean", "amplitude", "period", "frequency"),
    "vortex_center": ("x", "y", "psi"),
    "body_centroid": ("x", "y", "area"),
    "event": ("time", ""),
}
NO_OWN_COLUMN = ("mass_balance", "oscillation", "vortex_center", "centerline_profiles", "contact_profile", "hertz_exact",
                 "body_centroid")


def result_names(q: Mapping[str, Any]) -> tuple[set[str], tuple[str, ...]]:
    """Result names of a normalised quantity: exact names and name prefixes (``interface_summary``)."""
    name, kind = q["name"], q["type"]
    exact = set() if kind in NO_OWN_COLUMN else {name}
    exact |= {f"{name}_{s}" if s else name for s in SUFFIXES.get(kind, ())}
    if kind == "contact_profile":
        exact |= {q["prefix"] + c for c in FIXED_COLUMNS[kind]}
    elif kind == "hertz_exact":
        exact |= set(FIXED_COLUMNS[kind])
    return exact, ((name + "_",) if kind == "interface_summary" else ())


REFERENCE = Table([
    Key("name", Str(), REQUIRED, "a result name (a quantity or one of its columns)"),
    Key("value", Num(), REQUIRED, "reference value"),
    Key("rtol", Num(0.0), 0.01, "relative tolerance"),
    Key("source", Str(), "", "where the value comes from (author, year)"),
], "[[reference]]", "A reference value the run is checked against: `fsci run` prints each check and exits with "
                    "status 1 when one fails (`--no-check` to exit 0 anyway).")

# --------------------------------------------------------------------------- the case
CASE = Table([
    Key("parameters", Parameters(), {}, "named numbers usable in expressions and `\"=...\"` values; `--set NAME=V`"),
    Key("name", Str(), REQUIRED, "case name; the default output folder is results/<name>"),
    Key("description", Str(), "", "one line shown by `fsci list`"),
    Key("kind", Str(), "generic", "informational: the family of a built-in case"),
    Key("variant", Anything("string"), None, "selects the table `[variants.<name>]` (default: the first)"),
    Key("variants", Anything("table of tables of KEY = value"), None,
        "named sets of `--set`-style overrides (`\"bodies.stamp.slip_length\" = \"inf\"`), applied before validation"),
    Key("verified_at", MapOf(Num()), None, "parameter values at which the reference checks are verified"),
    Key("time", TIME, REQUIRED, "time grid"),
    Key("bodies", ListOf(BODY), [], "solid bodies"),
    Key("fluid", FLUID, None, "the fluid (omit for solids only)"),
    Key("contact", CONTACT, {}, "contact settings"),
    Key("solver", SOLVER, {}, "Newton and step control"),
    Key("output", OUTPUT, {}, "output settings"),
    Key("limits", LIMITS, {}, "size limits"),
    Key("quantities", ListOf(QUANTITY), [], "reported quantities"),
    Key("reference", ListOf(REFERENCE), [], "reference checks"),
], "case file", "The top-level keys; the tables they refer to follow.")


def validate(case: Mapping[str, Any]) -> dict[str, Any]:
    """Check a case dictionary (variants already applied) against :data:`CASE`; returns it
    normalised. Raises :class:`InputError` for the first problem found."""
    return CASE.check(case, "", Context())


# --------------------------------------------------------------------------- reference
INTRO = """# Case-file format

*Generated from the schema in `fsci/schema.py` by `fsci show --schema`; do not edit by hand
(`tests/test_schema.py` checks that this file is up to date).*

A case is a TOML file (or a built-in case: `fsci show CASE` prints it as one). Every key is
checked before anything runs or is written: a misspelt key or table is named with the closest
valid name, a bad value with what is allowed, and the command exits with status 2.

* **Units** are not fixed: use any consistent set (the built-in cases are dimensionless or SI).
  The *unit* column below says what kind of quantity a key is.
* **Parameters and `"=..."`.** `parameters = { re = 100, n = 64 }` defines names; any number in
  the file may be given as a string `"=expr"` of them, e.g. `mu = "=1/re"`, `cells = "=2*n"`.
  `--set re=1000` changes a parameter, `--set fluid.mu=0.01` any key (`bodies.<name>.` or
  `bodies[0].` address list entries).
* **Expressions in x, y, t.** Boundary values, loads and slip lengths may be expressions such as
  `"1.5*U*4*y*(H - y)/H**2"`: numbers, `x`, `y`, `t`, the parameters, `+ - * / **`, FUNCTIONS
  and the constants CONSTANTS. All arithmetic is in floating point (no expression can take
  long); a constant part that divides by zero or overflows is an input error naming the key.
* **Variants.** `variant = "name"` applies the overrides of `[variants.name]` before validation.
* **Limits.** `[limits]` bounds the number of time steps and unknowns (estimated before any
  mesh is built); raise them for a larger run.
"""


def markdown() -> str:
    """The case-file reference (docs/case-format.md)."""
    out = [INTRO.replace("FUNCTIONS", ", ".join(f"`{f}`" for f in FUNCTIONS))
           .replace("CONSTANTS", ", ".join(f"`{c}`" for c in CONSTANTS))]
    seen: set[str] = set()
    for sec in CASE.sections():
        if sec.title in seen:
            continue
        seen.add(sec.title)
        out.append(f"\n## {sec.title}\n")
        if sec.doc:
            out.append(sec.doc.strip() + "\n")
        if sec.keys:
            out.append("\n| key | allowed values | default | unit | meaning |\n|---|---|---|---|---|")
            for k in sec.keys:
                out.append(f"| `{k.name}` | {k.type.describe()} | {_default_text(k.default)} | {k.unit} | {k.doc} |")
    return "\n".join(out) + "\n"


def _default_text(d: Any) -> str:
    if d is REQUIRED:
        return "**required**"
    if d is None:
        return "—"
    if isinstance(d, bool):
        return "`true`" if d else "`false`"
    if isinstance(d, str):
        return f'`"{d}"`'
    if d == {}:
        return "defaults"
    if d == []:
        return "`[]`"
    return f"`{d!r}`" if not isinstance(d, float) else f"`{d:g}`"
