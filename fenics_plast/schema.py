"""The scene-file schema: every key of every table, declared once.

:data:`SCHEMA` maps each section to a :class:`Table` of :class:`Key` declarations: type, default
(or :data:`REQUIRED` / :data:`OPTIONAL`), range or choices, unit, scale from the file's unit and
meaning. Keys that only apply to some variants of a table (``analysis.type``,
``boundary.<name>.type``, ``tools.<name>.shape``, ``outputs.<name>.quantity``,
``materials.<name>.hardening.law``) say so in ``Key.when``. The ``outputs`` table's quantities,
their own keys and which shared keys each takes come from the quantity kinds
(:mod:`fenics_plast.quantities.registry`, one module per kind, light to import); :class:`Key` itself
is declared in :mod:`fenics_plast.scene_key`. The ``hardening`` table's laws and their keys come
from the law modules (:mod:`fenics_plast.hardening_laws`, standard library only). The validator
(:mod:`fenics_plast.validation`), the ``--set`` overrides and the key reference
(:mod:`fenics_plast.keys_doc`, docs/SCENE_KEYS.md) all read this one table, and so do the keyword
defaults and the allowed values of the solvers, materials and tools: :func:`default` and
:func:`choices` of a dotted key (``default("contact.*.law")``); no other module writes a default of a
scene key (tests/test_defaults_once.py).

Units inside the package: mm, N, MPa, s, tonne/mm^3. Converted on reading (the value as written is
kept under ``<key>_as_written``): densities in kg/m^3 (:data:`KG_M3`), velocities in m/s
(:data:`M_S`), explicit times in us (:data:`US`).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from fenics_plast.hardening_laws import laws as hardening_laws
from fenics_plast.quantities.registry import KINDS, kind_keys, quantity_doc, taking
from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key, number_text
from fenics_plast.state_variables import outputs as state_outputs
from fenics_plast import meshed_tools
from fenics_plast.tool_shapes import shapes as tool_shapes
from fenics_plast.thermal.boundaries import TYPES as thermal_boundary_types, W_M2

__all__ = ["SCHEMA", "SECTIONS", "Key", "Table", "REQUIRED", "OPTIONAL", "COMPONENTS", "COMPONENTS_3D", "GEOMETRIES",
           "component_index", "component_names", "is_cell_count", "vector_size", "LAWS", "US", "M_S", "KG_M3",
           "PENALTY_FACTOR", "key", "default", "choices", "discretisation_keys", "MESH_PARAMETER_REFINES"]


#: component names of vectors in 2-D: x = r and y = z (in axisymmetry; plane strain accepts the same names)
COMPONENTS = {"x": 0, "y": 1, "r": 0, "z": 1}
#: component names in 3-D: z is the third axis (index 2), there is no r
COMPONENTS_3D = {"x": 0, "y": 1, "z": 2}
GEOMETRIES = ("axisymmetric", "plane_strain", "3d")


def component_names(geometry: str) -> dict[str, int]:
    """{component name: index} of the displacement vector of ``geometry`` (see :data:`GEOMETRIES`)."""
    return COMPONENTS_3D if geometry == "3d" else COMPONENTS


def component_index(name: str, geometry: str) -> int:
    """Index of component ``name`` in ``geometry``: "z" is 1 in 2-D (r, z) but 2 in 3-D; KeyError for a
    name that does not apply (e.g. "r" in 3-D)."""
    return component_names(geometry)[name]


def is_cell_count(name: str) -> bool:
    """Whether the mesh parameter ``name`` is a number of cells (an integer >= 1 that ``mesh.refine``
    multiplies): a name that starts with ``cells`` or ends in ``_cells``."""
    return name.startswith("cells") or name.endswith("_cells")


def vector_size(geometry: str) -> int:
    """Entries of a point, direction or velocity in a scene of ``geometry``: 3 in 3-D, else 2."""
    return 3 if geometry == "3d" else 2

#: the hardening laws, one module each in fenics_plast/hardening_laws/
LAWS = tuple(hardening_laws())
#: the tool shapes, one module each in fenics_plast/tool_shapes/
TOOL_SHAPES = tuple(tool_shapes())
STATIC, EXPLICIT = ("static",), ("explicit",)
US = 1e-6          # explicit times are written in microseconds
M_S = 1e3          # velocities are written in m/s -> mm/s
KG_M3 = 1e-12      # densities are written in kg/m^3 -> tonne/mm^3
#: contact.<name>.penalty absent: PENALTY_FACTOR * E / h (chosen by measurement, see tests/test_contact.py:
#: penetration < 1 % of the thickness, force change < 1 % for x10; fenics_plast.tools.default_penalty)
PENALTY_FACTOR = 0.3


def _pos(**kw):
    return dict(lo=0.0, lo_open=True, **kw)


def _nonneg(**kw):
    return dict(lo=0.0, lo_open=False, **kw)


def _count(**kw):
    return dict(lo=1, lo_open=False, **kw)


@dataclass(frozen=True)
class Table:
    """A table of keys. ``collection``: the section holds any number of named tables of this shape.
    ``discriminator``: the key whose value selects which other keys apply. ``subtables``: nested
    tables (name -> Table). ``free``: a table of user-named numbers (mesh parameters)."""
    doc: str
    keys: dict[str, Key] = field(default_factory=dict)
    collection: bool = False
    discriminator: str | None = None
    subtables: dict[str, "Table"] = field(default_factory=dict)
    optional: bool = True
    free: bool = False
    when_analysis: tuple | None = None


_FORCE_UNITS = ("N", "kN")
VALUE_DOC = ("a number, an expression of x, y, z, t in quotes (\"3.0*t\"; x, y, z are the reference "
             "(initial) coordinates [mm]; the grammar: docs/guide/boundary-conditions.md, 'Expressions'), or a table "
             "{ t = [...], value = [...] } (piecewise linear, constant outside)")


def _gathered(declarations, discriminator: str) -> dict[str, Key]:
    """The keys of the variants ``declarations`` [(variant name, {key: Key})], each applying when
    ``discriminator`` names a variant that declares it; a key several variants declare (alike but for the
    doc) is one key, its doc each variant's ("variant: doc") where they differ."""
    users: dict[str, list] = {}
    for variant, params in declarations:
        for name, k in params.items():
            users.setdefault(name, []).append((variant, k))
    keys = {}
    for name, declared in users.items():
        first = declared[0][1]
        for variant, k in declared[1:]:
            if replace(k, doc=first.doc) != first:
                raise ValueError(f"key {name!r}: {variant} declares it unlike {declared[0][0]}")
        docs: dict[str, list] = {}
        for v, k in declared:
            docs.setdefault(k.doc.rstrip("."), []).append(v)
        doc = first.doc if len(docs) == 1 else "; ".join(f"{', '.join(v)}: {d}" for d, v in docs.items()) + "."
        keys[name] = replace(first, doc=doc, when={discriminator: tuple(v for v, _ in declared)})
    return keys


def _hardening_table() -> Table:
    """``materials.<name>.hardening``, gathered from the laws' declarations
    (:mod:`fenics_plast.hardening_laws`, :func:`_gathered`)."""
    keys = {"law": Key("str", REQUIRED, "Hardening law.", choices=LAWS)}
    keys.update(_gathered(((law.name, law.params) for law in hardening_laws().values()), "law"))
    return Table("Optional: absent = purely elastic (plasticity off). Only the keys of the chosen `law` apply. "
                 + " ".join(f"{law.name}: {law.doc}" for law in hardening_laws().values()),
                 discriminator="law", keys=keys)


def _tools_table() -> Table:
    """``tools.<name>``, gathered from the shapes' declarations (:mod:`fenics_plast.tool_shapes`,
    :func:`_gathered`) and the meshed tool's (:mod:`fenics_plast.meshed_tools`), and the tool's path."""
    shapes = tool_shapes().values()
    by_dim = {d: ", ".join([s.name for s in shapes if d in s.dims] + [meshed_tools.SHAPE]) for d in (2, 3)}
    keys = {"shape": Key("str", REQUIRED, "; ".join([s.doc for s in shapes] + [meshed_tools.DOC]) + ".",
                         choices=TOOL_SHAPES + (meshed_tools.SHAPE,))}
    keys.update(_gathered([(s.name, s.params) for s in shapes] + [(meshed_tools.SHAPE, meshed_tools.KEYS)], "shape"))
    keys["path"] = Key("path", OPTIONAL, "Translation: { t = [...], x = [...], y = [...] } (and z = [...] in 3-D; "
                       "piecewise linear; a missing component stays 0); absent = fixed.", "mm")
    keys["temperature"] = Key("float", OPTIONAL, "With [thermal]: the tool's temperature, a rigid isothermal body "
                              "(required by a contact pair with the tool and a conductance).", "K", lo=0.0)
    return Table(f"Rigid tools, analytic or meshed, one table per name, each moving along `path`. 2-D: {by_dim[2]}; "
                 f"3-D: {by_dim[3]}.",
                 collection=True, discriminator="shape", keys=keys)


def _thermal_boundary_table() -> Table:
    """``thermal_boundary.<name>``, gathered from the thermal boundary types' declarations
    (:mod:`fenics_plast.thermal.boundaries`, :func:`_gathered`)."""
    types = thermal_boundary_types.values()
    keys = {"group": Key("str", REQUIRED, "Gmsh physical curve (3-D: surface) name, a facet group."),
            "type": Key("str", REQUIRED, "; ".join(t.doc for t in types) + ".", choices=tuple(thermal_boundary_types))}
    keys.update(_gathered(((t.name, t.keys) for t in types), "type"))
    return Table("Thermal boundary conditions (with [thermal]), one table per name, each on a facet group; a "
                 "boundary without one is insulated. Heat into the body counts positive.",
                 collection=True, discriminator="type", keys=keys)


SCHEMA: dict[str, Table] = {
    "scene": Table("What the problem is.", optional=False, keys={
        "name": Key("str", REQUIRED, "Problem name; the default output directory is results/<name>."),
        "description": Key("str", "", "Free text."),
    }),
    "analysis": Table(
        "How the problem is solved. `static`: quasi-static load incrementation over a pseudo-time t "
        "(from 0 to the end of the last step; 1 when there are no [steps]) with Newton (PETSc SNES, MUMPS) "
        "and cut-back. `explicit`: central differences with a lumped mass over real time, written in µs.",
        optional=False, discriminator="type", keys={
            "type": Key("str", REQUIRED, "Static or explicit.", choices=("static", "explicit")),
            "increments": Key("int", 20, "Initial number of equal increments of a step.", when={"type": STATIC},
                              refines=+1, axis="time", **_count()),
            "min_increment": Key("float", 1e-4, "Smallest increment of pseudo-time before the run gives up.",
                                 when={"type": STATIC}, refines=-1, **_pos()),
            "max_increment": Key("float", 0.1, "Largest increment of pseudo-time.", when={"type": STATIC},
                                 refines=-1, axis="time", **_pos()),
            "max_iterations": Key("int", 25, "Newton iterations per increment before cutting back.",
                                  when={"type": STATIC}, lo=2, lo_open=False),
            "fast_iterations": Key("int", 4, "An increment that converges in at most this many Newton iterations "
                                   "lets the next one grow by half (up to max_increment); frictional contact "
                                   "typically takes 5 to 8.", when={"type": STATIC}, **_count()),
            "rtol": Key("float", 1e-9, "Relative residual tolerance.", when={"type": STATIC}, refines=-1, **_pos()),
            "atol": Key("float", 1e-8, "Absolute residual tolerance.", "N", when={"type": STATIC}, refines=-1,
                        **_pos()),
            "linesearch": Key("str", "bt", "SNES line search.", choices=("bt", "basic", "l2"),
                              when={"type": STATIC}),
            "linear_solver": Key("str", "mumps", "Linear solver of each Newton iteration: 'mumps' (direct LU, "
                                 "robust, the default) or 'gamg' (for large 3-D meshes: GMRES preconditioned with "
                                 "PETSc's algebraic multigrid GAMG and the rigid-body modes as near-nullspace; "
                                 "q1p0 condenses the cell dilatation exactly first). Same solution to the Newton "
                                 "tolerance.", choices=("mumps", "gamg"), when={"type": STATIC}),
            "linear_rtol": Key("float", 1e-8, "Relative tolerance of the iterative linear solve (linear_solver = "
                               "'gamg').", when={"type": STATIC}, lo=0.0, hi=1.0),
            "linear_max_iterations": Key("int", 500, "Iterations of the iterative linear solve (linear_solver = "
                                         "'gamg') before the Newton iteration counts as failed (cut-back).",
                                         when={"type": STATIC}, **_count()),
            "jacobian_every": Key("int", 1, "Newton's Jacobian (assembled and factorised) at every iteration (1: "
                                  "full Newton, quadratic convergence) or, modified Newton, at the first iteration "
                                  "of every increment, every jacobian_every-th iteration and whenever an iteration "
                                  "reduces the residual by less than jacobian_rate; the iterations between reuse "
                                  "the factorisation (cheaper iterations, linear convergence; the same solution to "
                                  "the Newton tolerance). On the shipped punch scenes it takes about twice the "
                                  "iterations and more time than full Newton.", when={"type": STATIC}, **_count()),
            "jacobian_rate": Key("float", 0.1, "Modified Newton (jacobian_every > 1): a new Jacobian whenever "
                                 "|R_k| > jacobian_rate |R_k-1|.", when={"type": STATIC}, lo=0.0, hi=1.0),
            "predictor": Key("str", "contact", "Newton's first iterate of an increment. 'contact': the last "
                             "increment extrapolated, with the nodes in contact moved back to their committed gaps, "
                             "and, at the first increment of a load step after another, the extrapolation or the "
                             "tangent predictor, whichever has the smaller residual. 'plain': the extrapolation "
                             "alone, and the tangent predictor at the first increment of every load step (as before "
                             "the contact predictor). Both converge to the same solution of an increment; 'contact' "
                             "takes fewer iterations on curved tools (3-D punch: 169 against 254), so the increments "
                             "grow sooner.", when={"type": STATIC}, choices=("contact", "plain")),
            "duration": Key("float", OPTIONAL, "Physical time of a static analysis: the pseudo-time t lasts t x "
                            "duration seconds (the press's stroke time: t from 0 to 1 is one stroke). Required "
                            "by [thermal] (heat conduction needs time); absent: no physical time.", "s",
                            when={"type": STATIC}, **_pos()),
            "end_time": Key("float", REQUIRED, "Simulated time.", "µs", when={"type": EXPLICIT}, scale=US, **_pos()),
            "dt_safety": Key("float", 0.8, "Time step = dt_safety x the stable limit.", when={"type": EXPLICIT},
                             lo=0.0, hi=1.0, hi_open=False, refines=-1, axis="time"),
            "time_steps": Key("int", OPTIONAL, "Fixes dt = end_time / time_steps; refused above the stable limit.",
                              when={"type": EXPLICIT}, refines=+1, axis="time", **_count()),
            "internal_force": Key("str", "fused", "How the explicit internal force is computed: 'fused' (one "
                                  "compiled pass, the default) or 'ufl' (the UFL residual assembled by dolfinx, "
                                  "the definition). Same numbers to round-off.", when={"type": EXPLICIT},
                                  choices=("fused", "ufl")),
            "stable_step": Key("str", "element", "The stable step of a cell: 'element' = the larger of h / c and "
                               "2 / omega_max of the cell's elastic element with its lumped mass (exact for the "
                               "element, an upper bound for the mesh; h / c collapses on a cell with a corner "
                               "near 180 degrees, a sound triangle); 'size' = h / c alone (h its smallest edge "
                               "or altitude, c the dilatational wave speed): 25-35 % more steps on the crushed "
                               "cells of an impact. The step used is dt_safety x the smallest over the cells.",
                               when={"type": EXPLICIT}, choices=("size", "element"), refines=0),
            "dt_floor": Key("float", 1e-3, "Time-step floor, as a fraction of the initial stable step: when the "
                            "stable step of the deformed mesh falls below it (a crushed cell), the run stops "
                            "(exit 1, summary.json with converged = false, the fields and a checkpoint at the "
                            "stop) with a message naming the cell and the remedies. 0: no floor.",
                            when={"type": EXPLICIT}, lo=0.0, lo_open=False, hi=1.0),
            "mass_scaling_dt": Key("float", 0.0, "Selective mass scaling: target stable step. At every step-size "
                                   "check (every 10 steps) the cells whose stable step h/c is below it get "
                                   "density (mass at their nodes) so that theirs reaches it; mass is never "
                                   "removed. The added mass, the cells affected and the kinetic energy the mass "
                                   "brings are in history.csv and summary.json, and in the energy balance. The "
                                   "step used is dt_safety x the stable step. 0: off.", "µs",
                                   when={"type": EXPLICIT}, scale=US, refines=-1, **_nonneg()),
            "erosion_ratio": Key("float", 0.0, "Element erosion: a cell whose smallest quadrature-point "
                                 "Jacobian falls below this fraction of its mean dilatation (a cell about to "
                                 "fold, which no time step or mass scaling prevents) is removed: it adds no "
                                 "force and no stable-step limit, its points keep their state (frozen), its "
                                 "nodes keep their mass. The eroded cells and their volume fraction are in "
                                 "history.csv, summary.json and fields.xdmf (eroded = 1). 0: off (the run "
                                 "stops at a folded cell).", "",
                                 when={"type": EXPLICIT}, lo=0.0, lo_open=False, hi=1.0),
        }),
    "mesh": Table(
        "The mesh: a Gmsh `.geo` file (meshed when the run starts, with `[mesh.parameters]` set as its "
        "`DefineConstant` values \"Parameters/<name>\") or a `.msh` file. Regions and boundaries are Gmsh "
        "physical groups, referred to by name: in 2-D regions are physical surfaces and boundaries physical "
        "curves; in 3-D regions are physical volumes and boundaries physical surfaces.", optional=False, keys={
            "file": Key("str", REQUIRED, "Path of the .geo or .msh file, relative to the scene file."),
            "geometry": Key("str", "axisymmetric", "axisymmetric (x = r, y = z; quadrilaterals), plane_strain "
                            "(x, y; quadrilaterals) or 3d (x, y, z; hexahedra: vectors take 3 entries, "
                            "components x, y, z).", choices=GEOMETRIES),
            "element": Key("str", "q1p0", "q1p0: Q1 displacement + DG0 dilatation (F-bar); q1: plain Q1 "
                           "(quadrilaterals in 2-D, hexahedra in 3-D).",
                           choices=("q1p0", "q1")),
            "refine": Key("float", 1, "Multiplies every cell count of `[mesh.parameters]` (.geo only; each "
                          "product rounded to the nearest integer, at least 1: 1.5 makes 6 cells 9). Before "
                          "meshing, the mesh's size is estimated (the .geo meshed at a smaller scale) and refused "
                          "when it would need more than the machine's memory (at 4 kB per cell in 2-D, 5 kB in 3-D, "
                          "half what the cheapest run takes).", refines=+1, axis="mesh", **_pos()),
        }, subtables={"parameters": Table("Named numbers passed to the .geo file (its DefineConstant "
                                          "\"Parameters/<name>\"); unknown names are refused. A name that starts "
                                          "with `cells` or ends in `_cells` is a cell count: an integer >= 1; any "
                                          "other must be > 0 and at most 1e9 (a length in mm), or lie within the "
                                          "`Min` and `Max` the .geo's DefineConstant gives it (e.g. `{0.0, Min 0, Max 0.9, Name "
                                          "\"Parameters/imperfection\"}`).", free=True)}),
    "materials": Table(
        "Materials, one table per name. Each applies to the cell regions it lists; a single material "
        "without `regions` applies to the whole mesh.", optional=False, collection=True, keys={
            "regions": Key("strs", OPTIONAL, "Gmsh physical surface (3-D: volume) names, the cell regions this "
                           "material fills."),
            "model": Key("str", "isochoric", "seed: be^-1 radial return (Almansi, Simo-Ortiz); isochoric: "
                         "exponential map in log strain.", choices=("seed", "isochoric")),
            "E": Key("float", REQUIRED, "Young's modulus.", "MPa", **_pos()),
            "nu": Key("float", REQUIRED, "Poisson's ratio.", "", lo=-1.0, hi=0.5),
            "density": Key("float", OPTIONAL, "Mass density (required in explicit analyses and with [thermal]).",
                           "kg/m³", scale=KG_M3, **_pos()),
            "conductivity": Key("float", OPTIONAL, "Thermal conductivity k (with [thermal], required there; 0: "
                                "the adiabatic limit).", "W/(m K)", **_nonneg()),
            "specific_heat": Key("float", OPTIONAL, "Specific heat c (with [thermal], required there): rho c the "
                                 "heat capacity per volume.", "J/(kg K)", **_pos()),
            "expansion": Key("float", OPTIONAL, "With [thermal]: the linear thermal expansion coefficient alpha: the "
                             "material's stress-free stretch is 1 + alpha (T - thermal.initial_temperature) in every "
                             "direction (F = F_e F_theta F_p); absent: no thermal expansion.", "1/K", **_nonneg()),
            "taylor_quinney": Key("float", 0.9, "Taylor-Quinney coefficient beta (with [thermal]): the fraction of "
                                  "the plastic work that heats the body.", "", lo=0.0, lo_open=False, hi=1.0,
                                  hi_open=False),
        }, subtables={"hardening": _hardening_table()}),
    "boundary": Table(
        "Boundary conditions and loads, one table per name, each on a Gmsh facet group. Static: t is the "
        "pseudo-time; explicit: t is the time in µs. Values: " + VALUE_DOC + ".",
        collection=True, discriminator="type", keys={
            "group": Key("str", OPTIONAL, "Gmsh physical curve (3-D: surface) name, a facet group. Required "
                         "for every type but wall, where it names the nodes the wall stops (absent: every "
                         "node)."),
            "type": Key("str", REQUIRED, "fixed: components held at 0; displacement: prescribed [mm]; velocity "
                        "(explicit): prescribed [m/s]; traction: dead load [MPa] per reference area (in axisymmetry on the "
                        "whole revolved surface); pressure: normal dead load [MPa], positive pushes into the body; symmetry: the normal component "
                        "held at 0 (the group must lie in a line (2-D) or plane (3-D) normal to x, y or z); axis: "
                        "u_r = 0 (axisymmetric only); wall (explicit): a rigid frictionless plane normal to "
                        "`components` at `position` that the nodes cannot pass (a node that reaches it stops "
                        "there and may leave it again; the energy the stops take is wall_energy_J, a "
                        "term of the energy balance). The body starts on one side of it.",
                        choices=("fixed", "displacement", "velocity", "traction", "pressure", "symmetry", "axis",
                                 "wall")),
            "components": Key("strs", REQUIRED, "Components: x, y (also r, z in 2-D: r = x, z = y); x, y, z "
                              "in 3-D. A wall takes one: the axis its plane is normal to.",
                              when={"type": ("fixed", "displacement", "velocity", "traction", "wall")}),
            "position": Key("float", REQUIRED, "The wall's plane: its coordinate along its component.", "mm",
                            when={"type": ("wall",)}),
            "value": Key("values", REQUIRED, "One value per component (a list), or one value for all.",
                         when={"type": ("displacement", "velocity", "traction", "pressure")}),
            "amplitude": Key("str", "ramp", "How a value that does not depend on t is applied (static): ramp = "
                             "from 0 at t = 0 to its full value at the end of the first step (t = 1 without "
                             "[steps]), then held, as Abaqus and CalculiX ramp a static step's loads; step = in "
                             "full from the first increment on. Values that depend on t (tables, expressions of "
                             "t) are applied as written.", choices=("ramp", "step"),
                             when={"type": ("displacement", "traction", "pressure")}, when_analysis=STATIC),
        }),
    "initial_velocity": Table(
        "Initial velocity (explicit), one table per name.", collection=True, when_analysis=EXPLICIT, keys={
            "regions": Key("strs", OPTIONAL, "Cell regions; absent = the whole body. A node shared by two "
                           "tables' regions takes the last table's value."),
            "value": Key("values", REQUIRED, "Velocity (x, y), in 3-D (x, y, z): numbers or expressions of x, "
                         "y, z.", "m/s",
                         scale=M_S),
        }),
    "tools": _tools_table(),
    "contact": Table(
        "Contact pairs, one table per name: the nodes of a facet group of the body against a master surface, "
        "a rigid tool or a facet group of the body (another body's; its own: self-contact) "
        "(penalty, nodal rule).",
        collection=True, keys={
            "tool": Key("str", OPTIONAL, "Name of a [tools.<name>] table: the master surface is that rigid "
                        "tool. Exactly one of tool and master."),
            "master": Key("str", OPTIONAL, "Gmsh physical curve (3-D: surface) name of a facet group of the "
                          "body: the master surface is that part of the body's boundary at its current "
                          "positions; two bodies are two regions of one mesh. Each force on a node of `group` "
                          "has its reaction on the nodes of the master facet it presses on. Exactly one of tool "
                          "and master. `group` itself: self-contact (a node against the facets of its "
                          "own group that face it, not its own). Friction as for tools, in both analyses."),
            "two_pass": Key("bool", OPTIONAL, "With master: also the master group's nodes against the group's "
                            "facets, the same law and penalty (symmetric: neither side passes through the "
                            "other); absent = true; false: the group's nodes only."),
            "group": Key("str", REQUIRED, "Gmsh physical curve (3-D: surface) name of the body's candidate "
                         "facets (the slave nodes)."),
            "friction": Key("float", 0.0, "Coulomb coefficient mu (0: frictionless, no friction term).", "",
                            **_nonneg()),
            "law": Key("str", "quasi-coulomb", "coulomb: current p and N; quasi-coulomb: p and N frozen over an "
                       "increment (seed eq. 24, symmetric).", choices=("coulomb", "quasi-coulomb")),
            "penalty": Key("float", OPTIONAL, f"Normal penalty; absent = {PENALTY_FACTOR:g} E / h, h the mean depth "
                           "of the cells along the group.", "N/mm³", refines=+1, axis="contact", **_pos()),
            "tangential_penalty": Key("float", OPTIONAL, "Tangential (stick) penalty; absent = the normal "
                                      "penalty.", "N/mm³", refines=+1, axis="contact", **_pos()),
            "conductance": Key("float", OPTIONAL, "With [thermal], a pair with a tool: the heat transfer coefficient "
                               "h of the contact: the nodes in contact exchange q = h (T_tool - T) with the tool "
                               "(tools.<tool>.temperature); absent: no heat crosses the contact.", "W/(m² K)",
                               scale=W_M2, **_nonneg()),
            "conductance_pressure": Key("float", OPTIONAL, "With a conductance: the contact pressure p_c at and above "
                                        "which the conductance is full; below it h = conductance x p / p_c (the "
                                        "real contact area grows with the pressure); absent: h does not depend "
                                        "on the pressure.", "MPa", **_pos()),
            "friction_heat_fraction": Key("float", 0.5, "With [thermal]: the share of the friction's dissipation "
                                          "that heats the body (the rest goes into the tool).", "", lo=0.0,
                                          lo_open=False, hi=1.0, hi_open=False),
        }),
    "steps": Table(
        "Static load steps, in order of `end`. Each ends at a pseudo-time where a converged state is "
        "written (profiles, fields); boundary values and tool paths are functions of t across steps.",
        collection=True, when_analysis=STATIC, keys={
            "end": Key("float", REQUIRED, "Pseudo-time at the end of the step.", "", **_pos()),
            "increments": Key("int", OPTIONAL, "Initial increments of this step (absent: analysis.increments).",
                              refines=+1, axis="time", **_count()),
            "max_increment": Key("float", OPTIONAL, "Largest increment (absent: analysis.max_increment).",
                                 refines=-1, axis="time", **_pos()),
        }),
    "remeshing": Table(
        "Automatic remeshing of 2-D bodies: after every converged increment (static) the deformed "
        "cells are measured (scaled Jacobian, largest corner angle); when a cell passes a threshold, or an "
        "increment fails to converge, the deformed outline is meshed anew (quadrilaterals, Gmsh), every "
        "facet group, region and contact pair carried over, the quadrature state (b_e^-1 through its "
        "logarithm, eqps) transferred, equilibrium restored at the same load, and the run goes on. Absent: "
        "the run follows the material with one mesh. Boundary values of a remeshed run must not depend on "
        "x, y, z (the new mesh's reference is the deformed shape). Explicit runs check the cells at every "
        "step-size check and remesh there, or where the next step would fold a cell (no contact pairs, "
        "prescribed motions, loads, erosion or mass scaling with it yet).", keys={
            "size": Key("float", REQUIRED, "Cell size of the new meshes.", "mm", refines=-1, axis="mesh", **_pos()),
            "refine_size": Key("float", OPTIONAL, "Cell size within 2 `size` of the corners of the deformed "
                               "outline (where it turns by more than `corner_angle`: tool edges, folds), "
                               "growing to `size` over a further 4 `size`; absent: `size` everywhere.", "mm",
                               refines=-1, axis="mesh", **_pos()),
            "corner_angle": Key("float", 20.0, "A vertex of the deformed outline where the boundary turns by more "
                                "than this is a corner, refined to `refine_size`.", "deg", lo=0.0, hi=180.0),
            "min_scaled_jacobian": Key("float", 0.2, "Remesh when a cell's scaled Jacobian (the sine of its "
                                       "worst corner angle, signed: <= 0 folded) falls below this.", "",
                                       lo=0.0, hi=1.0),
            "max_angle": Key("float", 160.0, "Remesh when a cell's corner angle exceeds this.", "deg",
                             lo=90.0, hi=180.0),
            "every": Key("int", 0, "Also remesh every N converged increments (0: only when the quality "
                         "asks).", lo=0, lo_open=False, when_analysis=STATIC),
            "max_remeshes": Key("int", 100, "The run stops with a message after this many remeshes.", **_count()),
        }),
    "thermal": Table(
        "Heat conduction in the body, coupled to the deformation: the temperature is a nodal field, advanced "
        "by one backward-Euler step after each converged increment (static: over its physical time, "
        "analysis.duration) or at each history row (explicit: over the row's time), heated by the plastic work (materials' taylor_quinney) and friction "
        "(contact pairs' friction_heat_fraction), exchanging heat with tools (contact pairs' conductance, "
        "tools' temperature) and through the [thermal_boundary] conditions (elsewhere insulated); a "
        "Johnson-Cook flow stress takes the field's temperature. Needs each "
        "material's density, conductivity and specific_heat (static: and analysis.duration). Explicit analyses: "
        "no tool contact heat, thermal expansion or [remeshing] with it yet. Absent: no heat equation is "
        "assembled.", keys={
            "initial_temperature": Key("float", REQUIRED, "Temperature of the body at t = 0.", "K", lo=0.0),
        }),
    "thermal_boundary": _thermal_boundary_table(),
    "outputs": Table(
        "Quantities recorded every increment (static) or history row (explicit): each is a history.csv "
        "column named <name>_<unit>, and its final value goes into summary.json. In axisymmetry, forces "
        "(reaction, tool_force) and energies are those of the whole 360° body.",
        collection=True, discriminator="quantity", keys={
            "quantity": Key("str", REQUIRED, quantity_doc(), choices=tuple(KINDS)),
            "group": Key("str", OPTIONAL, "Facet group: extent and group_mean measure it (extent: absent = the "
                         "whole body); displacement and position take the node nearest `point` among its nodes.",
                         when={"quantity": taking("group")}),
            "tool": Key("str", REQUIRED, "Tool name.", when={"quantity": taking("tool")}),
            "contact": Key("str", REQUIRED, "Name of a [contact.<name>] pair: its master surface (a tool, or the "
                           "body's master group) against the nodes of its group.",
                           when={"quantity": taking("contact")}),
            "component": Key("str", REQUIRED, "x or y (r or z) in 2-D; x, y or z in 3-D; extent also takes "
                             "radial: the distance from the z axis, sqrt(x^2 + y^2) (3-D; r in axisymmetry).",
                             choices=("x", "y", "r", "z", "radial"),
                             when={"quantity": taking("component")}),
            "point": Key("vector", REQUIRED, "Reference coordinates; the nearest node is used.", "mm",
                         when={"quantity": taking("point")}),
            "which": Key("str", "max", "Largest or smallest.", choices=("max", "min"),
                         when={"quantity": taking("which")}),
            "regions": Key("strs", OPTIONAL, "Cell regions (absent = the whole body); displacement and position "
                           "take the node nearest `point` among their cells' nodes.",
                           when={"quantity": taking("regions")}),
            "statistic": Key("str", "max", "contact_pressure: max, the largest nodal pressure, or mean, the normal "
                             "force over the area in contact; temperature: max, min or mean (the volume mean over "
                             "the current body).", choices=("max", "min", "mean"),
                             when={"quantity": taking("statistic")}),
            "unit": Key("str", "kN", "Force unit of the column.", choices=_FORCE_UNITS,
                        when={"quantity": taking("unit")}),
            "scale": Key("float", 1.0, "Factor applied to the measured value: e.g. 2 for the elongation of a "
                         "half model, 4 for the force or the energies of a quarter model (not to the energy "
                         "balance error, a ratio).",
                         when={"quantity": taking("scale")}),
            **kind_keys(),     # each quantity kind's own keys (fenics_plast/quantities/kinds/)
            "at_max_of": Key("str", OPTIONAL, "Name of another one-column output: summary.json also gets this "
                             "output's value where that one is largest (<column>_at_max_<its column>)."),
            "summary": Key("strs", ["final"], "What goes into summary.json: final, max, min (max adds "
                           "max_<column> and, for static runs, the pseudo-time of the maximum)."),
            "key": Key("bool", False, "A key result: `fenics-plast study` reports its error."),
            "reference": Key("float", OPTIONAL, "A published value of the final result (study: err_paper_)."),
            "reference_source": Key("str", "", "Where `reference` comes from."),
        }),
    "plots": Table(
        "Figures drawn from history.csv (and the profiles, final shape) at the end of the run and by "
        "`fenics-plast plot DIR`.", collection=True, discriminator="type", keys={
            "type": Key("str", "history", "history: columns against a column; profile: a thickness output "
                        "along its group at each step end; shape (2-D only): the final deformed mesh coloured "
                        "by a field.",
                        choices=("history", "profile", "shape")),
            "x": Key("str", REQUIRED, "Column of history.csv on the x axis.", when={"type": ("history",)}),
            "y": Key("strs", REQUIRED, "Columns on the y axis (one line each).", when={"type": ("history",)}),
            "output": Key("str", REQUIRED, "Name of a thickness output.", when={"type": ("profile",)}),
            "field": Key("str", "eqps", "The colour of a shape figure: eqps (equivalent plastic strain) or "
                         "temperature [K] (Johnson-Cook materials).", choices=state_outputs(),
                         when={"type": ("shape",)}),
            "title": Key("str", "", "Figure title (default: the scene name)."),
        }),
    "output": Table("What is written to the output directory.", keys={
        "xdmf": Key("bool", True, "Write fields to fields.xdmf."),
        "every": Key("int", 1, "Write fields every N increments (static) or history rows (explicit).", **_count()),
        "plots": Key("bool", True, "Draw the [plots] as PNG files."),
        "history_points": Key("int", 200, "Number of history rows (explicit), equally spaced in time. At most "
                              "one per time step: a run of fewer steps (analysis.time_steps, or end_time over "
                              "dt_safety x the initial stable step) writes one row per step and says so in its log.",
                              when_analysis=EXPLICIT, lo=2, lo_open=False, hi=100000, hi_open=False),
        "checkpoint_every": Key("int", None, "Checkpoint every N steps (explicit) or converged increments "
                                "(static) into checkpoint/ (0: never); `--resume DIR` continues a killed run.",
                                analysis_default={"explicit": 2000, "static": 10}, lo=0, lo_open=False),
    }),
}

SECTIONS = tuple(SCHEMA)



# ----------------------------------------------------------------------------------------------
# One key by its dotted path: what the solvers, materials and tools read for their own defaults


def key(path: str) -> Key:
    """The :class:`Key` at the dotted ``path``: ``"analysis.dt_safety"``; the tables of a collection
    are ``*`` (``"contact.*.law"``); a subtable goes by its name (``"materials.*.hardening.law"``).
    KeyError naming the path when no key is declared there."""
    parts = path.split(".")
    table = SCHEMA.get(parts[0])
    rest = parts[1:]
    if table is not None and table.collection:
        table = table if rest[:1] == ["*"] else None
        rest = rest[1:]
    while table is not None and len(rest) > 1:
        table = table.subtables.get(rest[0])
        rest = rest[1:]
    if table is None or len(rest) != 1 or rest[0] not in table.keys:
        raise KeyError(f"no scene key {path!r} in the schema")
    return table.keys[rest[0]]


def default(path: str, analysis: str | None = None) -> Any:
    """The value a scene that omits the key at ``path`` (see :func:`key`) gets, as validation fills it
    in: the declared default (a list as a tuple), None for an OPTIONAL key; ``analysis`` (static |
    explicit) picks a default that depends on the analysis type. Solvers, materials and tools take
    their keyword defaults from here (``law=default("contact.*.law")``), so each default is declared
    once. KeyError for a REQUIRED key (it has no default) or a missing ``analysis``."""
    k = key(path)
    value = k.default
    if k.analysis_default is not None:
        if analysis not in k.analysis_default:
            raise KeyError(f"the default of {path!r} depends on the analysis type: give analysis= one of "
                           f"{', '.join(k.analysis_default)}")
        value = k.analysis_default[analysis]
    if value is REQUIRED:
        raise KeyError(f"scene key {path!r} is required: it has no default")
    return None if value is OPTIONAL else (tuple(value) if isinstance(value, list) else value)


#: the free ``[mesh.parameters]`` names that are discretisation settings (fnmatch patterns on the name):
#: cell counts refine when larger (``mesh.refine`` multiplies them, so they are on no axis of their own);
#: a grading or size ratio orders nothing
MESH_PARAMETER_REFINES: dict[str, int] = {"cells*": +1, "*_cells": +1, "*grading": 0, "*size_ratio": 0}


def discretisation_keys() -> dict[str, tuple[int, str | None]]:
    """Every discretisation setting of the scene format: {dotted key (fnmatch pattern: a collection's
    tables are ``*``): (refines, axis)} from the keys' ``refines`` and ``axis`` declarations
    (:class:`~fenics_plast.scene_key.Key`) and :data:`MESH_PARAMETER_REFINES`. What ``fenics-plast
    study`` orders runs by, and what ``run --accuracy`` refines."""
    out: dict[str, tuple[int, str | None]] = {}

    def walk(prefix: str, table: Table) -> None:
        for name, k in table.keys.items():
            if k.refines is not None:
                out[f"{prefix}.{name}"] = (k.refines, k.axis)
        for name, sub in table.subtables.items():
            walk(f"{prefix}.{name}", sub)

    for section, table in SCHEMA.items():
        walk(f"{section}.*" if table.collection else section, table)
    for pattern, refines in MESH_PARAMETER_REFINES.items():
        out[f"mesh.parameters.{pattern}"] = (refines, None)
    return out


def choices(path: str) -> tuple:
    """The allowed values of the key at ``path`` (see :func:`key`): what solvers and materials check
    their arguments against (``choices("contact.*.law")``). KeyError for a key without choices."""
    k = key(path)
    if k.choices is None:
        raise KeyError(f"scene key {path!r} has no list of choices")
    return tuple(k.choices)
