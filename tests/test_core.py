"""Core pieces: quadrature exactness, sparse pattern assembly, meshes, time functions,
expressions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fsci.errors import InputError, MeshError
from fsci.expressions import Expression
from fsci.fem.quadrature import gauss_line, gauss_quad, gauss_triangle, triangle_rule
from fsci.fem.sparse import DofLayout, Pattern, add_local
from fsci.mesh import generate
from fsci.mesh.gmsh_io import initialize_gmsh, mesh_outline, read_msh
from fsci.mesh.quadmesh import QuadMesh
from fsci.timefunc import make_time_function


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_gauss_line_and_quad_exact_degree(n):
    x, w = gauss_line(n)
    for k in range(2 * n):
        exact = (1 - (-1) ** (k + 1)) / (k + 1)
        assert abs(np.dot(w, x ** k) - exact) < 1e-13
    p, w = gauss_quad(n)
    for a in range(2 * n):
        for b in range(2 * n):
            ex = (1 - (-1) ** (a + 1)) / (a + 1) * (1 - (-1) ** (b + 1)) / (b + 1)
            assert abs(np.dot(w, p[:, 0] ** a * p[:, 1] ** b) - ex) < 1e-12


@pytest.mark.parametrize("degree", [1, 2, 4, 6, 8])
def test_triangle_rule_exact_for_total_degree(degree):
    p, w = gauss_triangle(degree)
    for a in range(degree + 1):
        for b in range(degree + 1 - a):
            exact = math.factorial(a) * math.factorial(b) / math.factorial(a + b + 2)
            assert abs(np.dot(w, p[:, 0] ** a * p[:, 1] ** b) - exact) < 1e-14
    # mapped rule on an arbitrary triangle integrates x^2 y exactly
    tri = np.array([[[0.3, 0.1], [1.7, 0.4], [0.9, 1.3]]])
    pts, wts = triangle_rule(tri, 3)
    e1, e2 = tri[0, 1] - tri[0, 0], tri[0, 2] - tri[0, 0]
    area = 0.5 * abs(e1[0] * e2[1] - e1[1] * e2[0])
    assert abs(wts.sum() - area) < 1e-14


def test_pattern_assembly_equals_dense_assembly():
    """Random element blocks over mixed 2/3-dof nodes: CSR assembly equals dense assembly."""
    rng = np.random.default_rng(0)
    ndof = rng.choice([2, 3], size=12)
    lay = DofLayout(ndof)
    conn = np.array([rng.choice(12, size=4, replace=False) for _ in range(15)])
    conn[3, 2] = -1  # a slot without dofs is skipped
    pat = Pattern(lay, [conn])
    data = np.zeros(pat.nnz)
    rhs = np.zeros(lay.n_dofs)
    dense = np.zeros((lay.n_dofs, lay.n_dofs))
    dense_rhs = np.zeros(lay.n_dofs)
    pos = pat.positions(conn)
    for e, nodes in enumerate(conn):
        dofs = np.concatenate([lay.start[a] + np.arange(ndof[a]) for a in nodes if a >= 0])
        K = rng.standard_normal((len(dofs), len(dofs)))
        R = rng.standard_normal(len(dofs))
        add_local(data, rhs, pat.row_base, pat.row_len, lay.start, lay.ndof, nodes, pos[e], K, R, True)
        dense[np.ix_(dofs, dofs)] += K
        dense_rhs[dofs] += R
    assert np.allclose(pat.matrix(data).toarray(), dense)
    assert np.allclose(rhs, dense_rhs)
    diag = pat.diagonal_positions()
    assert np.array_equal(pat.indices[diag], np.arange(lay.n_dofs))


def test_pattern_reach_couples_only_across_its_two_groups_and_covers_what_it_holds():
    """A pattern with a reach block ``(A, B)`` holds every pair of a node of ``A[e]`` with one
    of ``B[e]`` (both ways) and no pair inside ``A[e]`` or ``B[e]``; :meth:`Pattern.covers` is
    True for blocks of such pairs and False for one more pair, whose positions are refused;
    the pattern rebuilt from its node graph is the same pattern."""
    lay = DofLayout(np.array([2, 2, 3, 3, 3, 3]))
    pat = Pattern(lay, [np.array([[0, 1]])], reach=[(np.array([[0, -1]]), np.array([[2, 3]]))])
    pairs = {(a, int(b)) for a in range(6) for b in pat.nbr[pat.nptr[a]:pat.nptr[a + 1]]}
    assert pairs == {(a, a) for a in range(6)} | {(0, 1), (1, 0), (0, 2), (2, 0), (0, 3), (3, 0)}
    assert pat.covers([np.array([[0, 2], [3, 0], [1, -1]])])
    assert not pat.covers([np.array([[2, 3]])])  # inside one group
    assert not pat.covers([np.array([[1, 2]])])  # a node not in the reach row
    with pytest.raises(ValueError, match="not in the sparsity pattern"):
        pat.positions(np.array([[1, 2]]))
    again = Pattern.from_graph(lay, pat.nptr, pat.nbr)
    assert again.key == pat.key
    assert np.array_equal(again.indptr, pat.indptr) and np.array_equal(again.indices, pat.indices)
    # a matrix assembled into the larger pattern equals the one of its own pattern
    conn = np.array([[0, 2]])
    own = Pattern(lay, [conn])
    K, R = np.arange(25.0).reshape(5, 5), np.ones(5)
    mats = []
    for p in (own, pat):
        data, rhs = np.zeros(p.nnz), np.zeros(lay.n_dofs)
        add_local(data, rhs, p.row_base, p.row_len, lay.start, lay.ndof, conn[0], p.positions(conn)[0], K, R, True)
        mats.append(p.matrix(data).toarray())
    assert np.array_equal(mats[0], mats[1])


def test_diagonal_block_assembly_equals_full_assembly_of_block_diagonal_locals():
    """Element matrices whose node-pair blocks are diagonal (the faces' CIP / ghost penalty)
    over 3-dof nodes: adding only the diagonal entries gives the matrix and residual that
    :func:`add_local` gives from the whole block; a local matrix with an off-diagonal entry
    does not (the shortcut is only for the matrices it is documented for)."""
    rng = np.random.default_rng(1)
    lay = DofLayout(np.full(10, 3))
    conn = np.array([rng.choice(10, size=6, replace=False) for _ in range(8)])
    conn[2, 4] = -1  # a slot without dofs is skipped
    pat = Pattern(lay, [conn])
    pos = pat.positions(conn)
    full, part = (np.zeros(pat.nnz), np.zeros(lay.n_dofs)), (np.zeros(pat.nnz), np.zeros(lay.n_dofs))
    for e, nodes in enumerate(conn):
        m = int(np.count_nonzero(nodes >= 0))
        K = np.kron(rng.standard_normal((m, m)), np.ones((3, 3))) * np.kron(np.ones((m, m)), np.eye(3))
        R = rng.standard_normal(3 * m)
        add_local(*full, pat.row_base, pat.row_len, lay.start, lay.ndof, nodes, pos[e], K, R, True)
        add_local(*part, pat.row_base, pat.row_len, lay.start, lay.ndof, nodes, pos[e], K, R, True, True)
    assert np.array_equal(full[0], part[0]) and np.array_equal(full[1], part[1])
    K[0, 1] = 1.0  # a coupling of two components: left out
    add_local(*full, pat.row_base, pat.row_len, lay.start, lay.ndof, conn[-1], pos[-1], K, R, True)
    add_local(*part, pat.row_base, pat.row_len, lay.start, lay.ndof, conn[-1], pos[-1], K, R, True, True)
    assert not np.allclose(full[0], part[0])


def test_structured_and_graded_meshes():
    m = generate.rectangle(0, 2, 0, 1, 4, 2)
    m.check()
    assert m.n_cells == 8 and abs(m.cell_areas().sum() - 2.0) < 1e-14
    assert set(m.edge_sets) >= {"left", "right", "bottom", "top", "all"}
    for name, e in m.edge_sets.items():
        bnd = {tuple(x) for x in m.boundary.edges}
        assert all(tuple(x) in bnd for x in e), name  # oriented with the cell on the left
    x = generate.graded(0.0, 1.0, 10, ratio=4.0)
    d = np.diff(x)
    assert abs(d[-1] / d[0] - 4.0) < 1e-12 and abs(x[-1] - 1.0) < 1e-15


def test_mapped_mesh_follows_an_arc():
    r = 0.05
    x0 = 0.2 + math.sqrt(r * r - 0.01 ** 2)
    from fsci.config import curve

    left = curve({"arc": {"start": [x0, 0.19], "center": [0.2, 0.2], "end": [x0, 0.21]}})
    line = lambda a, b: (lambda s: np.asarray(a)[None] + np.asarray(s)[:, None] * (np.asarray(b) - np.asarray(a))[None])
    m = generate.mapped(line([x0, 0.19], [0.6, 0.19]), line([0.6, 0.19], [0.6, 0.21]), line([x0, 0.21], [0.6, 0.21]),
                        left, 20, 4)
    m.check()
    ln = m.node_sets["left"]
    assert np.allclose(np.linalg.norm(m.nodes[ln] - [0.2, 0.2], axis=1), r)


def test_gmsh_outline_and_msh_roundtrip(tmp_path):
    loop = [{"line": [[0, 0], [1, 0]], "name": "bottom"},
            {"arc": {"start": [1, 0], "center": [0, 0], "end": [0, 1]}, "name": "round"},
            {"line": [[0, 1], [0, 0]], "name": "axis"}]
    m = mesh_outline([loop], 0.1)
    m.check()
    assert abs(m.cell_areas().sum() - math.pi / 4) < 5e-3
    assert set(m.edge_sets) >= {"bottom", "round", "axis", "all"}
    assert np.allclose(np.linalg.norm(m.nodes[m.node_sets["round"]], axis=1), 1.0, atol=1e-12)
    import gmsh

    initialize_gmsh()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("sq")
        geo = gmsh.model.geo
        p = [geo.addPoint(*c, 0, 0.25) for c in ((0, 0), (2, 0), (2, 1), (0, 1))]
        l = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
        s = geo.addPlaneSurface([geo.addCurveLoop(l)])
        geo.mesh.setTransfiniteSurface(s)
        for li in l:
            geo.mesh.setTransfiniteCurve(li, 5)
        geo.mesh.setRecombine(2, s)
        geo.synchronize()
        gmsh.model.addPhysicalGroup(1, [l[0]], name="floor")
        gmsh.model.addPhysicalGroup(2, [s], name="dom")
        gmsh.model.mesh.generate(2)
        path = str(tmp_path / "sq.msh")
        gmsh.write(path)
    finally:
        gmsh.finalize()
    m2 = read_msh(path)
    assert m2.n_cells == 16 and abs(m2.cell_areas().sum() - 2.0) < 1e-12
    assert np.allclose(m2.nodes[m2.node_sets["floor"], 1], 0.0)


def test_mesh_check_reports_inverted_and_degenerate_cells():
    nodes = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [2, 0], [2, 1]], float)
    bad = QuadMesh(nodes, np.array([[0, 1, 2, 3], [1, 5, 4, 2]]))  # second cell is a bow-tie
    with pytest.raises(MeshError, match="cell 1 is inverted"):
        bad.check()
    flat = QuadMesh(np.array([[0, 0], [1, 0], [2, 0], [1, 0]], float), np.array([[0, 1, 2, 3]]))
    with pytest.raises(MeshError, match="degenerate"):
        flat.check()


def test_time_functions():
    ramp = make_time_function({"type": "ramp", "t0": 1.0, "t1": 3.0})
    assert ramp(0.5) == 0.0 and ramp(2.0) == 0.5 and ramp(5.0) == 1.0
    th = make_time_function({"type": "one_minus_cos", "t1": 2.0})
    assert abs(th(1.0) - 0.5) < 1e-15 and th(3.0) == 1.0
    per = make_time_function({"type": "one_minus_cos", "period": 0.05, "amplitude": 1.5})
    assert abs(per(0.025) - 3.0) < 1e-12 and abs(per(0.05)) < 1e-12
    tab = make_time_function({"type": "table", "times": [0, 1, 2], "values": [0, 2, 2]})
    assert tab(0.5) == 1.0 and tab(10) == 2.0
    lin = make_time_function({"type": "linear", "slope": 0.5, "t0": 1000})
    assert lin(900) == 0.0 and lin(1010) == 5.0
    with pytest.raises(InputError, match="t1"):
        make_time_function({"type": "ramp", "t0": 1.0, "t1": 1.0})
    with pytest.raises(InputError, match="type"):
        make_time_function({"type": "wiggle"})


def test_expressions_are_whitelisted():
    e = Expression("1.5*U*4*y*(H - y)/H**2", {"U": 0.2, "H": 0.41})
    assert abs(float(e(0.0, 0.205)) - 0.3) < 1e-14
    assert np.allclose(Expression("sin(pi*x)*t")(np.array([0.5, 1.0]), 0.0, 2.0), [2.0, 0.0], atol=1e-15)
    with pytest.raises(InputError, match="unknown name 'z'"):
        Expression("z + 1")
    with pytest.raises(InputError):
        Expression("__import__('os')")
    with pytest.raises(InputError):
        Expression("x +* 2")


@pytest.mark.parametrize("text", ["0", "2*a + sqrt(2)", "log(0)", "-pi/a"])
def test_an_expression_without_x_y_t_is_made_once_with_the_shape_of_its_arguments(text):
    """A constant expression (no x, y or t; boundary values asked for at every step) gives
    the value its evaluation gives, in the broadcast shape of x and y, for every t."""
    e = Expression(text, {"a": 1.5})
    # the same expression made to depend on x is evaluated every call
    general = Expression(f"({text}) + 0*x", {"a": 1.5})
    x = np.linspace(0.0, 1.0, 5)
    for args in ((x, 0.0, 0.0), (0.0, x[:, None], 3.0), (x, x, -1.0), (0.0, 0.0, 2.0)):
        got, want = e(*args), general(*args)
        assert got.shape == want.shape == np.broadcast(np.asarray(args[0]), np.asarray(args[1])).shape
        assert np.array_equal(got, want)
    with pytest.raises(InputError, match="division by zero"):
        Expression("1/(a - 1.5)", {"a": 1.5})
