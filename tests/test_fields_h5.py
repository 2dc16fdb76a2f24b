"""fields.h5 read with h5py (python3-h5py, installed by scripts/install.sh) by the user guide's own recipe,
run as written in docs/guide/outputs.md ("Fields in Python"): the homogeneous bar (tests/scenes/bar.toml, the
end z = 4 mm pulled by 1 mm) written to XDMF/HDF5; at the last time the end face's nodes have moved by 1 mm
along z and the axis' nodes not at all along r, and there is one eqps value per cell (perfectly plastic at
250 MPa, the bar necks: eqps 0.005 to 0.53)."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_runs import ROOT, run_scene  # noqa: E402

GUIDE = ROOT / "docs" / "guide" / "outputs.md"
#: the path the guide's recipe reads, replaced by the test's own results folder
GUIDE_PATH = "results/bar/fields.h5"


def guide_recipe() -> str:
    """The one Python block of the guide's outputs page (the recipe that reads fields.h5)."""
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) == 1 and GUIDE_PATH in blocks[0], "docs/guide/outputs.md: one ```python block reading " \
                                                         + GUIDE_PATH
    return blocks[0]


def test_fields_h5_reads_with_the_guides_recipe(tmp_path):
    out = tmp_path / "bar"
    run_scene(ROOT / "tests" / "scenes" / "bar.toml", out, "output.xdmf=true", "output.plots=false",
              "materials.steel.hardening.law=linear", "materials.steel.hardening.yield_stress=250")
    h5, saved = str(out / "fields.h5"), str(tmp_path / "read.npz")
    # the recipe as written, on this run's file; then its variables saved for the assertions
    script = guide_recipe().replace(GUIDE_PATH, h5) + (
        "\nimport numpy\n"
        f"with h5py.File({h5!r}, 'r') as f:\n"
        "    cells = len(next(iter(f['Mesh'].values()))['topology'])\n"
        f"numpy.savez({saved!r}, X=X, u=u, eqps=eqps, cells=cells)\n")
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    r = np.load(saved)
    X, u, eqps = r["X"], r["u"], r["eqps"]
    top, axis = np.isclose(X[:, 1], 4.0), np.isclose(X[:, 0], 0.0)
    assert top.sum() >= 2 and axis.sum() >= 2
    np.testing.assert_allclose(u[top, 1], 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(u[axis, 0], 0.0, rtol=0, atol=1e-12)
    assert eqps.shape[0] == int(r["cells"]) and eqps.min() >= 0.0 and eqps.max() > 0.1
