"""Contact studies for docs/validation.md: Hertz mesh convergence, γ0^S sweep (table and
figure docs/figures/hertz_gamma_sweep.png) and the effect of split integration.

Usage:  python benchmarks/contact_studies.py [hertz] [gamma] [split]   (default: all three)
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


def run(name, *overrides):
    case = get_case(name)
    for o in overrides:
        apply_override(case, o)
    sim = Simulation(problem_from_dict(case))
    res = sim.run()
    return res, sim


def hertz_convergence():
    """P is the applied load (reaction of the prescribed top); the last column but one is the
    global equilibrium error |total contact force / P − 1|."""
    print("| h (contact zone) | unknowns | P | a | a exact | err | p0 | p0 exact | err | equilibrium | Newton |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for h in (0.008, 0.004, 0.002, 0.001):
        r, sim = run("hertz", f"h={h}")
        print(f"| {h} | {sim.system.layout.n_dofs} | {r['hertz_load']:.5f} | {r['half_width']:.5f} | "
              f"{r['half_width_exact']:.5f} | {r['half_width_ratio'] - 1:+.2%} | "
              f"{r['peak_pressure']:.5f} | {r['peak_pressure_exact']:.5f} | {r['peak_pressure_ratio'] - 1:+.2%} | "
              f"{abs(r['load_balance'] - 1):.1e} | {r['run']['newton_iterations']} |", flush=True)


def gamma_sweep():
    print("\n| γ0^S | max penetration | a / a_exact | p0 / p0_exact | Newton |")
    print("|---|---|---|---|---|")
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for g in (0.1, 1.0, 10.0, 100.0):
        r, sim = run("hertz", f"contact.gamma0={g}", "h=0.002")
        prof = sim.system.extra_terms[0].profile("cylinder")
        sel = np.abs(prof[:, 0]) < 0.06
        ax[0].plot(prof[sel, 0], -prof[sel, 3], ".-", ms=3, label=f"γ0 = {g:g}")
        ax[1].plot(prof[sel, 0], prof[sel, 2], ".-", ms=3, label=f"γ0 = {g:g}")
        print(f"| {g:g} | {r['penetration']:.3e} | {r['half_width'] / r['half_width_exact']:.4f} | "
              f"{r['peak_pressure'] / r['peak_pressure_exact']:.4f} | {r['run']['newton_iterations']} |", flush=True)
    a = r["half_width_exact"]
    xs = np.linspace(0, a, 200)
    ax[1].plot(xs, r["peak_pressure_exact"] * np.sqrt(1 - (xs / a) ** 2), "k--", label="Hertz")
    ax[0].set_xlabel("x")
    ax[0].set_ylabel("penetration  -g_n")
    ax[0].set_yscale("symlog", linthresh=1e-8)
    ax[1].set_xlabel("x")
    ax[1].set_ylabel("contact pressure")
    for a_ in ax:
        a_.legend(fontsize=7)
        a_.grid(alpha=0.3)
    fig.tight_layout()
    DOCS.mkdir(parents=True, exist_ok=True)
    fig.savefig(DOCS / "hertz_gamma_sweep.png", dpi=120)


def split_effect():
    print("\n| integration | |F_upper + F_lower| / F_upper | Newton iterations (10 steps) |")
    print("|---|---|---|")
    for label, ov in (("split at projected opposite nodes (default)", ("contact.split=true",)),
                      ("10 fixed midpoint sub-intervals per edge", ("contact.split=false", "contact.n_fixed=10")),
                      ("3 fixed midpoint sub-intervals per edge", ("contact.split=false", "contact.n_fixed=3"))):
        r, _ = run("two-blocks", "time.t_end=1.0", *ov)
        mis = abs(r["upper_contact_force_y"] + r["lower_contact_force_y"]) / r["upper_contact_force_y"]
        print(f"| {label} | {mis:.2%} | {r['run']['newton_iterations']} |", flush=True)


STUDIES = {"hertz": hertz_convergence, "gamma": gamma_sweep, "split": split_effect}

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("studies", nargs="*", metavar="STUDY", help="any of " + ", ".join(STUDIES) + " (default: all)")
    chosen = ap.parse_args().studies or list(STUDIES)
    if set(chosen) - set(STUDIES):
        ap.error("unknown study: " + ", ".join(sorted(set(chosen) - set(STUDIES))))
    for name in chosen:
        STUDIES[name]()
