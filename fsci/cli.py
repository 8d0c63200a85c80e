"""Command line: ``fsci list``, ``fsci show CASE`` (``--schema``: the case-file reference),
``fsci run CASE|FILE.toml``, ``fsci resume DIR``, ``fsci sweep CASE --set KEY=V1,V2 ...``.

Exit status: 0 done; 1 a reference check failed at the case's verified setting (everything
written; ``--no-check`` gives 0);
2 bad input — unknown case or key, malformed TOML, invalid values, meshes with inverted cells,
unknown boundary names, an output folder that is not empty — reported as one line
``fsci: error: <field> = <value>: <allowed>`` before anything is written; 3 a solve failed
(results so far written); 4 an output could not be written (disk full, permissions; the files
written before are intact); 128 + signal number after SIGINT/SIGTERM (checkpoint written).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
import warnings
from pathlib import Path
from typing import Any

import tomli_w

from fsci import __version__
from fsci.cases import CASES, get_case
from fsci.config import apply_override, apply_overrides, load_toml, problem_from_dict
from fsci.errors import InputError, MeshError, SolverError

EXIT_CHECK, EXIT_INPUT, EXIT_SOLVER, EXIT_WRITE = 1, 2, 3, 4


def case_dict(spec: str) -> tuple[dict[str, Any], Path | None]:
    """A built-in case or a case file → (case dictionary, folder of the file)."""
    if spec in CASES:
        return get_case(spec), None
    p = Path(spec)
    if p.suffix == ".toml" or p.exists():
        return load_toml(p), p.resolve().parent
    from fsci.schema import suggest

    raise InputError("case", spec, "a built-in case (" + ", ".join(CASES) + ") or a .toml file" + suggest(spec, list(CASES)))


def safe_name(name: str) -> str:
    """A folder name from a case name: only letters, digits, ``.``, ``_``, ``-`` (so that
    ``results/<name>`` cannot leave ``results``)."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "case"


def cmd_list(args) -> int:
    """One line per built-in case: name, wall time of its default run (2 cores), description."""
    width = max(len(n) for n in CASES)
    time_width = max(len(c.wall_time) for c in CASES.values())
    for name, case in CASES.items():
        print(f"{name:<{width}}  {case.wall_time:>{time_width}}  {case.description}")
    return 0


def cmd_show(args) -> int:
    if args.schema:
        from fsci.schema import markdown

        sys.stdout.write(markdown())
        return 0
    if args.case is None:
        raise InputError("show", None, "a case name or file (or --schema)")
    case, base = case_dict(args.case)
    for s in args.set or []:
        apply_override(case, s)
    problem_from_dict(case, base)  # validate
    sys.stdout.write(tomli_w.dumps(case))
    return 0


def prepare_out(out: Path, overwrite: bool) -> None:
    """Check the output folder before a run (an input error if it is a file, or a non-empty
    folder without ``overwrite``); nothing is changed here."""
    if out.exists() and not out.is_dir():
        raise InputError("--out", str(out), "a folder (a file of that name exists)")
    if out.is_dir() and any(out.iterdir()) and not overwrite:
        n = sum(1 for _ in out.iterdir())
        raise InputError("--out", str(out), f"an empty or new folder (it holds {n} entries; --overwrite clears it, "
                         "fsci resume DIR continues a run)")


def cmd_run(args) -> int:
    from fsci.io.atomic import write_text
    from fsci.monitor import Monitor, Notice
    from fsci.simulation import Simulation

    case, base = case_dict(args.case)
    settings = apply_overrides(case, args.set or [])
    problem = problem_from_dict(case, base)
    if problem.verification is not None:
        problem.verification.add_overrides(settings)
    out = Path(args.out) if args.out else Path("results") / safe_name(problem.name)
    prepare_out(out, args.overwrite)
    monitor = Monitor()
    notice = Notice("fsci: preparing (first use: compiling numerical kernels, cached for later runs)", monitor.message)
    try:
        sim = Simulation(problem, out, monitor, base_dir=base)  # the last input checks (quantities, geometry)
    finally:
        notice.cancel()
    if out.is_dir() and args.overwrite:
        for p in out.iterdir():
            shutil.rmtree(p) if p.is_dir() and not p.is_symlink() else p.unlink()
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "case.toml", tomli_w.dumps(case))
    return run_and_report(sim, out, check=not args.no_check)


def cmd_resume(args) -> int:
    from fsci.monitor import Monitor
    from fsci.simulation import Simulation

    out = Path(args.dir)
    if not (out / "case.toml").is_file():
        raise InputError("resume", str(out), "a run directory with case.toml and checkpoint.npz")
    for stale in out.glob(".*.tmp*"):  # temporary files of writes a kill interrupted
        stale.unlink(missing_ok=True)
    return run_and_report(Simulation.resume(out, args.set, Monitor(), first_dt=args.dt), out, check=not args.no_check)


def cmd_sweep(args) -> int:
    from fsci.sweep import run_sweep

    return run_sweep(args.case, args.set or [], Path(args.out) if args.out else None, jobs=args.jobs,
                     dask=args.dask, check=not args.no_check)


def run_and_report(sim, out: Path, check: bool = True) -> int:
    """Run to the end and report; a failed solve keeps everything computed so far."""
    try:
        res = sim.run()
    except SolverError as exc:
        print(f"fsci: solver failed: {exc}. Results up to t = {sim.t:.6g} are in {out}", file=sys.stderr)
        return EXIT_SOLVER
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", 2)
        print(f"fsci: interrupted at t = {sim.t:.6g}; checkpoint and results so far are in {out} "
              f"(continue with: fsci resume {out})", file=sys.stderr)
        return 128 + signum
    note = _record_verification(sim.problem, res, out)
    _report(res, out, note)
    failed = [c["name"] for c in res.get("reference_checks", []) if not c["pass"]]
    if failed and check and note is None:  # off the verified setting the note says the checks do not apply
        print(f"fsci: reference check failed: {', '.join(failed)} (all outputs are in {out}; --no-check to "
              "ignore)", file=sys.stderr)
        return EXIT_CHECK
    return 0


def _record_verification(problem, res: dict[str, Any], out: Path) -> str | None:
    """Add ``verification`` (verified_at, differing parameters, note) to results.json when the
    case declares ``verified_at``; returns the note for an unverified setting."""
    from fsci.io.atomic import write_text

    v = problem.verification
    if v is None:
        return None
    note = v.note()
    res["verification"] = {"verified_at": v.verified_at, "differs": v.differs, "verified": note is None,
                           "note": note}
    write_text(out / "results.json", json.dumps(res, indent=2) + "\n")
    return note


def _report(res: dict[str, Any], out: Path, note: str | None = None) -> None:
    scalars = {k: v for k, v in res.items() if isinstance(v, (int, float))}
    for k, v in scalars.items():
        print(f"  {k} = {v:.6g}")
    if note is not None:
        print(f"  {note}")
    for c in res.get("reference_checks", []):
        # away from the verified setting a reference need not apply (a value for another Re)
        status = "ok" if c["pass"] else ("FAIL" if note is None else "differs (not the verified setting)")
        err = "n/a" if c["rel_error"] is None else f"{100 * c['rel_error']:.3f} %"
        print(f"  reference {c['name']}: {c['value']} vs {c['reference']} ({err}, tolerance "
              f"{100 * c['rtol']:.2g} %) {status}")
    run = res["run"]
    print(f"  {run['steps']} steps, {run['newton_iterations']} Newton iterations, "
          f"{run['wall_time']:.1f} s, linear solver {run['linear_solver']}; results in {out}")


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    from fsci.errors import FsciWarning

    if issubclass(category, FsciWarning):
        print(f"fsci: warning: {message}", file=sys.stderr)
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line), file=sys.stderr, end="")


def parser() -> argparse.ArgumentParser:
    """The command-line parser."""
    ap = argparse.ArgumentParser(prog="fsci", description="Monolithic fluid-structure-contact interaction in 2D")
    ap.add_argument("--version", action="version", version=f"fsci {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)
    p = sub.add_parser("list", help="list the built-in cases")
    p.set_defaults(func=cmd_list)
    p = sub.add_parser("show", help="print a case as TOML, or the case-file reference (--schema)")
    p.add_argument("case", nargs="?", help="built-in case name or path to a .toml case file")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a key")
    p.add_argument("--schema", action="store_true", help="print the case-file reference (Markdown)")
    p.set_defaults(func=cmd_show)
    for name, func, text in (("run", cmd_run, "run a built-in case or a case file"),
                             ("sweep", cmd_sweep, "run the product of --set values as separate runs")):
        p = sub.add_parser(name, help=text)
        p.add_argument("case", help="built-in case name or path to a .toml case file")
        p.add_argument("--set", action="append", metavar="KEY=VALUE",
                       help="override a key (repeatable)" + ("; KEY=V1,V2,... sweeps the values" if name == "sweep" else ""))
        p.add_argument("--out", metavar="DIR", help="output folder (default results/<case>"
                       + ("-sweep)" if name == "sweep" else ")"))
        p.add_argument("--no-check", action="store_true", help="exit 0 even if a reference check fails")
        p.set_defaults(func=func)
        if name == "run":
            p.add_argument("--overwrite", action="store_true", help="clear a non-empty output folder first")
        else:
            p.add_argument("--jobs", type=int, default=1, metavar="N", help="runs in parallel (local processes)")
            p.add_argument("--dask", metavar="ADDRESS", help="run on a Dask cluster (scheduler address tcp://...)")
    p = sub.add_parser("resume", help="continue a run from the checkpoint in its output directory")
    p.add_argument("dir")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a key, e.g. time.t_end")
    p.add_argument("--dt", type=float, metavar="DT",
                   help="size of the next step (at most the scheduled one; it grows back as after a step cut), "
                        "e.g. for a run that stopped where every smaller step failed")
    p.add_argument("--no-check", action="store_true", help="exit 0 even if a reference check fails")
    p.set_defaults(func=cmd_resume)
    return ap


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        try:
            return args.func(args)
        except (InputError, MeshError) as exc:
            print(f"fsci: error: {exc}", file=sys.stderr)
            return EXIT_INPUT
        except OSError as exc:
            where = f" {exc.filename}" if exc.filename else ""
            print(f"fsci: error: cannot write{where}: {exc.strerror or exc}", file=sys.stderr)
            return EXIT_WRITE
        except KeyboardInterrupt:
            print("fsci: interrupted", file=sys.stderr)
            return 130


if __name__ == "__main__":
    raise SystemExit(main())
