"""Matplotlib figures written to ``DIR/figures``: time histories of every scalar quantity and a
picture of the final state (fluid speed, solids in their deformed configuration)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

MAX_ARROWS = 400  # traction arrows drawn per panel at most


def history_figures(history: list[dict[str, float]], out_dir: Path) -> list[Path]:
    """One PNG per quantity column of the history (if there is more than one row)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    if len(history) < 2:
        return []
    keys = [k for k in history[0] if k not in ("time", "step", "newton_iterations", "dt")]
    t = np.array([h["time"] for h in history])
    paths = []
    for k in keys:
        y = np.array([h.get(k, np.nan) for h in history])
        fig, ax = plt.subplots(figsize=(6, 3.5))
        ax.plot(t, y, lw=1.2)
        ax.set_xlabel("time")
        ax.set_ylabel(k)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        p = out_dir / f"history_{k}.png"
        fig.savefig(p, dpi=120)
        plt.close(fig)
        paths.append(p)
    return paths


def state_figure(system, path: Path, title: str = "") -> Path:
    """Fluid speed on the PHYSICAL fluid cells and the deformed solid meshes."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(8, 5))
    f = system.fluid
    if f is not None:
        polys, vals = f.speed_polygons() if hasattr(f, "speed_polygons") else _grid_polygons(f)
        pc = PolyCollection(polys, array=vals, cmap="viridis", edgecolors="none")
        ax.add_collection(pc)
        fig.colorbar(pc, ax=ax, label="|v|", shrink=0.8)
    _draw_solids(ax, system, 0.2)
    ax.autoscale_view()
    ax.set_aspect("equal")
    if title:
        ax.set_title(title)
    return _save(fig, path)


def _draw_solids(ax, system, linewidth: float) -> None:
    """The solid meshes in their deformed configuration."""
    for s in system.solids:
        ax.add_collection(PolyCollection((s.X + s.U)[s.mesh.cells], facecolors="lightgray", edgecolors="k",
                                         linewidths=linewidth))


def draw_case(ax, problem, colours: dict[str, str] | None = None, linewidth: float = 0.15) -> None:
    """A case as set up: every body's mesh in its reference configuration (grey, or
    ``colours[name]``) and the fluid box, equal axes (the geometry drawings of the examples)."""
    for b in problem.bodies:
        m = b.mesh
        ax.add_collection(PolyCollection(m.nodes[m.cells], facecolors=(colours or {}).get(b.name, "0.85"),
                                         edgecolors="0.4", linewidths=linewidth))
    if problem.fluid is not None:
        g = problem.fluid.grid
        ax.add_patch(plt.Rectangle((g.xs[0], g.ys[0]), g.xs[-1] - g.xs[0], g.ys[-1] - g.ys[0], fill=False,
                                   ec="tab:blue", lw=1.2))
    ax.set_aspect("equal")


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _grid_polygons(f) -> tuple[np.ndarray, np.ndarray]:
    g = f.grid
    cells = f.int_cells
    polys = g.nodes[g.cells[cells]]
    speed = np.linalg.norm(f.V, axis=1)
    return polys, speed[f.int_conn].mean(axis=1)


def snapshot_figure(system, path: Path, title: str = "", window: tuple[float, float, float, float] | None = None,
                    arrow_length: float = 0.1) -> Path:
    """Fluid speed and pressure on the PHYSICAL fluid cells (cut cells as their fluid parts), the
    deformed solids, and the interface traction at the Gauss points of the coupling as arrows
    coloured by case: blue FSI (case I), red contact (cases II-IV). ``window`` = (x0, x1, y0,
    y1) zooms; arrows are scaled so that the largest is ``arrow_length`` long."""
    from fsci.coupling import traction as tk

    f = system.fluid
    polys, parents = f.physical_polygons()
    cells = f.cut.conn_at(parents, np.array([p.mean(axis=0) for p in polys]).reshape(-1, 2))
    fields = {"|v|": np.linalg.norm(f.V, axis=1)[cells].mean(axis=1), "p": f.P[cells].mean(axis=1)}
    out = np.zeros((0, tk.N_OUT))
    if system.extra_terms:
        out = system.extra_terms[0].samples()[0].reshape(-1, tk.N_OUT)
        out = out[out[:, tk.O_CASE] > 0]
    solids = [(s.X + s.U)[s.mesh.cells] for s in system.solids]
    return _snapshot(polys, fields, solids, out[:, [tk.O_X, tk.O_Y]], out[:, [tk.O_TX, tk.O_TY]],
                     out[:, tk.O_CASE].astype(int), path, title, window, arrow_length)


def snapshot_from_output(out_dir: Path, index: int, path: Path, title: str = "",
                         window: tuple[float, float, float, float] | None = None, arrow_length: float = 0.1) -> Path:
    """:func:`snapshot_figure` of output number ``index`` of a finished (or running) run, from its
    VTU files (``DIR/vtu/fluid_NNNNN.vtu``, ``solid_<body>_NNNNN.vtu``, ``interface_NNNNN.vtu``;
    docs/output.md): cell means of the fluid point values, solids displaced from their
    reference points, interface points with their traction and case."""
    import meshio

    vtu = Path(out_dir) / "vtu"
    fl = meshio.read(vtu / f"fluid_{index:05d}.vtu")
    polys, fields = [], {"|v|": [], "p": []}
    speed = np.linalg.norm(fl.point_data["velocity"][:, :2], axis=1)
    for block in fl.cells:
        for conn in block.data:
            polys.append(fl.points[conn, :2])
            fields["|v|"].append(speed[conn].mean())
            fields["p"].append(fl.point_data["pressure"][conn].mean())
    solids = []
    for f in sorted(vtu.glob(f"solid_*_{index:05d}.vtu")):
        m = meshio.read(f)
        x = m.points[:, :2] + m.point_data["displacement"][:, :2]
        solids.append(x[m.cells_dict["quad"]])
    xy, tr, case = np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, dtype=int)
    if (vtu / f"interface_{index:05d}.vtu").exists():
        m = meshio.read(vtu / f"interface_{index:05d}.vtu")
        keep = m.point_data["case"] > 0
        xy, tr, case = m.points[keep, :2], m.point_data["traction"][keep, :2], m.point_data["case"][keep]
    return _snapshot(polys, {k: np.asarray(v) for k, v in fields.items()}, solids, xy, tr, case, path, title,
                     window, arrow_length)


def output_times(out_dir: Path) -> list[tuple[float, int]]:
    """(time, output number) of every field output listed in ``out_dir/fields.pvd``."""
    import re

    text = (Path(out_dir) / "fields.pvd").read_text(encoding="utf-8")
    return [(float(t), int(i)) for t, i in re.findall(r'timestep="([^"]+)"[^>]*file="vtu/fluid_(\d+)\.vtu"', text)]


def snapshots_at(out_dir: Path, instants: list[tuple[str, float]], fig_dir: Path, stem: str,
                 window: tuple[float, float, float, float] | None = None, arrow_length: float = 0.1) -> list[Path]:
    """:func:`snapshot_from_output` at the field output nearest to each ``(label, time)``, written
    to ``fig_dir/<stem>_<k>.png`` (k = 1, 2, ...); prints which output each one shows."""
    outs = output_times(out_dir)
    if not outs:
        raise ValueError(f"{out_dir}: no field outputs (output.every = 0?)")
    times = np.array([o[0] for o in outs])
    paths = []
    for k, (label, tt) in enumerate(instants):
        to, idx = outs[int(np.argmin(np.abs(times - tt)))]
        path = fig_dir / f"{stem}_{k + 1}.png"
        paths.append(snapshot_from_output(out_dir, idx, path, f"{label}: t = {to:.4g}", window, arrow_length))
        print(f"{path.name}: {label}, output at t = {to:.4g} (instant t = {tt:.4g})")
    return paths


def _snapshot(polys, fields: dict[str, np.ndarray], solids: list[np.ndarray], xy: np.ndarray, traction: np.ndarray,
              case: np.ndarray, path: Path, title: str, window, arrow_length: float) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    wide = window is not None and (window[1] - window[0]) > 3.0 * (window[3] - window[2])
    if wide:  # a long channel: the two fields one above the other
        fig, axes = plt.subplots(2, 1, figsize=(12, 2.0 + 8.0 * (window[3] - window[2]) / (window[1] - window[0])))
    else:
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    if window is not None:  # only what is seen: colour limits of the window, fewer polygons
        x0, x1, y0, y1 = window
        inside = np.array([p[:, 0].max() >= x0 and p[:, 0].min() <= x1 and p[:, 1].max() >= y0 and p[:, 1].min() <= y1
                           for p in polys], dtype=bool)
        polys = [p for p, k in zip(polys, inside) if k]
        fields = {k: v[inside] for k, v in fields.items()}
        near = (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
        xy, traction, case = xy[near], traction[near], case[near]
    if len(xy) > MAX_ARROWS:  # every k-th point: arrows that can still be told apart
        every = slice(None, None, int(np.ceil(len(xy) / MAX_ARROWS)))
        big = case > 1  # contact points are few and kept
        xy = np.concatenate([xy[~big][every], xy[big]])
        traction = np.concatenate([traction[~big][every], traction[big]])
        case = np.concatenate([case[~big][every], case[big]])
    for ax, (name, vals) in zip(axes, fields.items()):
        pc = PolyCollection(polys, array=vals, cmap="viridis" if name == "|v|" else "coolwarm", edgecolors="none")
        ax.add_collection(pc)
        fig.colorbar(pc, ax=ax, label=name, shrink=0.8, pad=0.01)
        for cells in solids:
            ax.add_collection(PolyCollection(cells, facecolors="lightgray", edgecolors="k", linewidths=0.15))
        if len(xy):
            scale = arrow_length / max(float(np.linalg.norm(traction, axis=1).max()), 1e-300)
            for mask, colour, label in ((case == 1, "tab:blue", "FSI (I)"), (case > 1, "tab:red", "contact (II-IV)")):
                if mask.any():
                    ax.quiver(xy[mask, 0], xy[mask, 1], scale * traction[mask, 0], scale * traction[mask, 1],
                              color=colour, angles="xy", scale_units="xy", scale=1.0, width=0.003, label=label)
            ax.legend(fontsize=7, loc="upper left")
        ax.set_aspect("equal")
        if window is not None:
            ax.set_xlim(window[0], window[1])
            ax.set_ylim(window[2], window[3])
        else:
            ax.autoscale_view()
    if title:
        fig.suptitle(title)
    return _save(fig, path)
