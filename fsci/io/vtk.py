"""VTU/PVD output for ParaView (written with meshio).

Per output time: one VTU per solid body (reference coordinates with point data
``displacement`` and ``velocity`` — use "Warp By Vector" — and cell data ``cauchy_stress``)
and one VTU of the fluid's ACTIVE cells (point data ``velocity``, ``pressure``). ``fields.pvd``
lists all of them with their time and part number.
"""

from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np


class VTKWriter:
    """Writes VTU files into ``out_dir/vtu`` and maintains ``out_dir/fields.pvd``."""

    def __init__(self, out_dir: Path) -> None:
        self.out_dir = Path(out_dir)
        self.vtu_dir = self.out_dir / "vtu"
        self.vtu_dir.mkdir(parents=True, exist_ok=True)
        self.entries: list[tuple[float, int, str]] = []
        self.count = 0

    def write(self, system, t: float) -> None:
        k = self.count
        part = 0
        for s in system.solids:
            name = f"solid_{s.name}_{k:05d}.vtu"
            mesh = meshio.Mesh(
                np.column_stack([s.X, np.zeros(s.n)]),
                [("quad", s.mesh.cells)],
                point_data={"displacement": np.column_stack([s.U, np.zeros(s.n)]),
                            "velocity": np.column_stack([s.V, np.zeros(s.n)])},
                cell_data={"cauchy_stress": [s.cell_stress()]},
            )
            meshio.write(self.vtu_dir / name, mesh, file_format="vtu", binary=True)
            self.entries.append((t, part, f"vtu/{name}"))
            part += 1
        if system.fluid is not None:
            name = f"fluid_{k:05d}.vtu"
            self._write_fluid(system, self.vtu_dir / name)
            self.entries.append((t, part, f"vtu/{name}"))
            part += 1
        for term in getattr(system, "extra_terms", []):
            for tag, mesh in term.output_meshes(system) if hasattr(term, "output_meshes") else []:
                name = f"{tag}_{k:05d}.vtu"
                meshio.write(self.vtu_dir / name, mesh, file_format="vtu", binary=True)
                self.entries.append((t, part, f"vtu/{name}"))
                part += 1
        self.count += 1
        self.write_pvd()

    def _write_fluid(self, system, path: Path) -> None:
        f = system.fluid
        writer = getattr(f, "output_mesh", None)
        if writer is not None:
            mesh = writer()
        else:
            g = f.grid
            cells = g.cells[f.int_cells]
            v = np.where(f.active[:, None], f.V, np.nan)
            p = np.where(f.active, f.P, np.nan)
            mesh = meshio.Mesh(np.column_stack([g.nodes, np.zeros(g.n_nodes)]), [("quad", cells)],
                               point_data={"velocity": np.column_stack([v, np.zeros(g.n_nodes)]), "pressure": p})
        meshio.write(path, mesh, file_format="vtu", binary=True)

    def write_pvd(self) -> None:
        lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">', "  <Collection>"]
        for t, part, f in self.entries:
            lines.append(f'    <DataSet timestep="{t:.10g}" group="" part="{part}" file="{f}"/>')
        lines += ["  </Collection>", "</VTKFile>", ""]
        (self.out_dir / "fields.pvd").write_text("\n".join(lines))
