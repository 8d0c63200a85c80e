"""The stamp study of the paper's Sec. 4.1 (built-in case ``stamp``): the five variants, the
mesh series h = 1/8 … 1/64 and the penalty sweep γ0^S, their event times, the paper's
qualitative statements checked one by one, and the figures of docs/cases/stamp.md.

    python benchmarks/stamp_study.py run [--jobs 2] [--dir results/stamp-study] [--only coarse|fine|gamma]
    python benchmarks/stamp_study.py report [--dir results/stamp-study]
    python benchmarks/stamp_study.py snapshots
    python benchmarks/stamp_study.py --help

``run`` starts every missing run (a run whose results.json exists is not redone; an
interrupted one continues from its checkpoint with ``fsci resume``); ``report`` reads the
histories and writes the tables (printed, Markdown) and figures (docs/figures/stamp_*.png);
``snapshots`` reruns the coarse navslip case with large steps (0.5 / 2 / 20, the CI test's;
events one step late at most) and draws the fields with the interface tractions just after
first contact and just before release, and the gap and contact traction along the stamp at
times around both events.
Event times come from the contact length (length of the stamp's interface with C ≤ 0):
first contact when it becomes positive, release when it returns to zero.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PAPER = {"coarse": (268.2, 2166.0), "fine": (616.0, 2290.0)}  # first contact, release (navslip)
VARIANTS = ["navslip", "noslip", "slip", "noslip-incpen", "navslip-incpen"]
MESHES = [8, 16, 32, 64]
GAMMAS = [0.01, 0.1, 1.0, 10.0, 100.0]


def runs(only: str | None = None) -> dict[str, list[str]]:
    """Run name -> ``fsci run stamp`` overrides."""
    out: dict[str, list[str]] = {}
    if only in (None, "coarse"):
        for v in VARIANTS:
            out[f"{v}-n16"] = [f"variant={v}"]
    if only in (None, "fine"):
        for n in MESHES:
            if n != 16:
                out[f"navslip-n{n}"] = ["variant=navslip", f"n={n}"]
    if only in (None, "gamma"):
        for g in GAMMAS:
            if g != 1.0:
                out[f"navslip-n16-gamma{g:g}"] = ["variant=navslip", f"gamma0S={g}"]
    return out


def start(name: str, overrides: list[str], base: Path) -> tuple[str, int]:
    d = base / name
    if (d / "results.json").exists():
        return name, 0
    log = open(base / f"{name}.log", "a")
    if (d / "checkpoint.json").exists():
        cmd = ["fsci", "resume", str(d)]
    else:
        cmd = ["fsci", "run", "stamp", *sum((["--set", o] for o in overrides), []), "--set", "output.every=100",
               "--set", "output.checkpoint_every=200", "--out", str(d)]
    return name, subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT)


def history(d: Path) -> dict[str, np.ndarray]:
    """history.csv of a run (also of a run still in progress: from its checkpoint)."""
    if (d / "history.csv").exists():
        r = np.genfromtxt(d / "history.csv", delimiter=",", names=True)
        return {k: r[k] for k in r.dtype.names}
    meta = json.loads((d / "checkpoint.json").read_text())
    h = meta["history"]
    return {k: np.array([row.get(k, np.nan) for row in h]) for k in h[0]}


def events(h: dict[str, np.ndarray]) -> tuple[float, float]:
    """(first contact, release) from the contact length; NaN if it did not happen. Release is
    the first step from t = 1000 (the lifting load starts) without contact, so a bounce at first
    contact does not count."""
    on = h["stamp_length_contact"] > 0
    t = h["time"]
    first = t[np.argmax(on)] if on.any() else np.nan
    off = np.nonzero(~on & (t >= 1000.0) & (np.cumsum(on) > 0))[0]
    rel = t[off[0]] if len(off) else np.nan
    return float(first), float(rel)


def report(base: Path, fig_dir: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    H = {d.name: history(d) for d in sorted(base.iterdir()) if d.is_dir() and
         ((d / "history.csv").exists() or (d / "checkpoint.json").exists())}
    print("| run | first contact | release | max penetration | max Φ¹_err | steps | Newton/step |")
    print("|---|---|---|---|---|---|---|")
    ev = {}
    for name, h in H.items():
        ev[name] = events(h)
        pen = np.nanmax(h.get("penetration", np.array([np.nan])))
        print(f"| {name} | {ev[name][0]:.1f} | {ev[name][1]:.1f} | {pen:.3g} | {np.nanmax(h['mass_err1']):.2g} "
              f"| {len(h['time'])} | {np.mean(h['newton_iterations']):.2f} |")
    checks = []

    def check(text: str, ok: bool) -> None:
        checks.append((text, ok))
        print(f"- [{'x' if ok else ' '}] {text}")

    if all(f"{v}-n16" in ev for v in VARIANTS):
        t = {v: ev[f"{v}-n16"][0] for v in VARIANTS}
        check("every variant reaches contact in finite time", all(np.isfinite(list(t.values()))))
        check(f"slip contacts much earlier ({t['slip']:.0f} vs navslip {t['navslip']:.0f}, noslip {t['noslip']:.0f})",
              t["slip"] < 0.5 * min(t["navslip"], t["noslip"]))
        check("incpen variants approach slower than their standard counterparts "
              f"({t['noslip-incpen']:.0f} > {t['noslip']:.0f}, {t['navslip-incpen']:.0f} > {t['navslip']:.0f})",
              t["noslip-incpen"] > t["noslip"] and t["navslip-incpen"] > t["navslip"])
    series = [n for n in MESHES if (f"navslip-n{n}" if n != 16 else "navslip-n16") in ev]
    if len(series) > 1:
        tc = [(n, ev[f"navslip-n{n}"][0]) for n in series if np.isfinite(ev[f"navslip-n{n}"][0])]
        if len(tc) > 1:  # a check needs two meshes that reached contact
            check(f"finer meshes contact later ({', '.join(f'h=1/{n}: {c:.0f}' for n, c in tc)})",
                  all(np.diff([c for _, c in tc]) > 0))
    if "navslip-n16" in ev:
        c, r = ev["navslip-n16"]
        print(f"coarse navslip: contact {c:.1f} (paper {PAPER['coarse'][0]}, {100 * (c / PAPER['coarse'][0] - 1):+.2f} %),"
              f" release {r:.1f} (paper {PAPER['coarse'][1]}, {100 * (r / PAPER['coarse'][1] - 1):+.2f} %)")
    finest = max((n for n in MESHES if f"navslip-n{n}" in H and n > 16), default=None)
    if finest is not None:  # the paper compares coarse and fine (h = 1/64); the finest run available here
        hc, hf = H["navslip-n16"], H[f"navslip-n{finest}"]
        tt = hc["time"][(hc["uy_X"] > -0.375)]
        d = np.abs(np.interp(tt, hf["time"], hf["uy_X"]) - np.interp(tt, hc["time"], hc["uy_X"]))
        check(f"coarse and h = 1/{finest} u_y(X*) agree down to u_y = -0.375 (max difference {d.max():.3g})",
              d.max() < 0.02)
        ta = min(ev["navslip-n16"][0], ev[f"navslip-n{finest}"][0])
        ea = [np.mean(H[f"navslip-n{n}"]["mass_err2"][(H[f"navslip-n{n}"]["time"] > 1.0)
                                                       & (H[f"navslip-n{n}"]["time"] < ta)]) for n in (16, finest)]
        rate = np.log(ea[0] / ea[1]) / np.log(finest / 16)
        check(f"Φ²_err falls about like h² before contact (h = 1/16 -> 1/{finest}: mean {ea[0]:.3g} -> {ea[1]:.3g}, "
              f"rate {rate:.2f})", 1.4 < rate < 2.6)
    if "navslip-n64" in ev:
        c, r = ev["navslip-n64"]
        print(f"fine navslip: contact {c:.1f} (paper {PAPER['fine'][0]}, {100 * (c / PAPER['fine'][0] - 1):+.1f} %),"
              f" release {r:.1f} (paper {PAPER['fine'][1]}, {100 * (r / PAPER['fine'][1] - 1):+.1f} %)")
    pens = [(g, np.nanmax(H[n]["penetration"])) for g in GAMMAS
            for n in [f"navslip-n16-gamma{g:g}" if g != 1.0 else "navslip-n16"] if n in H and "penetration" in H[n]]
    ok = [p for p in pens if np.isfinite(p[1])]
    if len(ok) > 2:
        check("penetration falls as γ0^S grows (" + ", ".join(f"{g:g}: {p:.2g}" for g, p in pens) + ")",
              all(np.diff([p for _, p in ok]) < 0))
    fig_dir.mkdir(parents=True, exist_ok=True)
    # u_y(X*) of the variants: overview and detail near the wall (lines at fluid cell boundaries)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for v in VARIANTS:
        if f"{v}-n16" in H:
            h = H[f"{v}-n16"]
            for a in ax:
                a.plot(h["time"], h["uy_X"], label=v)
    ax[1].set_ylim(-0.51, -0.30)
    ax[1].set_xlim(0.0, 700.0)
    for k in range(2, 6):  # X* reaches the coarse grid line y = k/16 at u_y = k/16 − 0.625
        ax[1].axhline(k / 16 - 0.625, color="0.8", lw=0.6)
    for a in ax:
        a.set_xlabel("t")
        a.set_ylabel("u_y(X*)")
    ax[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(fig_dir / "stamp_variants.png", dpi=120)
    # flow rate and mass-balance errors
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for v in ("navslip", "noslip"):
        if f"{v}-n16" in H:
            h = H[f"{v}-n16"]
            ax[0].plot(h["time"], h["flow_top"], label=v)
            ax[1].semilogy(h["time"], np.maximum(h["mass_err1"], 1e-18), label=f"Φ¹_err {v}")
            ax[1].semilogy(h["time"], h["mass_err2"], "--", label=f"Φ²_err {v}")
    ax[0].set_yscale("symlog", linthresh=1e-7)  # the small rates in contact and their sign
    ax[0].set_ylabel("flow rate through Γ^{F,N}")
    for a in ax:
        a.set_xlabel("t")
        a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(fig_dir / "stamp_flow.png", dpi=120)
    # h-series: u_y(X*) and the interface force split
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for n in series:
        h = H[f"navslip-n{n}"]
        ax[0].plot(h["time"], h["uy_X"], label=f"h = 1/{n}")
        tot = h["stamp_force_fsi_y"] + h["stamp_force_contact_y"]
        ax[1].plot(h["time"], tot, label=f"total 1/{n}")
        ax[1].plot(h["time"], h["stamp_force_contact_y"], "--", label=f"contact 1/{n}")
    ax[0].set_ylabel("u_y(X*)")
    ax[1].set_ylabel("vertical interface force on the stamp")
    for a in ax:
        a.set_xlabel("t")
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(fig_dir / "stamp_meshes.png", dpi=120)
    # penalty sweep
    if pens:
        fig, ax = plt.subplots(figsize=(5, 4))
        ax.loglog([g for g, _ in pens], [p for _, p in pens], "o-")
        ax.set_xlabel("γ0^S")
        ax.set_ylabel("largest penetration")
        fig.tight_layout()
        fig.savefig(fig_dir / "stamp_gamma.png", dpi=120)


def snapshots(fig_dir: Path) -> None:
    """Field snapshots at contact and release, gap and contact traction around both events."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fsci.cases import get_case
    from fsci.config import apply_override, problem_from_dict
    from fsci.post.figures import snapshot_figure
    from fsci.simulation import Simulation

    case = get_case("stamp")
    apply_override(case, "time.segments=[{until=20.0, dt=0.5}, {until=300.0, dt=2.0}, {until=2500.0, dt=20.0}]")
    case["output"] = {"every": 0, "figures": False, "fields": False}
    sim = Simulation(problem_from_dict(case))
    term = sim.system.extra_terms[0]
    profiles: list[tuple[float, np.ndarray]] = []
    state = {"contact": False, "shot": set()}
    window = (-0.8, 0.0, 0.0, 0.45)

    def hook(s, ctx, rep) -> None:
        t = s.t
        L = term.body_summary(s.system, term.names.index("stamp"))["length_contact"]
        if 240.0 <= t <= 300.0 or 2000.0 <= t <= 2200.0:
            profiles.append((t, term.profile("stamp")))
        if L > 0 and "contact" not in state["shot"]:
            state["shot"].add("contact")
            snapshot_figure(s.system, fig_dir / "stamp_snapshot_contact.png", f"first contact, t = {t:.4g}", window)
        if t >= 1000.0 and 0 < L and "release" not in state["shot"]:
            state["last"] = t
        if t >= 1000.0 and L == 0 and "release" not in state["shot"] and state.get("last"):
            state["shot"].add("release")
            snapshot_figure(s.system, fig_dir / "stamp_snapshot_release.png", f"release, t = {t:.4g}", window)

    sim.step_hooks.append(hook)
    sim.run()
    fig, ax = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    for col, (lo, hi) in enumerate(((240.0, 300.0), (2000.0, 2200.0))):
        sel = [(t, p) for t, p in profiles if lo <= t <= hi and len(p)]
        for t, p in sel[:: max(1, len(sel) // 6)]:
            near = p[:, 0] > -0.3
            ax[0, col].plot(p[near, 0], p[near, 3], label=f"t = {t:.4g}")
            ax[1, col].plot(p[near, 0], p[near, 2], label=f"t = {t:.4g}")
        ax[0, col].set_title("around first contact" if col == 0 else "around release")
        ax[0, col].set_ylabel("gap g_n")
        ax[1, col].set_ylabel("contact traction −σ̃_nn")
        ax[1, col].set_xlabel("x along the stamp")
        ax[0, col].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(fig_dir / "stamp_gap_traction.png", dpi=120)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("action", choices=["run", "report", "snapshots"])
    ap.add_argument("--dir", type=Path, default=ROOT / "results" / "stamp-study")
    ap.add_argument("--jobs", type=int, default=2, help="runs in parallel (default 2)")
    ap.add_argument("--only", choices=["coarse", "fine", "gamma"], help="a subset of the runs")
    ap.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    args = ap.parse_args(argv)
    args.dir.mkdir(parents=True, exist_ok=True)
    if args.action == "run":
        todo = runs(args.only)
        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            for name, code in pool.map(lambda kv: start(kv[0], kv[1], args.dir), todo.items()):
                print(f"{name}: exit {code}", flush=True)
        sys.exit(0)
    if args.action == "snapshots":
        snapshots(args.figures)
        return
    report(args.dir, args.figures)


if __name__ == "__main__":
    main()
