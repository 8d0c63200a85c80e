"""Matplotlib figures written to ``DIR/figures``: time histories of every scalar quantity and a
picture of the final state (fluid speed, solids in their deformed configuration)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402


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
    return polys, speed[g.cells[cells]].mean(axis=1)


def snapshot_figure(system, path: Path, title: str = "", window: tuple[float, float, float, float] | None = None,
                    arrow_length: float = 0.1) -> Path:
    """Fluid speed and pressure on the PHYSICAL fluid cells (cut cells as their fluid parts), the
    deformed solids, and the interface traction at the Gauss points of the coupling as arrows
    coloured by case: blue FSI (case I), red contact (cases II-IV). ``window`` = (x0, x1, y0,
    y1) zooms; arrows are scaled so that the largest is ``arrow_length`` long."""
    from fsci.coupling import traction as tk

    path.parent.mkdir(parents=True, exist_ok=True)
    f = system.fluid
    polys, parents = f.physical_polygons()
    cellmean = {"|v|": np.linalg.norm(f.V, axis=1)[f.grid.cells[parents]].mean(axis=1),
                "p": f.P[f.grid.cells[parents]].mean(axis=1)}
    out = np.zeros((0, tk.N_OUT))
    if system.extra_terms:
        out = system.extra_terms[0].samples()[0].reshape(-1, tk.N_OUT)
        out = out[out[:, tk.O_CASE] > 0]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    for ax, (name, vals) in zip(axes, cellmean.items()):
        pc = PolyCollection(polys, array=vals, cmap="viridis" if name == "|v|" else "coolwarm", edgecolors="none")
        ax.add_collection(pc)
        fig.colorbar(pc, ax=ax, label=name, shrink=0.8)
        _draw_solids(ax, system, 0.15)
        if len(out):
            t = out[:, [tk.O_TX, tk.O_TY]]
            scale = arrow_length / max(float(np.linalg.norm(t, axis=1).max()), 1e-300)
            for mask, colour, label in ((out[:, tk.O_CASE] == tk.CASE_I, "tab:blue", "FSI (I)"),
                                        (out[:, tk.O_CASE] > tk.CASE_I, "tab:red", "contact (II-IV)")):
                if mask.any():
                    ax.quiver(out[mask, tk.O_X], out[mask, tk.O_Y], scale * t[mask, 0], scale * t[mask, 1],
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
