"""Meshed rigid tools (tools.<name>.shape = "mesh"): a flat meshed wall gives the analytic plane's Taylor
impact in 2-D and 3-D to round-off; a tool the body must pass on its side is signed by its orientation
(flip); bad input stops with exit 2, the key named, nothing written."""
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scene_runs import MPIRUN, needs_mpirun

REPO = Path(__file__).resolve().parents[1]

WALL_2D = """Point(1) = {-1, 0, 0, 100};
Point(2) = {30, 0, 0, 100};
Line(1) = {1, 2};
Physical Curve("wall") = {1};
"""
# a square at z = 0, counter-clockwise seen from +z (normals +z: the body above)
WALL_3D = """Point(1) = {-20, -20, 0, 100}; Point(2) = {20, -20, 0, 100};
Point(3) = {20, 20, 0, 100}; Point(4) = {-20, 20, 0, 100};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Physical Surface("wall") = {1};
Physical Curve("rim") = {1, 2, 3, 4};
"""


def scene_text(name: str, tmp_path: Path, tool: str, end_us: float) -> str:
    """The demo scene ``name`` with an absolute mesh path, ``tool`` as its [tools.wall] table (and, for the
    3-D bar, the frictionless wall as contact instead of a sliding support), ending at ``end_us``."""
    text = (REPO / "demos" / name).read_text()
    text = text.replace('file = "../meshes/', f'file = "{REPO}/meshes/')
    text = re.sub(r"end_time = [0-9.]+", f"end_time = {end_us}", text)
    text = re.sub(r"\[tools\.wall\]\n(.*\n)*?\n", "", text)
    text = re.sub(r"\[boundary\.wall\]\n(.*\n)*?\n", "", text)
    if "[contact.face]" not in text:
        text += ('\n[contact.face]\ntool = "wall"\ngroup = "bottom"\nfriction = 0.0\nlaw = "coulomb"\n'
                 'penalty = 3.9e5\n')
    return text + "\n" + tool


def run(scene: Path, out: Path, *extra) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(out), *extra],
                          capture_output=True, text=True, timeout=1200)


@pytest.mark.parametrize("name, geo, plane, end_us", [
    ("taylor_bar_wall.toml", WALL_2D, 'shape = "plane"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n', 20.0),
    ("taylor_bar_3d.toml", WALL_3D, 'shape = "plane"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n', 8.0)])
def test_meshed_wall_is_the_analytic_plane(tmp_path, name, geo, plane, end_us):
    """The Taylor bar (227 m/s) against a wall given as a Gmsh curve (axisymmetric) or surface of two
    triangles (3-D quarter): the gaps are the plane's, so length, radius, energies and the contact force
    history equal the analytic plane's run to round-off."""
    (tmp_path / "wall.geo").write_text(geo)
    results = {}
    for kind, tool in (("analytic", plane), ("meshed", 'shape = "mesh"\nfile = "wall.geo"\ngroup = "wall"\n')):
        scene = tmp_path / f"{kind}.toml"
        scene.write_text(scene_text(name, tmp_path, "[tools.wall]\n" + tool, end_us))
        r = run(scene, tmp_path / kind, "--set", "output.xdmf=false", "--set", "output.plots=false")
        assert r.returncode == 0, r.stderr[-3000:]
        results[kind] = json.loads((tmp_path / kind / "summary.json").read_text())
        results[kind]["history"] = np.genfromtxt(tmp_path / kind / "history.csv", delimiter=",", names=True)
    a, m = results["analytic"], results["meshed"]
    assert a["length_mm"] < 0.97 * 32.4         # the bar (32.4 mm) has been shortened: the contact acted
    for key in ("length_mm", "radius_mm", "max_eqps"):
        assert m[key] == pytest.approx(a[key], rel=1e-9), key
    ha, hm = a["history"], m["history"]
    for col in ha.dtype.names:
        scale = max(np.max(np.abs(ha[col])), 1e-30)
        assert np.max(np.abs(hm[col] - ha[col])) <= 1e-8 * scale, col


def test_flip_turns_the_side_of_the_body(tmp_path):
    """With flip = true the 2-D wall's normals point down: the bar's face, which starts on the wall and
    moves down, is on the wall's body side all along and passes through untouched (its kinetic energy
    unchanged); without flip the wall stops it. The orientation decides, as documented."""
    (tmp_path / "wall.geo").write_text(WALL_2D)
    lengths = {}
    for flip in ("false", "true"):
        scene = tmp_path / f"flip_{flip}.toml"
        tool = f'[tools.wall]\nshape = "mesh"\nfile = "wall.geo"\ngroup = "wall"\nflip = {flip}\n'
        scene.write_text(scene_text("taylor_bar_wall.toml", tmp_path, tool, 20.0))
        r = run(scene, tmp_path / f"out_{flip}", "--set", "output.xdmf=false", "--set", "output.plots=false")
        assert r.returncode == 0, r.stderr[-3000:]
        hist = np.genfromtxt(tmp_path / f"out_{flip}" / "history.csv", delimiter=",", names=True)
        lengths[flip] = hist
    stopped, passed = lengths["false"], lengths["true"]
    # the kinetic energy: the stopped bar loses most of it; the bar on the wrong side flies on
    ke = [n for n in stopped.dtype.names if n.startswith("kinetic")][0]
    assert stopped[ke][-1] < 0.7 * stopped[ke][0]           # 240 -> 148 J in 20 us
    assert passed[ke][-1] == pytest.approx(passed[ke][0], rel=1e-12)      # no force at all


@pytest.mark.parametrize("tool, extra, message", [
    ('shape = "mesh"\nfile = "wall.geo"\ngroup = "nope"\n', [], r"tools\.wall: wall\.geo has no physical group 'nope'"),
    ('shape = "mesh"\nfile = "missing.geo"\ngroup = "wall"\n', [], r"tools\.wall: file .*missing\.geo not found"),
    ('shape = "mesh"\nfile = "wall3.geo"\ngroup = "wall"\n', [], r"tools\.wall: wall3\.geo: 'wall' is a physical "
     r"group of dimension 2: a 2-D tool needs a physical curve"),
    ('shape = "mesh"\nfile = "wall.geo"\ngroup = "wall"\n', ["static"],
     r"tools\.punch\.shape = 'mesh': a meshed tool is for explicit analyses")])
def test_bad_meshed_tool_exit_2_key_named_nothing_written(tmp_path, tool, extra, message):
    (tmp_path / "wall.geo").write_text(WALL_2D)
    (tmp_path / "wall3.geo").write_text(WALL_3D)
    scene = tmp_path / "bad.toml"
    if extra == ["static"]:         # the static punch with its punch meshed
        text = (REPO / "demos" / "punch_stretching.toml").read_text().replace('file = "../meshes/',
                                                                              f'file = "{REPO}/meshes/')
        text = re.sub(r"\[tools\.punch\]\n(.*\n)*?\n", "[tools.punch]\n" + tool + "\n", text)
        scene.write_text(text)
        extra = []
    else:
        scene.write_text(scene_text("taylor_bar_wall.toml", tmp_path, "[tools.wall]\n" + tool, 20.0))
    out = tmp_path / "out"
    r = run(scene, out, *extra)
    assert r.returncode == 2, r.stderr[-2000:]
    assert re.search(message, r.stderr), r.stderr[-2000:]
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.mpi
@needs_mpirun
def test_meshed_wall_serial_equals_two_ranks(tmp_path):
    """The 2-D meshed wall run on 2 ranks (each rank's nodes against the surface rank 0 read and sent):
    the same history as serially."""
    (tmp_path / "wall.geo").write_text(WALL_2D)
    scene = tmp_path / "meshed.toml"
    scene.write_text(scene_text("taylor_bar_wall.toml", tmp_path,
                                '[tools.wall]\nshape = "mesh"\nfile = "wall.geo"\ngroup = "wall"\n', 20.0))
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    hist = []
    for name, launch in (("serial", []), ("mpi", [MPIRUN, "--allow-run-as-root", "--oversubscribe", "-n", "2"])):
        r = subprocess.run([*launch, sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out",
                            str(tmp_path / name), "--set", "output.xdmf=false", "--set", "output.plots=false"],
                           capture_output=True, text=True, timeout=1200, env=env)
        assert r.returncode == 0, r.stderr[-3000:]
        hist.append(np.genfromtxt(tmp_path / name / "history.csv", delimiter=",", names=True))
    for col in hist[0].dtype.names:
        scale = max(np.max(np.abs(hist[0][col])), 1e-30)
        assert np.max(np.abs(hist[1][col] - hist[0][col])) <= 1e-10 * scale, col
