"""Time accuracy studies for docs/validation.md ("Time accuracy").

* ``moving``: temporal order of the fluid velocity around a rigid block moved smoothly inside
  one cell (tests/test_time.py), θ = 0.5 and 1, Δt = 0.05 … 0.00625 against Δt/32;
* ``contact``: the same for two blocks pressed together in dynamics, contact closed in every
  step (displacements and contact force);
* ``dfg``: DFG 2D-2 (Re = 100): c_D max, c_L max and St = f D / Ū of the lift over the last
  period against Schäfer & Turek (1996), for the settings given by ``--set`` (default: the
  case's defaults), e.g. ``--set n=20 --set dt=0.01 --set time.theta=0.6``.

Usage:  python benchmarks/time_accuracy.py [moving] [contact] [dfg [--set KEY=VALUE ...]]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_time import (cut_signature, fluid_nodes_off_the_block, moving_block_case,  # noqa: E402
                       pressed_blocks_case, rates_of, temporal_errors)

from fsci.cases import get_case  # noqa: E402
from fsci.config import apply_override, problem_from_dict  # noqa: E402
from fsci.simulation import Simulation  # noqa: E402

DTS = (0.05, 0.025, 0.0125, 0.00625)
# Schäfer & Turek (1996), 2D-2: midpoints of the published intervals
DFG_2D_2 = {"cd_max": 3.23, "cl_max": 1.00, "st": 0.300}


def _table(title: str, errors: dict[str, np.ndarray]) -> None:
    print(f"\n{title}\n")
    names = list(errors)
    print("| Δt | " + " | ".join(f"{n} error | rate" for n in names) + " |")
    print("|---|" + "---|---|" * len(names))
    for i, dt in enumerate(DTS):
        cells = []
        for n in names:
            e = errors[n]
            cells += [f"{e[i]:.3e}", "" if i == 0 else f"{rates_of(e)[i - 1]:.2f}"]
        print(f"| {dt:g} | " + " | ".join(cells) + " |", flush=True)


def moving() -> None:
    """Rigid block moved by 0.2 h (sin(πt/2))⁴ in a closed box, n = 16, t ≤ 0.5."""
    for theta in (0.5, 1.0):
        mask: dict[str, np.ndarray] = {}

        def observe(sim: Simulation) -> dict[str, np.ndarray]:
            if "fluid" not in mask:
                mask["fluid"] = fluid_nodes_off_the_block(sim)
            return {"fluid velocity": sim.system.fluid.V[mask["fluid"]]}

        errors, seen = temporal_errors(moving_block_case, theta, DTS, observe, cut_signature, ref_factor=32)
        _table(f"moving block, θ = {theta} (cut topologies seen: {len(seen)})", errors)


def contact() -> None:
    """Two blocks pressed together in dynamics, contact closed throughout, t ≤ 0.5."""
    for theta in (0.5, 1.0):
        def observe(sim: Simulation) -> dict[str, np.ndarray]:
            return {"displacements": np.concatenate([s.U.ravel() for s in sim.system.solids]),
                    "contact force": sim.history[-1]["upper_contact_force_y"]}

        errors, seen = temporal_errors(pressed_blocks_case, theta, DTS, observe,
                                       lambda sim: tuple(sim.history[-1][f"case_{c}"] for c in ("I", "II", "III", "IV")),
                                       ref_factor=32)
        _table(f"pressed blocks, θ = {theta} (case counts seen: {sorted(seen)})", errors)


def dfg(overrides: list[str]) -> None:
    """One DFG 2D-2 run; the values of the last full lift period against the references."""
    case = get_case("dfg-2d-2")
    for o in overrides:
        apply_override(case, o)
    sim = Simulation(problem_from_dict(case))
    res = sim.run()
    p = case["parameters"]
    ubar, diameter = 2.0 * p["Um"] / 3.0, 0.1
    got = {"cd_max": res["cd_osc_max"], "cl_max": res["cl_osc_max"], "st": res["cl_osc_frequency"] * diameter / ubar}
    print(f"\nDFG 2D-2, {' '.join(overrides) or 'defaults'}: {res['run']['unknowns']} unknowns, "
          f"{res['run']['steps']} steps, {res['run']['wall_time']:.0f} s\n")
    print("| quantity | fsci | reference | error |")
    print("|---|---|---|---|")
    for k, ref in DFG_2D_2.items():
        print(f"| {k} | {got[k]:.4f} | {ref} | {got[k] / ref - 1:+.2%} |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("studies", nargs="*", metavar="STUDY", help="any of moving, contact, dfg (default: moving contact)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override for the dfg run")
    args = ap.parse_args()
    chosen = args.studies or ["moving", "contact"]
    unknown = set(chosen) - {"moving", "contact", "dfg"}
    if unknown:
        ap.error("unknown study: " + ", ".join(sorted(unknown)))
    for name in chosen:
        if name == "dfg":
            dfg(args.set)
        else:
            {"moving": moving, "contact": contact}[name]()
