"""The build layer: from a validated :class:`fenics_plast.problem.Problem` and its checked mesh
(:func:`fenics_plast.scene_mesh.read_mesh`) to the objects both analyses consume, each built once.

- materials: :func:`material_of` (one table), :func:`body_material` (the body's, with its density
  [tonne/mm^3]), :func:`cell_regions` (region -> owned cells), :func:`contact_modulus` (E [MPa] along a
  group);
- boundary conditions and loads: :func:`boundaries` -> :class:`Boundary` records (the group's facet tag
  and local facets, component indices for mesh.geometry, a symmetry group's normal found on the mesh,
  the scene's values);
- tools: :func:`tool_of` / :func:`tools_of` (paths in the analysis's time), :func:`tool_force_of`;
- contact pairs: :func:`contact_pairs` -> :class:`ContactPair` (tool, facet tag, penalty [N/mm^3]: the
  scene's or the default, :func:`fenics_plast.tools.default_penalty`; friction, law; the depth [mm] of
  the cells along the group);
- the initial velocity: :func:`initial_velocity_field` [mm/s], (n_local_nodes, gdim).

Units: the scene's values are converted here (or, for plain numbers, in validation) and nowhere else.
Static values are functions of the pseudo-time t as written. Explicit values are written with t in µs
and velocities in m/s: :func:`time_function` (:meth:`Boundary.of_seconds`) makes them functions of t
[s] in mm/s, mm or MPa; :func:`tools_of` gives tool paths of t [s]; :func:`initial_velocity_field`
converts to mm/s (:data:`fenics_plast.schema.US`, :data:`fenics_plast.schema.M_S`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.material import Hardening, Material, MaterialRegions
from fenics_plast.scene_mesh import symmetry_component
from fenics_plast.schema import M_S, US, component_index
from fenics_plast.tool_shapes import shapes as tool_shapes

__all__ = ["material_of", "body_material", "cell_regions", "contact_modulus", "components_of", "values_of",
           "Boundary", "boundaries", "time_function", "tool_path", "tool_values", "tool_dim", "tool_of", "tools_of",
           "tool_force_of", "ContactPair", "contact_pairs", "initial_velocity_field"]


# ----------------------------------------------------------------------------------------------
# materials


def material_of(spec, field_temperature: float | None = None) -> Material:
    """:class:`Material` from a validated [materials.<name>] table. ``field_temperature`` [K]: a run with
    [thermal], whose temperature is a field (:mod:`fenics_plast.thermal`) starting there: a thermal law
    (Johnson-Cook) then starts its points at it and heats none of them itself (taylor_quinney 0 in the
    kernel: the plastic heat goes into the field, which sets the points' temperature after each
    increment)."""
    h = spec.hardening
    hardening = None
    if h is not None:
        kw = {k: v for k, v in h.to_dict().items() if k != "law"}
        if field_temperature is not None:           # (a temperature-dependent law: the field's; no own heating)
            kw.update(initial_temperature=field_temperature)
            if "taylor_quinney" in kw:
                kw.update(taylor_quinney=0.0)
        # tonne/mm^3: a thermal law's adiabatic heating rho c_p (a law that does not declare it ignores it)
        hardening = Hardening(h.law, density=spec.density, **kw)
    return Material(spec.E, spec.nu, hardening, model=spec.model)


def body_material(problem, cell_tags, groups, n_owned):
    """The body's material and density [tonne/mm^3] (None where the scene gives none).

    One material: a :class:`Material` and its density (it fills the mesh, :func:`read_mesh` has
    checked that). Several: a :class:`MaterialRegions` over the owned cells of their regions and the
    list of their densities, in the scene's order."""
    mats = problem.materials
    field = None if problem.tables.get("thermal") is None else problem.thermal.initial_temperature
    if len(mats) == 1:
        (spec,) = mats.values()
        return material_of(spec, field), spec.density
    regions = cell_regions(cell_tags, groups, n_owned)
    parts = [(material_of(spec, field), np.concatenate([regions[r] for r in spec.regions])) for spec in mats.values()]
    return MaterialRegions(parts, n_owned), [spec.density for spec in mats.values()]


def contact_modulus(material, mesh, facet_tags, tag):
    """Young's modulus [MPa] for a default contact penalty on the facets tagged ``tag``: the
    material's; with several materials, the largest among the cells along those facets (collective)."""
    if not isinstance(material, MaterialRegions):
        return material.E
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    cells = np.array([c for f in facet_tags.find(tag) for c in f2c.links(f)], dtype=np.int64)
    cells = cells[cells < material.n_cells]
    moduli = np.array([m.E for m in material.materials])
    E = mesh.comm.allreduce(float(moduli[material.cell_material[cells]].max()) if cells.size else 0.0, op=MPI.MAX)
    return E if E > 0.0 else material.E


def cell_regions(cell_tags, groups, n_owned):
    """{region name: owned cell indices} of the cell regions (groups of the cells' dimension)."""
    out = {}
    for name, (dim, tag) in groups.items():
        if dim == cell_tags.dim:
            c = cell_tags.find(tag)
            out[name] = c[c < n_owned]
    return out


# ----------------------------------------------------------------------------------------------
# boundary conditions and loads


def components_of(b, geometry):
    """Indices of a [boundary] table's components in ``geometry`` (mesh.geometry): "z" is 1 in 2-D but
    2 in 3-D."""
    return [component_index(c, geometry) for c in b.components]


def values_of(b, n):
    """A [boundary] table's value per component: its list, or its one value ``n`` times."""
    v = b.value
    return list(v) if isinstance(v, tuple) else [v] * n


def time_function(value, scale=None) -> Callable[[float], float]:
    """An explicit analysis's scene value (a function of t in µs, uniform in space: validation has
    checked) as a function of t [s]: ``value(t / US)``, times ``scale`` (M_S: m/s -> mm/s) if given."""
    if scale is None:
        return lambda t: float(value.evaluate(t=t / US))
    return lambda t: float(value.evaluate(t=t / US)) * scale


@dataclass(frozen=True)
class Boundary:
    """One [boundary.<name>] table resolved on the mesh.

    ``components``: the component indices it holds, prescribes or loads (fixed, displacement, velocity,
    traction, wall: its ``components``; axis: (0,), r; symmetry: the one normal to its group; pressure:
    none). ``values``: the scene's values (:class:`fenics_plast.expressions.Value`, in the file's units
    and time), one per component (displacement, velocity, traction) or the pressure alone; () for the
    types without a value. ``tag``, ``facets``: its group's facet tag and local facets (None: a wall
    without a group, which stops every node)."""
    name: str
    spec: Any                               # the validated table (type, amplitude, position, ...)
    tag: int | None
    facets: np.ndarray | None
    components: tuple
    values: tuple
    where: str                              # "<scene file>: boundary.<name>", for messages

    @property
    def type(self) -> str:
        return self.spec.type

    @property
    def group(self) -> str | None:
        return self.spec.group

    def of_seconds(self) -> list[Callable[[float], float]]:
        """Explicit analyses: one function of t [s] per component (:func:`time_function`), in mm/s
        (velocity: written in m/s), mm (displacement) or MPa (traction)."""
        scale = M_S if self.type == "velocity" else None
        return [time_function(v, scale) for v in self.values]


def boundaries(problem, V, facet_tags, groups) -> list[Boundary]:
    """The [boundary] tables of ``problem``, in the scene's order, resolved on the mesh (``V``: a
    vector CG1 space of the displacement, to find a symmetry group's normal; collective)."""
    geometry = problem.mesh.geometry          # "z" is component 1 in 2-D, 2 in 3-D
    out = []
    for name, b in problem.boundary.items():
        where = f"{problem.path}: boundary.{name}"
        tag = groups[b.group][1] if b.group is not None else None
        facets = facet_tags.find(tag) if tag is not None else None
        values = ()
        if b.type == "axis":
            comps = [0]
        elif b.type == "symmetry":
            comps = [symmetry_component(V, facet_tags, tag, where)]
        elif b.type == "pressure":
            comps, values = [], (b.value,)
        else:
            comps = components_of(b, geometry)
            if b.get("value") is not None:
                values = tuple(values_of(b, len(comps)))
        out.append(Boundary(name, b, tag, facets, tuple(comps), values, where))
    return out


# ----------------------------------------------------------------------------------------------
# tools and contact pairs


def tool_path(path, time_scale=1.0, dim=2):
    """A tool's translation ``(t, use_ufl) -> (dx, dy)`` (``dim`` = 3: (dx, dy, dz)) [mm] from a
    validated ``path`` table (component -> Value of t), or None (fixed). ``time_scale``: seconds per
    unit of the table's t (explicit: µs)."""
    if not path:
        return None

    def translation(t, use_ufl):
        tt = t * (1.0 / time_scale) if time_scale != 1.0 else t
        out = []
        for c in "xyz"[:dim]:
            val = path.get(c)
            if val is None:
                out.append(ufl.as_ufl(0.0) if use_ufl else 0.0)
            else:
                out.append(val.to_ufl(t=tt) if use_ufl else float(val.evaluate(t=tt)))
        return tuple(out) if use_ufl else np.array(out)
    return translation


def tool_values(spec) -> dict:
    """{key: value} of a validated [tools.<name>] table's shape keys (absent keys None)."""
    return {k: spec.get(k) for k in tool_shapes()[spec.shape].params}


def tool_dim(spec) -> int:
    """2 or 3: the space a validated [tools.<name>] table lives in (validation has matched its vectors
    to mesh.geometry): :meth:`~fenics_plast.tool_shapes.ToolShape.dim_of`."""
    return tool_shapes()[spec.shape].dim_of(tool_values(spec))


def tool_of(name, spec, time_scale=1.0):
    """A :class:`fenics_plast.tools.Tool` from a validated [tools.<name>] table (2-D or 3-D, from the
    table itself: see :func:`tool_dim`)."""
    from fenics_plast.tools import Tool
    dim = tool_dim(spec)
    return Tool(spec.shape, path=tool_path(spec.path, time_scale, dim=dim), name=name, dim=dim,
                **tool_values(spec))


def tools_of(problem, comm) -> dict:
    """{name: tool} of the scene's [tools], their paths functions of the analysis's time: the pseudo-time
    (static) or t [s] (explicit: the paths are written in µs). A meshed tool reads its surface (rank 0,
    collective: :func:`fenics_plast.meshed_tools.meshed_tool`; SceneError for a file or group it cannot use)."""
    from fenics_plast.meshed_tools import SHAPE, meshed_tool
    time_scale = US if problem.explicit else 1.0
    dim = 3 if problem.mesh.geometry == "3d" else 2
    return {n: meshed_tool(n, t, dim, tool_path(t.path, time_scale, dim=dim), comm, problem.path.parent)
            if t.shape == SHAPE else tool_of(n, t, time_scale=time_scale) for n, t in problem.tools.items()}


def tool_force_of(problem, pairs, dim) -> Callable[[str], np.ndarray]:
    """``tool_force(tool)``: the force [N] (``dim`` components) on tool ``tool`` of its contact pairs
    (``pairs``: contact name -> the solver's pair, with ``force()``)."""
    def tool_force(tool):
        return sum((np.asarray(p.force()) for n, p in pairs.items() if problem.contact[n].tool == tool),
                   np.zeros(dim))
    return tool_force


@dataclass(frozen=True)
class ContactPair:
    """One [contact.<name>] pair resolved on the mesh: the tool (None for a master group of the body), its
    group's facet tag, the penalty [N/mm^3] (``contact.<name>.penalty`` or ``default_penalty``), friction,
    law and tangential penalty [N/mm^3] (None: the solver's), the mean depth [mm] of the cells along the
    group and the pair's default penalty [N/mm^3] (0.3 E / depth); with a master group of the body, its
    facet tag, whether the master's nodes are pressed against the group's facets too (two passes) and the
    facet tags of the scene's symmetry and axis boundaries, across which a master surface continues."""
    name: str
    tool: Any
    tag: int
    penalty: float
    friction: float
    law: str
    tangential_penalty: float | None
    depth: float
    default_penalty: float
    master_tag: int | None = None
    two_pass: bool = False
    mirror_tags: tuple[int, ...] = ()

    def options(self) -> dict:
        """The keyword arguments of the solvers' ``add_pair`` / ``add_contact``."""
        return dict(penalty=self.penalty, friction=self.friction, law=self.law,
                    tangential_penalty=self.tangential_penalty)


def contact_pairs(problem, mesh, facet_tags, groups, material, tools, penalties=None) -> dict[str, ContactPair]:
    """{name: :class:`ContactPair`} of the scene's [contact] pairs, in its order (``tools``: name -> tool,
    :func:`tools_of`; ``penalties``: {name: penalty [N/mm^3]} in place of the scene's or default one, a
    remeshed body's, which keeps its first mesh's; collective)."""
    from fenics_plast.tools import contact_length_scale, default_penalty
    from fenics_plast.meshed_tools import MeshedTool, check_tool_size
    out = {}
    axisymmetric = problem.mesh.geometry == "axisymmetric"
    mirrors = tuple(groups[b.group][1] for b in problem.boundary.values() if b.type in ("symmetry", "axis"))
    for name, spec in problem.contact.items():
        tag = groups[spec.group][1]
        for key in ("group", "master"):
            if spec.get(key) is not None:
                _check_contact_area(problem, mesh, facet_tags, groups, f"contact.{name}.{key}", spec.get(key),
                                    axisymmetric)
        if spec.get("tool") is not None and isinstance(tools.get(spec.tool), MeshedTool):
            check_tool_size(spec.tool, tools[spec.tool], smallest_cell(mesh), where=str(problem.path))
        depth = contact_length_scale(mesh, facet_tags, tag)
        default = default_penalty(contact_modulus(material, mesh, facet_tags, tag), depth)
        eps = spec.penalty if spec.penalty is not None else default
        if penalties is not None:
            eps = penalties[name]
        master = spec.get("master")
        if master is not None:
            out[name] = ContactPair(name, None, tag, eps, spec.friction, spec.law, spec.tangential_penalty, depth,
                                    default, master_tag=groups[master][1],
                                    two_pass=spec.two_pass is not False and master != spec.group,
                                    mirror_tags=mirrors)
            continue
        if not getattr(tools[spec.tool], "has_ufl_gap", True):
            _check_starting_side(spec, tools[spec.tool], mesh, facet_tags, tag, depth)
        out[name] = ContactPair(name, tools[spec.tool], tag, eps, spec.friction, spec.law, spec.tangential_penalty,
                                depth, default)
    return out


def facet_measures(mesh, facet_tags, tag, axisymmetric=False):
    """(measure, plain measure) of the owned facets tagged ``tag``, summed over the ranks [mm or mm^2]: the
    length (2-D) or area (3-D) of the reference facets, the first weighted by 2 pi r in axisymmetry
    (the revolved surface; 0 for a group on the axis r = 0) (collective)."""
    fdim = mesh.topology.dim - 1
    facets = facet_tags.find(tag)
    facets = facets[facets < mesh.topology.index_map(fdim).size_local]
    total = np.zeros(2)
    if len(facets):             # (a rank without such facets adds nothing, and takes part in the sum)
        x = mesh.geometry.x[dc.entity_nodes(mesh, fdim, facets)]
        if fdim == 1:
            size = np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
            weighted = size * 2 * np.pi * 0.5 * (x[:, 0, 0] + x[:, 1, 0]) if axisymmetric else size
        else:       # triangles; quadrilaterals (vertices in tensor order: the diagonals 0-3 and 1-2)
            a, b = ((x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]) if x.shape[1] == 3 else
                    (x[:, 3] - x[:, 0], x[:, 2] - x[:, 1]))
            size = weighted = 0.5 * np.linalg.norm(np.cross(a, b), axis=1)
        total = np.array([float(np.sum(weighted)), float(np.sum(size))])
    return tuple(mesh.comm.allreduce(total, op=MPI.SUM)) if mesh.comm.size > 1 else tuple(total)


def _check_contact_area(problem, mesh, facet_tags, groups, key, group, axisymmetric):
    """SceneError naming ``key`` when the contact surface ``group`` has zero measure (in axisymmetry: lies on
    the axis, where its revolved surface is a line), so that no pressure can act on it (collective)."""
    from fenics_plast.errors import SceneError
    measure, plain = facet_measures(mesh, facet_tags, groups[group][1], axisymmetric)
    X = mesh.geometry.x
    size = mesh.comm.allreduce(float(np.abs(X).max()) if len(X) else 0.0, op=MPI.MAX)
    if measure > 1e-12 * plain * max(size, 1e-300) and plain > 0:
        return
    where = (" (it lies on the axis r = 0: with mesh.geometry = 'axisymmetric' its revolved surface is a line)"
             if axisymmetric and plain > 0 else "")
    raise SceneError(f"{problem.path}: {key} = {group!r}: the contact surface has zero area{where}: contact needs "
                     f"a surface that pressure can act on")


def smallest_cell(mesh) -> float:
    """The shortest distance between two nodes of one cell of the body [mm], over all ranks (collective)."""
    x = mesh.geometry.x[:, :mesh.geometry.dim]
    cells = dc.geometry_dofs(mesh)[:mesh.topology.index_map(mesh.topology.dim).size_local]
    k = cells.shape[1] if cells.ndim == 2 else 0
    h = np.inf
    for i in range(k):
        for j in range(i + 1, k):
            if len(cells):
                h = min(h, float(np.linalg.norm(x[cells[:, i]] - x[cells[:, j]], axis=1).min()))
    return mesh.comm.allreduce(h, op=MPI.MIN)


def _check_starting_side(spec, tool, mesh, facet_tags, tag, depth):
    """A meshed tool whose normals point away from the body (``flip`` the wrong way) has the contact group
    inside it from the start: SceneError if a node of the cells along the group lies more than half a cell
    depth [mm] inside the tool at t = 0 (collective)."""
    from fenics_plast.errors import SceneError
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, fdim + 1)
    f2c = mesh.topology.connectivity(fdim, fdim + 1)
    facets = facet_tags.find(tag)
    cells = np.unique(np.concatenate([f2c.links(f) for f in facets])) if len(facets) else np.zeros(0, int)
    x = mesh.geometry.x[np.unique(dc.geometry_dofs(mesh)[cells]), :tool.dim]
    g_min = float(tool.gap_np(x, 0.0)[0].min()) if len(x) else np.inf
    g_min = mesh.comm.allreduce(g_min, op=MPI.MIN)
    if g_min < -0.5 * depth:
        raise SceneError(f"tools.{spec.tool}: contact group {spec.group!r} starts {-g_min:.3g} mm inside the meshed "
                         f"tool (its cells are {depth:.3g} mm deep): the body lies on the side the surface's normals "
                         f"point away from; set tools.{spec.tool}.flip = {str(not tool.flip).lower()}")


# ----------------------------------------------------------------------------------------------
# initial state


def initial_velocity_field(problem, V, cell_tags, groups) -> np.ndarray:
    """Nodal initial velocities [mm/s] (n_local_nodes, gdim), owned and ghost nodes, from [initial_velocity]
    (gdim: V's block size, 2 or 3).

    Each table gives its value (numbers or expressions of x, y, z, in m/s: times M_S)
    at the nodes of its regions' cells, or of the whole body without ``regions``. A node covered by
    several tables (on the boundary between two regions) takes the last one's value. The nodes of a
    region are marked on every rank that holds one of its cells and the marks summed on the owners, so
    the result does not depend on the partition (collective)."""
    mesh = V.mesh
    tdim = mesh.topology.dim
    X = V.tabulate_dof_coordinates()
    n = X.shape[0]
    velocity = np.zeros((n, V.dofmap.index_map_bs))
    marker = fem.Function(dc.function_space(mesh, "Lagrange", 1))
    for name, iv in problem.initial_velocity.items():
        if iv.regions is None:
            on = np.ones(n, dtype=bool)
        else:
            cells = np.concatenate([cell_tags.find(groups[r][1]) for r in iv.regions]).astype(np.int32)
            marker.x.array[:] = 0.0
            marker.x.array[dc.locate_cell_dofs(marker.function_space, cells)] = 1.0
            dc.scatter_reverse_add(marker)
            marker.x.scatter_forward()
            on = marker.x.array[:n] > 0.0
        for c, value in enumerate(iv.value):
            v = value.evaluate(x=X[on, 0], y=X[on, 1], z=X[on, 2]) if value.depends_on_space else value.evaluate()
            velocity[on, c] = M_S * np.asarray(v, dtype=float)
    return velocity
