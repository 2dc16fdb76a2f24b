"""The contact outputs (issue 36) in explicit runs: contact_area, contact_radius and contact_pressure (max,
mean) of a pair between two bodies (demos/taylor_rod_on_rod.toml, two passes, to 5 us) and of a rigid tool
(demos/taylor_bar_oblique.toml, 3-D): measured through the CLI, consistent with each other and with the body,
and the same on 1 and 2 ranks. The static ones are held to Hertz in tests/test_static_body_contact.py."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_runs import ROOT, history, needs_mpirun, run_scene  # noqa: E402


def contact_sets(pair, group):
    """The contact outputs of ``pair`` and the radial extent of its ``group`` (the face's reach from the axis)."""
    return ("outputs.face_r.quantity=extent", f"outputs.face_r.group={group}", "outputs.face_r.component=radial",
            "outputs.c_area.quantity=contact_area", f"outputs.c_area.contact={pair}",
            "outputs.c_radius.quantity=contact_radius", f"outputs.c_radius.contact={pair}",
            "outputs.c_peak.quantity=contact_pressure", f"outputs.c_peak.contact={pair}",
            "outputs.c_mean.quantity=contact_pressure", f"outputs.c_mean.contact={pair}",
            "outputs.c_mean.statistic=mean", "analysis.end_time=5", "output.xdmf=false", "output.plots=false")


COLUMNS = ("c_area_mm2", "c_radius_mm", "c_peak_MPa", "c_mean_MPa")


@pytest.mark.parametrize("scene,pair,group", [("taylor_rod_on_rod", "interface", "upper_face"),
                                              ("taylor_bar_oblique", "face", "bottom")])
def test_explicit_contact_outputs(tmp_path, scene, pair, group):
    """During the impact (5 us): the contact zone's edge within the face's reach from the axis (the face's
    radial extent), a contact area within the disc of that radius, peak >= mean pressure >= 0 at every row,
    > 0 at the end (measured: rod on rod 16.1 mm^2, 3.78 mm, 2990 / 1596 MPa; the oblique 3-D bar
    5.92 mm^2, 4.32 mm, 4801 / 1559 MPa)."""
    s = run_scene(ROOT / "demos" / f"{scene}.toml", tmp_path / "out", *contact_sets(pair, group))
    area, radius, peak, mean = (s[c] for c in COLUMNS)
    print(f"\n{scene}: area {area:.4g} mm^2, radius {radius:.4g} mm, peak {peak:.4g} MPa, mean {mean:.4g} MPa")
    h = history(tmp_path / "out")
    assert np.all(h["c_peak_MPa"] >= h["c_mean_MPa"] * (1 - 1e-12)) and np.all(h["c_mean_MPa"] >= 0.0)
    face = s["face_r_mm"]
    assert 0.0 < radius <= face * (1 + 1e-12), (radius, face)
    assert 0.0 < area < np.pi * face ** 2, (area, face)
    assert peak >= mean > 0.0


@needs_mpirun
@pytest.mark.mpi
def test_explicit_contact_outputs_two_ranks(tmp_path):
    """The rod on rod's contact outputs on 2 ranks as serially (to 1e-9), and its contact fields (their sorted
    values at the last time: the nodes' order differs between partitions)."""
    sets = [s for s in contact_sets("interface", "upper_face") if s != "output.xdmf=false"] + ["output.xdmf=true"]
    run_scene(ROOT / "demos" / "taylor_rod_on_rod.toml", tmp_path / "serial", *sets)
    run_scene(ROOT / "demos" / "taylor_rod_on_rod.toml", tmp_path / "mpi", *sets, np_ranks=2)
    a, b = history(tmp_path / "serial"), history(tmp_path / "mpi")
    for c in COLUMNS:
        np.testing.assert_allclose(b[c], a[c], rtol=1e-9, atol=1e-12, err_msg=c)
    names = ("contact_pressure_interface", "contact_gap_interface", "contact_status_interface")
    fa, fb = (last_fields(tmp_path / d, *names)[1] for d in ("serial", "mpi"))
    for name, x, y in zip(names, fa, fb):
        x, y = np.sort(x[:, 0]), np.sort(y[:, 0])
        np.testing.assert_allclose(y, x, rtol=1e-9, atol=1e-9 * np.abs(x).max(), err_msg=name)


def last_fields(out, *names):
    """The reference coordinates and the named fields at the last time of OUT/fields.h5."""
    import h5py
    with h5py.File(out / "fields.h5", "r") as f:
        X = next(iter(f["Mesh"].values()))["geometry"][:]
        last = max(f["Function"][names[0]], key=lambda k: float(k.replace("_", ".")))
        return X, [f["Function"][n][last][:] for n in names]


def test_static_contact_fields(tmp_path):
    """The coarse Hertz sphere's contact fields in fields.xdmf/.h5: the pressure field's largest value is the
    peak_pressure output, the gap where pressed is -p / eps, the status 2 (frictionless: slipping) exactly
    where the pressure is positive, and every field 0 off the ball's surface."""
    s = run_scene(ROOT / "demos" / "hertz_sphere.toml", tmp_path / "h", "mesh.parameters.cells_contact=10",
                  "output.plots=false")
    X, (p, g, status) = last_fields(tmp_path / "h", "contact_pressure_hertz", "contact_gap_hertz",
                                    "contact_status_hertz")
    p, g, status = p[:, 0], g[:, 0], status[:, 0]
    assert p.max() == pytest.approx(s["peak_pressure_MPa"], rel=1e-12)
    on = p > 0.0
    assert 3 <= on.sum() <= 10
    np.testing.assert_allclose(g[on], -p[on] / 1e8, rtol=1e-9)
    np.testing.assert_allclose(status[on], 2.0, atol=1e-12)
    assert np.all(np.abs(status[~on]) < 1e-12)
    assert np.all(p[X[:, 1] < -1.0] == 0.0)       # far below the contact (the block's inside): nothing


def test_explicit_contact_fields_both_sides(tmp_path):
    """The rod on rod (two passes, the bars' meshes alike) at 5 us: the pressure written on both impact faces,
    each pressed node's twin on the other face pressed too, the status nonzero exactly there (measured: the
    nodes at r = 2.13 and 2.67 mm, 2990 and 481 MPa on both faces)."""
    run_scene(ROOT / "demos" / "taylor_rod_on_rod.toml", tmp_path / "r", "analysis.end_time=5",
              "output.plots=false", "output.xdmf=true")
    X, (p, status) = last_fields(tmp_path / "r", "contact_pressure_interface", "contact_status_interface")
    p, status = p[:, 0], status[:, 0]
    pressed = p > 1e-9 * p.max()                   # (the XDMF write leaves round-off, 1e-13 MPa, elsewhere)
    r, count = np.unique(np.round(X[pressed, 0], 9), return_counts=True)
    print(f"\nrod on rod: pressed at r = {r} mm, {count} nodes each; peak {p.max():.4g} MPa")
    assert len(r) >= 2 and np.all(count == 2) and np.allclose(X[pressed, 1], 0.0)
    assert np.all((status > 0.5) == pressed)
