"""Parameter studies: ``fsci sweep CASE --set KEY=V1,V2 ... --jobs N`` (or ``--dask ADDRESS``).

Every ``--set`` with several comma-separated values is an axis of the study; the runs are the
product of the axes, each a separate ``fsci run`` process in its own folder
``OUT/<key>=<value>_...`` (log in ``OUT/logs``). All combinations are validated first, so bad
input stops the sweep before any run starts (exit 2). A folder whose results.json exists is
not run again, one with a checkpoint is resumed, so an interrupted sweep continues where it
stopped. The processes run locally (``--jobs`` at a time, the cores shared out among them:
each run gets ``cores // jobs`` numba and MKL threads unless ``NUMBA_NUM_THREADS`` or
``MKL_NUM_THREADS`` is set) or as tasks on a Dask distributed cluster (the workers need fsci
installed and the output folder on a shared file system).

The summary ``OUT/summary.csv`` and ``OUT/summary.md`` has one row per run: the swept values,
the exit status, the reference checks, the wall time and every scalar result.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fsci.errors import InputError


@dataclass(frozen=True)
class Run:
    """One run of a sweep: its folder name, the swept values and all its overrides."""

    name: str
    values: tuple[tuple[str, str], ...]
    overrides: tuple[str, ...]


def split_values(text: str) -> list[str]:
    """Split ``V1,V2,...`` at commas outside brackets, braces and quotes."""
    parts, depth, quote, cur = [], 0, "", []
    for ch in text:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append("".join(cur).strip())
            cur = []
            continue
        cur.append(ch)
    parts.append("".join(cur).strip())
    return parts


def _clean(value: str) -> str:
    """A value as part of a folder name: anything but letters, digits, ``.+-`` becomes ``-``."""
    return re.sub(r"-{2,}", "-", re.sub(r"[^A-Za-z0-9.+-]", "-", value)).strip("-") or "_"


def plan(sets: list[str]) -> list[Run]:
    """The runs of a sweep: the product of every multi-valued ``KEY=V1,V2`` (in order)."""
    fixed: list[str] = []
    axes: list[tuple[str, list[str]]] = []
    for s in sets:
        if "=" not in s:
            raise InputError("--set", s, "KEY=VALUE or KEY=V1,V2,...")
        key, text = (x.strip() for x in s.split("=", 1))
        values = split_values(text)
        if len(values) > 1:
            axes.append((key, values))
        else:
            fixed.append(f"{key}={text}")
    runs = []
    for combo in itertools.product(*[[(k, v) for v in vs] for k, vs in axes]):
        name = "_".join(f"{k}={_clean(v)}" for k, v in combo) or "run"
        runs.append(Run(name, tuple(combo), tuple(fixed) + tuple(f"{k}={v}" for k, v in combo)))
    if len({r.name for r in runs}) != len(runs):
        raise InputError("--set", sets, "values that give distinct run folder names")
    return runs


def run_one(case: str, run: Run, folder: str, logs: str, threads: int | None = None) -> dict[str, Any]:
    """Run (or resume, or skip when finished) one run of a sweep in a separate process;
    returns its name, exit status and what it did. Module level, so a Dask worker can run it.
    ``threads``: the run's numba and MKL threads (``NUMBA_NUM_THREADS``, ``MKL_NUM_THREADS``),
    unless the environment sets them already; None leaves both to the run."""
    out = Path(folder)
    if (out / "results.json").is_file():
        return {"run": run.name, "exit": 0, "action": "done before"}
    if (out / "checkpoint.npz").is_file():
        cmd, action = ["resume", str(out)], "resumed"
    else:
        cmd, action = ["run", case, "--out", str(out), "--overwrite"], "run"
        for o in run.overrides:
            cmd += ["--set", o]
    Path(logs).mkdir(parents=True, exist_ok=True)
    with open(Path(logs) / f"{run.name}.log", "w") as log:
        env = dict(os.environ)
        if threads is not None:
            for var in ("NUMBA_NUM_THREADS", "MKL_NUM_THREADS"):
                env.setdefault(var, str(threads))
        code = subprocess.run([sys.executable, "-m", "fsci", *cmd, "--no-check"], stdout=log, stderr=subprocess.STDOUT,
                              stdin=subprocess.DEVNULL, env=env).returncode
    return {"run": run.name, "exit": code, "action": action}


def _validate(case: str, runs: list[Run]) -> str:
    """Check every combination before anything runs; returns the case name."""
    from fsci.cli import case_dict
    from fsci.config import apply_override, problem_from_dict

    name = ""
    for r in runs:
        d, base = case_dict(case)
        for o in r.overrides:
            apply_override(d, o)
        name = problem_from_dict(d, base).name
    return name


def summary(runs: list[Run], status: list[dict[str, Any]], out: Path) -> list[dict[str, Any]]:
    """One row per run: swept values, exit status, checks, wall time, scalar results."""
    rows = []
    for r, st in zip(runs, status):
        row: dict[str, Any] = {"run": r.name, **dict(r.values), "exit": st["exit"], "action": st["action"]}
        p = out / r.name / "results.json"
        if p.is_file():
            res = json.loads(p.read_text())
            checks = res.get("reference_checks", [])
            row["checks"] = ("ok" if all(c["pass"] for c in checks) else "FAIL") if checks else ""
            if checks and res.get("verification", {}).get("verified") is False:
                row["checks"] = "unverified"  # off the case's verified setting the checks do not apply
            row["wall_time"] = round(res["run"]["wall_time"], 1)
            row.update({k: v for k, v in res.items() if isinstance(v, (int, float)) and not isinstance(v, bool)})
        rows.append(row)
    return rows


def write_summary(rows: list[dict[str, Any]], out: Path) -> str:
    """Write summary.csv and summary.md; returns the Markdown table."""
    from fsci.io.atomic import write_text

    keys: list[str] = []
    for row in rows:
        keys += [k for k in row if k not in keys]

    def cell(v: Any) -> str:
        return f"{v:.6g}" if isinstance(v, float) else ("" if v is None else str(v))

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(keys)
    for row in rows:
        w.writerow([cell(row.get(k)) for k in keys])
    write_text(out / "summary.csv", buf.getvalue())
    md = "| " + " | ".join(keys) + " |\n|" + "---|" * len(keys) + "\n"
    md += "".join("| " + " | ".join(cell(row.get(k)) for k in keys) + " |\n" for row in rows)
    write_text(out / "summary.md", md)
    return md


def run_sweep(case: str, sets: list[str], out: Path | None, jobs: int = 1, dask: str | None = None,
              check: bool = True) -> int:
    """Plan, validate, run and summarise a sweep; the exit status of ``fsci sweep``: 0 all runs
    done, 1 a reference check failed, 3 a run failed."""
    if jobs < 1:
        raise InputError("--jobs", jobs, "an integer ≥ 1")
    runs = plan(sets)
    name = _validate(case, runs)
    from fsci.cli import safe_name

    out = out if out is not None else Path("results") / f"{safe_name(name)}-sweep"
    if out.exists() and not out.is_dir():
        raise InputError("--out", str(out), "a folder (a file of that name exists)")
    spec = str(Path(case).resolve()) if Path(case).suffix == ".toml" else case
    out.mkdir(parents=True, exist_ok=True)
    args = [(spec, r, str(out / r.name), str(out / "logs")) for r in runs]
    print(f"fsci sweep: {len(runs)} runs of '{name}' in {out} "
          + (f"on the Dask cluster {dask}" if dask else f"({jobs} at a time)"), flush=True)
    if dask:
        from dask.distributed import Client

        with Client(dask) as client:
            status = client.gather(client.map(run_one, *map(list, zip(*args)), pure=False))
    else:
        # the cores shared out: two fine-stamp runs side by side on 2 cores took 0.91x the wall
        # time with one thread each than with two each (docs/performance.md)
        threads = max(1, (os.cpu_count() or 1) // min(jobs, len(runs))) if jobs > 1 else None
        with ThreadPoolExecutor(max_workers=jobs) as pool:  # threads wait on the run processes
            status = list(pool.map(lambda a: run_one(*a, threads), args))
    rows = summary(runs, status, out)
    print(write_summary(rows, out), end="")
    if any(s["exit"] not in (0,) for s in status):
        return 3
    return 1 if check and any(r.get("checks") == "FAIL" for r in rows) else 0
