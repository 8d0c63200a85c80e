"""Whole-run benchmarks: wall time, steps, Newton iterations, factorisations and the per-phase
split of the runs in docs/performance.md, compared with the table recorded before the speed
work (same rows, same commands).

    python benchmarks/bench_runs.py                 # all rows (about 10 minutes on 2 cores)
    python benchmarks/bench_runs.py --rows stamp-coarse fsi1
    python benchmarks/bench_runs.py --set fluid.stabilization.scheme=residual   # an option on every row
    python benchmarks/bench_runs.py --help
"""

from __future__ import annotations

import argparse
import resource
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.simulation import Simulation

# name -> (case, overrides, wall time [s] recorded before (docs/performance.md), steps, Newton)
ROWS: dict[str, tuple[str, list[str], float, int, int]] = {
    # q = 0.4: the load of the "before" runs (the falling phase before the calibration to q = 0.5)
    "stamp-coarse": ("stamp", ["q=0.4", "time.segments=[{until=20.0, dt=0.01}, {until=250.0, dt=0.2}]"], 456.0, 3150, 13739),
    "stamp-fine": ("stamp", ["q=0.4", "n=64", "time.segments=[{until=5.0, dt=0.01}]"], 1450.0, 500, 2717),
    "fsi1": ("turek-hron-fsi1", ["m=12", "nx=280", "ny=16"], 97.0, 2, 23),
    # the first fifth of stamp-fine (t <= 1); "before" pro-rated from the t <= 5 run (1450 s / 5)
    "stamp-fine-1": ("stamp", ["q=0.4", "n=64", "time.segments=[{until=1.0, dt=0.01}]"], 290.0, 100, 543),
}


def run_row(name: str, extra: tuple[str, ...] = ()) -> dict[str, float]:
    """Run one row (with the overrides ``extra`` after the row's own) without file output;
    return its figures."""
    case_name, overrides, *_ = ROWS[name]
    case = get_case(case_name)
    for o in [*overrides, *extra]:
        apply_override(case, o)
    case["output"] = {"every": 0, "figures": False, "fields": False}
    sim = Simulation(problem_from_dict(case))
    rss: list[tuple[int, float]] = []  # (step, resident set size [MB]) every 250 steps

    def sample(s, ctx, rep) -> None:
        if s.step % 250 == 0:
            rss.append((s.step, _rss_mb()))

    sim.step_hooks.append(sample)
    t0 = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - t0
    lin = sim.linear
    return {"wall": wall, "steps": sim.step, "newton": sim.newton_total, "unknowns": sim.system.layout.n_dofs,
            "factorizations": lin.counts["factorization"], "analyses": lin.counts["analysis"], "reused": lin.counts.get("reused", 0),
            "krylov": lin.counts.get("krylov", 0), **{k: v for k, v in sim.system.timings.items()},
            **{k: v for k, v in lin.timings.items()},
            "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
            "growth_MB_per_1000": _growth(rss), "rss_samples": rss}


def _rss_mb() -> float:
    """Current resident set size of this process [MB] (Linux /proc; 0 elsewhere)."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * resource.getpagesize() / 2 ** 20
    except OSError:
        return 0.0


def _growth(rss: list[tuple[int, float]]) -> float:
    """RSS growth per 1000 steps: least-squares slope over the samples after the first 1000 steps
    (start-up, compilation and the first pattern/factor sizes excluded); NaN for short runs."""
    pts = [(k, m) for k, m in rss if k >= 1000]
    if len(pts) < 2:
        return float("nan")
    k = np.array([p[0] for p in pts], float)
    m = np.array([p[1] for p in pts])
    return float(np.polyfit(k, m, 1)[0] * 1000.0)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", nargs="+", choices=list(ROWS), default=[r for r in ROWS if r != "stamp-fine-1"],
                    help="rows to run (default: stamp-coarse stamp-fine fsi1; stamp-fine-1 is the first fifth of "
                         "stamp-fine, for a loaded machine)")
    ap.add_argument("--rss", action="store_true", help="also print the RSS samples (every 250 steps) of each row")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override for every row (repeatable), e.g. fluid.stabilization.scheme=residual")
    args = ap.parse_args(argv)
    print("| run | unknowns | steps | Newton (per step) | factorisations (reused) | cut | assembly | analysis "
          "(count) | factor | solve | wall [s] | before [s] | speed-up | peak RSS [MB] | RSS growth [MB/1000 steps] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.rows:
        with ProcessPoolExecutor(max_workers=1) as pool:  # a fresh process per row: its own peak RSS
            r = pool.submit(run_row, name, tuple(args.set)).result()
        before = ROWS[name][2]
        print(f"| {name} | {r['unknowns']} | {r['steps']} | {r['newton']} ({r['newton'] / max(r['steps'], 1):.2f}) "
              f"| {r['factorizations']} ({r['reused']}) | {r['cut']:.1f} | {r['assembly']:.1f} | {r['analysis']:.1f} ({r['analyses']}) "
              f"| {r['factorization']:.1f} | {r['solve']:.1f} | {r['wall']:.0f} | {before:.0f} "
              f"| {before / r['wall']:.2f} | {r['peak_rss_MB']:.0f} | {r['growth_MB_per_1000']:.2f} |", flush=True)
        if args.rss:
            print(f"<!-- {name} RSS samples (step, MB): {r['rss_samples']} -->", flush=True)


if __name__ == "__main__":
    main()
