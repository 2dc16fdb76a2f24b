"""The CLI: bad scene files exit 2 without writing anything; the run/summary/error plumbing
(with a stand-in runner); the deformation-table reader; a material-point path that fails exits 1
with one error line."""
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from fenics_plast import cli

REPO = Path(__file__).resolve().parent.parent

# a small static scene (the round bar in tension); the mesh file by absolute path, so that the scene
# can be written anywhere
GOOD = f"""
[scene]
name = "bar"

[analysis]
type = "static"
increments = 4

[mesh]
file = "{REPO / 'meshes' / 'round_bar.geo'}"
refine = 1

[mesh.parameters]
radius = 6.413
length = 26.667
cells_radial = 2
cells_axial = 4

[materials.steel]
E = 206.9e3
nu = 0.29

[materials.steel.hardening]
law = "linear"
yield_stress = 450

[boundary.axis]
group = "axis"
type = "axis"

[boundary.grip]
group = "top"
type = "displacement"
components = ["z"]
value = "4.0 * t"

[boundary.mid_plane]
group = "bottom"
type = "symmetry"
"""


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "fenics_plast.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd or REPO, timeout=120)


@pytest.mark.parametrize("text, extra, key", [
    ("[scene]\nname = 'x'\nkind = ", [], "TOML syntax"),
    (GOOD.replace("nu = 0.29", "nu = 0.5"), [], "materials.steel.nu"),
    (GOOD.replace("[boundary.grip]", "[boundary.grip]\nspeed = 3"), [], "boundary.grip.speed"),
    (GOOD.replace("E = 206.9e3", "E = -1"), [], "materials.steel.E"),
    (GOOD, ["--set", "materials.steel.hardening.yield_stress=-3"], "materials.steel.hardening.yield_stress"),
    (GOOD, ["--set", "mesh.refine=two"], "mesh.refine"),
    # the mesh's groups are checked before anything is written
    (GOOD.replace('group = "top"', 'group = "upper"'), [], "boundary.grip.group = 'upper'"),
])
def test_bad_scene_exit_2_nothing_written(tmp_path, text, extra, key):
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    out = tmp_path / "out"
    r = run_cli("run", scene, "--out", out, *extra, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("error: ")
    assert "bad.toml" in r.stderr and key in r.stderr, r.stderr
    assert not out.exists()
    assert not (tmp_path / "results").exists()


def test_point_bad_scene_exit_2(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text(GOOD.replace("nu = 0.29", "nu = 0.7"))
    r = run_cli("point", scene, "--path", "uniaxial", "--to", "0.5", "--steps", "10", cwd=tmp_path)
    assert r.returncode == 2 and "materials.steel.nu" in r.stderr


def test_point_no_lateral_equilibrium_exit_1(tmp_path):
    """Seed model, log strain -2 in one step: the Newton iteration on the lateral stretch finds no
    equilibrium (the step is too large). One ``error:`` line, exit 1, no traceback, no CSV."""
    pytest.importorskip("numba")
    scene = tmp_path / "good.toml"
    scene.write_text(GOOD)
    out = tmp_path / "p.csv"
    r = run_cli("point", scene, "--path", "uniaxial", "--to", "-2", "--steps", "1", "--set", "materials.steel.model=seed",
                "--out", out, cwd=tmp_path)
    assert r.returncode == 1, r.stdout + r.stderr
    assert r.stderr.startswith("error: ") and r.stderr.count("\n") == 1, r.stderr
    assert "lateral equilibrium not found at step 1" in r.stderr and "Traceback" not in r.stderr
    assert not out.exists()


def test_keys_prints_doc():
    r = run_cli("keys")
    assert r.returncode == 0
    assert r.stdout == (REPO / "docs" / "SCENE_KEYS.md").read_text()


# -- the run plumbing with a stand-in runner (in-process; needs mpi4py) -------------------------

FAKE_RUNNER = '''
import numpy as np
from fenics_plast.errors import RunError

def read_mesh(problem, comm, **kwargs):
    return None

def prepare(problem, comm, mesh_data):
    return mesh_data

def run(problem, output, mesh_data=None):
    for i in range(3):
        output.history(step=i, load_N=np.float64(10.0 * i))
    output.write_csv("profile", {"z_mm": np.arange(3.0), "r_mm": np.ones(3)})
    if problem.mesh.refine == 2:
        raise RunError("no convergence at load fraction 0.5", {"last_load_fraction": 0.5})
    return {"cells": np.int64(8), "dofs": 30, "converged": True, "final_radius_mm": np.float32(4.5),
            "curve": np.array([1.0, 2.0])}
'''


@pytest.fixture
def fake_runner(tmp_path, monkeypatch):
    """fenics_plast.runner's read_mesh and run replaced by stand-ins (no mesh, no solver)."""
    pytest.importorskip("mpi4py")
    mod = tmp_path / "fake_runner_mod.py"
    mod.write_text(FAKE_RUNNER)
    monkeypatch.syspath_prepend(str(tmp_path))
    import fake_runner_mod

    from fenics_plast import runner
    monkeypatch.setattr(runner, "read_mesh", fake_runner_mod.read_mesh)
    monkeypatch.setattr(runner, "prepare", fake_runner_mod.prepare)
    monkeypatch.setattr(runner, "run", fake_runner_mod.run)
    scene = tmp_path / "good.toml"
    scene.write_text(GOOD)
    return scene


def test_run_writes_summary(fake_runner, tmp_path):
    out = tmp_path / "out"
    assert cli.main(["run", str(fake_runner), "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["scene"] == "bar" and s["analysis"] == "static" and s["converged"] is True
    assert s["active_physics"] == ["plasticity"] and s["mpi_ranks"] == 1
    assert s["cells"] == 8 and s["final_radius_mm"] == 4.5 and s["curve"] == [1.0, 2.0]
    assert s["wall_time_s"] >= 0 and s["scene_file"] == str(fake_runner)
    assert s["scene_settings"]["materials"]["steel"]["hardening"]["yield_stress"] == 450.0
    hist = (out / "history.csv").read_text().splitlines()
    assert hist[0] == "step,load_N" and len(hist) == 4
    assert (out / "profile.csv").read_text().startswith("z_mm,r_mm")
    assert not list(out.glob(".*tmp*"))


def test_run_error_exit_1_summary_kept(fake_runner, tmp_path, capsys):
    out = tmp_path / "out2"
    assert cli.main(["run", str(fake_runner), "--out", str(out), "--set", "mesh.refine=2"]) == 1
    assert "no convergence" in capsys.readouterr().err
    s = json.loads((out / "summary.json").read_text())
    assert s["converged"] is False and "no convergence" in s["error"]
    assert s["last_load_fraction"] == 0.5
    assert len((out / "history.csv").read_text().splitlines()) == 4


def test_read_deformation_table(tmp_path):
    f = tmp_path / "F.csv"
    f.write_text(textwrap.dedent("""\
        t,F11,F12,F13,F21,F22,F23,F31,F32,F33
        0,1,0,0,0,1,0,0,0,1
        1,1.1,0.2,0,0,1,0,0,0,0.95
        """))
    t, F = cli.read_deformation_table(f)
    assert t.tolist() == [0.0, 1.0]
    assert F.shape == (2, 3, 3) and F[1, 0, 1] == 0.2 and F[1, 2, 2] == 0.95
    f.write_text("t,F11\n0,1\n")
    with pytest.raises(ValueError, match="header"):
        cli.read_deformation_table(f)


def test_point_table_via_cli(tmp_path):
    pytest.importorskip("numba")
    try:
        import fenics_plast.material.point  # noqa: F401  (written by the material developer)
    except ImportError:
        pytest.skip("fenics_plast.material.point not available")
    scene = tmp_path / "good.toml"
    scene.write_text(GOOD)
    f = tmp_path / "F.csv"
    f.write_text("t,F11,F12,F13,F21,F22,F23,F31,F32,F33\n"
                 "0.5,1.001,0,0,0,1,0,0,0,1\n1.0,1.05,0,0,0,0.976,0,0,0,0.976\n")
    out = tmp_path / "p.csv"
    r = run_cli("point", scene, "--path", "table", "--table", f, "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    lines = out.read_text().splitlines()
    header = lines[0].split(",")
    assert header[0] == "t" and len(lines) >= 3
    assert lines[-1].split(",")[0] == "1.0"
    assert all(len(line.split(",")) == len(header) for line in lines)


def test_gmsh_library_preloads_in_a_thread():
    """fenics_plast.preload loads the library that ``import gmsh`` loads, in a thread (the run overlaps it
    with its other imports): after the thread, libgmsh is mapped into the process before gmsh is imported."""
    code = ("import sys\n"
            "from fenics_plast.preload import start_gmsh\n"
            "start_gmsh().join()\n"
            "assert 'gmsh' not in sys.modules\n"
            "maps = open('/proc/self/maps').read()\n"
            "print('libgmsh' in maps)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"


def test_prompt_exit_flushes_and_keeps_the_status(tmp_path):
    """``exit_promptly`` (the command's end, skipping the interpreter's teardown) still delivers what was
    written but not flushed (standard streams, a logging handler's file), finalizes PETSc (``-log_view`` is
    printed there) and MPI, and exits with the status it is given."""
    log = tmp_path / "log.txt"
    petsc_log = tmp_path / "petsc.txt"
    code = ("import logging, sys\n"
            "from petsc4py import PETSc\n"
            "from mpi4py import MPI\n"
            "from fenics_plast import cli\n"
            f"logging.basicConfig(filename={str(log)!r}, level=logging.INFO)\n"
            "logging.getLogger('t').info('logged line')\n"
            "sys.stdout.write('no newline, not flushed')\n"
            "cli.exit_promptly(3)\n"
            "print('not reached')\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "PETSC_OPTIONS": f"-log_view :{petsc_log}"})
    assert r.returncode == 3, r.stderr
    assert r.stdout == "no newline, not flushed"
    assert "logged line" in log.read_text()
    assert "PETSc Performance Summary" in petsc_log.read_text()


@pytest.mark.parametrize("given, expected", [({}, "ob1"), ({"OMPI_MCA_pml": "ucx"}, "ucx"),
                                             ({"OMPI_COMM_WORLD_SIZE": "2"}, None), ({"PMI_RANK": "0"}, None)])
def test_single_process_mpi_only_without_a_launcher(monkeypatch, given, expected):
    """A run no launcher started takes OpenMPI's ob1 layer (no network probing at MPI's start); a layer the
    user chose, and a process that mpirun (or another launcher) started, are left as they are."""
    from fenics_plast import preload
    for var in (*preload.LAUNCHED, "OMPI_MCA_pml"):
        monkeypatch.delenv(var, raising=False)
    for var, value in given.items():
        monkeypatch.setenv(var, value)
    preload.single_process_mpi()
    assert os.environ.get("OMPI_MCA_pml") == expected
