"""Parametric Gmsh geometries (meshes/*.geo) -> dolfinx meshes and tags."""
import numpy as np
import pytest
from mpi4py import MPI

COMM = MPI.COMM_WORLD


def test_meshes_tags_and_parameters():
    from fenics_plast.meshing import bar_mesh, blank_mesh, ring_mesh
    mesh, ct, ft, ids = bar_mesh(COMM, 2.0, 10.0, 3, 7, imperfection=0.1)
    assert {"axis", "bottom", "top", "outer"} <= set(ids)
    assert mesh.topology.index_map(2).size_global == 21
    x = mesh.geometry.x
    rmax_bottom = COMM.allreduce(x[np.isclose(x[:, 1], 0.0), 0].max(initial=0.0), op=MPI.MAX)
    assert rmax_bottom == pytest.approx(1.8)
    mesh, ct, ft, ids = blank_mesh(COMM, 50.0, 1.0, 20, 3, grading=2.0)
    assert {"axis", "lower", "upper", "rim"} <= set(ids)
    assert mesh.topology.index_map(2).size_global == 60
    mesh, ct, ft, ids = ring_mesh(COMM, 1.0, 2.0, 4, 8)
    assert {"inner", "outer", "left", "bottom"} <= set(ids)
    r = np.hypot(mesh.geometry.x[:, 0], mesh.geometry.x[:, 1])
    assert r.min() == pytest.approx(1.0) and r.max() == pytest.approx(2.0)
    n_inner = COMM.allreduce(len([f for f in ft.find(ids["inner"])
                                  if f < mesh.topology.index_map(1).size_local]), op=MPI.SUM)
    assert n_inner == 8


def test_geo_files_define_all_parameters():
    from fenics_plast.meshing import MESH_DIR
    for name in ("round_bar", "circular_blank", "ring"):
        text = (MESH_DIR / f"{name}.geo").read_text()
        assert "DefineConstant" in text and "Transfinite Surface" in text and "Recombine Surface" in text


def test_mesh_parallel_cell_count():
    from fenics_plast.meshing import bar_mesh
    mesh, ct, ft, ids = bar_mesh(COMM, 1.0, 3.0, 4, 10)
    assert mesh.topology.index_map(2).size_global == 40
    n_top = COMM.allreduce(len([f for f in ft.find(ids["top"]) if f < mesh.topology.index_map(1).size_local]),
                           op=MPI.SUM)
    assert n_top == 4


def test_a_parameter_of_one_file_does_not_stick_to_the_next():
    """Gmsh's ONELAB parameters outlive gmsh.finalize: a file meshed with `gap` = 0 (two_bars.geo) left its gap
    to the next file defining a parameter of that name (u_strip.geo, default gap 2 mm: its arms then merged and
    three cells came out inverted). Each meshing starts from a clear ONELAB database."""
    from fenics_plast.meshing import MESH_DIR, mesh_from_file
    first = mesh_from_file(COMM, MESH_DIR / "u_strip.geo", {}, 1, gdim=2)[0]
    mesh_from_file(COMM, MESH_DIR / "two_bars.geo", {"gap": 0.0, "cells_axial": 4}, 1, gdim=2)
    again = mesh_from_file(COMM, MESH_DIR / "u_strip.geo", {}, 1, gdim=2)[0]
    assert again.topology.index_map(2).size_global == first.topology.index_map(2).size_global == 117
    x = again.geometry.x
    assert COMM.allreduce(float(x[:, 0].max()), op=MPI.MAX) == pytest.approx(6.0)
