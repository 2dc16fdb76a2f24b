"""Static contact between two deformable bodies (contact.<name>.master in a static scene,
fenics_plast.solvers.static_surface_contact): Hertz's sphere on a half-space (contact radius and peak
pressure against the closed form, converging with the mesh), the contact patch test (two passes transmit a
uniform pressure, one pass does not), Newton's observed order, the node-to-segment tangent against
central differences of the element force, serial = 2 ranks."""
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scene_runs import MPIRUN, history, needs_mpirun, run_scene

REPO = Path(__file__).resolve().parents[1]
E, NU, R = 210e3, 0.3, 10.0          # demos/hertz_sphere.toml


def run_static(scene, *sets):
    """The built solver of ``scene`` with ``sets``, run to the end (in process)."""
    from mpi4py import MPI

    from fenics_plast.problem import load_problem
    from fenics_plast.runner_static import build_static
    problem = load_problem(REPO / "demos" / scene, list(sets))
    b = build_static(problem, MPI.COMM_WORLD, log=lambda m: None)
    a = problem.analysis
    b.solver.run(increments=a.increments, max_increment=a.max_increment, min_increment=a.min_increment, lam_end=1.0)
    return b


def hertz_errors(b):
    """(contact radius a, peak pressure p0 fitted to the nodal pressures, p^2 = p0^2 (1 - r^2 / a^2) over the
    nodes above a fifth of Hertz's p0; Hertz's a and p0 for the contact force) [mm, MPa]."""
    pair = b.pairs["hertz"]
    x, p = pair.pressures()
    force = abs(pair.force()[1])
    e_star = E / (2 * (1 - NU ** 2))
    a_h = (3 * force * R / (4 * e_star)) ** (1 / 3)
    p0_h = 3 * force / (2 * math.pi * a_h ** 2)
    on = p > 0.2 * p0_h
    c, *_ = np.linalg.lstsq(np.column_stack([np.ones(on.sum()), x[on, 0] ** 2]), p[on] ** 2, rcond=None)
    return math.sqrt(-c[0] / c[1]), math.sqrt(c[0]), a_h, p0_h


def observed_orders(solver):
    """log(r_k+1 / r_k) / log(r_k / r_k-1) of each increment's last step, residuals above the solver's estimate
    of their round-off floor (StaticSolver.roundoff_floor, of the last Jacobian) and 1e-12 of the run's
    largest."""
    floor = max(solver.roundoff_floor, 1e-12 * max(max(rec["norms"]) for rec in solver.increments))
    out = []
    for rec in solver.increments:
        r = [x for x in rec["norms"] if x > floor]
        if len(r) >= 3 and r[-2] < r[-3]:
            out.append(math.log(r[-1] / r[-2]) / math.log(r[-2] / r[-3]))
    return np.array(out)


def test_hertz_sphere_coarse_within_4_percent_newton_quadratic():
    """The coarse Hertz scene (0.1 mm cells at the contact, a ~ 0.5 mm): contact radius and peak pressure
    within 4 % of Hertz's for the force it transmits (measured +3.0 % and -3.7 %; the table in docs/guide/results.md:
    20 and 40 cells per mm bring them to -0.35 / -1.1 % and -0.17 / -0.52 %); Newton's last steps quadratic."""
    b = run_static("hertz_sphere.toml", "mesh.parameters.cells_contact=10")
    a, p0, a_h, p0_h = hertz_errors(b)
    assert abs(a / a_h - 1) < 0.04 and abs(p0 / p0_h - 1) < 0.04, (a, a_h, p0, p0_h)
    orders = observed_orders(b.solver)
    assert len(orders) >= 5 and np.median(orders) > 1.5, orders


def hertz_outputs(b):
    """The demo's contact outputs (contact_radius, peak_pressure, mean_pressure, contact_area) measured by the
    package's own quantities on the run ``b``, and Hertz's a, p0 for the force transmitted."""
    from fenics_plast.problem import load_problem
    from fenics_plast.quantities import Quantities
    outputs = load_problem(REPO / "demos" / "hertz_sphere.toml").outputs
    q = Quantities(outputs, b.body, b.facet_tags, b.groups, b.reactions)
    got = {n: q.value(n, outputs[n], 1.0, {})[0]
           for n in ("contact_radius", "peak_pressure", "mean_pressure", "contact_area", "contact")}
    force = abs(got.pop("contact")) * 1e3
    e_star = E / (2 * (1 - NU ** 2))
    a_h = (3 * force * R / (4 * e_star)) ** (1 / 3)
    return got, a_h, 3 * force / (2 * math.pi * a_h ** 2), force


@pytest.mark.parametrize("cells", [20, pytest.param(40, marks=pytest.mark.slow)])
def test_hertz_contact_outputs(cells):
    """The contact outputs read as a user reads them (contact_radius, contact_pressure max and mean,
    contact_area of demos/hertz_sphere.toml) against Hertz for the force transmitted: radius and peak pressure
    within 2 % (measured at 20 / 40 cells per mm: -1.05 / -0.61 % and -1.45 / -0.83 %); the mean pressure is
    the normal force over the area (to round-off), the area within 4 % of pi a^2 (the nodal rule counts the
    outermost pressed node's whole tributary ring: +3.1 / +2.1 %)."""
    b = run_static("hertz_sphere.toml", f"mesh.parameters.cells_contact={cells}")
    got, a_h, p0_h, force = hertz_outputs(b)
    print(f"\nHertz at {cells} cells/mm: {got}; Hertz a {a_h:.5f} mm, p0 {p0_h:.2f} MPa")
    assert abs(got["contact_radius"] / a_h - 1) < 0.02, (got, a_h)
    assert abs(got["peak_pressure"] / p0_h - 1) < 0.02, (got, p0_h)
    assert abs(got["mean_pressure"] * got["contact_area"] / b.pairs["hertz"].normal_force() - 1) < 1e-12, got
    assert abs(got["contact_area"] / (math.pi * a_h ** 2) - 1) < 0.04, (got, a_h)


def test_hertz_cylinder_contact_outputs():
    """The same mesh in plane strain (a half cylinder R = 10 mm on a block, x = 0 a symmetry plane, 20 cells
    per mm): Hertz's line contact for the force per mm P (twice the half model's), half-width
    b = sqrt(4 P R / (pi E*)) and p0 = 2 P / (pi b), from the contact outputs: within 2 % (measured b -0.53 %,
    p0 +0.25 %; the mean pressure pi p0 / 4 +1.3 %)."""
    b = run_static("hertz_sphere.toml", "mesh.geometry=plane_strain", "boundary.axis.type=symmetry")
    got, _, _, force = hertz_outputs(b)
    e_star = E / (2 * (1 - NU ** 2))
    P = 2.0 * force
    half_width = math.sqrt(4 * P * R / (math.pi * e_star))
    p0 = 2 * P / (math.pi * half_width)
    print(f"\nHertz cylinder: {got}; Hertz b {half_width:.5f} mm, p0 {p0:.2f} MPa")
    assert abs(got["contact_radius"] / half_width - 1) < 0.02, (got, half_width)
    assert abs(got["peak_pressure"] / p0 - 1) < 0.02, (got, p0)
    assert abs(got["mean_pressure"] / (math.pi / 4 * p0) - 1) < 0.03, (got, p0)


@pytest.mark.slow
def test_hertz_sphere_fine_within_1_percent():
    """40 cells per mm (0.025 mm at the contact): within 1 % (measured -0.17 % and -0.52 %)."""
    a, p0, a_h, p0_h = hertz_errors(run_static("hertz_sphere.toml", "mesh.parameters.cells_contact=40"))
    assert abs(a / a_h - 1) < 0.01 and abs(p0 / p0_h - 1) < 0.01, (a, a_h, p0, p0_h)


def patch_error(*sets):
    """max |sigma_yy / p + 1| over the quadrature points of both blocks of the patch test (p = 1 MPa)."""
    b = run_static("contact_patch_test.toml", *sets)
    s = b.solver
    sigma_yy = s.qmap.tau_values.reshape(-1, 3, 3)[:, 1, 1] / np.asarray(s.qp_jacobian()).reshape(-1)
    return float(np.abs(sigma_yy + 1.0).max())


def test_patch_test_two_passes_transmit_a_uniform_pressure():
    """Non-matching meshes (4 and 5 cells across): with two passes the stress is uniform to 0.5 % (measured
    0.23 %); one pass (the upper block's nodes only) leaves the lower block's facets free between the slave
    nodes and the stress varies by several per cent (measured 7.9 %), the node-to-surface element's known
    failure of the patch test (Taylor and Papadopoulos 1991)."""
    two = patch_error()
    one = patch_error("contact.interface.two_pass=false")
    assert two < 5e-3, two
    assert 2e-2 < one < 0.2, one


@pytest.mark.parametrize("friction", [0.0, 0.3], ids=["frictionless", "coulomb"])
@pytest.mark.parametrize("case", ["inside", "corner"])
def test_node_to_segment_tangent_is_the_force_derivative(case, friction):
    """The element tangent of a pressed node (frictionless: analytic inside the segment, central differences at
    its end; with friction central differences, slipping here) equals central differences of the element's
    residual with a step far below the gap (the nodes' displacements since the commit moving with them)."""
    from fenics_plast.solvers.static_surface_contact import _node_terms
    rng = np.random.default_rng(3)
    law = (1e4, 1e4, friction, 0)
    t_n, N_n, p_n = np.array([[50.0, 0.0]]), np.array([[0.0, 1.0]]), np.array([300.0])
    for _ in range(5):
        V = np.array([[0.0, 0.0], [1.0, 0.1]]) + rng.uniform(-0.05, 0.05, (2, 2))
        x = np.array([[0.4 if case == "inside" else 1.04, -0.03]]) + rng.uniform(-0.005, 0.005, (1, 2))
        dx, dV = np.array([[0.1, 0.0]]), np.zeros((2, 2))           # the slave slid 0.1 mm since the commit
        F = np.array([[0, 1]])

        def residual(xs, verts, dxs, dverts):
            r, K, g, N = np.zeros((1, 6)), np.zeros((1, 6, 6)), np.zeros(1), np.zeros((1, 2))
            t, p, slip, pressed = np.zeros((1, 2)), np.zeros(1), np.zeros(1), np.zeros(1, dtype=bool)
            _node_terms(xs, dxs, np.array([0.7]), np.array([0]), verts, dverts, F, verts, law, t_n, N_n, p_n, r, K,
                        g, N, t, p, slip, pressed)
            return r[0], K[0], g[0], slip[0], pressed[0]

        r, K, g, slip, pressed = residual(x, V, dx, dV)
        assert g < 0 and slip == 1.0 and pressed
        h = 1e-7
        fd = np.zeros((6, 6))
        for c in range(6):
            xp, Vp, xm, Vm = x.copy(), V.copy(), x.copy(), V.copy()
            dxp, dVp, dxm, dVm = dx.copy(), dV.copy(), dx.copy(), dV.copy()
            if c < 2:
                for a, s in ((xp, h), (xm, -h), (dxp, h), (dxm, -h)):
                    a[0, c] += s
            else:
                for a, s in ((Vp, h), (Vm, -h), (dVp, h), (dVm, -h)):
                    a[(c - 2) // 2, c % 2] += s
            fd[:, c] = (residual(xp, Vp, dxp, dVp)[0] - residual(xm, Vm, dxm, dVm)[0]) / (2 * h)
        np.testing.assert_allclose(K, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_a_touching_node_has_the_pressed_sides_tangent_on_either_side_of_zero(friction):
    """A node touching its segment has the tangent of the pressed side whether round-off puts its gap at
    -1e-16 or +1e-16 mm (before: at +2.2e-16 it had none, its neighbours at 0 had theirs, and Newton
    stalled on the sliding blocks on one machine; surface TOUCHING); 1e-6 mm away it has none."""
    from fenics_plast.solvers.static_surface_contact import _node_terms
    law = (1e4, 1e4, friction, 0)
    V, F = np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0, 1]])

    def terms(gap):
        r, K, g, N = np.zeros((1, 6)), np.zeros((1, 6, 6)), np.zeros(1), np.zeros((1, 2))
        t, p, slip, pressed = np.zeros((1, 2)), np.zeros(1), np.zeros(1), np.zeros(1, dtype=bool)
        _node_terms(np.array([[0.4, gap]]), np.zeros((1, 2)), np.array([0.7]), np.array([0]), V, np.zeros((2, 2)),
                    F, V, law, np.zeros((1, 2)), np.array([[0.0, 1.0]]), np.zeros(1), r, K, g, N, t, p, slip, pressed)
        return K[0], pressed[0], g[0]

    K_minus, pressed_minus, g_minus = terms(-1e-16)
    K_plus, pressed_plus, g_plus = terms(1e-16)
    assert g_minus < 0.0 < g_plus and pressed_minus and pressed_plus
    assert abs(K_minus[1, 1]) > 1e3                    # the normal stiffness, ~ penalty x area
    np.testing.assert_allclose(K_plus, K_minus, rtol=1e-6, atol=1e-9 * np.abs(K_minus).max())
    K_apart, pressed_apart, _ = terms(1e-6)
    assert not pressed_apart and not K_apart.any()


@pytest.mark.mpi
@needs_mpirun
def test_hertz_serial_equals_two_ranks(tmp_path):
    """The coarse Hertz scene on 2 ranks (slave nodes of each rank against the whole master surface, entries
    to other ranks' rows stashed by PETSc): the same force as serially."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    forces = []
    for name, launch in (("serial", []), ("mpi", [MPIRUN, "--allow-run-as-root", "--oversubscribe", "-n", "2"])):
        scene = REPO / "demos" / "hertz_sphere.toml"
        r = subprocess.run([*launch, sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out",
                            str(tmp_path / name), "--set", "mesh.parameters.cells_contact=10", "--set",
                            "output.xdmf=true", "--set", "output.plots=false"], capture_output=True, text=True,
                           timeout=900, env=env)
        assert r.returncode == 0, r.stderr[-3000:]
        h = np.genfromtxt(tmp_path / name / "history.csv", delimiter=",", names=True)
        # the block's force on the ball through the contact balances the press's reaction
        np.testing.assert_allclose(h["contact_kN"], -h["force_kN"], rtol=1e-8, atol=1e-9)
        forces.append(np.column_stack([h[c] for c in ("force_kN", "contact_radius_mm", "peak_pressure_MPa",
                                                      "mean_pressure_MPa", "contact_area_mm2")]))
    # the force and the contact outputs (radius, peak and mean pressure, area) alike
    np.testing.assert_allclose(forces[1], forces[0], rtol=1e-8, atol=1e-12)
    # the contact fields alike (the nodes' order differs between partitions: their sorted values)
    fields = [contact_field_values(tmp_path / name / "fields.h5") for name in ("serial", "mpi")]
    for k in fields[0]:
        np.testing.assert_allclose(fields[1][k], fields[0][k], rtol=1e-8, atol=1e-9 * np.abs(fields[0][k]).max(),
                                   err_msg=k)


def contact_field_values(path):
    """{field: its sorted values at the last time} of the contact fields in fields.h5."""
    import h5py
    with h5py.File(path, "r") as f:
        out = {}
        for name in ("contact_pressure_hertz", "contact_gap_hertz", "contact_status_hertz"):
            steps = f["Function"][name]
            last = max(steps, key=lambda k: float(k.replace("_", ".")))
            out[name] = np.sort(steps[last][:, 0])
        return out


@pytest.mark.mpi
@needs_mpirun
def test_friction_between_bodies_serial_equals_two_ranks(tmp_path):
    """The sliding blocks (coulomb, two passes) on 2 ranks: the nodal history, the committed displacements and
    the master surfaces on each rank give the serial run's friction and normal forces (to 1e-8)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    runs = []
    for name, launch in (("serial", []), ("mpi", [MPIRUN, "--allow-run-as-root", "--oversubscribe", "-n", "2"])):
        r = subprocess.run([*launch, sys.executable, "-m", "fenics_plast.cli", "run",
                            str(REPO / "tests" / "scenes" / "sliding_blocks.toml"), "--out", str(tmp_path / name),
                            "--set", "output.xdmf=false", "--set", "output.plots=false"],
                           capture_output=True, text=True, timeout=900, env=env)
        assert r.returncode == 0, r.stderr[-3000:]
        runs.append(history(tmp_path / name))
    for column in ("friction_x_kN", "friction_y_kN"):
        scale = runs[0]["friction_y_kN"].max()
        np.testing.assert_allclose(runs[1][column], runs[0][column], rtol=1e-8, atol=1e-9 * scale)
    assert abs(runs[0]["friction_x_kN"][-1]) > 1e-3


def rigid_die_scene(tmp_path):
    """demos/elastic_die.toml without the die: the billet's top itself displaced by the die's travel (a rigid,
    frictionless die)."""
    import re
    text = (REPO / "demos" / "elastic_die.toml").read_text().replace('file = "../meshes/', f'file = "{REPO}/meshes/')
    for table in ("materials\\.die", "contact\\.die_face", "outputs\\.die_peak_stress"):
        text = re.sub(rf"\[{table}\]\n(.*\n)*?\n", "", text)
    text = text.replace('group = "die_top"', 'group = "billet_top"').replace("die_thickness = 8.0", "die_thickness = 0.0")
    scene = tmp_path / "rigid_die.toml"
    scene.write_text(text)
    return scene


def cli_summary(scene, out, *sets):
    import json
    cmd = [sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(out), "--set", "output.xdmf=false"]
    for s in sets:
        cmd += ["--set", s]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads((Path(out) / "summary.json").read_text())


def test_elastic_die_tends_to_the_rigid_die(tmp_path):
    """Billet upsetting by 2 mm of die travel with the die a deformable body: the die's elastic compression
    leaves the billet less pressed, by a share that falls as the die's modulus grows (about as 1 / E), and the
    press force tends to the rigid die's (measured 1 - F / F_rigid: 4.0e-3 at 70 GPa, 1.4e-3 at 210 GPa,
    1.8e-4 at 2,100 GPa); the die's peak von Mises stress is reported and below the billet's mean pressure
    times a few."""
    rigid = cli_summary(rigid_die_scene(tmp_path), tmp_path / "rigid")["press_force_kN"]
    deficit = []
    for E in (70e3, 210e3, 2.1e6):
        s = cli_summary(REPO / "demos" / "elastic_die.toml", tmp_path / f"die_{E:g}", f"materials.die.E={E}")
        deficit.append(1.0 - s["press_force_kN"] / rigid)
        assert 0.0 < s["die_peak_stress_MPa"] < 5 * abs(rigid) * 1e3 / (math.pi * 10.0 ** 2)
    assert deficit[0] > deficit[1] > deficit[2] > 0.0, deficit
    assert deficit[0] < 1e-2 and deficit[2] < 5e-4, deficit
    assert 2.0 < deficit[0] / deficit[1] < 4.0, deficit          # about as 1 / E (x 3)


def test_elastic_die_newton_converges_quadratically():
    """Plastic billet, elastic die, contact between them (q1p0): Newton's last steps quadratic."""
    b = run_static("elastic_die.toml")
    orders = observed_orders(b.solver)
    assert len(orders) >= 5 and np.median(orders) > 1.5, orders


def run_scene_in_process(path, *sets):
    """The built solver of the scene file ``path`` with ``sets``, run to the end with its commits (in process)."""
    from mpi4py import MPI

    from fenics_plast.problem import load_problem
    from fenics_plast.runner_static import build_static
    problem = load_problem(path, list(sets))
    b = build_static(problem, MPI.COMM_WORLD, log=lambda m: None)
    a = problem.analysis
    b.solver.run(increments=a.increments, max_increment=a.max_increment, min_increment=a.min_increment,
                 lam_end=1.0, callback=lambda s: b.contact.commit() or False)
    return b


@pytest.mark.parametrize("dim,sets", [
    (2, ["contact.interface.law=coulomb"]),
    (2, ["contact.interface.law=quasi-coulomb"]),
    (3, ["contact.interface.law=coulomb", "contact.interface.two_pass=false"]),
    (3, ["contact.interface.law=coulomb", "contact.interface.two_pass=true"]),
], ids=["2d-coulomb", "2d-quasi-coulomb", "3d-coulomb-one-pass", "3d-coulomb-two-pass"])
def test_friction_between_bodies_equals_friction_on_a_rigid_tool(dim, sets):
    """A block pressed onto a base 1000 times stiffer and slid along it (tests/scenes/sliding_blocks.toml, the
    onset of sliding: with coulomb the edges slip, the middle sticks) carries the same normal and tangential force
    as on a rigid plane with the same friction (sliding_block_on_tool.toml), within the base's compliance
    (measured: coulomb -0.04 % normal, -0.02 % tangential; quasi-coulomb -0.03 %, -0.07 %). In 3-D
    (sliding_blocks_3d.toml, 6 x 6 x 3 hexahedra on 10 x 10 x 3) with Coulomb 0.3, one pass and two, every
    increment converges without a cut-back (measured: normal -0.07 % / -0.03 %, tangential -0.05 % / -0.02 %;
    61 / 67 Newton iterations in 10 increments): before the friction predictor
    (``SurfaceContactTerm.keep_gaps``: stuck nodes start an increment stuck) it stopped at t = 0.53."""
    scenes = REPO / "tests" / "scenes"
    suffix = "_3d" if dim == 3 else ""
    body = run_scene_in_process(scenes / f"sliding_blocks{suffix}.toml", *sets)
    tool_sets = [s for s in sets if "two_pass" not in s]                 # a tool pair has one pass
    tool = run_scene_in_process(scenes / f"sliding_block_on_tool{suffix}.toml", *tool_sets)
    fb, ft = body.pairs["interface"].force(), tool.pairs["interface"].force()
    print(f"\n{dim}-D {sets}: body {fb} N, tool {ft} N, ratio {fb / np.where(ft != 0, ft, 1) - 1}, "
          f"{body.solver.total_iterations} Newton iterations, {len(body.solver.cutbacks)} cut-backs")
    if dim == 3:
        assert not body.solver.cutbacks, body.solver.cutbacks
    n = dim - 1                                                           # the normal component
    assert ft[n] > 20.0 and abs(fb[n] / ft[n] - 1) < 2e-3, (fb, ft)
    if "contact.interface.friction=0" in sets:
        return
    assert abs(ft[0]) > 0.02 * ft[n] and abs(fb[0] / ft[0] - 1) < 3e-3, (fb, ft)     # a real shear, the same
    contact, slipping = body.pairs["interface"].status()
    assert slipping < contact and (slipping > 0 or "quasi" in sets[0]), (contact, slipping)


@pytest.mark.parametrize("two_pass", [False, True], ids=["one-pass", "two-pass"])
def test_3d_frictionless_between_bodies_equals_a_rigid_plane(two_pass):
    """A 3-D block (6 x 6 x 3 hexahedra) pressed 1 um onto a base 1000 times stiffer (10 x 10 x 3, non-matching,
    block nodes over the base's facet edges) and slid 0.2 um, frictionless (tests/scenes/sliding_blocks_3d.toml):
    the normal force within 0.2 % of the same block on a rigid plane (sliding_block_on_tool_3d.toml; penalty
    1e7 N/mm^3: 0.1 % compliance), every increment converged without a cut-back in at most 4 Newton
    iterations (measured: -0.069 % one pass, -0.015 % two passes; 22 and 24 iterations in 10 increments).
    Before the master surface's normal was made continuous (static_surface_contact) Newton stalled at
    |R| ~ 3e-7 N and the run stopped at t = 0.002."""
    scenes = REPO / "tests" / "scenes"
    sets = ("contact.interface.friction=0", f"contact.interface.two_pass={str(two_pass).lower()}")
    body = run_scene_in_process(scenes / "sliding_blocks_3d.toml", *sets)
    tool = run_scene_in_process(scenes / "sliding_block_on_tool_3d.toml", sets[0])
    fb, ft = body.pairs["interface"].force(), tool.pairs["interface"].force()
    print(f"\n3-D frictionless, two_pass {two_pass}: normal force {fb[2]:.6g} N against {ft[2]:.6g} N on the plane "
          f"({fb[2] / ft[2] - 1:+.2e}), {body.solver.total_iterations} Newton iterations")
    assert ft[2] > 40.0 and abs(fb[2] / ft[2] - 1) < 2e-3, (fb, ft)
    assert abs(fb[0]) < 1e-6 * fb[2] and abs(fb[1]) < 1e-6 * fb[2], fb
    s = body.solver
    assert not s.cutbacks and len(s.increments) == 10, s.cutbacks
    assert max(inc["iterations"] for inc in s.increments) <= 4, [inc["iterations"] for inc in s.increments]


def test_friction_between_bodies_slips_at_mu_times_the_normal_force():
    """Slid farther (2 um, ten times the press), every node of both passes slips: the interface's tangential force
    is mu times its normal force (coulomb, to round-off), and the Newton steps of the sliding increments are
    quadratic (the central-difference element tangent of friction)."""
    b = run_scene_in_process(REPO / "tests" / "scenes" / "sliding_blocks.toml",
                             "boundary.press.value=['0.002 * max(2 * t - 1, 0)', '-0.001 * min(2 * t, 1)']")
    pair = b.pairs["interface"]
    contact, slipping = pair.status()
    assert contact == slipping > 0
    assert abs(abs(pair.tangential_force()) - 0.3 * pair.normal_force()) < 1e-9 * pair.normal_force()
    assert abs(abs(pair.force()[0]) - 0.3 * pair.normal_force()) < 1e-5 * pair.normal_force()   # normals ~ y
    orders = observed_orders(b.solver)
    assert len(orders) >= 3 and np.median(orders) > 1.5, orders


def test_static_self_contact_u_arms_stop_on_each_other(tmp_path):
    """Static self-contact (tests/scenes/u_closing.toml): two rollers push the U's arms toward each other by 1.1 mm
    each, more than the gap between the tips allows. Without the pair (a penalty of 1e-3 N/mm^3) the inner tips
    pass through each other (measured: by 0.45 mm); with it they stop on each other at the middle, within the
    penalty's penetration (measured: -4.3e-4 mm), the arms mirror each other, and every increment converges."""
    scene = REPO / "tests" / "scenes" / "u_closing.toml"
    free = tmp_path / "free"
    run_scene(scene, free, "contact.inner.penalty=1e-3", "output.xdmf=false", "output.plots=false")
    assert history(free)["tip_gap"][-1] < -0.3
    held = tmp_path / "held"
    s = run_scene(scene, held, "output.xdmf=false", "output.plots=false")
    h = history(held)
    assert s["converged"] and h["tip_gap"][-1] < 1e-2             # the tips met (they were 2 mm apart)
    assert h["tip_gap"].min() > -2e-3
    np.testing.assert_allclose(h["left_tip_mm"] - 3.0, 3.0 - h["right_tip_mm"], atol=1e-9)   # the mirror image
