"""Figures and numbers of the fluid-structure-contact checks in docs/validation.md.

    python benchmarks/fsci_figures.py              # all (about 3 minutes on 2 cores)
    python benchmarks/fsci_figures.py sweep        # contact-sweep, 40 and 80 steps per push
    python benchmarks/fsci_figures.py liftoff      # lift-off with and without the extension
    python benchmarks/fsci_figures.py film         # blocks-film

Figures go to docs/figures/ (``--out`` to change).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fsci.cases import get_case  # noqa: E402
from fsci.config import apply_override, problem_from_dict  # noqa: E402
from fsci.simulation import Simulation  # noqa: E402


def run(case_name: str, overrides: list[str]) -> Simulation:
    case = get_case(case_name)
    for o in overrides:
        apply_override(case, o)
    case["output"] = {"every": 0, "figures": False, "fields": False}
    sim = Simulation(problem_from_dict(case))
    sim.first_residuals = []
    sim.step_hooks.append(lambda s, ctx, rep: s.first_residuals.append(rep.residuals[0]))
    sim.run()
    return sim


def column(sim: Simulation, key: str) -> np.ndarray:
    return np.array([h.get(key, np.nan) for h in sim.history])


def sweep(out: Path) -> None:
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for n in (40, 80):
        sim = run("contact-sweep", [f"n={n}"])
        t = column(sim, "time")
        f = column(sim, "block_force_fsi_y") + column(sim, "block_force_contact_y")
        fc = column(sim, "block_force_contact_y")
        load = np.where(t <= 1.0, t, 2.0 - t)
        keep = t >= 0.6 - 1e-12
        jumps = np.abs(np.diff(f[keep]))
        print(f"n = {n}: largest force jump {jumps.max():.4g}, largest first residual "
              f"{max(sim.first_residuals[1:]):.4g}, steps {sim.step}, Newton {sim.newton_total}")
        ax[0].plot(load[keep], f[keep], "o-" if n == 40 else ".-", ms=3, label=f"total, 1/{n} steps")
        if n == 80:
            ax[0].plot(load[keep], fc[keep], "--", label="contact part (II-IV)")
        ax[1].semilogy(t[keep][1:], jumps, ".-", label=f"|ΔF| per step, 1/{n}")
    ax[0].set_xlabel("push / full push (pressing and lifting)")
    ax[0].set_ylabel("vertical interface force on the block")
    ax[0].legend()
    ax[1].set_xlabel("pseudo-time (push up to 1, back after)")
    ax[1].legend()
    fig.tight_layout()
    fig.savefig(out / "fsci_sweep.png", dpi=120)


def liftoff(out: Path) -> None:
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for ext in (True, False):
        sim = run("lift-off", [f"fluid.interface.extension={str(ext).lower()}",
                               "time.segments=[{until=0.9, dt=0.05}, {until=1.1, dt=0.002}]"])
        t = column(sim, "time")
        res = sim.results()
        label = "extension" if ext else "no extension"
        print(f"{label}: lift-off pressure {res.get('liftoff_pressure')} (predicted {res['liftoff_pressure_predicted']}),"
              f" max Φ1 error {res['mass_err1_max']:.2e}")
        ax[0].plot(t, column(sim, "block_length_contact"), label=label)
        ax[1].plot(t, column(sim, "block_force_contact_y"), label=f"contact part, {label}")
        ax[1].plot(t, column(sim, "block_force_fsi_y"), "--", label=f"FSI part, {label}")
    for a in ax:
        a.axvline(1.0, color="k", lw=0.6)
        a.set_xlabel("ambient pressure p = t (load q = 1)")
        a.legend(fontsize=8)
    ax[0].set_ylabel("contact length (C ≤ 0) under the block")
    ax[1].set_ylabel("vertical interface force on the block")
    fig.tight_layout()
    fig.savefig(out / "fsci_liftoff.png", dpi=120)


def film(out: Path) -> None:
    sim = run("blocks-film", [])
    t = column(sim, "time")
    res = sim.results()
    print(f"blocks-film: first contact {res['first_contact_time']}, fluid pieces at the end {res['pieces']:.0f}, "
          f"max Φ1 error {res['mass_err1_max']:.2e}, steps {sim.step}, Newton {sim.newton_total}")
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for c in ("I", "II", "III", "IV"):
        ax[0].plot(t, column(sim, f"case_{c}"), label=f"case {c}")
    ax[0].plot(t, 100 * column(sim, "pieces"), "k:", label="fluid pieces × 100")
    ax[0].set_xlabel("t")
    ax[0].set_ylabel("interface points")
    ax[0].legend(fontsize=8)
    ax[1].semilogy(t, column(sim, "mass_err1"), label="Φ¹ error")
    ax[1].semilogy(t, column(sim, "mass_err2"), label="Φ² error")
    ax[1].set_xlabel("t")
    ax[1].legend()
    fig.tight_layout()
    fig.savefig(out / "fsci_blocks_film.png", dpi=120)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("which", nargs="*", help="sweep, liftoff and/or film (default: all)")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "figures")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    studies = {"sweep": sweep, "liftoff": liftoff, "film": film}
    unknown = [w for w in args.which if w not in studies]
    if unknown:
        ap.error(f"unknown study {unknown[0]!r}: choose from {', '.join(studies)}")
    for w in args.which or list(studies):
        studies[w](args.out)


if __name__ == "__main__":
    main()
