"""The gmsh meshers honour the requested boundary size ``h``: edges along the outline within
20 % of h, also when a larger interior size ``h_max`` is given (the disk of issue 14 had edges of
2.2 h with h = 0.00125, h_max = 0.01: the distance to the outline was measured to 20 samples per
curve, so the size grew between them). Meshing leaves the process's SIGPIPE handling as Python
set it, and gives the same mesh whatever the process that asks for it."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

import fsci.mesh.gmsh_io as gmsh_io
from fsci.config import read_mesh
from fsci.errors import InputError, MeshError


def _edge_ratios(mesh, name: str, h: float) -> np.ndarray:
    e = mesh.edge_sets[name]
    return np.linalg.norm(mesh.nodes[e[:, 1]] - mesh.nodes[e[:, 0]], axis=1) / h


@pytest.mark.parametrize("h, h_max", [(0.00125, 0.01), (0.005, 0.05), (0.01, None), (0.02, None)])
def test_disk_boundary_edges_have_the_requested_size(h, h_max):
    m = read_mesh({"type": "disk", "center": [0.2, 0.2], "radius": 0.05, "h": h, "h_max": h_max,
                   "name": "surface"}, "mesh", None)
    r = _edge_ratios(m, "surface", h)
    assert np.all(np.abs(r - 1.0) <= 0.2), (r.min(), r.max())
    if h_max is not None:  # and the interior is coarser
        assert m.n_cells < np.pi * 0.05 ** 2 / h ** 2  # fewer than cells of size h everywhere


@pytest.mark.parametrize("h, h_max", [(0.0357, None), (0.02, None), (0.01, 0.1)])
def test_outline_boundary_edges_have_the_requested_size(h, h_max):
    """A stamp-like outline (lines and a quarter arc)."""
    loop = [{"line": [[0.0, 1.75], [0.0, 0.625]], "name": "axis"},
            {"arc": {"start": [0.0, 0.625], "center": [0.0, 1.125], "end": [-0.5, 1.125]}, "name": "round"},
            {"line": [[-0.5, 1.125], [-0.5, 1.75]], "name": "side"},
            {"line": [[-0.5, 1.75], [0.0, 1.75]], "name": "top"}]
    m = read_mesh({"type": "outline", "loops": [loop], "h": h, "h_max": h_max, "refine": []}, "mesh", None)
    r = _edge_ratios(m, "all", h)
    assert np.all(np.abs(r - 1.0) <= 0.2), (r.min(), r.max())


def test_a_hole_outside_its_outline_is_an_input_error():
    """A hole crossing the outer loop is named before gmsh sees it (gmsh hung on the pump's
    first cavity, which reached above the structure); the same hole inside meshes, whichever
    way its pieces run."""
    def square(a, b, c, d):
        return [{"line": [[a, c], [b, c]]}, {"line": [[b, c], [b, d]]}, {"line": [[b, d], [a, d]]},
                {"line": [[a, d], [a, c]]}]

    with pytest.raises(InputError) as e:
        read_mesh({"type": "outline", "loops": [square(0, 1, 0, 1), square(0.5, 1.5, 0.2, 0.4)], "h": 0.1, "h_max": None, "refine": []},
                  "mesh", None)
    assert e.value.field == "mesh.loops[1]" and "strictly inside the outer loop" in str(e.value)
    m = read_mesh({"type": "outline", "loops": [square(0, 1, 0, 1), square(0.3, 0.6, 0.2, 0.4)[::-1]], "h": 0.1, "h_max": None, "refine": []},
                  "mesh", None)
    assert m.n_cells > 0


def test_meshing_keeps_a_write_to_a_closed_pipe_an_exception():
    """gmsh's initialisation resets SIGPIPE to 'terminate'; after a mesh is made, a write to a
    closed pipe must still raise BrokenPipeError rather than kill the process (a Dask client's
    closing socket did, exit 141). Checked in a child process, which is what dies otherwise."""
    child = textwrap.dedent("""
        import os
        from fsci.config import read_mesh
        read_mesh({"type": "disk", "center": [0, 0], "radius": 1.0, "h": 0.5, "h_max": None, "name": "s"}, "mesh", None)
        r, w = os.pipe()
        os.close(r)
        try:
            os.write(w, b"x")
        except BrokenPipeError:
            print("BrokenPipeError")
    """)
    done = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and done.stdout.strip() == "BrokenPipeError", (done.returncode, done.stderr)


def test_a_mesh_does_not_depend_on_the_process_that_asks_for_it():
    """gmsh, called inside a process that had loaded numba, scipy and MKL, meshed the pump's upper
    body (``r = 2``) with 3182 instead of 3198 nodes in about one process in eight (the same
    input; 3 of 24 processes of this very script). Meshed in a clean child process it is the
    same in every process: eight processes with the solver loaded must agree to the bit (with
    the old in-process meshing 6 of 12 runs of this test failed)."""
    child = textwrap.dedent("""
        import hashlib
        import fsci.simulation  # the solver's libraries loaded, as in a run
        from fsci.cases import get_case
        from fsci.config import apply_override, problem_from_dict
        case = get_case("pump")
        apply_override(case, "r=2")
        p = problem_from_dict(case)
        for b in p.bodies:
            print(b.name, len(b.mesh.nodes), hashlib.sha1(b.mesh.nodes.tobytes() + b.mesh.cells.tobytes()).hexdigest())
    """)
    runs = [subprocess.Popen([sys.executable, "-c", child], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                             text=True) for _ in range(8)]
    out = [r.communicate(timeout=600)[0].strip() for r in runs]
    assert all(r.returncode == 0 for r in runs)
    assert len(set(out)) == 1, out


def test_errors_of_the_meshing_process_reach_the_caller(monkeypatch):
    """An input error found in the meshing process arrives as that error, with its field; a
    meshing process that ends without an answer is a MeshError naming its exit status."""
    triangle = [{"line": [[0, 0], [1, 0]]}, {"line": [[1, 0], [1, 1]]}, {"line": [[1, 1], [0, 0]]}]
    with pytest.raises(InputError) as e:
        read_mesh({"type": "outline", "loops": [triangle], "h": 0.1, "h_max": None,
                   "refine": [{"point": [0.5, 0.2], "h": -1.0, "radius": 0.1}]}, "mesh", None)
    assert e.value.field == "mesh.refine[0]" and "h > 0" in str(e.value)
    monkeypatch.setattr(gmsh_io.sys, "executable", "false")
    with pytest.raises(MeshError, match="status 1 without a mesh"):
        gmsh_io.mesh_outline([triangle], 0.1)
