"""The case-file schema: one definition for validation, ``fsci show --schema`` and
docs/case-format.md; misspelt keys and tables at any depth are named with a suggestion."""

from __future__ import annotations

from pathlib import Path

import pytest

from fsci.cases import CASES, get_case
from fsci.cli import main
from fsci.config import problem_from_dict
from fsci.errors import InputError
from fsci.schema import markdown

ROOT = Path(__file__).resolve().parents[1]

BLOCK = """
name = "block"
[time]
type = "static"
t_end = 1.0
dt = 1.0
[[bodies]]
name = "b"
material = { law = "neo_hooke", E = 10.0, nu = 0.3 }
mesh = { type = "rectangle", x0 = 0, x1 = 1, y0 = 0, y1 = 1, nx = 2, ny = 2 }
dirichlet = [ { boundary = "bottom", value = [0.0, 0.0] } ]
"""


def test_case_format_doc_is_generated_from_the_schema(capsys):
    """docs/case-format.md is exactly what the schema renders (regenerate it with
    ``fsci show --schema > docs/case-format.md``), and that is what --schema prints."""
    doc = (ROOT / "docs" / "case-format.md").read_text()
    assert doc == markdown(), "docs/case-format.md is out of date: fsci show --schema > docs/case-format.md"
    assert main(["show", "--schema"]) == 0
    assert capsys.readouterr().out == doc


def test_every_key_of_every_builtin_case_is_in_the_reference():
    """Each key a built-in case uses appears in the reference (the schema knows it)."""
    doc = markdown()

    def keys(d, out):
        if isinstance(d, dict):
            for k, v in d.items():
                out.add(k)
                keys(v, out)
        elif isinstance(d, list):
            for v in d:
                keys(v, out)
        return out

    used = set()
    for name in CASES:
        case = get_case(name)
        case.pop("variants", None)
        used |= keys(case, set())
    used -= {k for c in CASES for k in get_case(c).get("parameters", {})} | {k for c in CASES for k in
                                                                             get_case(c).get("verified_at", {}) or {}}
    missing = sorted(k for k in used if f"`{k}`" not in doc)
    assert not missing, missing


@pytest.mark.parametrize("text, field, suggestion", [
    (BLOCK.replace("[time]", "[tiem]"), "tiem", "time"),  # a misspelt table
    (BLOCK.replace('boundary = "bottom"', 'boundry = "bottom"'), "bodies[0].dirichlet[0].boundry", "boundary"),
    (BLOCK.replace("nx = 2,", "nxx = 2,"), "bodies[0].mesh.nxx", "nx"),
    (BLOCK + "[solver]\nmax_iter = 3\n", "solver.max_iter", "max_iterations"),
    (BLOCK + "[fluid.grdi.x]\nstart = 0\n", "fluid.grdi", "grid"),  # a misspelt nested table
    (BLOCK + '[[quantities]]\nname = "u"\ntype = "point_displacement"\nbody = "b"\npiont = [1, 1]\n',
     "quantities[0].piont", "point"),  # quantities go through the same schema
    (BLOCK.replace('dt = 1.0', 'dt = 1.0\n[time.function]\ntype = "ramp"'), "time.function", None),
    (BLOCK.replace('value = [0.0, 0.0] }', 'value = [0.0, 0.0], function = { type = "ramp", t0 = 0, t_1 = 2 } }'),
     "bodies[0].dirichlet[0].function.t_1", "t1"),  # time functions too
    (BLOCK.replace('type = "rectangle"', 'type = "rectangel"'), "bodies[0].mesh.type", "rectangle"),
])
def test_misspelt_keys_are_named_with_a_suggestion(tmp_path, capsys, text, field, suggestion):
    p = tmp_path / "case.toml"
    p.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(p), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"fsci: error: {field} = " in err, err
    if suggestion:
        assert f"did you mean '{suggestion}'?" in err, err
    assert not out.exists()


def test_missing_mesh_file_is_named_under_its_key(tmp_path, capsys):
    p = tmp_path / "case.toml"
    p.write_text(BLOCK.replace('mesh = { type = "rectangle", x0 = 0, x1 = 1, y0 = 0, y1 = 1, nx = 2, ny = 2 }',
                               'mesh = { type = "file", path = "nowhere.msh" }'))
    assert main(["run", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "bodies[0].mesh.path = 'nowhere.msh'" in err


def test_defaults_come_from_the_schema():
    p = problem_from_dict({"name": "x", "time": {"t_end": 1.0, "dt": 0.5},
                           "bodies": [{"name": "b", "material": {"E": 1.0},
                                       "mesh": {"type": "rectangle", "x0": 0, "x1": 1, "y0": 0, "y1": 1, "nx": 1, "ny": 1}}]})
    assert p.bodies[0].material.law == "neo_hooke" and p.bodies[0].material.nu == 0.0
    assert p.solver.max_iterations == 25 and p.time.kind == "transient" and p.time.segments == [(1.0, 0.5)]
    assert p.output.checkpoint_minutes == 5.0


@pytest.mark.parametrize("change, field", [
    ({"time": {"t_end": 1.0, "dt": 0.5, "segments": [{"until": 1.0, "dt": 0.1}]}}, "time.segments"),
    ({"time": {"segments": [{"until": 1.0, "dt": 0.1}, {"until": 0.5, "dt": 0.1}]}}, "time.segments[1].until"),
    ({"time": {"t_end": 1.0}}, "time.dt"),
    ({"reference": [{"name": "nothing", "value": 1.0}]}, "reference[0].name"),
    ({"quantities": [{"name": "a", "type": "value", "value": 1.0}, {"name": "a", "type": "value", "value": 2.0}]},
     "quantities[1].name"),
    ({"quantities": [{"name": "a", "type": "value", "value": "x"}]}, "quantities[0].value"),
    ({"parameters": {"sin": 1.0}}, "parameters.sin"),
])
def test_cross_key_rules(change, field):
    case = {"name": "x", "time": {"t_end": 1.0, "dt": 0.5},
            "bodies": [{"name": "b", "material": {"E": 1.0},
                        "mesh": {"type": "rectangle", "x0": 0, "x1": 1, "y0": 0, "y1": 1, "nx": 1, "ny": 1}}]}
    case.update(change)
    with pytest.raises(InputError) as exc:
        problem_from_dict(case)
    assert exc.value.field == field, str(exc.value)
