"""fields.h5 read with h5py (python3-h5py, installed by scripts/install.sh), as the README shows: the
homogeneous bar (tests/scenes/bar.toml, the end z = 4 mm pulled by 1 mm) written to XDMF/HDF5; at the last
time the end face's nodes have moved by 1 mm along z and the axis' nodes not at all along r, and there is
one eqps value per cell (perfectly plastic at 250 MPa, the bar necks: eqps 0.005 to 0.53)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_runs import ROOT, run_scene  # noqa: E402


def read_last(path, name):
    """(reference node coordinates, the field ``name`` at the last time) of fields.h5 (the README's recipe)."""
    import h5py
    with h5py.File(path, "r") as f:
        mesh = next(iter(f["Mesh"].values()))
        X = mesh["geometry"][:]
        steps = f["Function"][name]
        last = max(steps, key=lambda k: float(k.replace("_", ".")))
        return X, steps[last][:], len(mesh["topology"])


def test_fields_h5_reads_with_h5py(tmp_path):
    out = tmp_path / "bar"
    run_scene(ROOT / "tests" / "scenes" / "bar.toml", out, "output.xdmf=true", "output.plots=false",
              "materials.steel.hardening.law=linear", "materials.steel.hardening.yield_stress=250")
    X, u, cells = read_last(out / "fields.h5", "displacement")
    top, axis = np.isclose(X[:, 1], 4.0), np.isclose(X[:, 0], 0.0)
    assert top.sum() >= 2 and axis.sum() >= 2
    np.testing.assert_allclose(u[top, 1], 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(u[axis, 0], 0.0, rtol=0, atol=1e-12)
    _, eqps, _ = read_last(out / "fields.h5", "eqps")
    assert eqps.shape[0] == cells and eqps.min() >= 0.0 and eqps.max() > 0.1
