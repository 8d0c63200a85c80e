"""Figures and the event table of the squeezed elastic body (built-in case ``squeezed``, paper
Sec. 4.3) from the history of a run (also of a run still in progress: history.csv is written
every step).

    fsci run squeezed --out results/squeezed
    python benchmarks/squeezed_figures.py results/squeezed [--figures docs/figures]
    python benchmarks/squeezed_figures.py --geometry            # the reconstruction, drawn
    python benchmarks/squeezed_figures.py results/squeezed --snapshots  # fields at the events
    python benchmarks/squeezed_figures.py --help

Flow rates in the main flow direction -y (the paper's convention): Q_in = -(outward flux
through y = 5), Q_out = outward flux through y = 0; transported volumes V(t) = ∫ Q dt (θ = 1:
the flux of a step is its end-of-step value times its Δt). Events are read off the history:
contact with a wall when its contact length (points in case II or III) rises from zero, the
fluid split when the number of fluid pieces first exceeds one, a release when the body's
contact length falls back to zero; contact episodes shorter than ``--min-episode`` (a bounce)
are listed but not counted as events.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PAPER = {"contact right": 0.00324, "contact left (fluid splits)": 0.00386, "release": 0.00668,
         "recontact": 0.00713, "final separation": 0.015155}


def load(run: Path) -> dict[str, np.ndarray]:
    r = np.genfromtxt(run / "history.csv", delimiter=",", names=True)
    return {k: np.atleast_1d(r[k]) for k in r.dtype.names}


def first(t: np.ndarray, mask: np.ndarray) -> float:
    """First time at which ``mask`` holds (NaN if never)."""
    k = np.nonzero(mask)[0]
    return float(t[k[0]]) if len(k) else float("nan")


def episodes(t: np.ndarray, on: np.ndarray) -> list[tuple[float, float]]:
    """(start, end) of every interval in which ``on`` holds: start = first step with it, end =
    first step without it after (NaN if it still holds at the end of the record)."""
    out = []
    start = None
    for k in range(len(t)):
        if on[k] and start is None:
            start = float(t[k])
        elif not on[k] and start is not None:
            out.append((start, float(t[k])))
            start = None
    if start is not None:
        out.append((start, float("nan")))
    return out


def events(h: dict[str, np.ndarray], min_episode: float) -> dict[str, float]:
    """The paper's event sequence measured on a history (NaN: not reached)."""
    t = h["time"]
    ep = [e for e in episodes(t, h["body_length_contact"] > 0)
          if np.isnan(e[1]) or e[1] - e[0] >= min_episode]
    return {"contact right": first(t, h["right_length_contact"] > 0),
            "contact left (fluid splits)": first(t, h["left_length_contact"] > 0),
            "fluid splits (pieces ≥ 2)": first(t, h["pieces"] >= 2),
            "release": ep[0][1] if ep else float("nan"),
            "recontact": ep[1][0] if len(ep) > 1 else float("nan"),
            "final separation": ep[-1][1] if len(ep) > 1 else float("nan")}


def report(run: Path, fig_dir: Path, min_episode: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = load(run)
    t, dt = h["time"], h["dt"]
    q_in, q_out = -h["flow_in"], h["flow_out"]
    v_in, v_out = np.cumsum(q_in * dt), np.cumsum(q_out * dt)
    phi = np.abs(h["mass_phi_solid"]).max()
    print(f"run {run}: t = {t[-1]:.6g}, {len(t)} steps, Newton per step {h['newton_iterations'].mean():.2f}, "
          f"max Φ¹_err {h['mass_err1'].max():.2g} ({h['mass_err1'].max() / phi:.2g} of the largest flux), "
          f"fluid pieces {int(h['pieces'].min())}..{int(h['pieces'].max())}")
    ev = events(h, min_episode)
    print("| event | this run | paper |")
    print("|---|---|---|")
    for name, value in ev.items():
        ref = PAPER.get(name)
        print(f"| {name} | {value:.6g} | {'' if ref is None else f'{ref:g}'} |")
    print("contact episodes of the body (start, end):",
          ", ".join(f"[{a:.5g}, {b:.5g}]" for a, b in episodes(t, h["body_length_contact"] > 0)))
    print("fluid split (pieces ≥ 2):", ", ".join(f"[{a:.5g}, {b:.5g}]" for a, b in episodes(t, h["pieces"] >= 2)))
    drift = v_out - v_in
    area = h["centroid_area"]
    print(f"transported volume: in {v_in[-1]:.4g}, out {v_out[-1]:.4g}; out - in ranges {drift.min():.3g} .. "
          f"{drift.max():.3g}; change of the body's area {area[-1] - area[0]:.3g}")
    print(f"elastic energy: body up to {h['energy'].max():.4g} (t = {t[np.argmax(h['energy'])]:.5g}), walls up to "
          f"{h['energy_walls'].max():.4g}")

    fig_dir.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(3, 2, figsize=(12, 9.5), sharex=True)
    ax[0, 0].plot(t, q_in, label="Q_in (y = 5)")
    ax[0, 0].plot(t, q_out, label="Q_out (y = 0)")
    ax[0, 0].set_ylabel("flow rate, direction −y")
    ax[0, 1].plot(t, v_in, label="∫ Q_in dt")
    ax[0, 1].plot(t, v_out, "--", label="∫ Q_out dt")
    ax[0, 1].plot(t, 10 * drift, ":", label="10 × (out − in)")
    ax[0, 1].set_ylabel("transported volume")
    ax[1, 0].plot(t, h["right_length_contact"], label="right wall")
    ax[1, 0].plot(t, h["left_length_contact"], label="left wall")
    ax[1, 0].set_ylabel("contact length (cases II, III)")
    ax[1, 1].plot(t, h["pieces"], drawstyle="steps-post", label="fluid pieces")
    for c in ("II", "III", "IV"):
        ax[1, 1].plot(t, h[f"case_{c}"] / max(1.0, h["case_I"].max()) * 10, lw=0.8, label=f"case {c} (× 10/max I)")
    ax[1, 1].set_ylabel("count")
    ax[2, 0].plot(t, h["centroid_y"], label="y")
    ax2 = ax[2, 0].twinx()
    ax2.plot(t, h["centroid_x"], "C1", label="x (right axis)")
    ax2.legend(fontsize=7, loc="lower left")
    ax[2, 0].set_ylabel("centre of mass of the body")
    ax[2, 1].plot(t, h["energy"], label="body")
    ax[2, 1].plot(t, h["energy_walls"], label="walls")
    ax[2, 1].set_ylabel("elastic energy")
    for a in ax.ravel():
        for name, value in ev.items():
            if np.isfinite(value):
                a.axvline(value, color="0.6", lw=0.6, ls="--")
        for value in PAPER.values():
            a.axvline(value, color="tab:red", lw=0.5, ls=":")
        a.legend(fontsize=7)
    for a in ax[2]:
        a.set_xlabel("t (grey dashed: events of this run; red dotted: the paper's)")
    fig.tight_layout()
    fig.savefig(fig_dir / "squeezed_history.png", dpi=120)


def snapshots(run: Path, fig_dir: Path, min_episode: float) -> None:
    """Speed, pressure and interface tractions (FSI blue, contact red) at the field outputs
    nearest to first contact, the most squeezed state (largest elastic energy of the body while
    the channel is closed), the release and the recontact."""
    from fsci.post.figures import snapshots_at

    h = load(run)
    ev = events(h, min_episode)
    t = h["time"]
    closed = h["pieces"] >= 2
    wanted = [("first contact (right)", ev["contact right"])]
    if closed.any():
        wanted.append(("squeezed (largest energy, channel closed)", t[closed][np.argmax(h["energy"][closed])]))
    wanted += [(name, ev[name]) for name in ("release", "recontact") if np.isfinite(ev[name])]
    snapshots_at(run, wanted, fig_dir, "squeezed_snapshot", None, arrow_length=0.15)


def geometry(fig_dir: Path) -> None:
    """The reconstructed geometry: solid meshes (paper grid sizes), fluid box, barriers, body."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fsci.cases import get_case, squeezed as sq
    from fsci.config import problem_from_dict
    from fsci.post.figures import draw_case

    prob = problem_from_dict(get_case("squeezed"))
    fig, axes = plt.subplots(1, 2, figsize=(12, 8.5), gridspec_kw={"width_ratios": [1, 1.3]})
    for ax in axes:
        draw_case(ax, prob, {"body": "#f5d9a8"}, linewidth=0.12)
    ax = axes[0]
    ax.set_xlim(-1.45, 1.45)
    ax.set_ylim(-0.3, 5.45)
    xs = np.linspace(-1, 1, 11)
    for x in xs[1:-1]:  # the parabolic inflow profile
        ax.annotate("", (x, 5.0), (x, 5.0 + 0.3 * (1 - x * x)), arrowprops={"arrowstyle": "->", "color": "tab:blue"})
    ax.text(-0.95, 5.32, "Γ^in: v = (0, −100 (1 − x²) min(1, 4000 t))", fontsize=8, color="tab:blue")
    ax.text(-0.95, -0.2, "Γ^out (y = 0): zero traction", fontsize=8, color="tab:blue")
    ax.text(-1.04, 4.72, "no slip", fontsize=7, color="tab:blue", rotation=90, ha="right")
    ax.text(-1.04, 0.0, "no slip", fontsize=7, color="tab:blue", rotation=90, ha="right")
    ax.text(-1.42, 1.0, "left wall (E = 200), clamped at x = −1.15", fontsize=8, rotation=90)
    ax.text(1.22, 1.0, "right wall (E = 200), clamped at x = 1.15", fontsize=8, rotation=90)
    ax.text(-0.35, sq.Y0 + sq.R + 0.05, f"body (E = 100), R = {sq.R}", fontsize=8)
    for k, y in enumerate(sq.BARRIERS):
        ax.text(0.0, y - 0.5 * sq.STAGGER, f"barrier {k + 1}", fontsize=8, ha="center", va="center")
    ax.set_title("fluid box [−1, 1] × [0, 5]: 120 × 300 cells (n = 60)", fontsize=9)
    ax = axes[1]  # the first barrier and the body, enlarged, with the dimensions
    ax.set_xlim(-1.05, 1.2)
    ax.set_ylim(2.85, 4.85)
    yr, yl = sq.BARRIERS[0], sq.BARRIERS[0] - sq.STAGGER

    def dim(p0, p1, text, offset=(0.0, 0.0), **kw):
        ax.annotate("", p1, p0, arrowprops={"arrowstyle": "<->", "color": "tab:red", "lw": 0.8})
        ax.text(0.5 * (p0[0] + p1[0]) + offset[0], 0.5 * (p0[1] + p1[1]) + offset[1], text, fontsize=8,
                color="tab:red", **kw)

    dim((sq.W, yr), (sq.W - sq.RB, yr), f"RB = {sq.RB}", (-0.1, 0.03))
    dim((-sq.W, yl), (-sq.W + sq.RB, yl), f"RB = {sq.RB}", (-0.1, 0.03))
    dim((0.0, sq.Y0), (sq.R, sq.Y0), f"R = {sq.R}", (-0.12, 0.03))
    dim((-sq.W, 3.05), (sq.W, 3.05), f"2W = {2 * sq.W}", (-0.15, 0.03))
    dim((1.05, yl), (1.05, yr), f"{sq.STAGGER}", (0.02, 0.0))
    ax.plot([sq.W - 0.1, 1.1], [yl, yl], color="tab:red", lw=0.5, ls=":")
    ax.plot([sq.W, 1.1], [yr, yr], color="tab:red", lw=0.5, ls=":")
    cr, cl = np.array([sq.W, yr]), np.array([-sq.W, yl])
    u = (cr - cl) / np.linalg.norm(cr - cl)
    gap = np.linalg.norm(cr - cl) - 2 * sq.RB
    dim(tuple(cl + sq.RB * u), tuple(cr - sq.RB * u), f"narrowest passage {gap:.2f}", (-0.25, -0.1))
    ax.plot([0.0], [sq.Y0], "k+")
    ax.text(0.03, sq.Y0 - 0.08, f"(0, {sq.Y0})", fontsize=8)
    ax.set_title(f"first barrier: bump centres y = {yr:g} (right) and {yl:g} (left) on the walls x = ±{sq.W:g};\n"
                 f"barriers 2 and 3 the same, {sq.BARRIERS[0] - sq.BARRIERS[1]:.1f} and "
                 f"{sq.BARRIERS[0] - sq.BARRIERS[2]:.1f} lower", fontsize=9)
    fig.tight_layout()
    fig_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(fig_dir / "squeezed_geometry.png", dpi=130)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", type=Path, nargs="?", help="output folder of `fsci run squeezed`")
    ap.add_argument("--geometry", action="store_true", help="draw the reconstructed geometry")
    ap.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    ap.add_argument("--min-episode", type=float, default=0.0,
                    help="contact episodes shorter than this (a bounce) are not events (default 0: all count)")
    ap.add_argument("--snapshots", action="store_true", help="field snapshots of the run at the events")
    args = ap.parse_args(argv)
    if args.geometry:
        geometry(args.figures)
    if args.run is not None:
        report(args.run, args.figures, args.min_episode)
        if args.snapshots:
            snapshots(args.run, args.figures, args.min_episode)
    elif not args.geometry:
        ap.error("give a run folder or --geometry")


if __name__ == "__main__":
    main()
