"""Dry static study of the pump's structure (built-in case ``pump``): how far the Γ^P load
pushes the chamber wall, without fluid, for a choice of the reconstruction's dimensions.

    python benchmarks/pump_design.py                                  # the case as built in
    python benchmarks/pump_design.py --set T_WALL=0.015 R_P=0.25 Y_OUT=0.65 --loads 40 50 60

The two bodies of the case (their outer edges clamped, gravity on) with the pressure of Γ^P
raised statically to each load (the peak of 20 A (1 - cos 40πt) is 40 A); no fluid, so the
chamber pressure that resists the wall in a run is absent: the deflection is an upper bound
of the one in a run (reached there only if the chamber empties quasi-statically). Prints the
vertical displacement of the upper chamber wall at mid-chamber, the gap left there (2 H at
rest) and whether the chamber walls touch (contact points on the lower body).
"""

from __future__ import annotations

import argparse
import time

import fsci.cases.pump as pump
from fsci.config import problem_from_dict
from fsci.simulation import Simulation


def dry_case(load: float, steps: int) -> dict:
    """The pump's structure as a dry contact case, the Γ^P pressure ramped to ``load``."""
    bodies = pump.pump()["bodies"]  # upper, lower
    for body in bodies:
        for key in ("extends_outside", "interface", "slip_length"):  # fluid-side keys
            body.pop(key)
    bodies[0]["neumann"] = [{"boundary": "load", "type": "pressure", "value": f"{load}*t"}]
    cx = 0.5 * (pump.CH0 + pump.CH1)
    return {"name": "pump-dry", "kind": "contact", "bodies": bodies,
            "contact": {"gamma0": 1.0, "weighting": "harmonic"},
            "time": {"type": "static", "t_end": 1.0, "dt": 1.0 / steps},
            "solver": {"tol_residual": 1e-9, "tol_increment": 1e-10, "max_iterations": 40},
            "quantities": [
                {"name": "wall_upper", "type": "point_displacement", "body": "upper", "point": [cx, pump.H],
                 "component": 1},
                {"name": "wall_lower", "type": "point_displacement", "body": "lower", "point": [cx, -pump.H],
                 "component": 1}],
            "output": {"every": 0}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--loads", type=float, nargs="+", default=[40.0, 60.0],
                    help="peak pressures on Γ^P (40 A; default: A = 1 and 1.5)")
    ap.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE",
                    help="dimensions of fsci/cases/pump.py to change (T_WALL, R_P, H, Y_OUT, ...)")
    ap.add_argument("--steps", type=int, default=10, help="load steps")
    args = ap.parse_args()
    for item in args.set:
        name, value = item.split("=")
        if not hasattr(pump, name):
            raise SystemExit(f"--set {item}: fsci/cases/pump.py has no dimension {name!r}")
        setattr(pump, name, float(value))
    print(f"{'load':>6} {'wall u_y':>10} {'gap':>8} {'touch':>6} {'wall time':>10}")
    for load in args.loads:
        sim = Simulation(problem_from_dict(dry_case(load, args.steps)))
        t0 = time.perf_counter()
        sim.run()
        last = sim.history[-1]
        gap = 2 * pump.H + last["wall_upper"] - last["wall_lower"]
        touch = last["case_II"] + last["case_III"] > 0
        print(f"{load:6.1f} {last['wall_upper']:10.4f} {gap:8.4f} {str(touch):>6} {time.perf_counter() - t0:9.1f}s")


if __name__ == "__main__":
    main()
