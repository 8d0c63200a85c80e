"""Command line behaviour, in particular bad input: one clear line naming the field and the
value, exit status 2, nothing written outside --out (and nothing at all for bad input)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from fsci.cli import main

CASE = """
name = "block"
[time]
type = "static"
t_end = 1.0
dt = 1.0
[[bodies]]
name = "b"
material = {{ law = "neo_hooke", E = {E}, nu = {nu} }}
mesh = {{ type = "rectangle", x0 = 0, x1 = 1, y0 = 0, y1 = 1, nx = 2, ny = 2 }}
dirichlet = [ {{ boundary = "{bnd}", value = [0.0, 0.0] }} ]
neumann = [ {{ boundary = "top", type = "traction", value = [0.0, -0.1] }} ]
[[quantities]]
name = "uy"
type = "point_displacement"
body = "b"
point = [1.0, 1.0]
component = 1
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "case.toml"
    p.write_text(text)
    return p


def _run(args, tmp_path, capsys):
    before = set(tmp_path.rglob("*"))
    code = main(args)
    err = capsys.readouterr().err.strip()
    created = set(tmp_path.rglob("*")) - before
    return code, err, created


@pytest.mark.parametrize(
    "E, nu, bnd, field, value",
    [
        (0.0, 0.3, "bottom", "bodies[0].material.E", "0.0"),
        (-5.0, 0.3, "bottom", "bodies[0].material.E", "-5.0"),
        (10.0, 0.5, "bottom", "bodies[0].material.nu", "0.5"),
        (10.0, -0.1, "bottom", "bodies[0].material.nu", "-0.1"),
        (10.0, 0.3, "floor", "bodies[0].dirichlet[0].boundary", "floor"),
    ],
)
def test_bad_values_give_one_line_and_status_2(tmp_path, capsys, E, nu, bnd, field, value):
    case = _write(tmp_path, CASE.format(E=E, nu=nu, bnd=bnd))
    code, err, created = _run(["run", str(case), "--out", str(tmp_path / "out")], tmp_path, capsys)
    assert code == 2
    assert len(err.splitlines()) == 1
    assert field in err and value in err
    assert not created


def test_unknown_case_key_and_malformed_toml(tmp_path, capsys):
    code, err, created = _run(["run", "no-such-case", "--out", str(tmp_path / "o")], tmp_path, capsys)
    assert code == 2 and "no-such-case" in err and len(err.splitlines()) == 1 and not created
    code, err, created = _run(["run", "turek-hron-csm1", "--set", "bodies.bar.material.G=3", "--out",
                               str(tmp_path / "o")], tmp_path, capsys)
    assert code == 2 and "material.G" in err and "unknown key" in err and not created
    code, err, created = _run(["run", "turek-hron-csm1", "--set", "bodies.nobody.material.E=3", "--out",
                               str(tmp_path / "o")], tmp_path, capsys)
    assert code == 2 and "nobody" in err and not created
    bad = _write(tmp_path, "name = 'x'\n[time\n")
    code, err, created = _run(["run", str(bad), "--out", str(tmp_path / "o")], tmp_path, capsys)
    assert code == 2 and "valid TOML" in err and "line 2" in err and len(err.splitlines()) == 1
    extra = _write(tmp_path, CASE.format(E=1.0, nu=0.3, bnd="bottom") + "\n[solver]\nmax_iter = 3\n")
    code, err, _ = _run(["run", str(extra), "--out", str(tmp_path / "o")], tmp_path, capsys)
    assert code == 2 and "solver.max_iter" in err and "unknown key" in err


def test_inverted_cells_are_rejected(tmp_path, capsys):
    text = CASE.format(E=1.0, nu=0.3, bnd="bottom").replace(
        'mesh = { type = "rectangle", x0 = 0, x1 = 1, y0 = 0, y1 = 1, nx = 2, ny = 2 }',
        'mesh = { type = "mapped", nx = 2, ny = 2, sides = { bottom = { line = [[0, 0], [1, 0]] }, '
        'right = { line = [[1, 0], [0.2, 1]] }, top = { line = [[0.8, 1], [0.2, 1]] }, left = { line = [[0, 0], [0.8, 1]] } } }')
    code, err, created = _run(["run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o")], tmp_path, capsys)
    assert code == 2 and "bodies[0].mesh" in err and ("inverted" in err or "degenerate" in err)
    assert not created


def test_run_writes_results_history_fields_and_figures(tmp_path):
    case = _write(tmp_path, CASE.format(E=10.0, nu=0.3, bnd="bottom"))
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--set", "time.dt=0.5"]) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["uy"] < 0
    assert res["run"]["steps"] == 2 and res["run"]["newton_iterations"] >= 2
    assert res["run"]["linear_solver"] in ("pardiso", "superlu") and res["run"]["version"]
    assert (out / "history.csv").read_text().startswith("time,step,dt,newton_iterations,uy")
    assert (out / "fields.pvd").exists() and list((out / "vtu").glob("*.vtu"))
    assert (out / "figures" / "final_state.png").exists()
    assert not (tmp_path / "results").exists()  # nothing outside --out


def test_list_and_show_roundtrip(tmp_path, capsys):
    import re

    from fsci.cases import CASES

    assert main(["list"]) == 0
    listing = capsys.readouterr().out.splitlines()
    assert len(listing) == len(CASES)
    for line, name in zip(listing, CASES):  # name, wall time of the default run, description
        assert re.match(rf"{name} +~\d+ (s|min)  \S", line), line
    assert main(["show", "cavity", "--set", "re=1000"]) == 0
    toml_text = capsys.readouterr().out
    p = _write(tmp_path, toml_text)
    import tomllib

    case = tomllib.loads(p.read_text())
    assert case["parameters"]["re"] == 1000


def test_module_entry_point():
    out = subprocess.run([sys.executable, "-m", "fsci", "list"], capture_output=True, text=True, check=True)
    assert "cavity" in out.stdout


def test_readme_case_file_runs_and_meets_its_reference(tmp_path):
    """The case file shown in the README is valid and reproduces its own reference value."""
    import re

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = re.search(r"### A case file\n\n```toml\n(.*?)```", readme, re.S).group(1)
    case = _write(tmp_path, block)
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["reference_checks"] and all(c["pass"] for c in res["reference_checks"])


def test_run_off_the_verified_setting_says_so(tmp_path, capsys):
    """A built-in case run with other parameters than ``verified_at`` prints one note line and
    records it in results.json; its reference checks are still reported."""
    out = tmp_path / "coarse"
    assert main(["run", "turek-hron-csm1", "--set", "nx=20", "--set", "ny=2", "--out", str(out)]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if "note:" in line]
    assert len(notes) == 1 and "nx = 20, ny = 2" in notes[0] and "verified at nx = 320, ny = 16" in notes[0]
    res = json.loads((out / "results.json").read_text())
    v = res["verification"]
    assert not v["verified"] and v["differs"] == {"nx": 20, "ny": 2} and v["note"] == notes[0].strip()
    assert res["reference_checks"]


@pytest.mark.parametrize("value, field", [("{ zz = 1 }", "verified_at.zz"), ("{ E = 'x' }", "verified_at.E"),
                                          ("3", "verified_at")])
def test_bad_verified_at_is_rejected(tmp_path, capsys, value, field):
    text = CASE.format(E=1.0, nu=0.3, bnd="bottom").replace('name = "block"',
                                                            f'name = "block"\nparameters = {{ E = 1.0 }}\n'
                                                            f'verified_at = {value}')
    code, err, created = _run(["run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o")], tmp_path, capsys)
    assert code == 2 and field in err and len(err.splitlines()) == 1 and not created
