"""The Taylor bar converged in a minute (demos/taylor_bar_accurate.toml, issue 13).

The scene meshes meshes/round_bar_graded.geo, graded toward the impact face (axial_size_ratio =
top cell height / face cell height) and the outer surface (radial_size_ratio = axis cell width /
outer cell width), at mesh.refine = 2 of a 6 x 18 base, with the element stable step. Its outputs
declare the Richardson limit of the uniform-mesh study (docs/STUDIES.md) as their references.

Fast: the mesh is graded as declared (heights growing geometrically upward from the face, widths
shrinking geometrically toward r = R, the smallest cell at the face's outer corner; refine keeps the
ratios); with both ratios 1 the file gives round_bar.geo's mesh node for node; the same family at
refine = 1 (108 cells) runs the whole 80 us and lands within 1 % of the limit.
@slow: the scene as shipped, within 0.5 % of the limit on the radius and the length.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import scene_runs
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.meshing import mesh_from_file
from fenics_plast.problem import load_problem

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "demos" / "taylor_bar_accurate.toml"
#: Richardson limit of the uniform-mesh study (refine 1, 2, 4 of demos/taylor_bar.toml), docs/STUDIES.md
R_INF, L_INF = 7.22863, 21.4228
SERIAL = MPI.COMM_WORLD.size == 1
needs_serial = pytest.mark.skipif(not SERIAL, reason="starts its own process")


def cells_of(parameters, refine=1, geo="round_bar_graded.geo"):
    """Per cell (centre r, centre z, width, height) of a structured bar mesh, and its node coordinates."""
    mesh, *_ = mesh_from_file(MPI.COMM_SELF, ROOT / "meshes" / geo, parameters, refine)
    x = mesh.geometry.x[:, :2]
    P = x[dc.geometry_dofs(mesh)]     # (cells, 4 vertices, 2)
    lo, hi = P.min(axis=1), P.max(axis=1)
    return np.column_stack([(lo + hi) / 2, hi - lo]), x


def geometric(total, n, ratio):
    """Sizes of n cells filling `total`, growing geometrically by `ratio` from the first to the last."""
    p = ratio ** (1.0 / (n - 1))
    return total * p ** np.arange(n) * (p - 1) / (p ** n - 1)


@pytest.fixture(scope="module")
def scene():
    return load_problem(SCENE)


@pytest.mark.parametrize("refine", [1, 2])
def test_mesh_is_graded_as_declared(scene, refine):
    """Heights grow from the impact face by the declared ratio, widths shrink toward r = R by the
    declared ratio, both geometrically; the smallest cell is at the face's outer corner."""
    par = scene.mesh.parameters
    nr, nz = int(par["cells_radial"]) * refine, int(par["cells_axial"]) * refine
    c, _ = cells_of(par, refine)
    assert len(c) == nr * nz
    R, L = par["radius"], par["length"]
    heights = geometric(L, nz, par["axial_size_ratio"])               # from z = 0 up
    widths = geometric(R, nr, par["radial_size_ratio"])[::-1]         # from the axis out
    row = np.searchsorted(np.cumsum(heights), c[:, 1])                # each cell's row and column
    col = np.searchsorted(np.cumsum(widths), c[:, 0])
    assert sorted(zip(row, col)) == [(i, j) for i in range(nz) for j in range(nr)]
    np.testing.assert_allclose(c[:, 3], heights[row], rtol=1e-6)       # (Gmsh: ~5e-8)
    np.testing.assert_allclose(c[:, 2], widths[col], rtol=1e-6)
    assert heights[-1] / heights[0] == pytest.approx(par["axial_size_ratio"], rel=1e-12)
    assert widths[0] / widths[-1] == pytest.approx(par["radial_size_ratio"], rel=1e-12)
    smallest = np.argmin(np.minimum(c[:, 2], c[:, 3]))
    assert (row[smallest], col[smallest]) == (0, nr - 1)
    if refine == scene.mesh.refine:      # the scene's own mesh: 12 x 36, face cells 0.16 mm high
        assert (nr, nz) == (12, 36) and heights[0] == pytest.approx(0.1637, abs=1e-4)


def test_ratios_one_give_round_bar_mesh():
    """round_bar_graded.geo with both ratios 1 is round_bar.geo (no imperfection, no grading)."""
    par = dict(radius=3.2, length=32.4, cells_radial=6, cells_axial=36)
    _, x_graded = cells_of(dict(par, axial_size_ratio=1.0, radial_size_ratio=1.0))
    _, x_plain = cells_of(par, geo="round_bar.geo")
    assert np.array_equal(x_graded, x_plain)


def run_scene(out, *sets):
    """summary.json of a CLI run of the scene (no fields, no figures)."""
    return scene_runs.run_scene(SCENE, out, "output.xdmf=false", "output.plots=false", *sets)


def errors(s):
    return (s["radius_mm"] - R_INF) / R_INF, (s["length_mm"] - L_INF) / L_INF


@needs_serial
def test_coarse_family_member_runs(tmp_path):
    """refine = 1 (6 x 18 cells, 1-2 s): the whole 80 us (the face cells flatten to wedges whose h / c
    would collapse; the element step goes on), within 1 % of the limit; the scene declares the limit."""
    s = run_scene(tmp_path, "mesh.refine=1")
    assert s["converged"] and s["cells"] == 108
    assert s["references"]["radius_mm"]["value"] == R_INF and s["references"]["length_mm"]["value"] == L_INF
    er, el = errors(s)
    assert abs(er) < 0.01 and abs(el) < 0.01, (er, el)
    assert s["energy_balance_error"] < 1e-3


@pytest.mark.slow
@needs_serial
def test_scene_within_half_a_percent_of_the_limit(tmp_path):
    """The scene as shipped (refine = 2, 432 cells, ~44,000 steps, 11-14 s serially): radius and length
    within 0.5 % of the Richardson limit (measured -0.13 % and +0.10 %). The wall time (budget 60 s)
    is the benchmark's to measure (benchmarks/bench_taylor.py), not asserted on a shared machine."""
    s = run_scene(tmp_path)
    er, el = errors(s)
    assert s["converged"] and s["cells"] == 432
    assert abs(er) < 0.005 and abs(el) < 0.005, (er, el, s["wall_time_s"])
