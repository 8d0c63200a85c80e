"""Figures and tables of the elastic valve pump (built-in case ``pump``, paper Sec. 4.2) from
the history of a run (also of a run still in progress: history.csv is written every step).

    fsci run pump --out results/pump                       # A = 1 on [0, 0.15], 1.5 after
    python benchmarks/pump_figures.py results/pump [--figures docs/figures]
    python benchmarks/pump_figures.py --geometry               # the reconstruction, drawn
    python benchmarks/pump_figures.py results/pump --snapshots # fields at characteristic instants,
                                                               # the chamber's area swing per cycle
    python benchmarks/pump_figures.py --help

Flow rates in the design direction (-x, the paper's convention): Q_in = -(outward flux through
x = 1.5), Q_out = outward flux through x = 0; transported volume V(t) = ∫ Q_out dt, and per
load cycle (period 0.05) the volume leaving through Γ^out. A valve's opening is the distance of
its flap tips' faces: 2 × 0.003 at rest + u_y(upper tip) − u_y(lower tip) (tip points 0.0005 inside
the flaps).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from fsci.cases import pump as case

ROOT = Path(__file__).resolve().parents[1]
PERIOD = 0.05
TIP_GAP = 2 * case.FLAP_TIP  # distance of the two tip faces at rest


def load(run: Path) -> dict[str, np.ndarray]:
    r = np.genfromtxt(run / "history.csv", delimiter=",", names=True)
    return {k: r[k] for k in r.dtype.names}


def per_cycle(t: np.ndarray, dt: np.ndarray, q: np.ndarray) -> list[tuple[int, float, bool]]:
    """(cycle, volume through the boundary in that cycle, complete?) for every started cycle
    (θ = 1: the flux of a step is its end-of-step value times its Δt)."""
    out = []
    for k in range(int(np.ceil(t[-1] / PERIOD - 1e-9))):
        m = (t > k * PERIOD + 1e-12) & (t <= (k + 1) * PERIOD + 1e-12)
        out.append((k + 1, float(np.sum(q[m] * dt[m])), bool(t[-1] >= (k + 1) * PERIOD - 1e-12)))
    return out


def intervals(t: np.ndarray, on: np.ndarray) -> list[tuple[float, float]]:
    """Time intervals [first, last] of the runs of consecutive steps where ``on`` holds."""
    edges = np.diff(np.concatenate([[0], on.astype(int), [0]]))
    return [(float(t[a]), float(t[b - 1])) for a, b in zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0])]


def valve_jumps(h: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Pressure jump across each valve, positive in the direction it holds: the inflow (right)
    valve chamber minus inlet side (compression), the outflow (left) valve outlet minus chamber
    side (suction)."""
    return {"right": h["p_right_valve_chamber"] - h["p_right_valve_in"],
            "left": h["p_left_valve_out"] - h["p_left_valve_chamber"]}


def events(h: dict[str, np.ndarray]) -> None:
    """Per load cycle: when each valve is shut by contact and the jump it carries, the smallest
    gap between the chamber walls and when they touch, flaps that snap through (tip swung to +x
    by more than the flap's reach ``FLAP_DX``), and the largest per-piece mass imbalance."""
    t = h["time"]
    phi = np.abs(h["mass_phi_solid"]).max()
    jump = valve_jumps(h)
    print("| cycle | inflow valve shut (contact) | its largest jump | outflow valve shut | its largest jump | "
          "smallest wall gap | walls touch | flaps snapped through | largest per-piece imbalance / flux |")
    print("|---|---|---|---|---|---|---|---|---|")
    fmt = lambda iv: ", ".join(f"{a:.4g}–{b:.4g}" for a, b in iv) or "—"  # noqa: E731
    for k in range(int(np.ceil(t[-1] / PERIOD - 1e-9))):
        m = (t > k * PERIOD + 1e-12) & (t <= (k + 1) * PERIOD + 1e-12)
        row = [str(k + 1)]
        for v in ("right", "left"):
            shut = h[f"valve_{v}_length_contact"] > 0
            row += [fmt(intervals(t[m], shut[m])), f"{jump[v][m & shut].max():.3g}" if (m & shut).any() else "—"]
        gap = 2 * case.H + h["wall_upper"] - h["wall_lower"]
        row += [f"{gap[m].min():.4g}", fmt(intervals(t[m], h["chamber_length_contact"][m] > 0))]
        swung = {f"{v} {b}": h[f"tip_{v}_{b}_x"][m] > case.FLAP_DX
                 for v in ("left", "right") for b in ("upper", "lower") if f"tip_{v}_{b}_x" in h}
        snapped = [f"{flap} {fmt(intervals(t[m], on))}" for flap, on in swung.items() if on.any()]
        row += ["; ".join(snapped) or "—", f"{h['mass_err1_pieces'][m].max() / phi:.2g}"]
        print("| " + " | ".join(row) + " |")


def solver_per_cycle(h: dict[str, np.ndarray], segments: list[dict]) -> None:
    """Per load cycle: steps, Newton iterations per step, steps below the scheduled size
    (``segments`` of the case's ``[time]``; such steps follow a step cut) and the largest mass
    balance error Φ¹ (46) against the largest interface flux of the run, over all steps and over
    the steps of Δt ≥ 5e-5."""
    t, dt = h["time"], h["dt"]
    phi = np.abs(h["mass_phi_solid"]).max()
    ends = np.array([seg["until"] for seg in segments])
    sizes = np.array([seg["dt"] for seg in segments])
    scheduled = sizes[np.minimum(np.searchsorted(ends, t - dt + 1e-12, side="right"), len(ends) - 1)]
    print("| cycle (t) | steps | Newton per step | steps below the schedule | largest Φ¹_err / flux "
          "(steps of Δt ≥ 5e-5) |")
    print("|---|---|---|---|---|")
    for k in range(int(np.ceil(t[-1] / PERIOD - 1e-9))):
        m = (t > k * PERIOD + 1e-12) & (t <= (k + 1) * PERIOD + 1e-12)
        big = m & (dt >= 5e-5 - 1e-12)
        err, err_big = h["mass_err1"][m].max() / phi, (h["mass_err1"][big].max() / phi if big.any() else np.nan)
        print(f"| {k + 1} ({t[m][0] - dt[m][0]:.4g}–{t[m][-1]:.4g}) | {int(m.sum())} | "
              f"{h['newton_iterations'][m].mean():.2f} | {int(np.sum(dt[m] < 0.99 * scheduled[m]))} | "
              f"{err:.2g} ({err_big:.2g}) |")


def report(run: Path, fig_dir: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = load(run)
    t, dt = h["time"], h["dt"]
    q_in, q_out = -h["flow_in"], h["flow_out"]
    vol_out = np.cumsum(q_out * dt)
    vol_in = np.cumsum(q_in * dt)
    print(f"run {run}: t = {t[-1]:.4g}, {len(t)} steps, Newton per step {h['newton_iterations'].mean():.2f}, "
          f"max Φ¹_err {h['mass_err1'].max():.2g}, fluid pieces {int(h['pieces'].min())}..{int(h['pieces'].max())}")
    import tomllib

    spec = tomllib.loads((run / "case.toml").read_text(encoding="utf-8"))
    a2 = float(spec["parameters"]["A2"])
    # periodicity: the change of the volume out per cycle against the cycle before (same A)
    print("| cycle | A | volume out (design direction) | volume in | change of the volume out | complete |")
    print("|---|---|---|---|---|---|")
    cin = dict((k, v) for k, v, _ in per_cycle(t, dt, q_in))
    prev = None
    for k, v, done in per_cycle(t, dt, q_out):
        a = 1.0 if k <= 3 else a2
        change = f"{abs(v - prev[1]) / abs(prev[1]):.2%}" if prev and prev[0] == a and done else ""
        print(f"| {k} | {a:g} | {v:.4g} | {cin[k]:.4g} | {change} | {'yes' if done else 'no'} |")
        prev = (a, v)
    if "wall_upper" in h:  # columns added on 2026-12-04
        events(h)
    solver_per_cycle(h, spec["time"]["segments"])
    opening = {v: TIP_GAP + h[f"tip_{v}_upper"] - h[f"tip_{v}_lower"] for v in ("left", "right")}
    for v, g in opening.items():
        closed = t[g < 0.2 * TIP_GAP]
        print(f"{v} valve: opening {g.min():.3g} .. {g.max():.3g}; nearly closed (< 20 % of rest) during "
              f"{len(closed)} steps" + (f", first at t = {closed[0]:.4g}" if len(closed) else ""))
    fig_dir.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(2, 2, figsize=(12, 7), sharex=True)
    ax[0, 0].plot(t, q_in, label="Q_in (x = 1.5)")
    ax[0, 0].plot(t, q_out, label="Q_out (x = 0)")
    ax[0, 0].set_ylabel("flow rate, design direction −x")
    ax[0, 1].plot(t, vol_out, label="∫ Q_out dt")
    ax[0, 1].plot(t, vol_in, "--", label="∫ Q_in dt")
    ax[0, 1].set_ylabel("transported volume")
    for v, g in opening.items():
        ax[1, 0].plot(t, g, label={"left": "outflow valve (left)", "right": "inflow valve (right)"}[v])
    ax[1, 0].set_ylabel("valve opening (tip distance)")
    ax[1, 1].plot(t, h["p_chamber"], label="chamber")
    for name in ("left_valve_out", "left_valve_chamber", "right_valve_chamber", "right_valve_in"):
        ax[1, 1].plot(t, h[f"p_{name}"], lw=0.8, label=name.replace("_", " "))
    ax[1, 1].set_ylabel("pressure − p(outlet)")
    for a in ax.ravel():
        for k in range(1, int(t[-1] / PERIOD) + 1):
            a.axvline(k * PERIOD, color="0.85", lw=0.6)
        a.legend(fontsize=7)
    for a in ax[1]:
        a.set_xlabel("t")
    fig.tight_layout()
    suffix = "_A1" if a2 == 1.0 else ""  # a run at A = 1 throughout (`--set A2=1`)
    fig.savefig(fig_dir / f"pump_history{suffix}.png", dpi=120)
    fig, ax = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    for part, label in (("valve_left", "outflow valve"), ("valve_right", "inflow valve"), ("chamber", "chamber walls")):
        ax[0].plot(t, h[f"{part}_length_contact"], label=f"{label}: contact length (upper body)")
    ax[0].set_ylabel("length in contact")
    for c in ("II", "III", "IV"):
        ax[1].plot(t, h[f"case_{c}"], lw=0.8, label=f"case {c}")
    ax[1].set_ylabel("Gauss points")
    ax[1].set_yscale("symlog", linthresh=1)
    ax[1].set_xlabel("t")
    for a in ax:
        for k in range(1, int(t[-1] / PERIOD) + 1):
            a.axvline(k * PERIOD, color="0.85", lw=0.6)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(fig_dir / f"pump_contact{suffix}.png", dpi=120)


def snapshots(run: Path, fig_dir: Path) -> None:
    """Speed, pressure and interface tractions (FSI blue, contact red) at the outputs nearest to
    the characteristic instants of the last complete cycle at A = 1: compression (the largest
    pressure jump across the shut inflow valve; without a shut valve, the largest chamber
    pressure) and suction (the same for the outflow valve; else the lowest chamber pressure);
    and, if the run reached A = 1.5, the outputs nearest to the first snap-through (else the
    largest flap-tip excursion) and to the first touch of the chamber walls after t = 0.15."""
    from fsci.post.figures import snapshots_at

    h = load(run)
    t = h["time"]
    # the last complete cycle at A = 1 (t ≤ 0.15)
    k = max(1, min(3, int(np.floor(t[-1] / PERIOD + 1e-9))))
    c1 = (t > (k - 1) * PERIOD) & (t <= k * PERIOD)
    wanted = []
    jump = valve_jumps(h)
    for phase, valve, side, sign in (("compression", "inflow", "right", 1), ("suction", "outflow", "left", -1)):
        shut = c1 & (h[f"valve_{side}_length_contact"] > 0)
        if shut.any():
            wanted.append((f"{phase}, {valve} valve shut (cycle {k})", t[shut][np.nanargmax(jump[side][shut])]))
        else:  # p_chamber is NaN while a body covers its probe
            wanted.append((f"{phase} (cycle {k})", t[c1][np.nanargmax(sign * h["p_chamber"][c1])]))
    late = t > 0.15
    if late.any():
        # snap-through: the first step with a flap tip swung to +x by more than the flap's reach;
        # without one, the largest flap-tip excursion
        swing = np.column_stack([h[f"tip_{v}_{b}_x"] for v in ("left", "right") for b in ("upper", "lower")])
        snapped = late & (swing.max(axis=1) > case.FLAP_DX)
        if snapped.any():
            wanted.append(("snap-through, A = 1.5", t[np.argmax(snapped)]))
        else:
            tips = np.column_stack([h[f"tip_{v}_{b}"] for v in ("left", "right") for b in ("upper", "lower")])
            wanted.append(("largest flap excursion, A = 1.5", t[late][np.argmax(np.abs(tips[late]).max(axis=1))]))
        touch = late & (h["chamber_length_contact"] > 0)
        if touch.any():
            wanted.append(("chamber walls touch, A = 1.5", t[np.argmax(touch)]))
    snapshots_at(run, wanted, fig_dir, "pump_snapshot", (0.15, 1.35, -0.07, 0.07), arrow_length=0.03)


def valve_gap(run: Path, fig_dir: Path) -> None:
    """Gap g_n along the upper flap of the inflow (right) valve at the field outputs around its
    first shutting in the last complete A = 1 cycle (from the interface VTU: every Gauss point
    with its gap and case), contact points marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import meshio

    from fsci.post.figures import output_times

    h = load(run)
    t = h["time"]
    k = max(1, min(3, int(np.floor(t[-1] / PERIOD + 1e-9))))
    c = (t > (k - 1) * PERIOD) & (t <= k * PERIOD) & (h["valve_right_length_contact"] > 0)
    if not c.any():
        return
    t0, t1 = t[c][0], t[c][-1]
    outs = [(to, i) for to, i in output_times(run) if t0 - 0.006 <= to <= t1 + 0.002]
    fig, ax = plt.subplots(figsize=(8, 4))
    colours = plt.cm.viridis(np.linspace(0, 1, max(len(outs), 1)))
    for (to, i), col in zip(outs, colours):
        m = meshio.read(run / "vtu" / f"interface_{i:05d}.vtu")
        x, y = m.points[:, 0], m.points[:, 1]
        sel = (m.point_data["body"] == 0) & (x > 1.17) & (x < 1.245) & (np.abs(y) < 0.012) & (m.point_data["gap"] > -0.5)  # -1: no opposite surface
        if not sel.any():
            continue
        o = np.argsort(x[sel])
        ax.plot(x[sel][o], m.point_data["gap"][sel][o], "-", color=col, lw=1, label=f"t = {to:.4g}")
        hit = sel & (m.point_data["case"] > 1)
        ax.plot(x[hit], m.point_data["gap"][hit], "o", color=col, ms=3)
    ax.set_xlabel("x along the upper flap of the inflow valve")
    ax.set_ylabel("gap g_n to the lower flap")
    ax.set_yscale("symlog", linthresh=1e-5)
    ax.set_title(f"inflow valve shutting in cycle {k} (dots: contact, cases II-IV)", fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(fig_dir / "pump_valve_gap.png", dpi=120)
    print(f"pump_valve_gap.png: {len(outs)} outputs in [{t0 - 0.006:.4g}, {t1 + 0.002:.4g}]")


def chamber_area(run: Path) -> None:
    """The chamber's area between the walls (x ∈ [0.4, 1.1]) at every field output, from the
    interface VTU (deformed wetted surfaces), and its swing per load cycle: with tight valves
    the volume transported per cycle."""
    import meshio

    from fsci.post.figures import output_times

    grid = np.linspace(0.4, 1.1, 2000)
    per_cycle: dict[int, list[float]] = {}
    for to, i in output_times(run):
        f = run / "vtu" / f"interface_{i:05d}.vtu"
        if to <= 0 or not f.exists():  # no interface output at the start
            continue
        m = meshio.read(f)
        x, y = m.points[:, 0], m.points[:, 1]
        walls = []
        for body in (0, 1):  # upper, lower
            sel = (m.point_data["body"] == body) & (x > 0.38) & (x < 1.12) & (np.abs(y) < 0.06)
            o = np.argsort(x[sel])
            walls.append(np.interp(grid, x[sel][o], y[sel][o]))
        per_cycle.setdefault(int(np.ceil(to / PERIOD - 1e-9)), []).append(float(np.trapezoid(walls[0] - walls[1], grid)))
    for k, a in per_cycle.items():
        print(f"cycle {k}: chamber area {min(a):.4g} .. {max(a):.4g} over {len(a)} outputs, swing {max(a) - min(a):.4g}")


def geometry(fig_dir: Path) -> None:
    """The reconstructed geometry: solid meshes, fluid box, Γ^P, valves, with the chosen sizes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fsci.cases import get_case
    from fsci.config import problem_from_dict
    from fsci.post.figures import draw_case

    prob = problem_from_dict(get_case("pump"))
    fig, axes = plt.subplots(2, 1, figsize=(12, 8.5), gridspec_kw={"height_ratios": [2, 1.2]})
    for ax in axes:
        draw_case(ax, prob)
    ax = axes[0]
    ax.set_xlim(-0.08, 1.58)
    ax.set_ylim(-0.45, 0.45)
    cx = 0.5 * (case.CH0 + case.CH1)
    ax.annotate("Γ^P (cavity, pressure load)", (cx, case.H + case.T_WALL + 2 * case.R_P), (cx + 0.25, 0.43),
                arrowprops={"arrowstyle": "->"}, fontsize=8)
    ax.text(0.02, -0.165, "fluid box (the paper's 240 × 54 cells; valve zones 4 times finer)", color="tab:blue", fontsize=8)
    ax.text(0.01, 0.19, "Γ^out (x = 0)", fontsize=8)
    ax.text(1.36, 0.19, "Γ^in (x = 1.5)", fontsize=8)
    ax.set_title(f"chamber x ∈ [{case.CH0}, {case.CH1}], half-height {case.H}; channel half-height {case.C}; "
                 f"wall over the chamber {case.T_WALL}; cavity radius {case.R_P}", fontsize=9)
    ax = axes[1]  # the left valve, enlarged
    xa = case.VALVES[0]
    ax.set_xlim(xa - 0.12, xa + 0.07)
    ax.set_ylim(-0.045, 0.045)
    ax.set_title(f"valve (left; the right one at x = {case.VALVES[1]} is the same): flaps {case.FLAP_W} thick, "
                 f"reaching {case.FLAP_DX} in −x, tips ±{case.FLAP_TIP}", fontsize=9)
    fig.tight_layout()
    fig_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(fig_dir / "pump_geometry.png", dpi=130)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", type=Path, nargs="?", help="output folder of `fsci run pump`")
    ap.add_argument("--geometry", action="store_true", help="draw the reconstructed geometry")
    ap.add_argument("--snapshots", action="store_true", help="field snapshots of the run at characteristic instants")
    ap.add_argument("--figures", type=Path, default=None,
                    help="folder of the figures (default: RUN/figures, or docs/figures for --geometry); "
                         "docs/figures only when given")
    args = ap.parse_args(argv)
    if args.figures is None:
        args.figures = args.run / "figures" if args.run is not None else ROOT / "docs" / "figures"
    args.figures.mkdir(parents=True, exist_ok=True)
    if args.geometry:
        geometry(args.figures)
    if args.run is not None:
        report(args.run, args.figures)
        if args.snapshots:
            snapshots(args.run, args.figures)
            valve_gap(args.run, args.figures)
            chamber_area(args.run)
    elif not args.geometry:
        ap.error("give a run folder or --geometry")


if __name__ == "__main__":
    main()
