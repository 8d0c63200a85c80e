"""Checkpoints: the full state of a run, so that ``fsci resume DIR`` continues it and a
restarted run equals an uninterrupted one bit for bit.

``DIR/checkpoint.npz`` holds every state array (:func:`fsci.system.snapshot`);
``DIR/checkpoint.json`` the scalars of the time loop (time, step, step-size controller,
counters), the history so far and the list of written VTU files. Both are written to a
temporary name and renamed, so an interrupted write never destroys the previous checkpoint.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from fsci import __version__
from fsci.system import snapshot

NPZ = "checkpoint.npz"
META = "checkpoint.json"


def write_checkpoint(sim, directory: Path) -> Path:
    """Write the state of ``sim`` into ``directory``; returns the npz path."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    state = snapshot(sim.system)
    tmp = directory / (NPZ + ".tmp.npz")
    np.savez(tmp, **state)
    os.replace(tmp, directory / NPZ)
    meta = {
        "version": __version__,
        "case": sim.problem.name,
        "t": sim.t,
        "step": sim.step,
        "newton_total": sim.newton_total,
        "dt_current": sim.dt_current,
        "history": sim.history,
        "writer": None if sim.writer is None else {"count": sim.writer.count, "entries": sim.writer.entries},
        "base_dir": None if sim.base_dir is None else str(sim.base_dir),
    }
    tmpj = directory / (META + ".tmp")
    tmpj.write_text(json.dumps(meta))
    os.replace(tmpj, directory / META)
    return directory / NPZ


def read_checkpoint(directory: Path) -> tuple[dict[str, np.ndarray], dict]:
    """State arrays and metadata of a checkpoint."""
    directory = Path(directory)
    with np.load(directory / NPZ) as data:
        state = {k: data[k].copy() for k in data.files}
    meta = json.loads((directory / META).read_text())
    return state, meta
