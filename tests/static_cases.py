"""Small static problems for in-process tests, built from scene files with ``--set`` overrides.

Used by tests/test_static.py, tests/test_extremes.py, tests/test_contact.py and
tests/mpi_static_run.py. Each helper loads a scene (:func:`fenics_plast.problem.load_problem`),
builds its solver with :func:`fenics_plast.runner_static.build_static` and hands back the build
namespace (``solver``, ``reactions``, ``material``, ``pairs``, ...), so a test drives
``solver.run`` itself and reads reactions, contact forces and the quadrature-point state:

* :func:`necking_bar`: demos/bar_tension.toml (Simo's bar, Voce steel) on a coarser mesh;
* :func:`homogeneous_bar`: tests/scenes/bar.toml (no imperfection: a uniform stretch);
* :func:`solve_ring`: tests/scenes/ring.toml (plane-strain thick cylinder, prescribed inner
  displacement) run to the end, with the internal pressure of every increment;
* :func:`punch`: demos/punch_stretching.toml on a coarse mesh and a short travel.

Newton settings are StaticSolver's defaults (rtol 1e-9, atol 1e-8 N, 25 iterations, line search
bt) unless a test asks for others, whatever the scene file says.
"""
from __future__ import annotations

import math
from pathlib import Path

from mpi4py import MPI

from fenics_plast.errors import RunError
from fenics_plast.problem import load_problem
from fenics_plast.runner_static import build_static

ROOT = Path(__file__).resolve().parent.parent
SCENES = Path(__file__).resolve().parent / "scenes"
BAR = SCENES / "bar.toml"
RING = SCENES / "ring.toml"
NECKING = ROOT / "demos" / "bar_tension.toml"
PUNCH = ROOT / "demos" / "punch_stretching.toml"
COMM = MPI.COMM_WORLD

#: StaticSolver's default Newton settings (the tests below were written with them)
NEWTON = dict(rtol=1e-9, atol=1e-8, max_iterations=25, linesearch="bt")
#: the demos' default penalty 0.3 E / t of the aluminium blank, 1 mm thick [N/mm^3]
PUNCH_PENALTY = 0.3 * 69.0e3 / 1.0


def _toml(v) -> str:
    """A Python value as the TOML text of a --set value."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else repr(v)


def sets(prefix: str, **values) -> list[str]:
    """``--set`` overrides ``prefix.key=value`` (None values left out)."""
    return [f"{prefix}.{k}={_toml(v)}" for k, v in values.items() if v is not None]


def newton_sets(**opts) -> list[str]:
    return sets("analysis", **{**NEWTON, **opts})


def material_sets(name: str, E=None, nu=None, model=None, hardening=None) -> list[str]:
    """Overrides of [materials.<name>]; ``hardening``: a dict of [materials.<name>.hardening] keys."""
    out = sets(f"materials.{name}", E=E, nu=nu, model=model)
    return out + sets(f"materials.{name}.hardening", **(hardening or {}))


def build(scene, overrides, comm=COMM):
    """build_static of the scene with the overrides; the solver prints nothing."""
    b = build_static(load_problem(scene, overrides), comm)
    b.solver.verbose = False
    return b


def necking_bar(cells_radial, cells_axial, end_displacement, comm=COMM, **newton):
    """Simo's necking bar of demos/bar_tension.toml (steel, Voce hardening, half length 26.667 mm,
    1.8 % imperfection) on cells_radial x cells_axial cells, the gripped end moved by
    ``end_displacement`` mm at t = 1 (the demo: 7 mm)."""
    return build(NECKING, [*sets("mesh.parameters", cells_radial=cells_radial, cells_axial=cells_axial),
                           f'boundary.grip.value="{end_displacement!r} * t"', *newton_sets(**newton)], comm)


def top_force(b) -> float:
    """The axial reaction [N] on the gripped end of a bar built from either bar scene."""
    return b.solver.reaction(b.reactions[("top", "z")])


def homogeneous_bar(end_displacement, hardening=None, model="isochoric", E=200e3, nu=0.3, element="q1p0",
                    cells=(2, 3), radius=1.5, half_length=4.0, comm=COMM, **newton):
    """tests/scenes/bar.toml: a uniform axisymmetric cylinder (radius, half length; ends free to slide
    radially), its end moved by ``end_displacement`` mm at t = 1; ``hardening``: the
    [materials.steel.hardening] keys (None: elastic). Newton: rtol 1e-11, atol 1e-9 (the scene's)."""
    over = [*sets("mesh.parameters", radius=radius, length=half_length, cells_radial=cells[0],
                  cells_axial=cells[1]),
            *sets("mesh", element=element), *material_sets("steel", E=E, nu=nu, model=model, hardening=hardening),
            f'boundary.grip.value="{end_displacement!r} * t"', *sets("analysis", **newton)]
    return build(BAR, over, comm)


def limit_pressure(yield_stress, a, b):
    """Small-strain limit pressure of a thick cylinder, plane strain, von Mises (Hill 1950)."""
    return 2.0 / math.sqrt(3.0) * yield_stress * math.log(b / a)


def full_plastic_displacement(E, nu, yield_stress, a, b):
    """Inner radial displacement at which the plastic zone reaches r = b (incompressible estimate):
    the elastic outer zone yields at r = b when u(b) = sqrt(3)/2 sigma_y b / (2 mu); u r = const."""
    mu = E / (2.0 * (1.0 + nu))
    ub = math.sqrt(3.0) / 2.0 * yield_stress * b / (2.0 * mu)
    return ub * b / a


def solve_ring(a, b, cells_radial, cells_circumferential, nu, yield_stress, modulus=0.0, E=200e3,
               element="q1p0", delta=None, increments=20, min_increment=1e-4, max_increment=0.1, comm=COMM,
               **newton):
    """tests/scenes/ring.toml (quarter ring a <= r <= b, plane strain, linear hardening) with the inner
    boundary moved radially by ``delta`` at t = 1 (default: 3 x :func:`full_plastic_displacement`, past
    the limit load), run to t = 1. The internal pressure of each increment is (the x- and y-reactions
    on the inner boundary) / (2 a_current), the corner nodes' left-out shares p a (1 - cos dphi) / 2
    added back. Returns a dict: solver, material, history (inner_displacement_mm, pressure_MPa),
    delta, converged, error (the RunError, when not converged), limit_pressure_MPa, cells."""
    if delta is None:
        delta = 3.0 * full_plastic_displacement(E, nu, yield_stress, a, b)
    over = [*sets("mesh.parameters", inner_radius=a, outer_radius=b, cells_radial=cells_radial,
                  cells_circumferential=cells_circumferential),
            *sets("mesh", element=element),
            *material_sets("steel", E=E, nu=nu, hardening=dict(yield_stress=yield_stress, modulus=modulus)),
            "boundary.inner.value=" + _toml([f"{delta!r} * t * x / {a!r}", f"{delta!r} * t * y / {a!r}"]),
            *newton_sets(**newton)]
    bld = build(RING, over, comm)
    s = bld.solver
    rx, ry = bld.reactions[("inner", "x")], bld.reactions[("inner", "y")]
    corner = 0.5 * (1.0 + math.cos(0.5 * math.pi / cells_circumferential))
    hist = dict(inner_displacement_mm=[0.0], pressure_MPa=[0.0])

    def cb(solver):
        d = delta * solver.lam_converged
        hist["inner_displacement_mm"].append(d)
        hist["pressure_MPa"].append((solver.reaction(rx) + solver.reaction(ry)) / (2.0 * (a + d) * corner))
        return False

    out = dict(solver=s, material=bld.material, history=hist, delta=delta, converged=True,
               cells=bld.mesh.topology.index_map(2).size_global)
    try:
        s.run(increments=increments, min_increment=min_increment, max_increment=max_increment, callback=cb)
    except RunError as e:
        out.update(converged=False, error=e)
    out["limit_pressure_MPa"] = float(max(hist["pressure_MPa"]))
    return out


def punch(friction=0.0, law="quasi-coulomb", penalty=PUNCH_PENALTY, travel=8.0, cells_radial=30,
          cells_thickness=1, comm=COMM, **newton):
    """demos/punch_stretching.toml on cells_radial x cells_thickness cells, the punch moving up by
    ``travel`` mm at t = 1; the same friction coefficient, law and penalty on punch and die."""
    over = [*sets("mesh.parameters", cells_radial=cells_radial, cells_thickness=cells_thickness),
            f"tools.punch.path.y=[0.0, {travel!r}]", *newton_sets(**newton)]
    for pair in ("punch", "die"):
        over += sets(f"contact.{pair}", friction=friction, law=law, penalty=penalty)
    return build(PUNCH, over, comm)
