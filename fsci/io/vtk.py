"""VTU/PVD output for ParaView (written with meshio); the content is described in
docs/output.md.

Per output time: one VTU per solid body (reference coordinates with point data
``displacement`` and ``velocity`` — use "Warp By Vector" with ``displacement`` for the current
configuration — and cell data ``cauchy_stress``), one VTU of the PHYSICAL fluid (uncut cells
and the polygons of cut cells; coincident points are merged, so cells share their points and
ParaView filters such as Plot Over Line and Stream Tracer work directly) and the meshes of
coupling terms (interface pieces). ``fields.pvd`` lists all of them with their time and part
number. Every file is written to a temporary name and renamed.
"""

from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np

from fsci.io.atomic import replacing, write_text


def _write(path: Path, mesh: meshio.Mesh) -> None:
    with replacing(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu", binary=True)


def merge_points(mesh: meshio.Mesh, tol: float) -> meshio.Mesh:
    """The same mesh with points closer than ``tol`` (on a grid of that spacing) merged; point
    data of a merged point is taken from its first copy."""
    if len(mesh.points) == 0:
        return mesh
    keys = np.round(mesh.points[:, :2] / tol).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    cells = [(block.type, inverse[block.data]) for block in mesh.cells]
    return meshio.Mesh(mesh.points[first], cells, point_data={k: np.asarray(v)[first] for k, v in mesh.point_data.items()},
                       cell_data=mesh.cell_data)


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
        meshes: list[tuple[str, meshio.Mesh]] = []
        for s in system.solids:
            meshes.append((f"solid_{s.name}", meshio.Mesh(
                np.column_stack([s.X, np.zeros(s.n)]),
                [("quad", s.mesh.cells)],
                point_data={"displacement": np.column_stack([s.U, np.zeros(s.n)]),
                            "velocity": np.column_stack([s.V, np.zeros(s.n)])},
                cell_data={"cauchy_stress": [s.cell_stress()]},
            )))
        if system.fluid is not None:
            f = system.fluid
            meshes.append(("fluid", merge_points(f.output_mesh(), 1e-9 * float(np.min(f.grid.cell_size)))))
        for term in system.extra_terms:
            if hasattr(term, "output_meshes"):
                meshes += list(term.output_meshes(system))
        meshes = [(tag, m) for tag, m in meshes if any(len(c.data) for c in m.cells)]  # meshio cannot write none
        for part, (tag, mesh) in enumerate(meshes):
            name = f"{tag}_{k:05d}.vtu"
            _write(self.vtu_dir / name, mesh)
            self.entries.append((t, part, f"vtu/{name}"))
        self.count += 1
        self.write_pvd()

    def write_pvd(self) -> None:
        lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">', "  <Collection>"]
        for t, part, f in self.entries:
            lines.append(f'    <DataSet timestep="{t:.10g}" group="" part="{part}" file="{f}"/>')
        lines += ["  </Collection>", "</VTKFile>", ""]
        write_text(self.out_dir / "fields.pvd", "\n".join(lines))
