"""Command line behaviour, in particular bad input: one clear line naming the field and the
value, exit status 2, nothing written outside --out (and nothing at all for bad input)."""

from __future__ import annotations

import json
import tomllib
import subprocess
import sys
from pathlib import Path

import pytest

import numpy as np

from fsci.cli import main
from fsci.config import problem_from_dict

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
        assert re.match(rf"{name} +~\d+ (s|min|h)  \S", line), line
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


def test_run_with_another_setting_than_the_verified_one_says_so(tmp_path, capsys):
    """An override of a key outside the case parameters (here the Newton tolerance; the same
    for a different stabilisation scheme) leaves the verified setting too; one that restates
    the case file's own value does not."""
    out = tmp_path / "tol"
    assert main(["run", "turek-hron-csm1", "--set", "nx=20", "--set", "ny=2", "--set", "solver.tol_residual=1e-9",
                 "--set", "solver.tol_increment=1e-10", "--out", str(out)]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if "note:" in line]
    assert len(notes) == 1 and "solver.tol_residual = 1e-09" in notes[0], notes
    assert "the case's own solver.tol_residual" in notes[0] and "solver.tol_increment" not in notes[0]
    v = json.loads((out / "results.json").read_text())["verification"]
    assert v["differs"] == {"nx": 20, "ny": 2, "solver.tol_residual": 1e-9}


@pytest.mark.parametrize("value, field", [("{ zz = 1 }", "verified_at.zz"), ("{ E = 'x' }", "verified_at.E"),
                                          ("3", "verified_at")])
def test_bad_verified_at_is_rejected(tmp_path, capsys, value, field):
    text = CASE.format(E=1.0, nu=0.3, bnd="bottom").replace('name = "block"',
                                                            f'name = "block"\nparameters = {{ E = 1.0 }}\n'
                                                            f'verified_at = {value}')
    code, err, created = _run(["run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o")], tmp_path, capsys)
    assert code == 2 and field in err and len(err.splitlines()) == 1 and not created


def test_non_empty_output_folder_is_refused_and_overwrite_clears_it(tmp_path, capsys):
    case = _write(tmp_path, CASE.format(E=10.0, nu=0.3, bnd="bottom"))
    out = tmp_path / "out"
    out.mkdir()
    (out / "stale.vtu").write_text("old")
    code = main(["run", str(case), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "--out" in err and "--overwrite" in err and len(err.strip().splitlines()) == 1
    assert [p.name for p in out.iterdir()] == ["stale.vtu"]  # untouched
    assert main(["run", str(case), "--out", str(out), "--overwrite"]) == 0
    assert not (out / "stale.vtu").exists() and (out / "results.json").exists()
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert main(["run", str(case), "--out", str(afile)]) == 2
    assert "a folder" in capsys.readouterr().err and afile.read_text() == "x"


def test_case_name_cannot_leave_results(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    case = _write(tmp_path, CASE.format(E=10.0, nu=0.3, bnd="bottom").replace('name = "block"', 'name = "../../x"'))
    assert main(["run", str(case), "--set", "output.fields=false", "--set", "output.figures=false"]) == 0
    assert (tmp_path / "results" / "x" / "results.json").exists()


def test_failing_reference_check_exits_1_with_all_outputs(tmp_path, capsys):
    text = CASE.format(E=10.0, nu=0.3, bnd="bottom") + '\n[[reference]]\nname = "uy"\nvalue = 1.0\nrtol = 0.01\n'
    case = _write(tmp_path, text)
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out)]) == 1
    assert "reference check failed: uy" in capsys.readouterr().err
    res = json.loads((out / "results.json").read_text())
    assert res["reference_checks"][0]["pass"] is False
    assert (out / "history.csv").exists() and (out / "fields.pvd").exists() and (out / "figures").is_dir()
    assert main(["run", str(case), "--out", str(tmp_path / "o2"), "--no-check"]) == 0


def test_conflicting_dirichlet_values_warn_which_wins(tmp_path, capsys):
    text = CASE.format(E=10.0, nu=0.3, bnd="bottom").replace(
        'dirichlet = [ { boundary = "bottom", value = [0.0, 0.0] } ]',
        'dirichlet = [ { boundary = "bottom", value = [0.0, 0.0] }, { boundary = "left", value = [0.01, "free"] } ]')
    assert main(["run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    warn = [line for line in err.splitlines() if "warning" in line]
    assert len(warn) == 1 and "'left' over 'bottom' (x at 1 node)" in warn[0] and "listed last wins" in warn[0]
    same = text.replace("value = [0.01, \"free\"]", "value = [0.0, \"free\"]")
    assert main(["run", str(_write(tmp_path, same)), "--out", str(tmp_path / "o2")]) == 0
    assert "warning" not in capsys.readouterr().err  # equal values at the shared node: nothing to say
    twice = text.replace('value = [0.01, "free"]', 'value = [0.01, "free"] }, { boundary = "left", value = [0.0, 0.0]')
    assert main(["run", str(_write(tmp_path, twice)), "--out", str(tmp_path / "o3")]) == 2
    assert "dirichlet[2].boundary = 'left'" in capsys.readouterr().err


def test_fluid_vtu_shares_points_between_uncut_cells(tmp_path):
    """An uncut block of n × n fluid cells is written with its (n+1)² grid points, each shared by
    the cells around it, so ParaView line plots and stream tracers work without a merge."""
    import meshio

    out = tmp_path / "cav"
    assert main(["run", "cavity", "--set", "n=4", "--set", "time.dt=1.0", "--set", "output.figures=false",
                 "--out", str(out)]) == 0
    m = meshio.read(sorted((out / "vtu").glob("fluid_*.vtu"))[-1])
    quads = m.cells_dict["quad"]
    assert len(quads) == 16 and len(m.points) == 25
    assert len(np.unique(quads)) == 25 and m.point_data["velocity"].shape == (25, 3)


def test_eta_counts_the_steps_left_on_the_time_grid():
    """Steps left: each segment at its own step size; after a step-size cut the reduced step
    grows back by 1/step_cut_factor per step."""
    from fsci.simulation import Simulation

    case = tomllib.loads(CASE.format(E=10.0, nu=0.3, bnd="bottom"))
    case["time"] = {"type": "static", "segments": [{"until": 1.0, "dt": 0.1}, {"until": 3.0, "dt": 0.5}]}
    sim = Simulation(problem_from_dict(case))
    assert sim.remaining_steps() == 14
    sim.t, sim.step = 0.5, 5
    assert sim.remaining_steps() == 9
    sim.dt_current = 0.025  # cut twice: steps of 0.025 and 0.05 to 0.575, five of 0.1 to 1, four of 0.5
    assert sim.remaining_steps() == 2 + 5 + 4


def test_progress_line_fits_80_columns_and_shows_case_counts():
    import io

    from fsci.monitor import Monitor

    class Sim:
        t, step, dt_current = 123.456789, 12345, None
        history = [{"case_I": 1234, "case_II": 56, "case_III": 7, "case_IV": 89}]

        class problem:
            name = "x"

            class time:
                t_end = 2500.0

        def remaining_steps(self):
            return 4000

    mon = Monitor(io.StringIO(), live=False)
    mon._res, mon._it = 1.234e-9, 12
    mon.clock.per_step, mon.clock.steps = 0.9, 10
    line = mon.line(Sim())
    assert len(line) <= 79 and "ETA 1:00:00" in line and "I-IV 1234/56/7/89" in line, line
