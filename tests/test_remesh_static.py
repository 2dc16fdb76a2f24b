"""Remeshing in static runs (issue 35): fenics_plast/runner_static.py ``remeshed`` and ``run_static``'s
``[remeshing]`` table, on docs/tutorial/billet.toml (axisymmetric upsetting, 8 x 8 cells, one die,
Coulomb friction 0.1).

1. The billet pressed to t = 0.5 and remeshed 10 times in a row at that load (remeshing.size 1.25 mm):
   max eqps within 1 %, each re-equilibration at most 10 Newton iterations, the deformed volume within
   1e-3 and the stress-free volume within 2e-5 of the values before the first remesh, in both the
   frictionless billet and the tutorial's (mu = 0.1). The die force within 0.5 % and its radial (friction)
   force within 5 %: measured +0.05 % without friction after 10 remeshes, -0.35 % with mu = 0.1 (-0.50 %
   before the reference volume ratio was carried, below), where
   the contact's committed tractions (the stick state) are carried to the new nodes
   (``runner_static_remesh._carry_contact_history``); reset instead, each remesh at rest lost 12-24 % of the
   die's friction force (radial die force -21.3 -> -2.4 kN in 10 remeshes, press force -5.2 %).
   A homogeneous state (the billet pressed by a displacement condition) keeps its force to 1e-6 over 3
   remeshes at rest: the stress is tau / (J_ref theta), J_ref the new reference's volume ratio.
2. Scene checks: no [remeshing] -> ``problem.remeshing is None``; a 3-D scene, refine_size > size and a
   boundary value of x, y, z are refused by the CLI (exit 2, the key named, nothing written).
3. The tutorial through the CLI with remeshing.size = 1.25, remeshing.every = 5: converges, remeshes
   (summary's count and records, history's nondecreasing ``remeshes`` column), final die force and
   bulge radius within 1 % of the run without remeshing (measured -0.19 % and +0.03 %).
4. The same on two ranks (mpirun -n 2): the same final die force to 1e-6 (measured ~1e-14).
5. Slow: the backward extrusion (1 and 2 ranks; to 12 mm) and demos/billet_upsetting.toml with and without
   remeshing at 0.125 mm to 40 % (the die force within 0.5 %).
Run with ``pytest -s`` to see the measured numbers.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.problem import load_problem

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_runs import MPIRUN, history, needs_mpirun  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BILLET = ROOT / "docs" / "tutorial" / "billet.toml"
COMM = MPI.COMM_WORLD
REMESHES = 10
QUIET = ("output.xdmf=false", "output.plots=false")


def cli(*args, np_ranks=1, timeout=600):
    """``fenics-plast ARGS`` (under ``mpirun -n np_ranks`` when > 1, in an environment without this
    process's MPI variables); the CompletedProcess."""
    cmd = [sys.executable, "-m", "fenics_plast.cli", *map(str, args)]
    if np_ranks > 1:
        cmd = [MPIRUN, "--allow-run-as-root", "--oversubscribe", "-n", str(np_ranks)] + cmd
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    env.update(FENICS_PLAST_PROGRESS="off", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    return subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT, timeout=timeout)


def run_billet(out, *sets, np_ranks=1):
    p = cli("run", BILLET, "--out", out, *(a for s in (*QUIET, *sets) for a in ("--set", s)), np_ranks=np_ranks)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    return json.loads((Path(out) / "summary.json").read_text())


# --- 1. remeshed 10 times at one load --------------------------------------------------------------

def loaded_build(p, lam_end):
    """:func:`build_static` of the problem ``p`` loaded to ``lam_end`` by its analysis settings (the contact
    committed after each increment, as the runner does), ready for ``remeshed``."""
    from fenics_plast.runner_static import build_static
    b = build_static(p, COMM)
    b.u_before = 0.0
    ana = p.analysis
    commit = (lambda s: (b.contact.commit(), False)[1]) if b.contact is not None else None
    b.solver.run(increments=ana.increments, min_increment=ana.min_increment, max_increment=ana.max_increment,
                 lam_end=lam_end, callback=commit)
    return b


def remesh_series(friction):
    """The billet (friction ``friction``) pressed to t = 0.5, then remeshed REMESHES times at that load:
    (values before, [values after each remesh], [RemeshRecord]); values: die_force, max_eqps,
    bulge_radius, die_radial (the die's radial force: its friction), volume (deformed), free_volume
    (stress-free)."""
    from fenics_plast.quantities import Quantities
    from fenics_plast.remeshing.quality import deformed_nodes
    from fenics_plast.remeshing.remesher import Remesher
    from fenics_plast.runner_static import build_static
    from fenics_plast.runner_static_remesh import remeshed
    p = load_problem(BILLET, ["remeshing.size=1.25", "analysis.increments=10", f"contact.die.friction={friction}",
                              "outputs.die_radial.quantity=tool_force", "outputs.die_radial.tool=die",
                              "outputs.die_radial.component=r"])
    b = loaded_build(p, 0.5)
    assert b.solver.lam_converged == pytest.approx(0.5, abs=1e-12)
    remesher = Remesher(p.remeshing, True)

    def values(b):
        q = Quantities(p.outputs, b.body, b.facet_tags, b.groups, b.reactions)
        s = b.solver
        t = s.lam_converged
        v = {n: float(q.value(n, p.outputs[n], t, {})[0]) for n in ("die_force", "max_eqps", "bulge_radius",
                                                                      "die_radial")}
        v["volume"], v["free_volume"] = remesher.volumes(b.mesh, deformed_nodes(s.displacement_function()),
                                                         s.qmap.degree, s.qmap.state()["binv"])
        return q, v

    q, first = values(b)
    after, records = [], []
    for _ in range(REMESHES):
        b, rec, _before = remeshed(p, COMM, b, remesher, "test", q, build_static)
        assert b.solver.lam_converged == pytest.approx(0.5, abs=1e-12)
        q, v = values(b)
        after.append(v)
        records.append(rec)
    print(f"\nbillet mu = {friction}, t = 0.5, before: " + ", ".join(f"{k} {x:.6g}" for k, x in first.items()))
    for i, (v, r) in enumerate(zip(after, records), start=1):
        print(f"  remesh {i:2d}: {r.new_cells} cells, {r.equilibrium_iterations} Newton its, "
              + ", ".join(f"{k} {x:.6g}" + (f" ({(x - first[k]) / abs(first[k]):+.2e})" if first[k] else "")
                         for k, x in v.items()))
    return first, after, records


_SERIES = {}


def series(friction):
    """remesh_series(friction), made once per session."""
    if friction not in _SERIES:
        _SERIES[friction] = remesh_series(friction)
    return _SERIES[friction]


def relative(after, first, key):
    return np.array([(v[key] - first[key]) / abs(first[key]) for v in after])


@pytest.mark.parametrize("friction", [0.0, 0.1], ids=["frictionless", "mu0.1"])
def test_remesh_at_rest_keeps_state(friction):
    first, after, records = series(friction)
    assert len(after) == REMESHES and all(r.new_cells > 64 for r in records)
    its = [r.equilibrium_iterations for r in records]
    assert max(its) <= 10, its
    eqps = relative(after, first, "max_eqps")
    assert np.abs(eqps).max() <= 0.01, eqps
    vol = relative(after, first, "volume")
    assert np.abs(vol).max() <= 1e-3, vol
    free = relative(after, first, "free_volume")
    assert np.abs(free).max() <= 2e-5, free
    assert abs(first["free_volume"] - np.pi * 10.0 ** 2 * 10.0) <= 1e-9 * first["free_volume"]
    if friction == 0.0:             # with friction: test_remesh_keeps_friction_force
        force = relative(after, first, "die_force")
        assert np.abs(force).max() <= 0.005, force


def test_remesh_keeps_friction_force():
    friction = 0.1
    first, after, records = series(friction)
    radial = relative(after, first, "die_radial")
    force = relative(after, first, "die_force")
    print(f"\nmu = {friction}: die radial force relative change {radial}, die force {force}")
    # the target is 0.5 %; measured -0.33 % after 5 remeshes, -0.35 % after 10 (the drift slows down)
    assert np.abs(force).max() <= 0.005, force
    assert np.abs(radial).max() <= 0.05, radial


def pressed_scene(tmp_path):
    """The tutorial's billet without its die: the top face pressed down 3 t mm (a displacement
    condition, no contact): a homogeneous elastic-plastic state, which every transfer carries exactly."""
    text = BILLET.read_text().replace('file = "billet.geo"', f'file = "{BILLET.parent / "billet.geo"}"')
    text = text[:text.index("[contact.die]")] + text[text.index("[outputs.die_travel]"):]
    text = text.replace('[outputs.die_force]\nquantity = "tool_force"\ntool = "die"',
                        '[outputs.die_force]\nquantity = "reaction"\ngroup = "top"')
    text += '\n[boundary.press]\ngroup = "top"\ntype = "displacement"\ncomponents = ["z"]\nvalue = "-3.0*t"\n'
    scene = tmp_path / "pressed.toml"
    scene.write_text(text)
    return scene


def test_remesh_at_rest_keeps_homogeneous_stress(tmp_path):
    """The billet pressed 0.03 mm (0.3 %, yielding: 103 kN) and remeshed 3 times at that load: the press
    force stays to 1e-6 (measured 7e-8). The new mesh's reference is the deformed shape, and the stress
    is tau / (J_ref theta) with J_ref the reference's volume ratio carried over
    (``runner_static_remesh._volume_ratio``); taken as 1, the force dropped by the elastic volume change,
    -6.2e-4."""
    from fenics_plast.quantities import Quantities
    from fenics_plast.remeshing.remesher import Remesher
    from fenics_plast.runner_static import build_static
    from fenics_plast.runner_static_remesh import remeshed
    p = load_problem(pressed_scene(tmp_path), ["remeshing.size=1.25", "analysis.increments=4"])
    b = loaded_build(p, 0.01)

    def force(b):
        q = Quantities(p.outputs, b.body, b.facet_tags, b.groups, b.reactions)
        return q, float(q.value("die_force", p.outputs["die_force"], b.solver.lam_converged, {})[0])

    q, first = force(b)
    assert first > 100.0                   # kN: beyond the yield force 100 kN of 318 MPa on 314 mm^2
    remesher = Remesher(p.remeshing, True)
    for _ in range(3):
        b, rec, _before = remeshed(p, COMM, b, remesher, "test", q, build_static)
        q, now = force(b)
        print(f"\npressed billet remeshed at rest: {first!r} -> {now!r} kN ({(now - first) / first:+.2e}), "
              f"{rec.new_cells} cells, {rec.equilibrium_iterations} Newton iterations")
        assert abs(now - first) <= 1e-6 * first


# --- 2. scene checks -------------------------------------------------------------------------------

def test_no_table_no_remeshing():
    assert load_problem(BILLET).remeshing is None
    rm = load_problem(BILLET, ["remeshing.size=1.25"]).remeshing
    assert rm is not None and rm.size == 1.25 and rm.refine_size is None and rm.every == 0
    assert rm.max_remeshes == 100 and rm.min_scaled_jacobian == 0.2 and rm.max_angle == 160.0
    assert load_problem(BILLET, ["remeshing.size=1.25", "remeshing.refine_size=1.25"]).remeshing.refine_size == 1.25


def xdep_scene(tmp_path, value):
    text = BILLET.read_text().replace('file = "billet.geo"', f'file = "{BILLET.parent / "billet.geo"}"')
    text += f'\n[boundary.squeeze]\ngroup = "outer"\ntype = "displacement"\ncomponents = ["r"]\nvalue = "{value}"\n'
    scene = tmp_path / f"xdep_{len(value)}.toml"
    scene.write_text(text)
    return scene


@pytest.mark.parametrize("case", ["3d", "refine_size", "x_dependent"])
def test_refused_scenes(tmp_path, case):
    if case == "3d":
        scene, sets, key = ROOT / "demos" / "punch_stretching_3d.toml", ["remeshing.size=1"], "remeshing"
        assert load_problem(scene).remeshing is None                    # loads without the table
    elif case == "refine_size":
        scene, sets, key = BILLET, ["remeshing.size=1.25", "remeshing.refine_size=2"], "remeshing.refine_size"
    else:
        scene, sets, key = xdep_scene(tmp_path, "0.01*x*t"), ["remeshing.size=1.25"], "boundary.squeeze.value"
        assert load_problem(scene).remeshing is None                    # fine without remeshing
        assert load_problem(xdep_scene(tmp_path, "0.01*t"), sets).remeshing.size == 1.25    # fine: t alone
    out = tmp_path / "out"
    r = cli("run", scene, "--out", out, *(a for s in sets for a in ("--set", s)), timeout=120)
    print(f"\n{case}: exit {r.returncode}: {r.stderr.strip()}")
    assert r.returncode == 2, r.stdout + r.stderr
    assert r.stderr.startswith("error: ") and key in r.stderr, r.stderr
    assert "Traceback" not in r.stderr
    assert not out.exists() or not any(out.iterdir())


# --- 3. and 4. whole runs through the CLI ----------------------------------------------------------

REMESH_SETS = ("remeshing.size=1.25", "remeshing.every=5")


@pytest.fixture(scope="module")
def billet_runs(tmp_path_factory):
    """(without remeshing, with remeshing): (summary, history) of the tutorial through the CLI."""
    d = tmp_path_factory.mktemp("billet_remesh")
    plain = run_billet(d / "plain")
    remeshed_run = run_billet(d / "remeshed", *REMESH_SETS)
    return (plain, history(d / "plain")), (remeshed_run, history(d / "remeshed"))


def test_cli_run_with_remeshing(billet_runs):
    (s0, h0), (s1, h1) = billet_runs
    assert s0["converged"] and s1["converged"] and s1["final_time"] == pytest.approx(1.0, abs=1e-12)
    assert "remeshes" not in s0 and "remeshes" not in h0.dtype.names
    assert s1["remeshes"] >= 1 and len(s1["remesh_records"]) == s1["remeshes"]
    for i, rec in enumerate(s1["remesh_records"], start=1):
        assert rec["number"] == i and rec["reason"] == "every 5 increments" and rec["new_cells"] > 0
        assert rec["equilibrium_iterations"] <= 10 and "die_force" in rec["jump"]
    col = h1["remeshes"]
    assert col[0] == 0 and np.all(np.diff(col) >= 0) and col[-1] == s1["remeshes"]
    f0, f1 = h0["die_force_kN"][-1], h1["die_force_kN"][-1]
    r0, r1 = h0["bulge_radius_mm"][-1], h1["bulge_radius_mm"][-1]
    print(f"\nCLI billet: {s1['remeshes']} remeshes, {s1['cells']} cells at the end; final die force "
          f"{f0:.6g} -> {f1:.6g} kN ({(f1 - f0) / f0:+.3%}), bulge radius {r0:.6g} -> {r1:.6g} mm "
          f"({(r1 - r0) / r0:+.3%}), volume change {s1['volume_change']:+.3e} "
          f"(unexplained {s1['volume_change_unexplained']:+.3e})")
    assert abs(f1 - f0) <= 0.01 * f0
    assert abs(r1 - r0) <= 0.01 * r0
    assert s1["max_die_force_kN"] == pytest.approx(f1, rel=1e-12)


@needs_mpirun
def test_cli_remeshing_two_ranks(billet_runs, tmp_path):
    (_, _), (s1, h1) = billet_runs
    s2 = run_billet(tmp_path / "two", *REMESH_SETS, np_ranks=2)
    h2 = history(tmp_path / "two")
    assert s2["mpi_ranks"] == 2 and s1["mpi_ranks"] == 1
    f1, f2 = h1["die_force_kN"][-1], h2["die_force_kN"][-1]
    print(f"\n1 vs 2 ranks: final die force {f1!r} vs {f2!r} kN ({(f2 - f1) / f1:+.2e}), remeshes "
          f"{s1['remeshes']} vs {s2['remeshes']}, cells {s1['cells']} vs {s2['cells']}")
    assert s2["remeshes"] == s1["remeshes"] and s2["cells"] == s1["cells"]
    assert [r["new_cells"] for r in s2["remesh_records"]] == [r["new_cells"] for r in s1["remesh_records"]]
    assert abs(f2 - f1) <= 1e-6 * abs(f1)
    assert s2["max_die_force_kN"] == pytest.approx(s1["max_die_force_kN"], rel=1e-6)
    assert s2["bulge_radius_mm"] == pytest.approx(s1["bulge_radius_mm"], rel=1e-6)


def test_kill_and_resume_across_remeshes(tmp_path):
    """A run killed after its third checkpoint (increment 9: the body remeshed once, at increment 5)
    resumes on the remeshed mesh (made again from the checkpoint's record) and ends as the run that
    was not killed: same remeshes, cells, die force and energies, to round-off."""
    sets = ("remeshing.size=1.25", "remeshing.every=5", "output.checkpoint_every=3", "outputs.e.quantity=energy",
            "outputs.e.energy=all")
    whole = run_billet(tmp_path / "whole", *sets)
    args = [a for s in (*QUIET, *sets) for a in ("--set", s)]
    import os
    os.environ["FENICS_PLAST_KILL_AFTER_CHECKPOINTS"] = "3"
    try:
        p = cli("run", BILLET, "--out", tmp_path / "killed", *args)
    finally:
        del os.environ["FENICS_PLAST_KILL_AFTER_CHECKPOINTS"]
    assert p.returncode != 0 and not (tmp_path / "killed" / "summary.json").exists()
    p = cli("run", BILLET, *args, "--resume", tmp_path / "killed")
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    resumed = json.loads((tmp_path / "killed" / "summary.json").read_text())
    final = [history(d)["die_force_kN"][-1] for d in (tmp_path / "killed", tmp_path / "whole")]
    print(f"\nresumed from checkpoint {resumed['resumed_from_checkpoint']}: final die force {final[0]!r} vs "
          f"{final[1]!r}, remeshes {resumed['remeshes']} vs {whole['remeshes']}")
    assert resumed["resumed_from_checkpoint"] == 9 and whole["remesh_records"][0]["at"] < 0.5
    assert resumed["remeshes"] == whole["remeshes"] == 2 and resumed["cells"] == whole["cells"]
    assert final[0] == pytest.approx(final[1], rel=1e-9)
    for k in ("max_die_force_kN", "bulge_radius_mm", "plastic_dissipation_J", "elastic_energy_J", "contact_work_J"):
        assert resumed[k] == pytest.approx(whole[k], rel=1e-9, abs=1e-12), k


EXTRUSION = ROOT / "demos" / "backward_extrusion.toml"


@pytest.mark.slow
@needs_mpirun
def test_backward_extrusion_serial_equals_two_ranks(tmp_path):
    """demos/backward_extrusion.toml to 3 mm of punch travel (several remeshes), 1 and 2 ranks: the same
    remeshes and punch force history to 1e-6 relative (Gmsh meshes on rank 0 for both; the solves differ
    in their sums' order only)."""
    sets = ("tools.punch.path={t=[0.0,1.0],y=[0.0,-3.0]}",)
    one = run_billet_like(EXTRUSION, tmp_path / "one", sets)
    two = run_billet_like(EXTRUSION, tmp_path / "two", sets, np_ranks=2)
    f1, f2 = history(tmp_path / "one")["punch_force_kN"], history(tmp_path / "two")["punch_force_kN"]
    print(f"\nextrusion to 3 mm: {one['remeshes']} remeshes; final punch force {f1[-1]!r} vs {f2[-1]!r}; largest "
          f"relative difference over the history {np.max(np.abs(f2 - f1) / np.maximum(np.abs(f1), 1e-9)):.2e}")
    assert one["remeshes"] == two["remeshes"] >= 1 and len(f1) == len(f2)
    assert np.max(np.abs(f2 - f1) / np.maximum(np.abs(f1), 1.0)) <= 1e-6


@pytest.mark.slow
def test_backward_extrusion_to_12_mm(tmp_path):
    """The demo as shipped: to 12 mm of travel; volume change beyond the elastic one below 0.2 %; punch
    work = plastic dissipation + elastic energy + contact work within 1 % (the remeshes' jumps count);
    the plastic dissipation the eqps field implies within 2 % of the one the work gives."""
    s = run_billet_like(EXTRUSION, tmp_path / "r", ())
    print(f"\nextrusion: {s['remeshes']} remeshes, volume change {s['volume_change']:.3e} (unexplained "
          f"{s['volume_change_unexplained']:.3e}), balance {s['energy_balance_error']:.3e}, plastic "
          f"{s['plastic_dissipation_J']:.2f} J (from eqps {s['plastic_dissipation_from_eqps_J']:.2f} J)")
    assert s["converged"] and history(tmp_path / "r")["punch_travel_mm"][-1] == pytest.approx(12.0)
    assert abs(s["volume_change_unexplained"]) < 2e-3
    assert s["energy_balance_error"] < 0.01
    assert s["plastic_dissipation_from_eqps_J"] == pytest.approx(s["plastic_dissipation_J"], rel=0.02)


@pytest.mark.slow
def test_billet_with_and_without_remeshing(tmp_path):
    """demos/billet_upsetting.toml to 40 % height reduction (6 mm of die travel, 0.09 mm increments as in
    the demo) at the finest level of benchmarks/bench_remesh_billet.py: the 80 x 120 structured mesh without
    remeshing and remeshed at 0.125 mm (0.0625 at corners): the die force within the issue's 0.5 % from
    0.3 mm on (measured -0.20 %, at the first remesh, 1.7 mm; -0.22 % in the benchmark's run to 60 %; at
    0.5 and 0.25 mm the benchmark gives 1.33 and 0.78 %: the first remesh's transient at the sticking
    corner, first order in h). About 6 minutes."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_remesh_billet import SCENE, against, cells, plain_scene
    h = 0.125
    sets = (*cells(h), "tools.die.path={t=[0.0,1.0],y=[0.0,-6.0]}", "analysis.increments=67",
            "analysis.max_increment=0.015")
    plain = run_billet_like(plain_scene(tmp_path), tmp_path / "plain", sets)
    remeshed = run_billet_like(SCENE, tmp_path / "remeshed", (*sets, f"remeshing.size={h}",
                                                               f"remeshing.refine_size={h / 2}"))
    h0, h1 = (history(tmp_path / d) for d in ("plain", "remeshed"))
    d, where, mean = against(h1, h0, 6.0)
    print(f"\nbillet at {h} mm to 40 %: {remeshed['remeshes']} remeshes; die force remeshed against plain: "
          f"largest {d:+.3%} (at {where:.2f} mm), mean {mean:.3%}")
    assert plain["converged"] and remeshed["converged"] and remeshed["remeshes"] >= 1
    assert h1["die_travel_mm"][-1] == pytest.approx(6.0)
    assert abs(d) <= 0.005


def run_billet_like(scene, out, sets, np_ranks=1):
    p = cli("run", scene, "--out", out, *(a for s in (*QUIET, *sets) for a in ("--set", s)), np_ranks=np_ranks,
            timeout=3000)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    return json.loads((Path(out) / "summary.json").read_text())
