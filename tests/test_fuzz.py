"""Fuzzing the input path: a few hundred seeded mutations of small built-in cases (deleted,
misspelt and retyped keys; NaN, ±inf, huge, zero and negative numbers; bad expressions; garbage
files; bad --set) are run through ``fsci run``. Every one must end with exit status 0, 2 or 3
(never a traceback), within its size limits, and an input error (2) must leave no output folder.
A list of known-invalid inputs, one for each kind of problem found before (issue 15), must each
exit 2 naming the offending key."""

from __future__ import annotations

import copy
import random
import shutil
import time
from pathlib import Path
from typing import Any

import pytest
import tomli_w

from fsci.cases import get_case
from fsci.cli import main

LIMITS = {"max_steps": 40, "max_unknowns": 20000}
SEED = 20260915
N_MUTATIONS = 300
RUN_SECONDS = 60.0  # a run taking longer counts as a hang


def _small(name: str) -> dict[str, Any]:
    """A built-in case made small: a few steps, coarse, no figures; limits that keep it small."""
    c = get_case(name)
    if name == "cavity":
        c["parameters"]["n"] = 4
        c["time"] = {"type": "static", "t_end": 1.0, "dt": 1.0}
    elif name == "sinking-disk":
        c["parameters"]["n"] = 8
        c["time"] = {"type": "transient", "t_end": 0.02, "dt": 0.01}
    elif name == "two-blocks":
        c["time"] = {"type": "static", "t_end": 0.2, "dt": 0.1}
    elif name == "turek-hron-csm1":
        c["parameters"].update(nx=8, ny=2)
        c.pop("verified_at", None)
        c.pop("reference", None)
    c["output"] = {"every": 0, "figures": False, "fields": name == "cavity"}
    c["limits"] = dict(LIMITS)
    return c


BASES = ("turek-hron-csm1", "cavity", "two-blocks", "sinking-disk")
BAD_NUMBERS = (float("nan"), float("inf"), -float("inf"), 1e300, -1e300, 0, -1, 1e-300, 10 ** 30, 2.5)
BAD_VALUES = ("", "abc", [], [1, 2, 3], {}, {"x": 1}, True, "=1/0", "=10**10**10", "=x+", "=__import__('os')",
              "sin(", "1/0", "=nan", "=1e308*10", "free", "gap_law", "inf")


def _paths(d: Any, prefix: tuple = ()) -> list[tuple]:
    """Every key path in a case (lists by index), except the limits."""
    out = []
    if isinstance(d, dict):
        for k, v in d.items():
            if k == "limits":
                continue
            out.append(prefix + (k,))
            out += _paths(v, prefix + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            out.append(prefix + (i,))
            out += _paths(v, prefix + (i,))
    return out


def _parent(d: Any, path: tuple) -> Any:
    for p in path[:-1]:
        d = d[p]
    return d


def _misspell(key: str, rng: random.Random) -> str:
    if len(key) < 2:
        return key + "x"
    i = rng.randrange(len(key) - 1)
    op = rng.choice(("swap", "drop", "double"))
    if op == "swap":
        return key[:i] + key[i + 1] + key[i] + key[i + 2:]
    if op == "drop":
        return key[:i] + key[i + 1:]
    return key[:i] + key[i] + key[i:]


def mutate(case: dict[str, Any], rng: random.Random) -> tuple[str, dict[str, Any] | bytes, list[str]]:
    """One mutation: (class, mutated case or raw file bytes, extra command-line arguments)."""
    kind = rng.choice(("delete", "misspell", "retype", "number", "number", "value", "garbage", "set"))
    c = copy.deepcopy(case)
    if kind == "garbage":
        text = tomli_w.dumps(c).encode()
        return kind, rng.choice((
            bytes(rng.randrange(256) for _ in range(200)),
            text[: rng.randrange(len(text))],
            text.replace(b"\n", b"\x00\n", 3),
            tomli_w.dumps(c).encode("utf-16"),
            b"a = " + b"[" * 5000 + b"]" * 5000,
            b"x = {" + b"y = {" * 300 + b"}" * 301,
        )), []
    if kind == "set":
        return kind, c, ["--set", rng.choice(("foo", "=3", "bodies[9].x=1", "a.b.c.d=1", "time=3", "parameters=[1]",
                                             "time.dt=-1", "quantities[0]=1", "n=abc", "fluid.grid.x.cells=1e9",
                                             "bodies[0].name=[1]", "output.every=-2"))]
    paths = _paths(c)
    path = rng.choice(paths)
    parent = _parent(c, path)
    key = path[-1]
    if kind == "delete":
        if isinstance(parent, list):
            parent.pop(key)
        else:
            del parent[key]
    elif kind == "misspell" and isinstance(key, str):
        parent[_misspell(key, rng)] = parent.pop(key)
    elif kind == "number":
        parent[key] = rng.choice(BAD_NUMBERS)
    else:
        parent[key] = rng.choice(BAD_VALUES)
    return kind, c, []


def _run(tmp: Path, k: int, case: dict[str, Any] | bytes, extra: list[str]) -> tuple[int, float, Path]:
    f = tmp / f"case{k}.toml"
    f.write_bytes(case if isinstance(case, bytes) else tomli_w.dumps(case).encode())
    out = tmp / f"out{k}"
    t0 = time.perf_counter()
    code = main(["run", str(f), "--out", str(out), "--no-check", *extra])
    return code, time.perf_counter() - t0, out


def test_fuzzed_inputs_end_cleanly(tmp_path, capsys):
    """Exit 0, 2 or 3 only, no traceback, no run beyond its limits, nothing written on exit 2."""
    rng = random.Random(SEED)
    bases = {name: _small(name) for name in BASES}
    counts: dict[tuple[str, int], int] = {}
    problems = []
    for k in range(N_MUTATIONS):
        kind, case, extra = mutate(bases[BASES[k % len(BASES)]], rng)
        try:
            code, seconds, out = _run(tmp_path, k, case, extra)
        except BaseException as exc:  # a traceback: exactly what must not happen
            problems.append(f"{k} {kind}: {type(exc).__name__}: {exc}")
            continue
        capsys.readouterr()
        counts[kind, code] = counts.get((kind, code), 0) + 1
        if code not in (0, 2, 3):
            problems.append(f"{k} {kind}: exit {code}")
        if code == 2 and out.exists():
            problems.append(f"{k} {kind}: exit 2 but {out} was written")
        if seconds > RUN_SECONDS:
            problems.append(f"{k} {kind}: ran {seconds:.0f} s")
        shutil.rmtree(out, ignore_errors=True)
    print("mutations by class and exit status:", dict(sorted(counts.items())))
    assert not problems, problems[:10]
    assert sum(counts.values()) == N_MUTATIONS
    assert sum(n for (kind, code), n in counts.items() if code == 2) > N_MUTATIONS / 2


def _case(name: str, change) -> dict[str, Any]:
    c = _small(name)
    change(c)
    return c


def _set(path: str, value: Any):
    def change(c):
        node = c
        parts = path.split(".")
        for p in parts[:-1]:
            node = node[int(p)] if p.isdigit() else node[p]
        last = parts[-1]
        node[int(last) if last.isdigit() else last] = value
    return change


def _rename(path: str, new: str):
    def change(c):
        parts = path.split(".")
        node = c
        for p in parts[:-1]:
            node = node[int(p)] if p.isdigit() else node[p]
        node[new] = node.pop(parts[-1])
    return change


def _add_quantity(q: dict[str, Any]):
    return lambda c: c.setdefault("quantities", []).append(q)


KNOWN_INVALID = [
    # tracebacks before
    ("division by zero in a value", _case("turek-hron-csm1", _set("bodies.0.material.E", "=1/0")), [],
     "bodies[0].material.E"),
    ("re = 0 in mu = 1/re", _case("cavity", _set("parameters.re", 0)), [], "fluid.mu"),
    ("n = 0 in a mesh size", _case("sinking-disk", _set("parameters.n", 0)), [], "bodies[0].mesh.h"),
    ("binary file", b"\x00\x01\xff\xfe" * 50, [], "case"),
    ("NUL in the file", tomli_w.dumps(_small("cavity")).replace("\n", "\x00\n", 1).encode(), [], "case"),
    ("UTF-16 file", tomli_w.dumps(_small("cavity")).encode("utf-16"), [], "case"),
    ("TOML nested thousands deep", b"a = " + b"[" * 3000 + b"]" * 3000, [], "case"),
    ("wrong type in a quantity", _case("sinking-disk", _set("quantities.0.point", "abc")), [], "quantities[0].point"),
    ("missing key in a quantity", _case("sinking-disk", lambda c: c["quantities"][0].pop("body")), [],
     "quantities[0].body"),
    ("grid of one cell", _case("cavity", _set("parameters.n", 1)), [], "fluid.grid.x"),
    ("coordinates of 1e300", _case("two-blocks", _set("bodies.0.mesh.x1", 1e300)), [], "bodies[0].mesh"),
    ("disk radius 1e300", _case("sinking-disk", _set("bodies.0.mesh.radius", 1e300)), [], "bodies[0].mesh"),
    ("grid of 1e9 cells", _case("cavity", _set("parameters.n", 10 ** 9)), [], "fluid.grid"),
    ("crossing outline (gmsh aborted)", _case("turek-hron-csm1", lambda c: c["bodies"][0].update(mesh={
        "type": "outline", "h": 0.1, "loops": [[{"line": [[0, 0], [1, 1]]}, {"line": [[1, 1], [1, 0]]},
                                               {"line": [[1, 0], [0, 1]]}, {"line": [[0, 1], [0, 0]]}]]})), [],
     "bodies[0].mesh.loops[0]"),
    # hangs before
    ("10**10**10", _case("cavity", _set("fluid.mu", "=10**10**10")), [], "fluid.mu"),
    ("t_end = 1e300", _case("cavity", _set("time.t_end", 1e300)), [], "time.dt"),
    ("dt = 1e-12", _case("cavity", _set("time.dt", 1e-12)), [], "time.dt"),
    ("body covering the box", _case("sinking-disk", _set("bodies.0.mesh.radius", 5.0)), [], "bodies[0].mesh"),
    ("body covering the box, crossing allowed", _case("sinking-disk", lambda c: (
        c["bodies"][0]["mesh"].update(radius=5.0, h=1.0), c["bodies"][0].update(extends_outside=True))), [], "bodies"),
    # silently accepted before
    ("misspelt key in a quantity", _case("sinking-disk", _rename("quantities.0.body", "bdy")), [],
     "quantities[0].bdy"),
    ("misspelt key in a time function", _case("cavity", lambda c: c["fluid"]["dirichlet"][0]["function"].update(
        t_1=1.0)), [], "fluid.dirichlet[0].function.t_1"),
    ("number where a quantity name is expected", _case("sinking-disk", _add_quantity(
        {"name": "osc", "type": "oscillation", "of": 3})), [], "quantities[4].of"),
    ("reference to no quantity", _case("cavity", lambda c: c.update(reference=[{"name": "nothing", "value": 1.0}])), [],
     "reference[0].name"),
    ("duplicate quantity names", _case("sinking-disk", _set("quantities.1.name", "uy_center")), [],
     "quantities[1].name"),
    ("pressure probe outside the box", _case("sinking-disk", _add_quantity(
        {"name": "dp", "type": "pressure_difference", "points": [[0.5, 0.5], [2.0, 0.5]]})), [],
     "quantities[4].points[1]"),
    ("pressure probe inside a body", _case("sinking-disk", _add_quantity(
        {"name": "dp", "type": "pressure_difference", "points": [[0.5, 1.0], [0.5, 0.5]]})), [],
     "quantities[4].points[0]"),
    ("bodies overlapping at the start", _case("two-blocks", _set("bodies.1.mesh.y0", 0.5)), [], "bodies[1].mesh"),
    ("duplicate Dirichlet condition", _case("cavity", lambda c: c["fluid"]["dirichlet"].append(
        {"boundary": "top", "value": [0.0, 0.0]})), [], "fluid.dirichlet[4].boundary"),
    # outputs
    ("--out naming a file", _small("cavity"), ["FILE"], "--out"),
]


@pytest.mark.parametrize("label, case, extra, field", KNOWN_INVALID, ids=[k[0] for k in KNOWN_INVALID])
def test_known_invalid_input_is_named(tmp_path, capsys, label, case, extra, field):
    if extra == ["FILE"]:
        (tmp_path / "afile").write_text("keep")
        f = tmp_path / "case.toml"
        f.write_text(tomli_w.dumps(case))
        assert main(["run", str(f), "--out", str(tmp_path / "afile")]) == 2
        assert (tmp_path / "afile").read_text() == "keep"
    else:
        code, _, out = _run(tmp_path, 0, case, extra)
        assert code == 2 and not out.exists()
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("fsci: warning")]
    assert len(err) == 1 and err[0].startswith(f"fsci: error: {field} = "), err
