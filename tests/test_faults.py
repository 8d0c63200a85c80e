"""Faults from outside: a run killed with SIGKILL between steps, inside a checkpoint write and
while writing output resumes to exactly the result of an uninterrupted run; a damaged or
mismatched checkpoint is refused with one line; SIGTERM stops cleanly with a checkpoint; a full
disk gives exit 4 with a valid results.json and no partial file."""

from __future__ import annotations

import errno
import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from fsci.cli import main
from fsci.io.checkpoint import read_checkpoint

SMALL = ["--set", "n=8", "--set", "time.dt=0.02", "--set", "time.t_end=0.12", "--set", "output.every=2",
         "--set", "output.figures=false", "--set", "output.checkpoint_every=2"]

# runs fsci in a child process that SIGKILLs itself at the chosen point
KILLER = textwrap.dedent("""
    import os, signal, sys
    import fsci.io.atomic as atomic
    import fsci.simulation as simulation
    from fsci.cli import main

    where, count = sys.argv[1], int(sys.argv[2])
    calls = {"n": 0}

    def hit():
        calls["n"] += 1
        if calls["n"] == count:
            os.kill(os.getpid(), signal.SIGKILL)

    if where == "step":  # before the count-th step (the previous one complete, history flushed)
        real_advance = simulation.Simulation.advance
        def advance(self):
            hit()
            return real_advance(self)
        simulation.Simulation.advance = advance
    else:  # inside the count-th atomic write of a file whose name contains `where`, before the rename
        real_replace = os.replace
        def replace(src, dst):
            if where in str(dst):
                hit()
            return real_replace(src, dst)
        atomic.os.replace = replace
    sys.exit(main(sys.argv[3:]))
""")


def _killed(tmp_path: Path, where: str, count: int, out: Path) -> int:
    script = tmp_path / "killer.py"
    script.write_text(KILLER)
    return subprocess.run([sys.executable, str(script), where, str(count), "run", "sinking-disk", *SMALL, "--out",
                           str(out)], capture_output=True, text=True).returncode


def _same(a: Path, b: Path) -> None:
    sa, ma = read_checkpoint(a)
    sb, mb = read_checkpoint(b)
    assert ma["step"] == mb["step"] == 6
    assert set(sa) == set(sb) and all(np.array_equal(sa[k], sb[k]) for k in sa)
    assert ma["history"] == mb["history"]
    assert (a / "history.csv").read_text() == (b / "history.csv").read_text()
    ra, rb = (json.loads((d / "results.json").read_text()) for d in (a, b))
    assert {k: v for k, v in ra.items() if k != "run"} == {k: v for k, v in rb.items() if k != "run"}
    assert (a / "fields.pvd").read_text() == (b / "fields.pvd").read_text()


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("faults") / "full"
    assert main(["run", "sinking-disk", *SMALL, "--out", str(out)]) == 0
    return out


@pytest.mark.parametrize("where, count", [("step", 4), ("checkpoint.npz", 2), (".vtu", None), ("history.csv", 1)],
                         ids=["between steps", "inside a checkpoint write", "writing a VTU", "writing history.csv"])
def test_sigkill_then_resume_equals_an_uninterrupted_run(tmp_path, reference, where, count):
    if count is None:  # the first VTU of the output at step 4 (outputs at steps 0, 2, 4, 6; checkpoint at 2)
        count = 2 * len(list((reference / "vtu").glob("*.vtu"))) // 4 + 1
    out = tmp_path / "killed"
    assert _killed(tmp_path, where, count, out) == -signal.SIGKILL
    assert (out / "checkpoint.npz").exists() or where == "history.csv"
    if not (out / "checkpoint.npz").exists():  # killed before the first checkpoint: nothing to resume
        assert main(["resume", str(out)]) == 2
        return
    assert main(["resume", str(out)]) == 0
    assert not list(out.glob(".*.tmp*"))  # the interrupted write's temporary file is gone
    _same(reference, out)


def test_damaged_or_mismatched_checkpoint_is_refused(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "sinking-disk", *SMALL, "--set", "time.t_end=0.04", "--out", str(out)]) == 0
    capsys.readouterr()
    ck = out / "checkpoint.npz"
    data = ck.read_bytes()
    ck.write_bytes(data[: len(data) // 2])  # a torn file
    assert main(["resume", str(out), "--set", "time.t_end=0.08"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "damaged" in err
    ck.write_bytes(data)
    (out / "case.toml").write_text((out / "case.toml").read_text().replace("mu = 0.05", "mu = 0.06"))
    assert main(["resume", str(out), "--set", "time.t_end=0.08"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "case.toml" in err


def test_a_checkpoint_without_the_solids_rate_resumes(tmp_path):
    """A checkpoint written before the solid's velocity rate was stored (the constant-
    acceleration predictor's, docs/architecture.md decision 50) resumes: the first step after
    it starts from the constant-velocity predictor, and the run ends where an uninterrupted one
    does within the solver tolerance (not bit for bit: its first step starts elsewhere)."""
    full, old = tmp_path / "full", tmp_path / "old"
    assert main(["run", "sinking-disk", *SMALL, "--out", str(full)]) == 0
    assert main(["run", "sinking-disk", *SMALL, "--set", "time.t_end=0.04", "--out", str(old)]) == 0
    ck = old / "checkpoint.npz"
    with np.load(ck) as data:
        arrays = {k: data[k] for k in data.files if k != "solid0.Vrate"}
    assert len(arrays) == len(np.load(ck).files) - 1
    np.savez(ck, **arrays)
    assert main(["resume", str(old), "--set", "time.t_end=0.12"]) == 0
    a, b = (np.genfromtxt(d / "history.csv", delimiter=",", names=True) for d in (full, old))
    assert len(a) == len(b) == 6
    np.testing.assert_allclose(b["uy_center"], a["uy_center"], rtol=0, atol=1e-9)


def test_resume_without_the_field_files_lists_only_files_that_exist(tmp_path):
    """A run directory carried on without its vtu/ folder (case.toml and checkpoint.npz only):
    the resumed run writes its new outputs, and fields.pvd lists those, not the missing ones.
    results.json reports the wall time, timings and counts of the whole run, both processes."""
    out = tmp_path / "run"
    assert main(["run", "sinking-disk", *SMALL, "--set", "time.t_end=0.04", "--out", str(out)]) == 0
    first = json.loads((out / "results.json").read_text())["run"]
    for f in (out / "vtu").glob("*.vtu"):
        f.unlink()
    assert main(["resume", str(out), "--set", "time.t_end=0.08"]) == 0
    whole = json.loads((out / "results.json").read_text())["run"]
    assert whole["steps"] == 4 and whole["wall_time"] > first["wall_time"]
    # one assembly per Newton iteration at least (a chord step's without the matrix), of both processes
    assert whole["counts"]["assembly"] + whole["counts"]["residual_only"] >= whole["newton_iterations"] \
        > first["newton_iterations"]
    assert all(whole["timings"][k] >= first["timings"][k] for k in first["timings"])
    listed = re.findall(r'file="([^"]+)"', (out / "fields.pvd").read_text())
    assert listed and all((out / f).exists() for f in listed)
    assert len(listed) == len(list((out / "vtu").glob("*.vtu")))


def test_sigterm_stops_cleanly_with_a_checkpoint(tmp_path):
    out = tmp_path / "term"
    args = [sys.executable, "-m", "fsci", "run", "sinking-disk", "--set", "n=8", "--set", "time.dt=0.01",
            "--set", "output.figures=false", "--out", str(out)]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not ((out / "history.csv").exists()
                                          and len((out / "history.csv").read_text().splitlines()) >= 3):
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert "fsci resume" in err
    state, meta = read_checkpoint(out)
    rows = (out / "history.csv").read_text().splitlines()
    assert meta["step"] == len(rows) - 1 >= 2  # the checkpoint holds the last completed step


def test_full_disk_exits_4_with_valid_results(tmp_path, monkeypatch, capsys):
    """Writing the figures fails with ENOSPC: exit 4, results.json complete, no partial PNG."""
    import matplotlib.figure

    def no_space(self, fname, *args, **kwargs):
        Path(fname).write_bytes(b"\x89PNG partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(fname))

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", no_space)
    out = tmp_path / "full"
    code = main(["run", "two-blocks", "--set", "time.t_end=0.2", "--set", "time.dt=0.1", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 4 and "No space left on device" in err
    res = json.loads((out / "results.json").read_text())
    assert res["run"]["steps"] == 2
    assert not list(out.rglob("*.png")) and not list(out.glob(".*"))
