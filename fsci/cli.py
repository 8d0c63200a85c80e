"""Command line: ``fsci list``, ``fsci show CASE``, ``fsci run CASE|FILE.toml``,
``fsci resume DIR``.

Bad input (unknown case or key, malformed TOML, invalid values, meshes with inverted cells,
unknown boundary names) prints one line ``fsci: error: <field> = <value>: <allowed>`` and exits
with status 2 before anything is written.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import tomli_w

from fsci import __version__
from fsci.cases import CASES, get_case
from fsci.config import apply_override, load_toml, problem_from_dict
from fsci.errors import InputError, MeshError, SolverError


def _case_dict(spec: str) -> tuple[dict[str, Any], Path | None]:
    if spec in CASES:
        return get_case(spec), None
    p = Path(spec)
    if p.suffix == ".toml" or p.exists():
        return load_toml(p), p.resolve().parent
    raise InputError("case", spec, "a built-in case (" + ", ".join(CASES) + ") or a .toml file")


def _to_toml(case: dict[str, Any]) -> str:
    return tomli_w.dumps(case)


def cmd_list(args) -> int:
    """One line per built-in case: name, wall time of its default run (2 cores), description."""
    width = max(len(n) for n in CASES)
    time_width = max(len(c.wall_time) for c in CASES.values())
    for name, case in CASES.items():
        print(f"{name:<{width}}  {case.wall_time:>{time_width}}  {case.description}")
    return 0


def cmd_show(args) -> int:
    case, _ = _case_dict(args.case)
    for s in args.set or []:
        apply_override(case, s)
    problem_from_dict(case)  # validate
    sys.stdout.write(_to_toml(case))
    return 0


def cmd_run(args) -> int:
    from fsci.monitor import Monitor
    from fsci.simulation import Simulation

    case, base = _case_dict(args.case)
    for s in args.set or []:
        apply_override(case, s)
    problem = problem_from_dict(case, base)  # all validation happens before anything is written
    out = Path(args.out) if args.out else Path("results") / problem.name
    out.mkdir(parents=True, exist_ok=True)
    (out / "case.toml").write_text(_to_toml(case))
    return _run_and_report(Simulation(problem, out, Monitor(), base_dir=base), out)


def cmd_resume(args) -> int:
    from fsci.monitor import Monitor
    from fsci.simulation import Simulation

    out = Path(args.dir)
    if not (out / "checkpoint.npz").exists() or not (out / "case.toml").exists():
        raise InputError("resume", str(out), "a run directory with case.toml and checkpoint.npz")
    return _run_and_report(Simulation.resume(out, args.set, Monitor()), out)


def _run_and_report(sim, out: Path) -> int:
    """Run to the end; a failed solve keeps everything computed so far (exit status 3)."""
    try:
        res = sim.run()
    except SolverError as exc:
        print(f"fsci: solver failed: {exc}. Results up to t = {sim.t:.6g} are in {out}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print(f"fsci: interrupted at t = {sim.t:.6g}; checkpoint and results so far are in {out} "
              f"(continue with: fsci resume {out})", file=sys.stderr)
        return 130
    note = _record_verification(sim.problem, res, out)
    _report(res, out, note)
    return 0


def _record_verification(problem, res: dict[str, Any], out: Path) -> str | None:
    """Add ``verification`` (verified_at, differing parameters, note) to results.json when the
    case declares ``verified_at``; returns the note for an unverified setting."""
    v = problem.verification
    if v is None:
        return None
    note = v.note()
    res["verification"] = {"verified_at": v.verified_at, "differs": v.differs, "verified": note is None,
                           "note": note}
    (out / "results.json").write_text(json.dumps(res, indent=2) + "\n")
    return note


def _report(res: dict[str, Any], out: Path, note: str | None = None) -> None:
    scalars = {k: v for k, v in res.items() if isinstance(v, (int, float))}
    for k, v in scalars.items():
        print(f"  {k} = {v:.6g}")
    if note is not None:
        print(f"  {note}")
    for c in res.get("reference_checks", []):
        status = "ok" if c["pass"] else "FAIL"
        err = "n/a" if c["rel_error"] is None else f"{100 * c['rel_error']:.3f} %"
        print(f"  reference {c['name']}: {c['value']} vs {c['reference']} ({err}, tolerance "
              f"{100 * c['rtol']:.2g} %) {status}")
    run = res["run"]
    print(f"  {run['steps']} steps, {run['newton_iterations']} Newton iterations, "
          f"{run['wall_time']:.1f} s, linear solver {run['linear_solver']}; results in {out}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fsci", description="Monolithic fluid-structure-contact interaction in 2D")
    parser.add_argument("--version", action="version", version=f"fsci {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("list", help="list the built-in cases")
    p.set_defaults(func=cmd_list)
    p = sub.add_parser("show", help="print a case as TOML")
    p.add_argument("case")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a key")
    p.set_defaults(func=cmd_show)
    p = sub.add_parser("run", help="run a built-in case or a case file")
    p.add_argument("case", help="built-in case name or path to a .toml case file")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a key (repeatable)")
    p.add_argument("--out", metavar="DIR", help="output directory (default results/<case>)")
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("resume", help="continue a run from the checkpoint in its output directory")
    p.add_argument("dir")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a key, e.g. time.t_end")
    p.set_defaults(func=cmd_resume)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (InputError, MeshError) as exc:
        print(f"fsci: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
