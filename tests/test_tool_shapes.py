"""The tool-shape registry (fenics_plast/tool_shapes/, one module per shape) and each shape's one gap
formula read three ways: the UFL expression (static solver), numpy (reports) and the compiled gap
(explicit solver) give the same g and N; N is a unit vector and the gradient of g wherever g is smooth;
the compiled contact kernel takes every shape; the schema, validation and ``Tool`` follow the registry.

A new shape adds its example to :data:`EXAMPLES` (the first test fails until it does).
"""
from __future__ import annotations

import pkgutil
from pathlib import Path

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dm
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast import dolfinx_compat as dc
from fenics_plast import schema, tool_shapes
from fenics_plast.errors import SceneError
from fenics_plast.solvers import tool_gaps
from fenics_plast.tools import Tool, piecewise_path

REPO = Path(__file__).resolve().parent.parent

#: per shape and dimension: key values of a tool that crosses the sample box [-1, 3] x [-1, 2] (x [-1, 1.5])
EXAMPLES = {
    "plane": {2: dict(point=(0.1, 0.2), normal=(0.3, 1.0)),
              3: dict(point=(0.1, 0.2, 0.3), normal=(0.3, 1.0, -0.4))},
    "circle": {2: dict(center=(1.1, 0.4), radius=0.7)},
    "sphere": {3: dict(center=(1.1, 0.4, 0.2), radius=0.7)},
    "cylinder": {3: dict(center=(0.9, 0.5, 0.0), axis=(0.2, 1.0, 0.3), radius=0.6)},
    "torus": {3: dict(center=(0.8, 0.4, 0.1), axis=(0.0, 0.3, 1.0), ring_radius=0.9, radius=0.35)},
    "profile": {2: dict(segments=(("line", (0.5, -1.5), (0.5, -0.4)), ("arc", (0.9, -0.4), 0.4, 180, 90),
                                  ("line", (0.9, 0.0), (2.5, 0.0)))),
                3: dict(segments=(("line", (0.5, -1.5), (0.5, -0.4)), ("arc", (0.9, -0.4), 0.4, 180, 90),
                                  ("line", (0.9, 0.0), (2.5, 0.0))), center=(0.9, 0.5, 0.3), axis=(0.1, 0.2, 1.0))},
    "box": {2: dict(center=(1.0, 0.3), half_sizes=(0.8, 0.4), edge_radius=0.3),
            3: dict(center=(1.0, 0.3, 0.2), half_sizes=(0.8, 0.4, 0.5), edge_radius=0.3)},
}
CASES = [(name, dim) for name, by_dim in EXAMPLES.items() for dim in by_dim]
T = 0.7                                                      # the time the tools are read at


def tool(name, dim):
    path = piecewise_path([0.0, 1.0], [0.0, 0.3], [0.0, -0.2], *([[0.0, 0.1]] if dim == 3 else []))
    return Tool(name, path=path, dim=dim, **EXAMPLES[name][dim])


def points(dim, n=400, seed=3):
    lo, hi = np.array([-1.0, -1.0, -1.0][:dim]), np.array([3.0, 2.0, 1.5][:dim])
    return np.random.default_rng(seed).uniform(lo, hi, (n, dim))


def test_every_shape_module_is_registered_has_an_example_and_feeds_the_schema():
    modules = {m.name for m in pkgutil.iter_modules(tool_shapes.__path__)} - {"ops", "axis"}
    shapes = tool_shapes.shapes()
    assert set(shapes) == modules                                   # one module per shape, no list to edit
    assert set(EXAMPLES) == set(shapes)
    assert all(set(EXAMPLES[s.name]) == set(s.dims) for s in shapes.values())
    # the analytic shapes, then the meshed tool (fenics_plast.meshed_tools, no gap formula)
    assert schema.TOOL_SHAPES == tuple(shapes) and schema.choices("tools.*.shape") == tuple(shapes) + ("mesh",)
    assert len({s.code for s in shapes.values()}) == len(shapes) and min(s.code for s in shapes.values()) >= 0
    table = schema.SCHEMA["tools"]
    for s in shapes.values():
        for key in s.params:
            assert s.name in table.keys[key].when["shape"]
    assert table.keys["center"].when["shape"] == tuple(s.name for s in shapes.values() if "center" in s.params)


@pytest.mark.parametrize("name,dim", CASES)
def test_numpy_compiled_and_gradient_agree(name, dim):
    """numpy == compiled (tool_gaps) to round-off; |N| = 1; N = grad g (central differences) at the
    points where g is smooth (all but those near a kink of the distance: >= 90 %)."""
    t, x = tool(name, dim), points(dim)
    g, N = t.gap_np(x, T)
    assert (g < 0).sum() > 10 and (g > 0).sum() > 10
    np.testing.assert_allclose(np.linalg.norm(N, axis=1), 1.0, rtol=1e-12)
    gap = tool_gaps.gap_2d if dim == 2 else tool_gaps.gap_3d
    d = tuple(float(c) for c in t.translation(T, use_ufl=False))
    compiled = [gap(t.shape.code, t.params, tuple(p), d) for p in x]
    np.testing.assert_allclose([c[0] for c in compiled], g, rtol=0, atol=1e-13)
    np.testing.assert_allclose([c[1] for c in compiled], N, rtol=0, atol=1e-13)
    h = 1e-6
    grad = np.stack([(t.gap_np(x + h * e, T)[0] - t.gap_np(x - h * e, T)[0]) / (2 * h) for e in np.eye(dim)], axis=1)
    smooth = np.abs(grad - N).max(axis=1) < 1e-6
    assert smooth.mean() >= 0.9, smooth.mean()


def _mesh(dim):
    if dim == 2:
        return dm.create_rectangle(MPI.COMM_WORLD, [np.array([-1.0, -1.0]), np.array([3.0, 2.0])], [8, 6],
                                   dm.CellType.quadrilateral)
    return dm.create_box(MPI.COMM_WORLD, [np.array([-1.0, -1.0, -1.0]), np.array([3.0, 2.0, 1.5])], [4, 3, 3],
                         dm.CellType.hexahedron)


@pytest.mark.parametrize("name,dim", CASES)
def test_ufl_equals_numpy(name, dim):
    """The UFL gap (the static solver's, at displaced points and a UFL time) == numpy, its derivative
    along a displacement == the numpy gap's directional difference, and the Jacobian of a penalty residual
    built on it compiles."""
    t = tool(name, dim)
    msh = _mesh(dim)
    V = dc.vector_space(msh)
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([0.03 * np.sin(3 * x[1] + 1), 0.02 * np.cos(2 * x[0]), 0.02 * x[0]][:dim]))
    x = ufl.SpatialCoordinate(msh) + u
    g, N = t.gap(x, fem.Constant(msh, PETSc.ScalarType(T)))
    direction = np.array([0.4, -0.3, 0.2][:dim])
    w = fem.Function(V)
    w.interpolate(lambda x: np.tile(direction[:, None], (1, x.shape[1])))
    dg = ufl.derivative(g, u, w)                                  # what Newton differentiates
    q = np.array([[a, b, c][:msh.topology.dim] for a in (0.0, 0.37, 1.0) for b in (0.0, 0.61, 1.0)
                  for c in ((0.0, 0.29, 1.0) if dim == 3 else (0.0,))])
    cells = np.arange(msh.topology.index_map(dim).size_local, dtype=np.int32)
    vals = dc.eval_expression(fem.Expression(ufl.as_vector([g, dg, *(N[i] for i in range(dim))]), q), msh, cells)
    vals = vals.reshape(-1, 2 + dim)
    xs = dc.eval_expression(fem.Expression(x, q), msh, cells).reshape(-1, dim)
    g_np, N_np = t.gap_np(xs, T)
    assert (g_np < 0).any() and (g_np > 0).any()
    assert np.max(np.abs(vals[:, 0] - g_np)) <= 1e-12
    assert np.max(np.abs(vals[:, 2:] - N_np)) <= 1e-12
    h = 1e-6
    fd = (t.gap_np(xs + h * direction, T)[0] - t.gap_np(xs - h * direction, T)[0]) / (2 * h)
    assert np.mean(np.abs(vals[:, 1] - fd) < 1e-6) >= 0.9
    # the penalty residual's Jacobian compiles (FFCx factors it): what the static solver's Newton assembles
    v = ufl.TestFunction(V)
    residual = ufl.inner(ufl.conditional(ufl.lt(g, 0.0), -g, 0.0) * N, v) * ufl.ds
    fem.form(ufl.derivative(residual, u))


def test_validation_reads_the_registry():
    """A shape outside its dimensions, a key its dimension requires, a value its packing refuses and a
    shape's own check: each a scene error naming the key."""
    from fenics_plast.problem import parse_problem
    scene = REPO / "demos" / "ring_compression.toml"
    cases = {
        '[tools.x]\nshape = "sphere"\ncenter = [0, 0]\nradius = 1.0\n':
            "tools.x.shape = 'sphere' is a 3-D tool (mesh.geometry = '3d'): in 2-D use 'circle'",
        '[tools.x]\nshape = "circle"\nradius = 1.0\n':
            "tools.x.center is missing: required for shape = 'circle'",
        '[tools.x]\nshape = "plane"\npoint = [0, 0]\nnormal = [0, 0]\n':
            "tools.x: plane normal must be a non-zero 2-vector",
        '[tools.x]\nshape = "profile"\nsegments = [{ line = [[0, 0], [1, 0]] }, { line = [[2, 0], [3, 0]] }]\n':
            "tools.x: profile pieces 0 and 1 do not join",
        '[tools.x]\nshape = "profile"\ncenter = [0, 0]\nsegments = [{ line = [[0, 0], [1, 0]] }]\n':
            "tools.x.center is for 3-D profiles only",
    }
    for extra, message in cases.items():
        with pytest.raises(SceneError) as e:
            parse_problem(scene.read_text() + "\n" + extra, scene)
        assert message in str(e.value)


def test_tool_refuses_unknown_shapes_and_missing_keys():
    with pytest.raises(ValueError, match="unknown tool shape 'cone'"):
        Tool("cone", radius=1.0)
    with pytest.raises(ValueError, match="needs 'radius'"):
        Tool("circle", center=(0.0, 0.0))
    with pytest.raises(ValueError, match="exists in 3-D, not in 2-D"):
        Tool("sphere", center=(0.0, 0.0, 0.0), radius=1.0, dim=2)


def test_box_closed_form():
    """A box of core half sizes (1, 2, 3) and edge radius 0.5: on the faces' normals, beyond an edge and a
    corner, on the rounded edge (g = 0) and inside; the 2-D box is its (x, y) section."""
    box = Tool("box", center=(0.0, 0.0, 0.0), half_sizes=(1.0, 2.0, 3.0), edge_radius=0.5)
    t = np.radians(30.0)
    x = np.array([[3.0, 0.0, 0.0], [0.0, -4.0, 1.0], [2.0, 3.0, 0.0], [-2.0, 3.0, 4.0],
                  [1.0 + 0.5 * np.cos(t), 2.0 + 0.5 * np.sin(t), 0.0], [0.5, 0.0, 0.0], [0.0, 0.0, -2.9]])
    g, N = box.gap_np(x, 0.0)
    r2, r3 = np.sqrt(2.0), np.sqrt(3.0)
    np.testing.assert_allclose(g, [1.5, 1.5, r2 - 0.5, r3 - 0.5, 0.0, -1.0, -0.6], atol=1e-14)
    np.testing.assert_allclose(N, [[1, 0, 0], [0, -1, 0], [1 / r2, 1 / r2, 0], [-1 / r3, 1 / r3, 1 / r3],
                                   [np.cos(t), np.sin(t), 0], [1, 0, 0], [0, 0, -1]], atol=1e-14)
    flat = Tool("box", center=(0.0, 0.0), half_sizes=(1.0, 2.0), edge_radius=0.5)
    g2, N2 = flat.gap_np(x[[0, 2, 4, 5], :2], 0.0)
    np.testing.assert_allclose(g2, g[[0, 2, 4, 5]], atol=1e-14)
    np.testing.assert_allclose(N2, N[[0, 2, 4, 5], :2], atol=1e-14)


def _scene_with_box(scene, plane_block, box_block, tmp_path, name):
    """``scene``'s text with its mesh file made absolute and its plane tool replaced by a box, written to
    tmp_path; (plane scene path, box scene path)."""
    text = scene.read_text()
    mesh = next(ln.split('"')[1] for ln in text.splitlines() if ln.startswith("file = "))
    text = text.replace(f'file = "{mesh}"', f'file = "{(scene.parent / mesh).resolve()}"')
    assert plane_block in text
    paths = (tmp_path / f"{name}_plane.toml", tmp_path / f"{name}_box.toml")
    paths[0].write_text(text)
    paths[1].write_text(text.replace(plane_block, box_block))
    return paths


@pytest.mark.parametrize("case", ["static", "explicit"])
def test_a_box_whose_face_is_the_plane_acts_as_the_plane(case, tmp_path):
    """A wide box (edge radius 0) whose lower (upper) face lies on a scene's plane tool gives the plane's
    run: the frictionless coarse ring compression (static: the box through the UFL contact and Newton) and
    the Taylor bar against its wall (explicit: the compiled gap), to round-off. The box goes through the
    scene keys, validation, build and both solvers."""
    import scene_runs
    if case == "static":
        scene, out_cols = REPO / "demos" / "ring_compression.toml", ("die_force_kN", "inner_radius_mm")
        plane = 'shape = "plane"\npoint = [0.0, 10.0]\nnormal = [0.0, -1.0]\n'
        box = 'shape = "box"\ncenter = [0.0, 15.0]\nhalf_sizes = [100.0, 5.0]\n'
        sets = ["mesh.parameters.cells_radial=6", "mesh.parameters.cells_axial=4", "analysis.increments=10",
                "analysis.max_increment=0.1"]
        sets += [f"contact.{p}.friction=0.0" for p in ("die", "die_inner", "die_outer")]
    else:
        scene, out_cols = REPO / "demos" / "taylor_bar_wall.toml", ("length_mm", "radius_mm", "wall_force_kN")
        plane = 'shape = "plane"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n'
        box = 'shape = "box"\ncenter = [0.0, -5.0]\nhalf_sizes = [100.0, 5.0]\n'
        sets = ["analysis.end_time=10"]
    sets += ["output.xdmf=false", "output.plots=false"]
    runs = {}
    for path in _scene_with_box(scene, plane, box, tmp_path, case):
        out = tmp_path / path.stem
        runs[path.stem] = (scene_runs.run_scene(path, out, *sets), scene_runs.history(out))
    (_, hp), (_, hb) = runs[f"{case}_plane"], runs[f"{case}_box"]
    assert len(hp) == len(hb) > 2
    for col in out_cols:
        assert np.abs(hp[col]).max() > 0
        np.testing.assert_allclose(hb[col], hp[col], rtol=1e-9, atol=1e-9 * np.abs(hp[col]).max())
