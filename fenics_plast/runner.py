"""Runs a validated :class:`fenics_plast.problem.Problem`: mesh -> forms -> solver -> results.

One runner for every problem; it knows no scene by name. What it does, in order:

1. mesh the scene's Gmsh file (:func:`fenics_plast.meshing.mesh_from_file`) and check that every
   group the scene names exists, with the right dimension (regions: surfaces, groups: curves);
2. build the material(s), the kinematics and the solver of ``analysis.type``;
3. apply the boundary conditions and loads, tools and contact pairs: only what the scene names is
   assembled (no contact pairs: no contact forms; explicit: no Newton);
4. run the steps (static) or the time integration (explicit), recording the declared outputs
   (:mod:`fenics_plast.quantities`) into history.csv, fields into fields.xdmf, profiles at step ends;
5. return the results for summary.json (final values, maxima, study keys, run statistics).

Times: static t is the pseudo-time (the load factor of the solver); explicit t is in seconds
inside the package and in µs in scene files, tables and expressions, history.csv (``time_us``).
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem, io
from mpi4py import MPI

from fenics_plast.checkpoint import Checkpointer, scene_settings
from fenics_plast.material import Hardening, Material, MaterialRegions
from fenics_plast.meshing import MeshError, mesh_from_file
from fenics_plast.errors import SceneError
from fenics_plast.schema import COMPONENTS

US = 1e-6


# ----------------------------------------------------------------------------------------------
# set-up shared by both analyses


def material_of(spec) -> Material:
    """:class:`Material` from a validated [materials.<name>] table."""
    h = spec.hardening
    hardening = None
    if h is not None:
        kw = {k: v for k, v in h.to_dict().items() if k != "law"}
        if h.law == "johnson_cook":
            kw["density"] = spec.density          # tonne/mm^3: the adiabatic heating's rho c_p
        hardening = Hardening(h.law, **kw)
    return Material(spec.E, spec.nu, hardening, model=spec.model)


def read_mesh(problem, comm):
    """Mesh + tags + groups; checks every group and region the scene names (SceneError, exit 2)."""
    m = problem.mesh
    where = f"{problem.path}"
    try:
        mesh, ct, ft, groups = mesh_from_file(comm, problem.mesh_file, m.parameters, m.refine)
    except MeshError as e:
        raise SceneError(f"{where}: mesh.file: {e}") from None
    facets = sorted(n for n, (d, _) in groups.items() if d == 1)
    regions = sorted(n for n, (d, _) in groups.items() if d == 2)

    def need(dotted, name, dim):
        if name in groups and groups[name][0] == dim:
            return
        kind, have = ("facet group (Physical Curve)", facets) if dim == 1 else ("region (Physical Surface)", regions)
        if name in groups:
            raise SceneError(f"{where}: {dotted} = {name!r} is not a {kind} of the mesh: it is a "
                             f"{'region' if dim == 1 else 'facet group'}")
        raise SceneError(f"{where}: {dotted} = {name!r} is not a {kind} of the mesh: the mesh's "
                         f"{'facet groups' if dim == 1 else 'regions'} are {', '.join(have) or 'none'}")
    for n, b in problem.boundary.items():
        need(f"boundary.{n}.group", b.group, 1)
    for n, c in problem.contact.items():
        need(f"contact.{n}.group", c.group, 1)
    for n, o in problem.outputs.items():
        for k in ("group", "opposite"):
            if o.get(k) is not None:
                need(f"outputs.{n}.{k}", o.get(k), 1)
        for r in o.get("regions") or ():
            need(f"outputs.{n}.regions", r, 2)
    for n, mat in problem.materials.items():
        for r in mat.regions or ():
            need(f"materials.{n}.regions", r, 2)
    for n, iv in problem.initial_velocity.items():
        for r in iv.regions or ():
            need(f"initial_velocity.{n}.regions", r, 2)
    check_material_regions(problem, ct, groups, mesh)
    return mesh, ct, ft, groups


def check_material_regions(problem, cell_tags, groups, mesh):
    """Every cell in exactly one material (SceneError naming ``materials.<name>.regions``; collective).

    A single material without ``regions`` fills the mesh. Otherwise a region listed by two materials
    is refused, and so is a region of the mesh that no material lists (its cells would have no
    material). Each cell of a Gmsh mesh lies in one physical surface, so this is a check on names."""
    mats = problem.materials
    if len(mats) == 1 and next(iter(mats.values())).regions is None:
        return
    owner: dict[str, str] = {}
    for n, m in mats.items():
        for r in m.regions or ():
            if r in owner and owner[r] != n:
                raise SceneError(f"{problem.path}: materials.{n}.regions: region {r!r} is also in "
                                 f"materials.{owner[r]}.regions: a cell belongs to one material")
            owner[r] = n
    unclaimed = sorted(r for r, (d, _) in groups.items() if d == 2 and r not in owner)
    if not unclaimed:
        return
    n_owned = mesh.topology.index_map(mesh.topology.dim).size_local
    counts = [int((cell_tags.find(groups[r][1]) < n_owned).sum()) for r in unclaimed]
    counts = mesh.comm.allreduce(np.array(counts), op=MPI.SUM)
    what = ", ".join(f"{r!r} ({c} cells)" for r, c in zip(unclaimed, counts))
    keys = " and ".join(f"materials.{n}.regions" for n in mats)
    verb = "leaves" if len(mats) == 1 else "leave"
    raise SceneError(f"{problem.path}: {keys} {verb} region(s) {what} without a material: every cell needs "
                     f"one (add the region to a material's regions)")


def body_material(problem, cell_tags, groups, n_owned):
    """The body's material and density [tonne/mm^3] (None where the scene gives none).

    One material: a :class:`Material` and its density (it fills the mesh, :func:`read_mesh` has
    checked that). Several: a :class:`MaterialRegions` over the owned cells of their regions and the
    list of their densities, in the scene's order."""
    mats = problem.materials
    if len(mats) == 1:
        (spec,) = mats.values()
        return material_of(spec), spec.density
    regions = cell_regions(cell_tags, groups, n_owned)
    parts = [(material_of(spec), np.concatenate([regions[r] for r in spec.regions])) for spec in mats.values()]
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
    out = {}
    for name, (dim, tag) in groups.items():
        if dim == 2:
            c = cell_tags.find(tag)
            out[name] = c[c < n_owned]
    return out


def initial_velocity_field(problem, V, cell_tags, groups, scale) -> np.ndarray:
    """Nodal initial velocities (n_local_nodes, 2), owned and ghost nodes, from [initial_velocity].

    Each table gives its value (numbers or expressions of x, y, z; ``scale`` converts the file's unit)
    at the nodes of its regions' cells, or of the whole body without ``regions``. A node covered by
    several tables (on the boundary between two regions) takes the last one's value. The nodes of a
    region are marked on every rank that holds one of its cells and the marks summed on the owners, so
    the result does not depend on the partition (collective)."""
    from dolfinx.cpp.la import ScatterMode
    mesh = V.mesh
    tdim = mesh.topology.dim
    X = V.tabulate_dof_coordinates()
    n = X.shape[0]
    velocity = np.zeros((n, 2))
    marker = fem.Function(fem.FunctionSpace(mesh, ("Lagrange", 1)))
    for name, iv in problem.initial_velocity.items():
        if iv.regions is None:
            on = np.ones(n, dtype=bool)
        else:
            cells = np.concatenate([cell_tags.find(groups[r][1]) for r in iv.regions]).astype(np.int32)
            marker.x.array[:] = 0.0
            marker.x.array[fem.locate_dofs_topological(marker.function_space, tdim, cells)] = 1.0
            marker.x.scatter_reverse(ScatterMode.add)
            marker.x.scatter_forward()
            on = marker.x.array[:n] > 0.0
        for c, value in enumerate(iv.value):
            v = value.evaluate(x=X[on, 0], y=X[on, 1], z=X[on, 2]) if value.depends_on_space else value.evaluate()
            velocity[on, c] = scale * np.asarray(v, dtype=float)
    return velocity


def symmetry_component(V, facet_tags, tag, where):
    """The component normal to a straight symmetry line (0: normal to x, 1: normal to y)."""
    nodes = fem.locate_dofs_topological(V, V.mesh.topology.dim - 1, facet_tags.find(tag))
    X = V.tabulate_dof_coordinates()[nodes, :2]
    comm = V.mesh.comm
    lo = X.min(axis=0) if len(X) else np.full(2, np.inf)
    hi = X.max(axis=0) if len(X) else np.full(2, -np.inf)
    comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)        # buffer form: element-wise on arrays
    comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    span = hi - lo
    scale = max(span.max(), 1e-300)
    if span[0] <= 1e-9 * scale:
        return 0
    if span[1] <= 1e-9 * scale:
        return 1
    raise SceneError(f"{where}: type = 'symmetry' needs a straight group normal to x or y; this one "
                     f"spans {span[0]:.4g} mm in x and {span[1]:.4g} mm in y")


def components_of(b):
    return [COMPONENTS[c] for c in b.components]


def values_of(b, n):
    v = b.value
    return list(v) if isinstance(v, tuple) else [v] * n


def tool_path(path, time_scale=1.0):
    """A tool's translation ``(t, use_ufl) -> (dx, dy)`` from a validated ``path`` table (component ->
    Value of t), or None (fixed). ``time_scale``: seconds per unit of the table's t (explicit: µs)."""
    if not path:
        return None

    def translation(t, use_ufl):
        tt = t * (1.0 / time_scale) if time_scale != 1.0 else t
        out = []
        for c in ("x", "y"):
            val = path.get(c)
            if val is None:
                out.append(ufl.as_ufl(0.0) if use_ufl else 0.0)
            else:
                out.append(val.to_ufl(t=tt) if use_ufl else float(val.evaluate(t=tt)))
        return tuple(out) if use_ufl else np.array(out)
    return translation


def tool_of(name, spec, time_scale=1.0):
    """A :mod:`fenics_plast.tools` tool from a validated [tools.<name>] table."""
    from fenics_plast import tools as T
    path = tool_path(spec.path, time_scale)
    if spec.shape == "plane":
        return T.Plane(spec.point, spec.normal, path=path, name=name)
    if spec.shape == "circle":
        return T.Circle(spec.center, spec.radius, path=path, name=name)
    return T.Profile(spec.segments, body_side=spec.body_side, path=path, name=name)


def open_fields(problem, output, comm, mesh):
    if not problem.output.xdmf:
        return None
    xf = io.XDMFFile(comm, str(output.xdmf_path), "w")
    xf.write_mesh(mesh)
    return xf


def checkpointer(problem, output, comm):
    every = int(problem.output.checkpoint_every)
    resume = bool(getattr(output, "resume", False))
    if not (every > 0 or resume):
        return None
    return Checkpointer(output.out_dir, comm, scene_settings(problem), problem.analysis.type, every=every,
                        resume=resume, output=output)


def write_final_shape(problem, output, V, positions, qmap):
    """final_shape.csv (deformed cells and their mean eqps, and temperature with Johnson-Cook materials)
    when the scene declares a shape plot; collective."""
    if not any(p.type == "shape" for p in problem.plots.values()):
        return
    from fenics_plast.plots import cells_table
    table = cells_table(V, positions, qmap.cell_mean(qmap.eqps, name="eqps"), "eqps")
    if qmap.thermal:
        table["temperature"] = cells_table(V, positions, qmap.cell_mean(qmap.temperature, name="temperature"),
                                           "temperature")["temperature"]
    output.write_csv("final_shape", table)


def draw_plots(problem, output):
    """The scene's [plots] as PNGs (rank 0); a figure that fails is logged and does not fail the run."""
    if not problem.output.plots or not output.is_root or not problem.plots:
        return
    from fenics_plast.plots import draw_declared
    from fenics_plast.quantities import study_keys
    output.close_history()
    try:
        draw_declared(output.out_dir, problem.to_dict(), title=problem.name,
                      references=study_keys(problem.outputs)["references"])
    except Exception as e:  # noqa: BLE001 - plots are a by-product; the results stand
        output.log(f"warning: plots of {output.out_dir} not drawn: {type(e).__name__}: {e}")


def run(problem, output, mesh_data=None) -> dict:
    """CLI entry point: runs the problem, returns the results for summary.json. ``mesh_data``: the
    result of :func:`read_mesh` when the caller has read (and checked) the mesh already."""
    comm = output.comm if output.comm is not None else MPI.COMM_WORLD
    if problem.explicit:
        from fenics_plast.runner_explicit import run_explicit
        return run_explicit(problem, output, comm, mesh_data)
    from fenics_plast.runner_static import run_static
    return run_static(problem, output, comm, mesh_data)


