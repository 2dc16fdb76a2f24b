"""Remeshing, the mesh part (issue 35): quality measures, the deformed outline, the new mesh.

* :mod:`fenics_plast.remeshing.quality` on hand-made cells of known measures, and collectively;
* a round bar (meshes/round_bar.geo, groups axis, bottom, top, outer) bent smoothly, and one with a
  folded corner (cells near the top outer corner at a scaled Jacobian of 0.06, 177 deg): the new
  mesh all quadrilaterals above the thresholds, its area and axisymmetric volume 2 pi int r dA equal
  to the old deformed ones to 1e-12 with straight lines, each group's length to 1e-12 and every old
  facet of a group on new facets of that group; splines: the area difference printed;
* the size near a refinement point ~ h_min; two regions (meshes/two_region_bar.geo) each keeping its
  area; a facet in two groups; serial = ``mpirun -n 2`` (same cells, same area).

Run as a script (``python tests/test_remesh_mesh.py OUT.npz``) it is the helper of the serial = 2
ranks test: it remeshes the bent bar on every rank of its communicator and writes the counts.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from fenics_plast.dolfinx_compat import entity_nodes  # noqa: E402
from fenics_plast.meshing import mesh_from_file  # noqa: E402
from fenics_plast.remeshing.new_mesh import RemeshError, mesh_outline, remesh  # noqa: E402
from fenics_plast.remeshing.outline import crossings, group_lengths, outline  # noqa: E402
from fenics_plast.dolfinx_compat import vector_space  # noqa: E402
from fenics_plast.remeshing.quality import (Thresholds, cell_corners, corner_measures, deformed_nodes,  # noqa: E402
                                            judge, mesh_quality, signed_areas)

COMM = MPI.COMM_WORLD
#: round_bar.geo's defaults (its DefineConstant values) and a finer mesh of it
R, L = 6.413, 26.667
BAR = {"cells_radial": 10, "cells_axial": 40}
H = 0.5


def geo_mesh(path, parameters, comm=COMM, used_groups=None):
    """(mesh, cell_tags, facet_tags, groups) of a .geo with its ONELAB parameters (the package's reader;
    ``used_groups``: as mesh_from_file's, {} to read groups that share facets)."""
    return mesh_from_file(comm, path, parameters, used_groups=used_groups)


def bent(X):
    """A smooth deformation of the bar (mm): a bulge r (1 + 0.3 sin(pi z / L)), the top curved."""
    x = X.copy()
    x[:, 0] = X[:, 0] * (1 + 0.3 * np.sin(np.pi * X[:, 1] / L))
    x[:, 1] = X[:, 1] + 0.1 * X[:, 0] ** 2 / R
    return x


def folded(X, s=1.25):
    """The top outer corner pushed out by s and down by 1.6 s (mm), over a Gaussian of width 1.5 mm:
    the corner cells at a scaled Jacobian of 0.06 and a corner angle of 177 deg, not inverted."""
    phi = np.exp(-((R - X[:, 0]) ** 2 + (L - X[:, 1]) ** 2) / 1.5 ** 2)
    x = X.copy()
    x[:, 0] += s * phi * X[:, 0] / R           # (the axis stays at r = 0)
    x[:, 1] -= 1.6 * s * phi
    return x


def _moment(corners):
    """(cells,) integral of x dA [mm^3] of the quadrilaterals (Green: exact for straight edges)."""
    p, n = corners, np.roll(corners, -1, axis=1)
    cross = p[..., 0] * n[..., 1] - n[..., 0] * p[..., 1]
    return (cross * (p[..., 0] + n[..., 0])).sum(axis=1) / 6.0


def volume(mesh, x=None):
    """(area [mm^2], integral of r dA [mm^3]) of the owned cells, summed over ranks."""
    c = cell_corners(mesh, x)
    return mesh.comm.allreduce(float(signed_areas(c).sum())), mesh.comm.allreduce(float(_moment(c).sum()))


def segments(mesh, facets, x=None):
    """(k, 2, 2) end points of the local ``facets``, owned ones only."""
    x = mesh.geometry.x if x is None else x
    facets = np.asarray(facets, dtype=np.int32)
    facets = facets[facets < mesh.topology.index_map(1).size_local]
    if not len(facets):
        return np.zeros((0, 2, 2))
    return x[entity_nodes(mesh, 1, facets)][:, :, :2]


def gathered(comm, a):
    return np.concatenate(comm.allgather(a))


def on_segments(points, segs, tol):
    """Whether each point (k, 2) lies within ``tol`` of one of the segments (m, 2, 2)."""
    a, b = segs[None, :, 0], segs[None, :, 1]
    d = b - a
    t = np.clip(np.sum((points[:, None] - a) * d, axis=-1) / np.sum(d * d, axis=-1), 0, 1)
    dist = np.linalg.norm(points[:, None] - (a + t[..., None] * d), axis=-1)
    return dist.min(axis=1) <= tol


# -- quality ----------------------------------------------------------------------------------------
def test_quality_of_hand_made_cells():
    s60 = np.sqrt(3) / 2
    cells = np.array([
        [(0, 0), (1, 0), (1, 1), (0, 1)],                 # unit square
        [(0, 0), (2, 0), (2, 1), (0, 1)],                 # 2 x 1 rectangle
        [(0, 0), (1, 0), (1.5, s60), (0.5, s60)],         # rhombus of 60 / 120 deg
        [(0, 0), (2, 0), (0.5, 0.5), (0, 2)],             # dart: reflex corner at (0.5, 0.5)
        [(0, 0), (0, 1), (1, 1), (1, 0)],                 # the square traversed clockwise: inverted
        [(0, 0), (1, 0), (2, 0), (0, 1)],                 # a corner of 180 deg
    ], dtype=float)
    sj, ang, asp = corner_measures(cells)
    assert np.allclose(sj[:3], [1, 1, s60], atol=1e-14)
    assert np.allclose(ang[:3], [90, 90, 120], atol=1e-12)
    assert np.allclose(asp[:3], [1, 2, 1], atol=1e-14)
    # dart: the edges from (0.5, 0.5) are (1.5, -0.5) and (-0.5, 1.5): cos = -0.6, sin = -0.8 turning
    # inward, so the interior (reflex) angle is 360 - acos(-0.6) = 233.13 deg
    assert sj[3] == pytest.approx(-0.8) and ang[3] == pytest.approx(360 - np.degrees(np.arccos(-0.6)))
    assert sj[4] == pytest.approx(-1.0) and ang[4] == pytest.approx(270.0)
    assert abs(sj[5]) < 1e-15 and ang[5] == pytest.approx(180.0)
    # the clockwise square is fine when its reference was clockwise too
    sj_ref, ang_ref, _ = corner_measures(cells[4:5], orientation=[-1])
    assert sj_ref[0] == pytest.approx(1.0) and ang_ref[0] == pytest.approx(90.0)
    assert np.allclose(signed_areas(cells[:3]), [1, 2, s60])
    t = Thresholds()
    assert not judge(0.25, 150.0, 8.0, thresholds=t).remesh
    assert judge(0.19, 150.0, 8.0, thresholds=t).remesh
    assert judge(0.5, 161.0, 8.0, thresholds=t).reason.startswith("corner angle 161.0")
    assert judge(0.5, 150.0, 8.0, thresholds=Thresholds(max_aspect_ratio=5)).remesh


def test_mesh_quality_decides_on_every_rank():
    mesh, ct, ft, groups = geo_mesh(ROOT / "meshes/round_bar.geo", BAR)
    q0 = mesh_quality(mesh)
    assert q0.min_scaled_jacobian == pytest.approx(1.0) and q0.max_angle_deg == pytest.approx(90.0)
    assert not q0.remesh and q0.cells == 400
    q = mesh_quality(mesh, folded(mesh.geometry.x))
    assert q.remesh and 0 < q.min_scaled_jacobian < 0.1 and q.max_angle_deg > 175
    assert np.hypot(q.worst_cell_point[0] - R, q.worst_cell_point[1] - L) < 3.5     # near the corner
    assert all(COMM.allgather(q.remesh))


def test_deformed_nodes_from_a_displacement():
    from dolfinx import fem
    mesh = geo_mesh(ROOT / "meshes/round_bar.geo", BAR)[0]
    u = fem.Function(vector_space(mesh))
    u.interpolate(lambda X: (bent(X.T)[:, :2] - X.T[:, :2]).T)
    assert np.abs(deformed_nodes(u) - bent(mesh.geometry.x)[:, :2]).max() < 1e-13


# -- outline and new mesh ----------------------------------------------------------------------------
def check_remeshed(mesh, ct, ft, groups, x, **options):
    """Remesh ``mesh`` deformed to ``x`` and check what must hold; returns (new, outline, numbers)."""
    out = outline(mesh, ct, ft, groups, x=x)
    new = mesh_outline(COMM, out, H, **options)
    m, ct2, ft2, g2 = new
    assert g2 == groups                                       # same names, same tags
    assert m.topology.cell_type.name == "quadrilateral"
    q = mesh_quality(m)
    assert q.min_scaled_jacobian > Thresholds().min_scaled_jacobian and not q.remesh, q
    area0, mom0 = volume(mesh, x)
    area1, mom1 = volume(m)
    numbers = dict(area=abs(area1 - area0) / area0, volume=abs(mom1 - mom0) / mom0, sj=q.min_scaled_jacobian,
                   angle=q.max_angle_deg, cells=new.info["cells"])
    if COMM.rank == 0:
        assert out.area == pytest.approx(area0, rel=1e-13)
    lengths = {}
    for name, (dim, tag) in groups.items():
        if dim != 1:
            continue
        old = gathered(COMM, segments(mesh, ft.find(tag), x))
        new_segs = gathered(COMM, segments(m, new.group_facets[name]))
        assert np.array_equal(np.sort(new.group_facets[name]), np.sort(ft2.find(tag)))   # one group per facet
        l0 = np.linalg.norm(old[:, 1] - old[:, 0], axis=1).sum()
        l1 = np.linalg.norm(new_segs[:, 1] - new_segs[:, 0], axis=1).sum()
        lengths[name] = abs(l1 - l0) / l0
        if options.get("curves", "lines") == "lines":
            # every old facet (both ends and the midpoint) on new facets of its group
            pts = np.concatenate([old[:, 0], old[:, 1], old.mean(axis=1)])
            assert on_segments(pts, new_segs, 1e-12 * L).all(), name
    numbers["length"] = max(lengths.values())
    return new, out, numbers


@pytest.mark.parametrize("deform", ["bent", "folded"])
def test_deformed_bar_remeshed_with_lines(deform):
    mesh, ct, ft, groups = geo_mesh(ROOT / "meshes/round_bar.geo", BAR)
    assert set(groups) == {"axis", "bottom", "top", "outer", "bar"}
    x = {"bent": bent, "folded": folded}[deform](mesh.geometry.x)
    if deform == "folded":
        assert mesh_quality(mesh, x).remesh
    new, out, n = check_remeshed(mesh, ct, ft, groups, x)
    print(f"\n{deform}, lines: {n['cells']} cells, min scaled Jacobian {n['sj']:.3f}, max angle {n['angle']:.1f} deg, "
          f"area {n['area']:.1e}, volume {n['volume']:.1e}, group lengths {n['length']:.1e} (relative)")
    assert n["area"] < 1e-12 and n["volume"] < 1e-12 and n["length"] < 1e-12
    assert not new.info["subdivided"]
    if COMM.rank == 0:
        # four curves, each one whole group, corners kept
        assert sorted(sorted(c.names) for c in out.curves if len(c.names)) == [["axis"], ["bottom"], ["outer"],
                                                                               ["top"]] or deform == "folded"
        assert {n for c in out.curves for n in c.names} == {"axis", "bottom", "top", "outer"}
        assert all(len(c.names) == 1 for c in out.curves)
        if deform == "bent":
            assert group_lengths(out)["axis"] == pytest.approx(L, rel=1e-14)
        assert len(out.surfaces) == 1 and len(out.surfaces[0][1]) == 1 and not out.lost_groups


def test_an_outline_through_itself_is_refused():
    """The outer side pushed across the axis at mid-height (r < 0 there): the outline crosses itself."""
    mesh, ct, ft, groups = geo_mesh(ROOT / "meshes/round_bar.geo", BAR)
    X = mesh.geometry.x
    x = X.copy()
    x[:, 0] = X[:, 0] * (1 - 2.5 * np.exp(-((X[:, 1] - L / 2) / 2) ** 2))
    out = outline(mesh, ct, ft, groups, x=x)
    if COMM.rank == 0:
        assert len(crossings(out)) > 0
    ok = outline(mesh, ct, ft, groups, x=bent(X))
    if COMM.rank == 0:
        assert len(crossings(ok)) == 0
    with pytest.raises(RemeshError, match="crosses or touches itself"):
        mesh_outline(COMM, out, H)


def test_splines_smooth_but_change_the_area():
    mesh, ct, ft, groups = geo_mesh(ROOT / "meshes/round_bar.geo", BAR)
    x = bent(mesh.geometry.x)
    new, out, n = check_remeshed(mesh, ct, ft, groups, x, curves="splines")
    print(f"\nbent, splines: {n['cells']} cells, min scaled Jacobian {n['sj']:.3f}, area {n['area']:.1e}, "
          f"volume {n['volume']:.1e}, group lengths {n['length']:.1e} (relative)")
    assert 1e-7 < n["area"] < 1e-3 and n["volume"] < 1e-3 and n["length"] < 1e-3


def test_size_near_a_refinement_point():
    mesh, ct, ft, groups = geo_mesh(ROOT / "meshes/round_bar.geo", BAR)
    x = bent(mesh.geometry.x)
    point, h_min, radius = np.array([3.0, 20.0]), 0.1, 0.5
    m = remesh(mesh, ct, ft, groups, H, x=x, h_min=h_min, refine_points=[point], radius=radius)[0]
    c = cell_corners(m)
    size = np.sqrt(np.abs(signed_areas(c)))
    d = np.linalg.norm(c.mean(axis=1) - point, axis=1)
    near = gathered(COMM, size[d < radius])
    far = gathered(COMM, size[d > 4 * radius])
    print(f"\nrefined: cell size within {radius} mm of the point {near.mean():.3f} mm (h_min {h_min}), "
          f"beyond {4 * radius} mm {far.mean():.3f} mm (h {H})")
    assert len(near) > 30
    assert 0.7 * h_min < near.mean() < 1.5 * h_min
    assert 0.7 * H < far.mean() < 1.3 * H


def test_two_regions_keep_their_areas_and_interface():
    mesh, ct, ft, groups = geo_mesh(ROOT / "meshes/two_region_bar.geo",
                                    {"cells_across": 6, "cells_lower": 12, "cells_upper": 18})
    X = mesh.geometry.x
    x = X.copy()
    x[:, 0] = X[:, 0] * (1 + 0.2 * np.sin(np.pi * X[:, 1] / 10))
    x[:, 1] = X[:, 1] + 0.05 * X[:, 0] ** 2
    new, out, n = check_remeshed(mesh, ct, ft, groups, x)
    assert n["area"] < 1e-12 and n["length"] < 1e-12
    m, ct2 = new[0], new[1]
    for name in ("lower", "upper"):
        tag = groups[name][1]
        a0 = COMM.allreduce(float(signed_areas(cell_corners(mesh, x, _owned(mesh, ct.find(tag)))).sum()))
        a1 = COMM.allreduce(float(signed_areas(cell_corners(m, None, _owned(m, ct2.find(tag)))).sum()))
        assert a1 == pytest.approx(a0, rel=1e-12), name
    if COMM.rank == 0:
        interfaces = [c for c in out.curves if -1 not in c.regions]
        assert len(interfaces) == 1 and interfaces[0].regions == (1, 2)
        assert len(out.surfaces) == 2


def _owned(mesh, cells):
    cells = np.asarray(cells)
    return cells[cells < mesh.topology.index_map(mesh.topology.dim).size_local]


def test_a_facet_in_two_groups(tmp_path):
    """A group "side" = outer + top. dolfinx's facet tags keep one value per facet (the old mesh's
    ``ft.find(15)`` is empty), so the caller gives the groups as facet lists; the new mesh returns them
    the same way (``group_facets``), and a second remesh carries them again."""
    geo = (ROOT / "meshes/round_bar.geo").read_text() + 'Physical Curve("side", 15) = {2, 3};\n'
    (tmp_path / "bar2.geo").write_text(geo)
    mesh, ct, ft, groups = geo_mesh(tmp_path / "bar2.geo", BAR, used_groups={})     # (a scene would be refused)
    assert len(ft.find(15)) == 0
    x = bent(mesh.geometry.x)
    given = {n: ft.find(t) for n, (d, t) in groups.items() if d == 1}
    given["side"] = np.union1d(given["outer"], given["top"])
    out = outline(mesh, ct, ft, groups, x=x, group_facets=given)
    if COMM.rank == 0:
        assert {c.names for c in out.curves} == {frozenset({"outer", "side"}), frozenset({"top", "side"}),
                                                 frozenset({"axis"}), frozenset({"bottom"})}
    old = gathered(COMM, np.concatenate([segments(mesh, given["side"], x)]))
    side_length = np.linalg.norm(old[:, 1] - old[:, 0], axis=1).sum()
    new = mesh_outline(COMM, out, H)
    for _ in range(2):                  # remeshed, then the new mesh remeshed again (undeformed)
        m, ct2, ft2, g2 = new
        side = set(new.group_facets["side"].tolist())
        assert side == set(new.group_facets["outer"].tolist()) | set(new.group_facets["top"].tolist())
        # facet_tags: one value per facet, the smaller tag (outer 14, top 13), none is "side"
        assert len(ft2.find(15)) == 0 and set(ft2.find(14).tolist()) == set(new.group_facets["outer"].tolist())
        segs = gathered(COMM, segments(m, new.group_facets["side"]))
        assert np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1).sum() == pytest.approx(side_length, rel=1e-12)
        new = remesh(m, ct2, ft2, g2, H, group_facets=new.group_facets)


# -- MPI ----------------------------------------------------------------------------------------------
def mpi_numbers():
    """Cells, area, r-moment and owned facets per group of the bent bar remeshed (collective)."""
    mesh, ct, ft, groups = geo_mesh(ROOT / "meshes/round_bar.geo", BAR)
    x = bent(mesh.geometry.x)
    new = remesh(mesh, ct, ft, groups, H, x=x, h_min=0.1, refine_points=[(3.0, 20.0)], radius=0.5)
    m = new[0]
    area, moment = volume(m)
    counts = [COMM.allreduce(len(segments(m, new.group_facets[n]))) for n in ("axis", "bottom", "top", "outer")]
    return dict(cells=new.info["cells"], area=area, moment=moment, counts=np.array(counts), ranks=COMM.size)


def test_serial_equals_two_ranks(tmp_path):
    from scene_runs import MPIRUN, serial_and_two_ranks
    if COMM.size > 1 or MPIRUN is None:
        pytest.skip("starts its own mpirun (serial pytest, mpirun installed)")
    one, two = serial_and_two_ranks(Path(__file__), [], tmp_path)
    assert int(one["ranks"]) == 1 and int(two["ranks"]) == 2
    assert int(one["cells"]) == int(two["cells"])
    assert np.array_equal(one["counts"], two["counts"])
    assert float(two["area"]) == pytest.approx(float(one["area"]), rel=1e-13)
    assert float(two["moment"]) == pytest.approx(float(one["moment"]), rel=1e-13)


if __name__ == "__main__":
    numbers = mpi_numbers()
    if COMM.rank == 0:
        np.savez(sys.argv[1], **numbers)
