"""Figures for docs/validation.md: the sinking elastic disk (interface force history with
the number of cut cells) and the stamp's mass-balance errors against h.

Usage:  python benchmarks/fsi_figures.py sink [OUTDIR]
        python benchmarks/fsi_figures.py stamp RUN_DIR [RUN_DIR ...]   (output dirs of `fsci run stamp` runs)
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

DOCS = Path(__file__).resolve().parents[1] / "docs" / "figures"


def sink(out_dir: Path) -> None:
    case = get_case("sinking-disk")
    sim = Simulation(problem_from_dict(case), out_dir)
    cuts = []
    sim.step_hooks.append(lambda s, ctx, rep: cuts.append(len(s.system.cut.cut_cells)))
    sim.run()
    h = sim.history
    t = np.array([r["time"] for r in h])
    fig, ax = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
    ax[0].plot(t, [r["uy_center"] for r in h])
    ax[0].set_ylabel("u_y of the centre")
    ax[1].plot(t, [r["force_y"] for r in h], label="volume form")
    ax[1].plot(t, [r["force_y_traction"] for r in h], "--", label="traction form ∫σ_Γ")
    weight = 2.0 * 10.0 * np.pi * 0.1 ** 2
    ax[1].axhline(weight, color="k", lw=0.8, ls=":", label="weight ρ_s g π r² (terminal value)")
    ax[1].set_ylabel("vertical fluid force")
    ax[1].legend(fontsize=8)
    ax[2].step(t, cuts, where="post")
    ax[2].set_ylabel("cut cells")
    ax[2].set_xlabel("time")
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    DOCS.mkdir(parents=True, exist_ok=True)
    fig.savefig(DOCS / "sinking_disk.png", dpi=120)
    F = np.array([r["force_y"] for r in h])
    print("max |second difference| / max |F| =", np.abs(np.diff(F[2:], 2)).max() / np.abs(F).max())
    print("max err1 =", max(r["mass_err1"] for r in h), " max |phi_S| =", max(abs(r["mass_phi_solid"]) for r in h))


def stamp(dirs: list[Path]) -> None:
    """Histories of stamp runs over their common time range; with several meshes also the
    Φ² rate between consecutive meshes (paper: ≈ h²)."""
    runs = [(d.name, np.genfromtxt(d / "history.csv", delimiter=",", names=True)) for d in dirs]
    t_max = min(r["time"][-1] for _, r in runs)
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.8))
    for label, r in runs:
        m = r["time"] <= t_max + 1e-9
        ax[0].plot(r["time"][m], r["uy_X"][m], label=label)
        ax[1].semilogy(r["time"][m], np.abs(r["flow_top"][m]), label=label)
        ax[2].semilogy(r["time"][m], r["mass_err2"][m], label=f"Φ²_err {label}")
        ax[2].semilogy(r["time"][m], np.maximum(r["mass_err1"][m], 1e-20), ":", label=f"Φ¹_err {label}")
    ax[0].set_ylabel("u_y(X*)")
    ax[1].set_ylabel("|flow rate through Γ^FN|")
    ax[2].set_ylabel("mass-balance errors (45)")
    for a in ax:
        a.set_xlabel("time")
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    DOCS.mkdir(parents=True, exist_ok=True)
    name = "stamp_falling.png" if len(runs) == 1 else "stamp_falling_meshes.png"
    fig.savefig(DOCS / name, dpi=120)
    if len(runs) > 1:
        print("| run | max Φ¹_err | mean Φ²_err on [1, t_end] | rate vs previous | u_y(X*) at t_end | flow at t_end |")
        print("|---|---|---|---|---|---|")
        prev = None
        for label, r in runs:
            m = (r["time"] >= 1.0) & (r["time"] <= t_max + 1e-9)
            e2 = float(np.mean(r["mass_err2"][m]))
            rate = "" if prev is None else f"{np.log(prev / e2) / np.log(2.0):.2f}"
            k = np.nonzero(r["time"] <= t_max + 1e-9)[0][-1]
            print(f"| {label} | {r['mass_err1'][r['time'] <= t_max + 1e-9].max():.1e} | {e2:.3e} | {rate} | "
                  f"{r['uy_X'][k]:.5f} | {r['flow_top'][k]:.4e} |")
            prev = e2


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="figure", required=True)
    p = sub.add_parser("sink", help="run the sinking disk and draw its force history")
    p.add_argument("out", nargs="?", type=Path, default=Path("results/sinking-disk-figure"),
                   help="run directory (default: %(default)s)")
    p = sub.add_parser("stamp", help="mass-balance errors of stamp runs against h")
    p.add_argument("runs", nargs="+", type=Path, help="output directories of stamp runs")
    a = ap.parse_args()
    if a.figure == "sink":
        sink(a.out)
    else:
        stamp(a.runs)
