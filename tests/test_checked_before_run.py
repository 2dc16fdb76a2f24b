"""What can be known before the run is checked before the run (issue 21, item 4).

Each defect of the issue is run through ``fenics-plast run`` on a small scene of tests/scenes (or
demos/taylor_bar.toml for an explicit one), with the issue's values as ``--set`` options: the run exits
2, stderr names the file and the dotted key, there is no traceback, and nothing is written (the
``--out`` folder is not created; the test's folder holds only what the test put there). Before this
work, each of them either passed validation and crashed at run time (exit 1, a traceback), ran and
reported nonsense (exit 0), or was refused after the output folder (summary.json, fields.xdmf,
checkpoint/) had been written.

Also here: what still goes wrong during the run (an output that is not finite for the values the
run gives it) ends as a failed run (exit 1, summary.json naming the key, no traceback), and the
history rows are capped at one per time step.
"""
from __future__ import annotations

import json
import os
import subprocess
import textwrap
from pathlib import Path

import pytest

from scene_runs import FP, ROOT

BAR = ROOT / "tests" / "scenes" / "bar.toml"              # static, axisymmetric, 2 x 3 cells
RING = ROOT / "tests" / "scenes" / "ring.toml"            # static, plane strain
WALL = ROOT / "tests" / "scenes" / "bar_on_wall.toml"     # explicit, axisymmetric, 2 x 40 cells
TAYLOR = ROOT / "demos" / "taylor_bar.toml"               # explicit, 6 x 24 cells


def cli(scene, out, *sets, expect):
    """``fenics-plast run SCENE --out OUT --set ...``: asserts the exit status and no traceback;
    returns stderr."""
    cmd = FP + ["run", str(scene), "--out", str(out)]
    for s in sets:
        cmd += ["--set", s]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=Path(out).parent, timeout=300,
                       env=dict(os.environ, FENICS_PLAST_PROGRESS="off"))
    assert p.returncode == expect, p.stdout[-2000:] + p.stderr[-2000:]
    assert "Traceback" not in p.stderr + p.stdout, p.stderr
    return p.stderr


def refused(tmp_path, scene, key, *sets, words=()):
    """The run is refused: exit 2, "error: SCENE: KEY..." on stderr, nothing written."""
    before = sorted(os.listdir(tmp_path))
    out = tmp_path / "out"
    err = cli(scene, out, *sets, expect=2)
    assert err.startswith(f"error: {scene}: {key}"), err
    for w in words:
        assert w in err, err
    assert not out.exists(), sorted(os.listdir(out))
    assert sorted(os.listdir(tmp_path)) == before
    return err


# ----------------------------------------------------------------------------------------------
# expressions


@pytest.mark.parametrize("value, words", [
    ("9**9**9", ["'9**9**9' is not finite (it computes to inf)"]),
    ("10**400", ["'10**400' is not finite"]),
    ("log(t)", ['"log(t)" gives a non-finite value (-inf) at t=0']),
    ("exp(1000*t)", ['"exp(1000*t)" gives a non-finite value (inf) at t=']),
], ids=["9**9**9", "10**400", "log(t)", "exp(1000*t)"])
def test_displacement_expression_not_finite(tmp_path, value, words):
    """Passed validation and crashed at run time (exit 1, traceback); exp(1000 t) as a displacement
    ended in a ZeroDivisionError in the material kernel."""
    refused(tmp_path, BAR, "boundary.grip.value", f'boundary.grip.value="{value}"', words=words)


def test_traction_overflowing_constant(tmp_path):
    """A traction "1e308*10*t" reached the generated C code ('inf' undeclared, VerificationError, no
    key named): the constant part is computed when the file is read."""
    refused(tmp_path, BAR, "boundary.pull.value", 'boundary.pull.type="traction"', 'boundary.pull.group="outer"',
            'boundary.pull.components=["r"]', 'boundary.pull.value="1e308*10*t"',
            words=["'1e308*10' is not finite"])


def test_traction_of_x_not_finite_on_its_group(tmp_path):
    """A value of x, y, z is evaluated at its group's nodes (here r = 0 to 1.5 mm on "top")."""
    refused(tmp_path, BAR, "boundary.pull.value", 'boundary.pull.type="traction"', 'boundary.pull.group="top"',
            'boundary.pull.components=["z"]', 'boundary.pull.value="t * sqrt(x - 1)"',
            words=['"t * sqrt(x - 1)" gives a non-finite value (nan) at x='])


def test_initial_velocity_not_finite_over_the_body(tmp_path):
    """sqrt(x - 100) in an initial velocity crashed (traceback, exit 1)."""
    refused(tmp_path, WALL, "initial_velocity.bar.value[1]", 'initial_velocity.bar.value=[0.0, "sqrt(x - 100)"]',
            words=['"sqrt(x - 100)" gives a non-finite value (nan) at x='])


def test_output_expression_divides_by_zero(tmp_path):
    """force/(elongation - elongation) in an output crashed (traceback, exit 1)."""
    refused(tmp_path, BAR, "outputs.ratio.expression", 'outputs.ratio.quantity="expression"',
            'outputs.ratio.expression="force/(radius - radius)"',
            words=["divides by (radius - radius), which is 0 whatever the values"])


def test_output_expression_not_finite_at_t0(tmp_path):
    refused(tmp_path, BAR, "outputs.ratio.expression", 'outputs.ratio.quantity="expression"',
            'outputs.ratio.expression="force * log(t)"', words=["is not finite at t = 0"])


def test_output_not_finite_during_the_run_fails_the_run(tmp_path):
    """What the check cannot know (force / force is finite for every force but 0, and the force is 0 at
    t = 0): a failed run, exit 1, summary.json with the error naming the key, no traceback."""
    out = tmp_path / "out"
    err = cli(BAR, out, 'outputs.ratio.quantity="expression"', 'outputs.ratio.expression="force/force"', expect=1)
    assert "outputs.ratio.expression" in err and "non-finite value (nan)" in err, err
    s = json.loads((out / "summary.json").read_text())
    assert s["converged"] is False and s["error"].startswith(f"{BAR}: outputs.ratio.expression: ")


def test_flat_sum_of_41_terms_runs(tmp_path):
    """A flat sum of 41 terms was refused as "nesting deeper than 40 levels"."""
    value = " + ".join(["t/41"] * 41)
    cli(BAR, tmp_path / "out", f'boundary.grip.value="{value}"', expect=0)
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["converged"] is True and s["final_time"] == pytest.approx(1.0)


# ----------------------------------------------------------------------------------------------
# mesh parameters, the mesh itself, its size


@pytest.mark.parametrize("count", ["0", "-4", "2.5"])
def test_cell_count_not_a_positive_integer(tmp_path, count):
    """cells_radial = 0 or -4 ran a 1-cell-wide mesh."""
    refused(tmp_path, BAR, f"mesh.parameters.cells_radial = {count} is out of range",
            f"mesh.parameters.cells_radial={count}", words=["must be an integer >= 1"])


def test_negative_radius(tmp_path):
    """radius = -6.413 ran an axisymmetric body at r < 0 and reported converged = true, force 0."""
    refused(tmp_path, BAR, "mesh.parameters.radius = -6.413 is out of range", "mesh.parameters.radius=-6.413",
            words=["must be > 0"])


def test_parameter_outside_the_geo_min_max(tmp_path):
    """round_bar.geo declares imperfection with Min 0 and Max 0.9 (its default 0 is allowed)."""
    refused(tmp_path, BAR, "mesh.parameters.imperfection = 1.5 is out of range", "mesh.parameters.imperfection=1.5",
            words=["round_bar.geo allows 0.0 <= imperfection <= 0.9"])


SQUARE_GEO = """\
Point(1) = {X0, 0, 0, 0.5};
Point(2) = {1.5, 0, 0, 0.5};
Point(3) = {1.5, 4, 0, 0.5};
Point(4) = {X0, 4, 0, 0.5};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
RECOMBINE
Physical Curve("bottom") = {1};
Physical Curve("outer") = {2};
Physical Curve("top") = {3};
Physical Curve("axis") = {4};
Physical Surface("body") = {1};
"""


def _bar_on(tmp_path, geo_text, scene=BAR):
    """The scene with its mesh replaced by a .geo of ``geo_text`` (no parameters) in tmp_path."""
    (tmp_path / "body.geo").write_text(geo_text)
    text = scene.read_text()
    text = text.replace('file = "../../meshes/round_bar.geo"', 'file = "body.geo"')
    start = text.index("[mesh.parameters]")
    text = text[:start] + text[text.index("[materials", start):]
    path = tmp_path / scene.name
    path.write_text(text)
    return path


def test_axisymmetric_node_at_negative_radius(tmp_path):
    """An axisymmetric mesh reaching x < 0 (here from a .geo without parameters) is refused after
    meshing, before anything is written."""
    geo = SQUARE_GEO.replace("X0", "-0.5").replace("RECOMBINE", "Transfinite Surface{1}; Recombine Surface{1};")
    scene = _bar_on(tmp_path, geo)
    refused(tmp_path, scene, "mesh.file: with mesh.geometry = 'axisymmetric' x is the radius",
            words=["this mesh reaches x = -0.5 mm"])


@pytest.mark.parametrize("scene", [BAR, WALL], ids=["static", "explicit"])
def test_triangles_refused(tmp_path, scene):
    """2-D triangles were accepted by the static solver (reported as q1p0) and crashed the explicit
    one with a traceback after 8 s."""
    geo = SQUARE_GEO.replace("X0", "0").replace("RECOMBINE", "")
    refused(tmp_path, _bar_on(tmp_path, geo, scene), "mesh.file: body.geo: the 2-D elements are linear "
            "quadrilaterals only", words=["Triangle 3"])


@pytest.mark.parametrize("sets, key", [
    (["mesh.refine=10000"], "mesh.refine = 10000"),
    (["mesh.parameters.cells_radial=100000", "mesh.parameters.cells_axial=100000"], "mesh.parameters: cells_radial"),
], ids=["refine", "1e5 a side"])
def test_mesh_too_large_for_the_memory(tmp_path, sets, key):
    """mesh.refine = 1000 (or 1e5 cells a side) ended in std::bad_alloc, exit 134: the size is estimated
    before meshing (here 6e8 and 1e10 cells, hundreds of GiB at the least)."""
    refused(tmp_path, BAR, key, *sets, words=["cells, which need at least", "GiB of memory"])


# ----------------------------------------------------------------------------------------------
# rules the runners enforced after meshing (after writing summary.json, fields.xdmf, checkpoint/)


def test_symmetry_group_not_straight(tmp_path):
    refused(tmp_path, RING, "boundary.s: type = 'symmetry' needs a straight group", 'boundary.s.type="symmetry"',
            'boundary.s.group="outer"', "output.checkpoint_every=1")


@pytest.mark.parametrize("sets, words", [
    (['outputs.force.group="outer"'], ["group 'outer' has no boundary condition on component z"]),
    (['outputs.force.group="bottom"', 'outputs.force.component="r"'],      # bottom: a symmetry in z
     ["group 'bottom' has no boundary condition on component r"]),
], ids=["no condition", "symmetry in another component"])
def test_reaction_without_a_condition(tmp_path, sets, words):
    refused(tmp_path, BAR, "outputs.force", *sets, words=words)


def test_fixed_time_step_above_the_stable_limit(tmp_path):
    """Exited 1 after writing summary.json, fields.xdmf and an empty checkpoint/."""
    refused(tmp_path, TAYLOR, "analysis.time_steps = 2", "analysis.end_time=2", "analysis.time_steps=2",
            words=["exceeds the stable limit", "use at least 18 steps"])


def test_wall_through_the_body(tmp_path):
    """A wall the body lies on both sides of was refused after the output folder was written."""
    refused(tmp_path, WALL, "boundary.floor: the body lies on both sides of the wall at z = 5 mm",
            "boundary.floor.position=5.0")


@pytest.mark.parametrize("scene, sets, axis", [(WALL, "mesh.parameters.length=1e-300", "z"),
                                               (BAR, "mesh.parameters.radius=1e-9", "r")])
def test_a_body_thinner_than_a_nanometre(tmp_path, scene, sets, axis):
    """mesh.parameters.length = 1e-300 (found by the slow fuzz test) passed the "lengths > 0" check and
    crashed the stable step with a ZeroDivisionError (cell areas underflow): exit 1, a traceback."""
    refused(tmp_path, scene, f"mesh.parameters: the body spans", sets, words=[f"mm along {axis}", "1e-06 mm"])


def test_cold_compiler_cache_prints_nothing_before_the_error(tmp_path):
    """On a fresh machine FFCx compiles every form; through setuptools (Debian 12) each gcc call was
    logged as "INFO:root:..." on stderr ahead of the error (found by the fresh-root check). With an
    empty compiler cache, stderr is the error message alone."""
    before = sorted(os.listdir(tmp_path))
    cache = tmp_path.parent / f"{tmp_path.name}_cache"
    cmd = FP + ["run", str(WALL), "--out", str(tmp_path / "out"), "--set", "boundary.floor.position=5.0"]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, timeout=300,
                       env=dict(os.environ, FENICS_PLAST_PROGRESS="off", XDG_CACHE_HOME=str(cache)))
    assert p.returncode == 2, p.stderr
    assert any((cache / "fenics").iterdir()), "the compiler cache was not cold: nothing was compiled"
    assert p.stderr.startswith(f"error: {WALL}: boundary.floor: the body lies on both sides"), p.stderr
    assert p.stderr.count("\n") == 1, p.stderr
    assert sorted(os.listdir(tmp_path)) == before


@pytest.mark.parametrize("sets, key", [
    (['outputs.r.quantity="reaction"', 'outputs.r.group="axis"', 'outputs.r.component="r"'],
     "outputs.r.quantity = 'reaction' is for static analyses"),
    (['boundary.p.type="pressure"', 'boundary.p.group="top"', "boundary.p.value=1"],
     "boundary.p.type = 'pressure' is for static analyses"),
    (['boundary.p.type="traction"', 'boundary.p.group="top"', 'boundary.p.components=["z"]',
      'boundary.p.value="x * t"'], "boundary.p.value: explicit tractions must be uniform"),
], ids=["reaction", "pressure", "traction of x"])
def test_explicit_rules_in_validation(tmp_path, sets, key):
    """A reaction output in an explicit run crashed (KeyError, traceback); pressure and tractions of x
    were refused after the output folder was written."""
    refused(tmp_path, WALL, key, *sets)


# ----------------------------------------------------------------------------------------------
# conflicting conditions, history rows


@pytest.mark.parametrize("kind, extra", [("displacement", ["boundary.g2.value=0.5"]), ("fixed", [])],
                         ids=["displacement z twice", "fixed z + displacement z"])
def test_two_conditions_on_one_component(tmp_path, kind, extra):
    """The last condition, or the displacement, won silently."""
    refused(tmp_path, BAR, "boundary.g2: component z of group 'top' is also held by boundary.grip",
            'boundary.g2.group="top"', f'boundary.g2.type="{kind}"', 'boundary.g2.components=["z"]', *extra)


def test_symmetry_and_fixed_on_one_component(tmp_path):
    """The component a symmetry holds is known on the mesh: checked there, before writing."""
    refused(tmp_path, BAR, "boundary.mid_plane: the component normal to symmetry group 'bottom' (z) is also held "
            "by boundary.s", 'boundary.s.group="bottom"', 'boundary.s.type="fixed"', 'boundary.s.components=["z"]')


def test_history_points_beyond_the_limit(tmp_path):
    """history_points = 100000000 forced dt 10,000 times below the stable step (25-32 h estimated)."""
    refused(tmp_path, TAYLOR, "output.history_points = 100000000 is out of range", "output.history_points=100000000",
            words=["history_points <= 100000"])


def test_history_rows_capped_at_one_per_step(tmp_path):
    """More rows than time steps: one row per step, and the log says so."""
    out = tmp_path / "out"
    p = subprocess.run(FP + ["run", str(TAYLOR), "--out", str(out), "--set", "analysis.end_time=2", "--set",
                             "output.history_points=5000", "--set", "output.xdmf=false", "--set", "output.plots=false"],
                       capture_output=True, text=True, cwd=tmp_path, timeout=300,
                       env=dict(os.environ, FENICS_PLAST_PROGRESS="off"))
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    s = json.loads((out / "summary.json").read_text())
    rows = (out / "history.csv").read_text().splitlines()[1:]
    assert len(rows) == s["steps"] + 1 < 5000
    assert f"output.history_points = 5000 is more than the run's about {s['steps']} time steps" in p.stdout


def test_geo_parameters_read_from_the_text(tmp_path):
    """The DefineConstant defaults, Min and Max as the parameter checks read them (comments skipped)."""
    from fenics_plast.mesh_size import geo_parameters
    f = tmp_path / "p.geo"
    f.write_text(textwrap.dedent("""\
        // x = {9, Name "Parameters/commented"}
        DefineConstant[
          a = {1.5, Min 0.5, Max 2e1, Name "Parameters/length"},
          n = {4, Name "Parameters/cells_x"}, /* {7, Name "Parameters/hidden"} */
          g = {-1, Min -3, Name "Parameters/offset"}
        ];
        """))
    assert geo_parameters(f) == {"length": {"value": 1.5, "min": 0.5, "max": 20.0}, "cells_x": {"value": 4.0},
                                 "offset": {"value": -1.0, "min": -3.0}}


def test_geo_parameters_read_through_includes(tmp_path):
    """A parameter defined in an Include'd file (where the Include stands; the first definition counts, as
    in Gmsh) has its default, Min and Max read too; an Include cycle ends."""
    from fenics_plast.mesh_size import geo_parameters
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "params.geo").write_text(
        'DefineConstant[ t = {2, Min 0.5, Max 4, Name "Parameters/thickness"},\n'
        '                w = {7, Name "Parameters/width"} ];\nInclude "../main.geo";\n')
    (tmp_path / "main.geo").write_text(
        'DefineConstant[ w = {3, Min 1, Name "Parameters/width"} ];\nInclude "sub/params.geo";\n'
        'Include "missing.geo";\n')
    assert geo_parameters(tmp_path / "main.geo") == {"width": {"value": 3.0, "min": 1.0},
                                                     "thickness": {"value": 2.0, "min": 0.5, "max": 4.0}}
