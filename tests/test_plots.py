"""Plots: every scene kind's runner writes the PNGs of plots.FIGURES from its CSV files, and
`fenics-plast plot DIR` redraws the same ones; the CSVs hold the run's numbers; clear errors."""
import json
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest

from fenics_plast import cli
from fenics_plast.plots import FIGURES, read_csv

ROOT = Path(__file__).resolve().parent.parent
DEMOS = ROOT / "demos"

RING = Path(__file__).resolve().parent / "scenes" / "ring.toml"    # small thick cylinder

# small runs of a few seconds each: scene file, overrides
RUNS = {
    "bar_tension": (DEMOS / "bar_tension.toml",
                    ["mesh.cells_radial=3", "mesh.cells_axial=6", "loading.displacement=2",
                     "solver.increments=4", "output.xdmf=false"]),
    "thick_cylinder": (None, []),
    "punch_stretching": (DEMOS / "punch_stretching.toml",
                         ["mesh.cells_radial=12", "mesh.cells_thickness=1", "loading.travel=4",
                          "solver.increments=2", "solver.max_increment=0.5", "output.xdmf=false"]),
    "taylor_bar": (DEMOS / "taylor_bar.toml",
                   ["loading.end_time_us=2", "output.history_points=3", "mesh.cells_axial=12",
                    "mesh.cells_radial=3", "output.xdmf=false"]),
}

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def assert_png(path):
    data = Path(path).read_bytes()
    assert data[:8] == PNG_MAGIC, path
    w, h = struct.unpack(">II", data[16:24])        # IHDR
    assert data[12:16] == b"IHDR" and w >= 300 and h >= 300 and len(data) > 5000, (path, w, h, len(data))


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """kind -> results folder of a small `fenics-plast run`."""
    base = tmp_path_factory.mktemp("plots")
    out = {}
    for kind, (scene, sets) in RUNS.items():
        if scene is None:
            scene = RING
        d = base / kind
        args = ["run", str(scene), "--out", str(d)]
        for s in sets:
            args += ["--set", s]
        assert cli.main(args) == 0, kind
        out[kind] = d
    return out


@pytest.mark.parametrize("kind", list(RUNS))
def test_run_writes_the_pngs_and_plot_redraws_them(results, kind, capsys):
    d = results[kind]
    names = [f.name + ".png" for f in FIGURES[kind]]
    for n in names:
        assert_png(d / n)
    for n in names:
        (d / n).unlink()
    capsys.readouterr()
    assert cli.main(["plot", str(d)]) == 0
    said = capsys.readouterr().out
    assert f"{len(names)} figure(s)" in said
    for n in names:
        assert_png(d / n)
        assert n in said


def test_plotted_columns_hold_the_run_results(results):
    """The figures read the same numbers the summary reports."""
    s = {k: json.loads((d / "summary.json").read_text()) for k, d in results.items()}
    h = {k: read_csv(d / "history.csv") for k, d in results.items()}
    assert np.max(h["bar_tension"]["force_kN"]) == pytest.approx(s["bar_tension"]["max_force_kN"], rel=1e-12)
    assert np.max(h["thick_cylinder"]["pressure_MPa"]) == pytest.approx(
        s["thick_cylinder"]["limit_pressure_MPa"], rel=1e-12)
    # the plateau is the small-strain limit pressure (the reference line of the figure), within 1 %
    assert s["thick_cylinder"]["limit_pressure_MPa"] == pytest.approx(
        s["thick_cylinder"]["analytic_limit_pressure_MPa"], rel=0.01)
    assert np.max(h["punch_stretching"]["punch_force_kN"]) == pytest.approx(
        s["punch_stretching"]["max_punch_force_kN"], rel=1e-12)
    th = read_csv(results["punch_stretching"] / "thickness_strain.csv")
    # travel 4 mm < 20 mm: one curve (the final state), not a mislabelled "20 mm" one
    assert set(th["travel_mm"]) == {4.0}
    assert np.min(th["thickness_strain"]) == pytest.approx(s["punch_stretching"]["min_thickness_strain"],
                                                            rel=1e-12)
    ke = h["taylor_bar"]["kinetic_energy_J"]
    assert ke[0] == pytest.approx(s["taylor_bar"]["initial_kinetic_energy_J"], rel=1e-12)
    assert ke[-1] == pytest.approx(s["taylor_bar"]["final_kinetic_energy_J"], rel=1e-12)


def test_taylor_final_shape_table(results):
    """final_shape.csv: one deformed cell per row; its top and impact face are the bar's length
    and impact-face radius of summary.json, its cell-mean eqps below the quadrature-point maximum."""
    s = json.loads((results["taylor_bar"] / "summary.json").read_text())
    t = read_csv(results["taylor_bar"] / "final_shape.csv")
    assert len(t["eqps"]) == s["cells"] == 36
    x = np.column_stack([t[f"x{k}"] for k in range(1, 5)])
    y = np.column_stack([t[f"y{k}"] for k in range(1, 5)])
    assert y.max() == pytest.approx(s["final_length_mm"], rel=1e-12)
    assert x[np.abs(y) < 1e-9].max() == pytest.approx(s["final_radius_mm"], rel=1e-12)
    assert x.min() == pytest.approx(0.0, abs=1e-12)
    # cyclic vertex order: every quadrilateral has a positive (shoelace) area
    area = 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)
    assert np.all(area > 0)
    assert 0.3 * s["max_eqps"] < t["eqps"].max() <= s["max_eqps"] * (1 + 1e-12)


def test_plot_errors_exit_2(tmp_path, results, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert cli.main(["plot", str(empty)]) == 2
    assert "no summary.json" in capsys.readouterr().err
    assert cli.main(["plot", str(tmp_path / "nowhere")]) == 2
    assert "no such directory" in capsys.readouterr().err

    no_hist = tmp_path / "no_hist"
    no_hist.mkdir()
    (no_hist / "summary.json").write_text('{"kind": "bar_tension"}')
    assert cli.main(["plot", str(no_hist)]) == 2
    assert "no history.csv" in capsys.readouterr().err

    unknown = tmp_path / "unknown"
    shutil.copytree(results["bar_tension"], unknown)
    (unknown / "summary.json").write_text('{"kind": "rolling_mill"}')
    assert cli.main(["plot", str(unknown)]) == 2
    assert "rolling_mill" in capsys.readouterr().err

    cols = tmp_path / "cols"
    shutil.copytree(results["bar_tension"], cols)
    (cols / "history.csv").write_text("increment,elongation_mm\n0,0.0\n1,0.5\n")
    assert cli.main(["plot", str(cols)]) == 2
    err = capsys.readouterr().err
    assert "force_kN" in err and "force_elongation.png" in err
