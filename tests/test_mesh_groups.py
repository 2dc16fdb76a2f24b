"""Facet groups, conditions and contact surfaces checked before the run; Gmsh meshes in a child (issue 34,
items 3 and 4).

Item 3. dolfinx keeps one tag per facet: a facet in two physical groups came out in one of them only, so
the other group was silently empty (a reaction of 0 N on a grip named ``grip_face`` that shares line 3
with ``top``; a contact master sharing its facets with the group crashed; a group {1, 3} with 3 also in
``top`` kept line 1 only). Two groups sharing a facet are refused before the run when the scene names
one of them (``mesh.file``, both groups and the key named). A group with elements off the body crashed
the mesh distribution (exit 59 or 134): refused. A traction on a component a condition holds was
ignored; a contact surface of zero area (the axis in axisymmetry) and a meshed tool shorter than a cell
failed in the run; a misspelt boundary group was reported as the reaction output's problem: all are
refused before the run, the key named, nothing written.

Item 4. Gmsh reads and meshes the file in a child process with its memory capped: Gmsh dying is a
message naming mesh.file; the memory estimate reads the element sizes a .geo sets
(``Mesh.MeshSizeMax``).

Every case was a defect of the code before this work (it ran, crashed, or was refused after writing).
"""
from __future__ import annotations

import copy
import os
import signal
import subprocess
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mpi4py import MPI

from fenics_plast.errors import SceneError
from scene_runs import FP, ROOT

BAR = ROOT / "tests" / "scenes" / "bar.toml"        # static, axisymmetric, 2 x 3 cells of round_bar.geo
ROUND_BAR = (ROOT / "meshes" / "round_bar.geo").read_text(encoding="utf-8")
# round_bar.geo's lines: 1 bottom (z = 0), 2 outer, 3 top (z = L), 4 axis (r = 0); bar.toml: 2 x 3 cells
LINE_FACETS = {1: 2, 2: 3, 3: 2, 4: 3}
ORIGINAL = {"axis": {4}, "bottom": {1}, "top": {3}, "outer": {2}}


def scene(folder: Path, geo_extra: str = "", edits: dict | None = None, base: Path = BAR, geo: str = ROUND_BAR,
          name="scene") -> Path:
    """``base`` with its mesh a copy of ``geo`` + ``geo_extra`` in ``folder`` and ``edits`` ({"a.b.c":
    value}; None deletes the key) applied; returns the scene file."""
    raw = copy.deepcopy(tomllib.loads(base.read_text(encoding="utf-8")))
    (folder / f"{name}.geo").write_text(geo + geo_extra + "\n", encoding="utf-8")
    raw["mesh"]["file"] = f"{name}.geo"
    for dotted, value in (edits or {}).items():
        *parents, last = dotted.split(".")
        d = raw
        for p in parents:
            d = d.setdefault(p, {})
        if value is None:
            d.pop(last, None)
        else:
            d[last] = value
    path = folder / f"{name}.toml"
    path.write_text(tomli_w.dumps(raw), encoding="utf-8")
    return path


def refused_cli(tmp_path, path, *words):
    """``fenics-plast run``: exit 2, "error: SCENE: ..." with ``words`` on stderr, no traceback, nothing
    written (the --out folder absent, the test's folder unchanged)."""
    before = sorted(os.listdir(tmp_path))
    out = tmp_path / "out"
    p = subprocess.run(FP + ["run", str(path), "--out", str(out)], capture_output=True, text=True, cwd=tmp_path,
                       timeout=300, env=dict(os.environ, FENICS_PLAST_PROGRESS="off"))
    assert p.returncode == 2, p.stdout[-2000:] + p.stderr[-3000:]
    assert "Traceback" not in p.stderr + p.stdout, p.stderr
    assert p.stderr.startswith(f"error: {path}: "), p.stderr
    for w in words:
        assert w in p.stderr, (w, p.stderr)
    assert not out.exists() and sorted(os.listdir(tmp_path)) == before
    return p.stderr


def set_up(path: Path, sets=()):
    """The phase of ``fenics-plast run`` before its output folder: read_mesh + prepare, in-process."""
    from fenics_plast.problem import load_problem
    from fenics_plast.runner import prepare, read_mesh
    problem = load_problem(path, list(sets))
    mesh_data = read_mesh(problem, MPI.COMM_WORLD)
    return problem, mesh_data, prepare(problem, MPI.COMM_WORLD, mesh_data)


def facets_of(mesh_data, group) -> int:
    mesh, _, ft, groups = mesh_data
    fdim = mesh.topology.dim - 1
    n_owned = mesh.topology.index_map(fdim).size_local
    return MPI.COMM_WORLD.allreduce(int((ft.find(groups[group][1]) < n_owned).sum()), op=MPI.SUM)


# ----------------------------------------------------------------------------------------------
# item 3: groups sharing facets

GRIP = 'Physical Curve("grip_face", 20) = {3};'


def test_grip_face_sharing_top_is_refused(tmp_path):
    """The issue's case: `grip_face` = line 3, which `top` holds already; the grip and the force output
    on grip_face ran to exit 0 with a force of 0.0 N (grip_face was empty)."""
    path = scene(tmp_path, GRIP, {"boundary.grip.group": "grip_face", "outputs.force.group": "grip_face"})
    refused_cli(tmp_path, path, "mesh.file: ", "'top'", "'grip_face'", "share line 3", "boundary.grip.group",
                "a facet belongs to one group in this solver; name the facets once")


def test_a_group_named_once_works(tmp_path):
    """The same line named once (grip_face instead of top) is a group like any other: every facet in it."""
    geo = ROUND_BAR.replace('Physical Curve("top", 13) = {3};', GRIP)
    path = scene(tmp_path, "", {"boundary.grip.group": "grip_face", "outputs.force.group": "grip_face"}, geo=geo)
    _, mesh_data, built = set_up(path)
    assert facets_of(mesh_data, "grip_face") == 2 and built.solver is not None


def test_sharing_groups_the_scene_does_not_name_are_kept(tmp_path):
    """Groups that share a line and that no key names are no problem (the scene uses others): the outer
    line is in three groups, none of them named once outputs.radius is gone."""
    path = scene(tmp_path, 'Physical Curve("spare", 21) = {2};\nPhysical Curve("spare2", 22) = {2};',
                 {"outputs.radius": None})
    _, mesh_data, built = set_up(path)
    assert facets_of(mesh_data, "top") == 2 and built.solver is not None


@pytest.mark.parametrize("extra, edits, words", [
    # contact master sharing its facets with the group: a traceback before
    ('Physical Curve("outer_copy", 21) = {2};', {"contact.c.group": "outer", "contact.c.master": "outer_copy"},
     ["'outer'", "'outer_copy'", "share line 2", "contact.c.group names 'outer'", "contact.c.master"]),
    # a group of lines {1, 3} where 1 is also bottom's (and 3 top's): it kept one line only
    ('Physical Curve("ends", 21) = {1, 3};', {"outputs.radius.group": "ends"},
     ["'bottom'", "'ends'", "share line 1", "outputs.radius.group names 'ends'"]),
    # the scene names the group that already existed: it would be the one left empty
    ('Physical Curve("grip_face", 20) = {3};', {},
     ["'top'", "'grip_face'", "share line 3", "boundary.grip.group names 'top'"]),
], ids=["contact master", "two lines one shared", "the older group named"])
def test_groups_sharing_facets_are_refused_in_setup(tmp_path, extra, edits, words):
    path = scene(tmp_path, extra, edits)
    with pytest.raises(SceneError) as e:
        set_up(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}: mesh.file: "), msg
    for w in words:
        assert w in msg, (w, msg)


def test_a_msh_listing_one_facet_in_two_groups_is_refused(tmp_path):
    """A .msh (format 2) listing the same facet element twice, in two physical groups: refused naming both."""
    import gmsh
    base = tmp_path / "base.msh"
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        for k, v in {"radius": 1.5, "length": 4.0, "cells_radial": 2, "cells_axial": 3}.items():
            gmsh.onelab.setNumber(f"Parameters/{k}", [v])
        gmsh.open(str(ROOT / "meshes" / "round_bar.geo"))
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
        gmsh.write(str(base))
    finally:
        gmsh.onelab.clear()
        gmsh.finalize()
    lines = base.read_text().splitlines()
    i = lines.index("$Elements")
    n = int(lines[i + 1])
    elements = lines[i + 2:i + 2 + n]
    top = [e.split() for e in elements if e.split()[1] == "1" and e.split()[3] == "13"]
    extra = [" ".join([str(n + 1 + k), "1", "2", "20", "20"] + t[5:]) for k, t in enumerate(top)]
    j = lines.index("$PhysicalNames")
    lines[j + 1] = str(int(lines[j + 1]) + 1)
    lines.insert(j + 2, '1 20 "grip_face"')
    i = lines.index("$Elements")
    lines[i + 1] = str(n + len(extra))
    lines[i + 2 + n:i + 2 + n] = extra
    (tmp_path / "bar.msh").write_text("\n".join(lines) + "\n")
    raw = tomllib.loads(BAR.read_text())
    raw["mesh"] = {"file": "bar.msh", "geometry": "axisymmetric"}
    raw["boundary"]["grip"]["group"] = raw["outputs"]["force"]["group"] = "grip_face"
    path = tmp_path / "msh.toml"
    path.write_text(tomli_w.dumps(raw))
    with pytest.raises(SceneError) as e:
        set_up(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}: mesh.file: ") and "'top'" in msg and "'grip_face'" in msg and "share" in msg, msg


def test_a_group_off_the_body_is_refused(tmp_path):
    """A physical curve not on the body ended in a PETSc SEGV (exit 59) or a malloc crash (134), no message."""
    path = scene(tmp_path, 'Point(31) = {0.5, 50, 0}; Point(32) = {1.5, 50, 0}; Line(31) = {31, 32};\n'
                           'Physical Curve("floating", 18) = {31};')
    refused_cli(tmp_path, path, "mesh.file: ", "'floating'", "line 31", "nodes on no cell of the body")


# ----------------------------------------------------------------------------------------------
# item 3: conditions, contact surfaces, tools, names

def test_traction_on_a_held_component_is_refused(tmp_path):
    """A z traction on `top`, next to the z displacement of the grip, was accepted and ignored."""
    path = scene(tmp_path, "", {"boundary.t": {"group": "top", "type": "traction", "components": ["z"],
                                               "value": 10.0}})
    refused_cli(tmp_path, path, "boundary.t: component z of group 'top' is held by boundary.grip",
                "one condition per component")


@pytest.mark.parametrize("load, words", [
    ({"group": "bottom", "type": "traction", "components": ["z"], "value": 5.0},
     ["boundary.t: component z of group 'bottom' is held by boundary.mid_plane (type = 'symmetry')"]),
    ({"group": "top", "type": "pressure", "value": 5.0},
     ["boundary.t: component z of group 'top' is held by boundary.grip", "a pressure there would be ignored"]),
], ids=["traction on a symmetry", "pressure on a displacement"])
def test_loads_on_components_held_on_the_mesh_are_refused(tmp_path, load, words):
    path = scene(tmp_path, "", {"boundary.t": load})
    with pytest.raises(SceneError) as e:
        set_up(path)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_pressure_on_a_free_group_runs_setup(tmp_path):
    path = scene(tmp_path, "", {"boundary.t": {"group": "outer", "type": "pressure", "value": 5.0}})
    assert set_up(path)[2].solver is not None


def test_contact_surface_of_zero_area_is_refused(tmp_path):
    """The axis r = 0 has zero revolved area: the run wrote summary.json, then a traceback."""
    path = scene(tmp_path, "", {"contact.c": {"group": "outer", "master": "axis"}})
    refused_cli(tmp_path, path, "contact.c.master = 'axis'", "zero area", "r = 0")


TINY_TOOL = """Point(1) = {0.5, 4.2, 0}; Point(2) = {%s, 4.2, 0};
Line(1) = {2, 1};
Physical Curve("punch") = {1};
"""


@pytest.mark.parametrize("end, law", [("0.5000000001", "ludwik"), ("0.01", "swift")], ids=["1e-10 mm", "0.01 mm"])
def test_meshed_tool_shorter_than_a_cell_is_refused(tmp_path, end, law):
    """A meshed tool of 1e-10 mm (Ludwik: ZeroDivisionError) or 0.01 mm near the axis (Swift: "non-finite
    stress ... cell inverted"); only zero-length facets were refused."""
    geo = TINY_TOOL % end if end != "0.01" else TINY_TOOL.replace("0.5, 4.2", "0.0, 4.2") % end
    (tmp_path / "tool.geo").write_text(geo)
    hardening = {"ludwik": {"law": "ludwik", "yield_stress": 250.0, "K": 500.0, "n": 0.3},
                 "swift": {"law": "swift", "K": 500.0, "eps0": 0.01, "n": 0.2}}[law]
    path = scene(tmp_path, "", {"tools.p": {"shape": "mesh", "file": "tool.geo", "group": "punch"},
                                "contact.c": {"tool": "p", "group": "top"},
                                "materials.steel.hardening": hardening})
    refused_cli(tmp_path, path, "tools.p: the tool's surface spans", "less than the body's smallest cell")


def test_misspelt_boundary_group_is_named(tmp_path):
    """boundary.grip.group = "nope" was reported as outputs.force's missing condition."""
    path = scene(tmp_path, "", {"boundary.grip.group": "nope"})
    refused_cli(tmp_path, path, "boundary.grip.group = 'nope' is not a facet group")


def test_reaction_without_a_condition_is_still_refused(tmp_path):
    path = scene(tmp_path, "", {"outputs.force.group": "outer"})
    with pytest.raises(SceneError, match="outputs.force: group 'outer' has no boundary condition on component z"):
        set_up(path)


# ----------------------------------------------------------------------------------------------
# item 4: Gmsh in a child process

def test_gmsh_dying_is_a_message_naming_mesh_file(tmp_path, monkeypatch):
    """Gmsh killed by a signal while meshing (here: the child kills itself) ended the run with the raw
    signal; now a SceneError naming mesh.file, the file and the signal, and this process lives on."""
    import fenics_plast.meshing as meshing

    def die(*args):
        os.kill(os.getpid(), signal.SIGSEGV)
    monkeypatch.setattr(meshing, "_mesh_in_child", die)
    path = scene(tmp_path)
    with pytest.raises(SceneError) as e:
        set_up(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}: mesh.file: Gmsh died (signal 11, SIGSEGV) while meshing scene.geo"), msg


def test_gmsh_out_of_memory_is_a_message(tmp_path, monkeypatch):
    """The child's memory is capped: Gmsh running out of it is a MeshError, not the machine's memory."""
    import fenics_plast.gmsh_child as gmsh_child
    import fenics_plast.meshing as meshing
    monkeypatch.setattr(gmsh_child, "CHILD_MEMORY_SHARE", 1e-4 * 2**30 / (gmsh_child.machine_memory() or 2**30))
    geo = tmp_path / "square.geo"
    geo.write_text(SQUARE % "Mesh.MeshSizeMax = 0.01;")
    with pytest.raises(meshing.MeshError,
                       match=r"Gmsh ran out of memory \(its limit .* while meshing square.geo: the mesh is too fine"):
        meshing.mesh_from_file(MPI.COMM_WORLD, geo, gdim=2)


SQUARE = """%s
Point(1) = {0, 0, 0}; Point(2) = {10, 0, 0}; Point(3) = {10, 10, 0}; Point(4) = {0, 10, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Recombine Surface{1};
Physical Surface("bar", 1) = {1};
Physical Curve("bottom", 12) = {1}; Physical Curve("outer", 14) = {2};
Physical Curve("top", 13) = {3}; Physical Curve("axis", 11) = {4};
"""


def test_memory_estimate_reads_the_sizes_a_geo_sets(tmp_path):
    """`Mesh.MeshSizeMax = 0.0005` on a 10 x 10 square (4e8 cells): Gmsh grew past 3.4 GB in 150 s; now
    refused before meshing, naming mesh.file and the size."""
    path = scene(tmp_path, "", {"mesh.parameters": None}, geo=SQUARE % "Mesh.MeshSizeMax = 0.0005;")
    refused_cli(tmp_path, path, "mesh.file: scene.geo sets Mesh.MeshSizeMax = 0.0005 mm", "cells, which need")


def test_a_size_that_fits_meshes(tmp_path):
    path = scene(tmp_path, "", {"mesh.parameters": None}, geo=SQUARE % "Mesh.MeshSizeMax = 2.5;")
    _, mesh_data, _ = set_up(path)
    assert mesh_data[0].topology.index_map(2).size_global >= 16


# ----------------------------------------------------------------------------------------------
# property: random groups of round_bar.geo's lines named by random keys

KEYS = ["boundary.grip.group", "boundary.mid_plane.group", "outputs.force.group", "outputs.radius.group"]


@st.composite
def group_cases(draw):
    groups = {f"g{k}": set(draw(st.lists(st.sampled_from([1, 2, 3, 4]), min_size=1, max_size=4, unique=True)))
              for k in range(draw(st.integers(1, 3)))}
    names = sorted(ORIGINAL) + sorted(groups)
    edits = {k: draw(st.sampled_from(names)) for k in draw(st.lists(st.sampled_from(KEYS), max_size=3, unique=True))}
    return groups, edits


@settings(derandomize=True, database=None, deadline=None, max_examples=30,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(case=group_cases())
def test_random_groups_run_or_are_refused_naming_both(tmp_path_factory, case):
    from fenics_plast.problem import load_problem
    groups, edits = case
    folder = tmp_path_factory.mktemp("groups")
    extra = "\n".join(f'Physical Curve("{n}", {30 + i}) = {{{", ".join(map(str, sorted(lines)))}}};'
                      for i, (n, lines) in enumerate(groups.items()))
    path = scene(folder, extra, edits)
    try:
        problem = load_problem(path, [])
    except SceneError as e:         # (e.g. two conditions on one group's component: the scene alone tells)
        assert str(e).startswith(f"{path}: "), str(e)
        return
    lines = {**ORIGINAL, **groups}
    named = {b.group for b in problem.boundary.values()} | {o.group for o in problem.outputs.values()
                                                           if o.get("group")}
    sharing = [(a, b) for a in lines for b in lines if a < b and lines[a] & lines[b] and {a, b} & named]
    try:
        _, mesh_data, built = set_up(path)
    except SceneError as e:
        msg = str(e)
        assert msg.startswith(f"{path}: "), msg
        if sharing:
            assert msg.startswith(f"{path}: mesh.file: ") and "share line" in msg, msg
            assert any(f"'{a}'" in msg and f"'{b}'" in msg for a, b in sharing), (sharing, msg)
        else:
            assert "share" not in msg, msg
        return
    assert not sharing, (sharing, "ran")
    for n in named:                 # every group the scene uses holds every facet of its lines
        assert facets_of(mesh_data, n) == sum(LINE_FACETS[k] for k in lines[n]), n
    assert built.solver is not None
