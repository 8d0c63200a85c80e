"""``fsci sweep``: the product of --set values as separate runs in parallel processes, one
folder each, a summary table; a rerun skips finished runs; the same sweep on a Dask cluster
(a local one, started in this process) gives the same table."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from fsci.cli import main
from fsci.sweep import plan, split_values

CASE = """
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
neumann = [ { boundary = "top", type = "traction", value = [0.0, -0.1] } ]
[output]
fields = false
figures = false
[[quantities]]
name = "uy"
type = "point_displacement"
body = "b"
point = [1.0, 1.0]
component = 1
"""
SETS = ["--set", "bodies.b.material.E=10,20", "--set", "time.dt=0.5,1.0", "--set", "bodies.b.material.nu=0.3"]


def _table(path: Path) -> list[dict[str, str]]:
    with open(path) as fh:
        return list(csv.DictReader(fh))


def test_values_split_outside_brackets():
    assert split_values("1,[2, 3],'a,b'") == ["1", "[2, 3]", "'a,b'"]
    runs = plan(["a=1,2", "b.c=x", "d=[1,2],[3,4]"])
    assert [r.name for r in runs] == ["a=1_d=1-2", "a=1_d=3-4", "a=2_d=1-2", "a=2_d=3-4"]
    assert runs[0].overrides == ("b.c=x", "a=1", "d=[1,2]")


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sweep")
    case = tmp / "block.toml"
    case.write_text(CASE)
    out = tmp / "local"
    assert main(["sweep", str(case), *SETS, "--jobs", "2", "--out", str(out)]) == 0
    return case, out


def test_sweep_runs_the_product_and_writes_a_summary(local_sweep):
    _, out = local_sweep
    rows = _table(out / "summary.csv")
    assert [(r["bodies.b.material.E"], r["time.dt"]) for r in rows] == [("10", "0.5"), ("10", "1.0"), ("20", "0.5"),
                                                                       ("20", "1.0")]
    assert all(r["exit"] == "0" and r["action"] == "run" for r in rows)
    for r in rows:
        assert (out / r["run"] / "results.json").is_file()
    uy = {(r["bodies.b.material.E"], r["time.dt"]): float(r["uy"]) for r in rows}
    assert uy[("20", "1.0")] == pytest.approx(uy[("10", "1.0")] / 2, rel=0.05)  # twice as stiff
    md = (out / "summary.md").read_text().splitlines()
    assert md[0].startswith("| run | bodies.b.material.E | time.dt | exit |") and len(md) == 6


def test_rerun_skips_finished_runs(local_sweep):
    case, out = local_sweep
    before = {p: p.stat().st_mtime_ns for p in out.rglob("results.json")}
    assert main(["sweep", str(case), *SETS, "--jobs", "2", "--out", str(out)]) == 0
    assert all(r["action"] == "done before" for r in _table(out / "summary.csv"))
    assert {p: p.stat().st_mtime_ns for p in out.rglob("results.json")} == before


def test_dask_cluster_gives_the_same_table(local_sweep, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    case, local = local_sweep
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster:
        assert main(["sweep", str(case), *SETS, "--dask", cluster.scheduler_address, "--out", str(tmp_path / "d")]) == 0
    drop = ("wall_time", "action")
    a = [{k: v for k, v in r.items() if k not in drop} for r in _table(local / "summary.csv")]
    b = [{k: v for k, v in r.items() if k not in drop} for r in _table(tmp_path / "d" / "summary.csv")]
    assert a == b


def test_bad_value_stops_the_sweep_before_any_run(tmp_path, capsys):
    case = tmp_path / "block.toml"
    case.write_text(CASE)
    out = tmp_path / "bad"
    assert main(["sweep", str(case), "--set", "bodies.b.material.E=10,-1", "--out", str(out)]) == 2
    assert "bodies[0].material.E = -1:" in capsys.readouterr().err
    assert not out.exists()


def test_runs_side_by_side_share_the_cores(tmp_path, monkeypatch):
    """Each run of ``--jobs N`` gets ``cores // N`` numba and MKL threads (runs side by side with
    every core each contend for them); a thread count the user set in the environment is kept;
    one run at a time is left alone."""
    import subprocess

    import fsci.sweep as sweep

    envs: list[dict[str, str]] = []

    class Done:
        returncode = 0

    monkeypatch.setattr(subprocess, "run", lambda *a, env=None, **kw: envs.append(env) or Done())
    monkeypatch.setattr(sweep.os, "cpu_count", lambda: 4)
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    monkeypatch.setenv("MKL_NUM_THREADS", "3")
    case = tmp_path / "block.toml"
    case.write_text(CASE)
    sweep.run_sweep(str(case), ["bodies.b.material.E=10,20"], tmp_path / "s", jobs=2)
    assert [e["NUMBA_NUM_THREADS"] for e in envs] == ["2", "2"]
    assert [e["MKL_NUM_THREADS"] for e in envs] == ["3", "3"]  # the user's
    envs.clear()
    sweep.run_sweep(str(case), ["bodies.b.material.E=10,20"], tmp_path / "s1", jobs=1)
    assert [e.get("NUMBA_NUM_THREADS") for e in envs] == [None, None]
