"""Per-iteration cost of the coarse stamp (≈ 2.2k unknowns): the time-step loop is run to
``--warm`` steps (falling phase, Δt = 0.01), then ``--steps`` further steps are timed, split into
cut (``CutState``), assembly (all terms), and the linear solver's phases, and profiled with
cProfile (top ``--top`` entries by internal time and by cumulative time).

    python benchmarks/bench_step.py                       # 30 warm-up steps, 20 profiled
    python benchmarks/bench_step.py --steps 5 --top 15 --no-profile
    python benchmarks/bench_step.py --case turek-hron-fsi1 --set m=12 --warm 0 --steps 1
    NUMBA_NUM_THREADS=1 python benchmarks/bench_step.py --cpu --no-profile --split --steps 60

Printed per Newton iteration (means over the timed steps): cut, assembly, factorisation,
solve, and the rest ("other": Newton bookkeeping, quantities, step start), in milliseconds;
then the residual history of the last timed step. ``--split``: also the parts of the cut and
of the assembly, each timed by wrapping its function.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import time

from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.simulation import Simulation


def build(case_name: str, overrides: list[str]) -> Simulation:
    case = get_case(case_name)
    for o in overrides:
        apply_override(case, o)
    case["output"] = {"every": 0, "figures": False, "fields": False}
    return Simulation(problem_from_dict(case))


# the parts of the cut and of the assembly that --split times: (module, owner, function, label)
SPLIT = [("fsci.cut.state", "CutState", "_build_region", "cut: fluid region"),
         ("fsci.cut.state", "CutState", "_classify_cells", "cut: cell classes"),
         ("fsci.cut.state", "CutState", "_build_quadrature", "cut: cut-cell quadrature"),
         ("fsci.cut.state", "CutState", "_build_segments", "cut: boundary segments"),
         ("fsci.cut.state", "CutState", "_build_active", "cut: ACTIVE set"),
         ("fsci.system", "System", "outlines", "cut: outlines"),
         ("fsci.coupling.term", None, "build_pieces", "assembly: coupling pieces"),
         ("fsci.coupling.term", "CouplingTerm", "_gather_static", "assembly: their step data"),
         ("fsci.coupling.traction", None, "assemble_pieces", "assembly: coupling kernel"),
         ("fsci.fields", "FluidField", "assemble", "assembly: fluid"),
         ("fsci.fields", "SolidField", "assemble", "assembly: solid")]


def time_parts(clock) -> tuple[dict[str, float], dict[str, int]]:
    """Wrap the functions of :data:`SPLIT` to add their time (``clock``) and calls to the
    returned dictionaries."""
    import importlib

    spent: dict[str, float] = {label: 0.0 for *_, label in SPLIT}
    calls: dict[str, int] = {label: 0 for *_, label in SPLIT}
    for module, owner, name, label in SPLIT:
        obj = importlib.import_module(module)
        obj = getattr(obj, owner) if owner else obj
        func = getattr(obj, name)

        def timed(*a, _f=func, _label=label, **k):
            t0 = clock()
            try:
                return _f(*a, **k)
            finally:
                spent[_label] += clock() - t0
                calls[_label] += 1

        setattr(obj, name, timed)
    return spent, calls


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", default="stamp")
    ap.add_argument("--set", dest="overrides", action="append", default=None,
                    help="override (repeatable); default for the stamp: the falling phase at Δt = 0.01")
    ap.add_argument("--warm", type=int, default=30, help="steps run before timing (also compiles the kernels)")
    ap.add_argument("--steps", type=int, default=20, help="timed steps")
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--no-profile", action="store_true", help="time only (no cProfile overhead)")
    ap.add_argument("--split", action="store_true", help="also time the parts of the cut and the assembly")
    ap.add_argument("--cpu", action="store_true",
                    help="CPU time of this process instead of wall time (phases and profile; steadier on a shared "
                         "machine; PARDISO runs one thread below 20k unknowns, so both agree on an idle machine)")
    args = ap.parse_args(argv)
    overrides = args.overrides
    clock = time.process_time if args.cpu else time.perf_counter
    if args.cpu:  # the phase timers of the system and the linear solver read this clock too
        import types

        import fsci.solver.linear
        import fsci.system

        shim = types.SimpleNamespace(perf_counter=time.process_time)
        fsci.system.time = shim
        fsci.solver.linear.time = shim
    if overrides is None:
        overrides = ["time.segments=[{until=20.0, dt=0.01}]"] if args.case == "stamp" else []
    sim = build(args.case, overrides)
    residuals: list[list[float]] = []
    sim.step_hooks.append(lambda s, ctx, rep: residuals.append(rep.residuals))
    for _ in range(args.warm):
        sim.advance()
    parts = time_parts(clock) if args.split else None
    sys_t0 = dict(sim.system.timings)
    lin_t0 = dict(sim.linear.timings)
    cnt0 = dict(sim.linear.counts)
    asm0 = dict(sim.system.counts)
    it0 = sim.newton_total
    prof = None if args.no_profile else cProfile.Profile(clock)
    t0 = clock()
    if prof is not None:
        prof.enable()
    for _ in range(args.steps):
        sim.advance()
    if prof is not None:
        prof.disable()
    wall = clock() - t0
    its = sim.newton_total - it0
    n_asm = sim.system.counts["assembly"] - asm0["assembly"]
    n_res = sim.system.counts["residual_only"] - asm0["residual_only"]
    d = {k: sim.system.timings[k] - sys_t0[k] for k in sys_t0}
    d.update({k: sim.linear.timings[k] - lin_t0[k] for k in lin_t0})
    fac = sim.linear.counts["factorization"] - cnt0["factorization"]
    other = wall - sum(d.values())
    print(f"{args.case} {' '.join(overrides)}: {sim.system.layout.n_dofs} unknowns, {args.steps} steps, "
          f"{its} Newton iterations ({its / args.steps:.2f}/step), {fac} factorisations, "
          f"{n_asm} assemblies with matrix + {n_res} without, "
          f"{'CPU' if args.cpu else 'wall'} {wall:.3f} s{' (under cProfile)' if prof else ''}")
    print("per Newton iteration [ms]: " + ", ".join(f"{k} {1e3 * v / max(its, 1):.2f}" for k, v in d.items())
          + f", other {1e3 * other / max(its, 1):.2f}, total {1e3 * wall / max(its, 1):.2f}")
    if fac:
        print(f"one factorisation: {1e3 * d['factorization'] / fac:.2f} ms")
    if parts is not None:
        spent, calls = parts
        for label in spent:
            print(f"  {label:30s} {1e3 * spent[label] / max(its, 1):6.2f} ms per iteration ({calls[label]} calls)")
    print("last step residuals: " + ", ".join(f"{r:.2e}" for r in residuals[-1]))
    if prof is not None:
        for key in ("tottime", "cumulative"):
            s = io.StringIO()
            pstats.Stats(prof, stream=s).strip_dirs().sort_stats(key).print_stats(args.top)
            text = s.getvalue()
            print(f"\n--- top {args.top} by {key} ---")
            print(text[text.index("   ncalls"):].rstrip())


if __name__ == "__main__":
    main()
