"""Checkpoints: the full state of a run, so that ``fsci resume DIR`` continues it and a
restarted run equals an uninterrupted one bit for bit.

``DIR/checkpoint.npz`` is one atomic unit: every state array (:func:`fsci.system.snapshot`)
plus the entry ``__meta__``, the JSON of the time loop's scalars (time, step, step-size
controller, counters), the history so far, the list of written VTU files and the SHA-256 of
the ``case.toml`` it belongs to. It is written to a temporary name, synced and renamed, so a
kill at any moment leaves the previous checkpoint or the new one; a damaged file fails the
zip checksum and :func:`read_checkpoint` refuses it with one line.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from pathlib import Path

import numpy as np

from fsci import __version__
from fsci.errors import InputError
from fsci.io.atomic import replacing
from fsci.system import snapshot

NPZ = "checkpoint.npz"
CASE = "case.toml"
_META = "__meta__"


def case_digest(directory: Path) -> str | None:
    """SHA-256 of the run directory's case.toml (None if there is none)."""
    p = Path(directory) / CASE
    return hashlib.sha256(p.read_bytes()).hexdigest() if p.exists() else None


def write_checkpoint(sim, directory: Path) -> Path:
    """Write the state of ``sim`` into ``directory`` atomically; returns the file's path."""
    directory = Path(directory)
    state = snapshot(sim.system)
    meta = {
        "version": __version__,
        "case": sim.problem.name,
        "case_sha256": case_digest(directory),
        "t": sim.t,
        "step": sim.step,
        "newton_total": sim.newton_total,
        "run_totals": sim.run_totals(),
        "dt_current": sim.dt_current,
        "steps_at_dt": sim.steps_at_dt,
        "history": sim.history,
        "writer": None if sim.writer is None else {"count": sim.writer.count, "entries": sim.writer.entries},
        "base_dir": None if sim.base_dir is None else str(sim.base_dir),
    }
    blob = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    with replacing(directory / NPZ) as tmp:
        np.savez(tmp, **state, **mesh_arrays(sim.problem), **{_META: blob})
    return directory / NPZ


def mesh_arrays(problem) -> dict[str, np.ndarray]:
    """Every body's mesh as arrays (``mesh<b>.nodes``, ``.cells``, ``.node.<set>``,
    ``.edge.<set>``): a resumed run continues on the meshes it ran on, even if the mesher
    would not reproduce them."""
    out = {}
    for b, body in enumerate(problem.bodies):
        m = body.mesh
        out[f"mesh{b}.nodes"], out[f"mesh{b}.cells"] = m.nodes, m.cells
        out.update({f"mesh{b}.node.{k}": v for k, v in m.node_sets.items()})
        out.update({f"mesh{b}.edge.{k}": v for k, v in m.edge_sets.items()})
    return out


def stored_meshes(state: dict[str, np.ndarray]) -> dict[int, "QuadMesh"]:
    """The meshes a checkpoint holds, by body index (removed from ``state``)."""
    from fsci.mesh.quadmesh import QuadMesh

    parts: dict[int, dict] = {}
    for key in [k for k in state if k.startswith("mesh")]:
        head, _, rest = key.partition(".")
        b = int(head[4:])
        d = parts.setdefault(b, {"node_sets": {}, "edge_sets": {}})
        arr = state.pop(key)
        if rest in ("nodes", "cells"):
            d[rest] = arr
        else:
            kind, _, name = rest.partition(".")
            d[f"{kind}_sets"][name] = arr
    return {b: QuadMesh(d["nodes"], d["cells"], d["node_sets"], d["edge_sets"]) for b, d in parts.items()}


def read_checkpoint(directory: Path) -> tuple[dict[str, np.ndarray], dict]:
    """State arrays and metadata of a checkpoint; an unreadable or damaged file, or one that
    belongs to another case.toml, is an :class:`InputError`."""
    path = Path(directory) / NPZ
    try:
        with np.load(path) as data:
            state = {k: data[k].copy() for k in data.files}
        meta = json.loads(state.pop(_META).tobytes().decode())
    except FileNotFoundError:
        raise InputError("resume", str(directory), f"a run directory with {NPZ}") from None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, UnicodeDecodeError) as exc:
        raise InputError("resume", str(path), f"a complete checkpoint (this one is damaged: {exc}); "
                         "rerun the case") from None
    digest = case_digest(Path(directory))
    if meta.get("case_sha256") not in (None, digest):
        raise InputError("resume", str(Path(directory) / CASE), "the case.toml the checkpoint was written for (it "
                         "changed since; use --set to change keys when resuming)")
    return state, meta
