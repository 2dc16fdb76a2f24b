"""Runs a validated :class:`fenics_plast.problem.Problem`: mesh -> forms -> solver -> results.

One runner for every problem; it knows no scene by name. What it does, in order:

1. mesh the scene's Gmsh file (:func:`fenics_plast.meshing.mesh_from_file`) and check that every
   group the scene names exists, with the right dimension (2-D: regions are surfaces, groups curves;
   3-D: regions are volumes, groups surfaces);
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

from fenics_plast import dolfinx_compat as dc
from fenics_plast.checkpoint import Checkpointer, scene_settings
from fenics_plast.material import Hardening, Material, MaterialRegions
from fenics_plast.meshing import MeshError, mesh_from_file
from fenics_plast.errors import SceneError
from fenics_plast.schema import component_index

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
    gdim = 3 if m.geometry == "3d" else 2     # cell regions have dim gdim, facet groups gdim - 1
    try:
        mesh, ct, ft, groups = mesh_from_file(comm, problem.mesh_file, m.parameters, m.refine, gdim=gdim)
    except MeshError as e:
        raise SceneError(f"{where}: mesh.file: {e}") from None
    fdim = gdim - 1
    facets = sorted(n for n, (d, _) in groups.items() if d == fdim)
    regions = sorted(n for n, (d, _) in groups.items() if d == gdim)
    facet_kind = "facet group (Physical Curve)" if gdim == 2 else "facet group (Physical Surface)"
    region_kind = "region (Physical Surface)" if gdim == 2 else "region (Physical Volume)"

    def need(dotted, name, dim):
        if name in groups and groups[name][0] == dim:
            return
        kind, have = (facet_kind, facets) if dim == fdim else (region_kind, regions)
        if name in groups:
            what = {fdim: "facet group", gdim: "region"}.get(groups[name][0], f"group of dimension {groups[name][0]}")
            raise SceneError(f"{where}: {dotted} = {name!r} is not a {kind} of the mesh: it is a {what}")
        raise SceneError(f"{where}: {dotted} = {name!r} is not a {kind} of the mesh: the mesh's "
                         f"{'facet groups' if dim == fdim else 'regions'} are {', '.join(have) or 'none'}")
    for n, b in problem.boundary.items():
        if b.group is not None:                 # (a wall without group stops every node)
            need(f"boundary.{n}.group", b.group, fdim)
    for n, c in problem.contact.items():
        need(f"contact.{n}.group", c.group, fdim)
    for n, o in problem.outputs.items():
        for k in ("group", "opposite"):
            if o.get(k) is not None:
                need(f"outputs.{n}.{k}", o.get(k), fdim)
        for r in o.get("regions") or ():
            need(f"outputs.{n}.regions", r, gdim)
    for n, mat in problem.materials.items():
        for r in mat.regions or ():
            need(f"materials.{n}.regions", r, gdim)
    for n, iv in problem.initial_velocity.items():
        for r in iv.regions or ():
            need(f"initial_velocity.{n}.regions", r, gdim)
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
    tdim = mesh.topology.dim
    unclaimed = sorted(r for r, (d, _) in groups.items() if d == tdim and r not in owner)
    if not unclaimed:
        return
    n_owned = mesh.topology.index_map(tdim).size_local
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
    """{region name: owned cell indices} of the cell regions (groups of the cells' dimension)."""
    out = {}
    for name, (dim, tag) in groups.items():
        if dim == cell_tags.dim:
            c = cell_tags.find(tag)
            out[name] = c[c < n_owned]
    return out


def initial_velocity_field(problem, V, cell_tags, groups, scale) -> np.ndarray:
    """Nodal initial velocities (n_local_nodes, gdim), owned and ghost nodes, from [initial_velocity]
    (gdim: V's block size, 2 or 3).

    Each table gives its value (numbers or expressions of x, y, z; ``scale`` converts the file's unit)
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
            velocity[on, c] = scale * np.asarray(v, dtype=float)
    return velocity


def symmetry_component(V, facet_tags, tag, where):
    """The component normal to a symmetry group: the coordinate that is constant over its nodes (0: x,
    1: y, 2: z in 3-D). The group must lie in a line (2-D) or plane (3-D) normal to an axis, e.g. x = 0
    or z = 5 (collective; SceneError naming ``where`` otherwise)."""
    gdim = V.mesh.geometry.dim
    nodes = fem.locate_dofs_topological(V, V.mesh.topology.dim - 1, facet_tags.find(tag))
    X = V.tabulate_dof_coordinates()[nodes, :gdim]
    comm = V.mesh.comm
    lo = X.min(axis=0) if len(X) else np.full(gdim, np.inf)
    hi = X.max(axis=0) if len(X) else np.full(gdim, -np.inf)
    comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)        # buffer form: element-wise on arrays
    comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    span = hi - lo
    scale = max(span.max(), 1e-300)
    for c in range(gdim):
        if span[c] <= 1e-9 * scale:
            return c
    spans = ", ".join(f"{span[c]:.4g} mm in {'xyz'[c]}" for c in range(gdim))
    shape = "a straight group normal to x or y" if gdim == 2 else "a plane group normal to x, y or z"
    raise SceneError(f"{where}: type = 'symmetry' needs {shape}; this one spans {spans}")


def components_of(b, geometry):
    """Indices of a [boundary] table's components in ``geometry`` (mesh.geometry): "z" is 1 in 2-D but
    2 in 3-D."""
    return [component_index(c, geometry) for c in b.components]


def values_of(b, n):
    v = b.value
    return list(v) if isinstance(v, tuple) else [v] * n


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


def tool_dim(spec) -> int:
    """2 or 3: the space a validated [tools.<name>] table lives in (validation has matched its vectors
    to mesh.geometry: 3-D shapes, 3-vectors, a profile with an axis)."""
    if spec.shape in ("sphere", "cylinder", "torus"):
        return 3
    vec = spec.get("point") if spec.shape == "plane" else spec.get("center")
    return 3 if vec is not None and len(vec) == 3 else 2


def tool_of(name, spec, time_scale=1.0):
    """A :mod:`fenics_plast.tools` tool from a validated [tools.<name>] table (2-D or 3-D, from the
    table itself: see :func:`tool_dim`)."""
    from fenics_plast import tools as T
    path = tool_path(spec.path, time_scale, dim=tool_dim(spec))
    if spec.shape == "plane":
        return T.Plane(spec.point, spec.normal, path=path, name=name)
    if spec.shape == "circle":
        return T.Circle(spec.center, spec.radius, path=path, name=name)
    if spec.shape == "sphere":
        return T.Sphere(spec.center, spec.radius, path=path, name=name)
    if spec.shape == "cylinder":
        return T.Cylinder(spec.center, spec.axis, spec.radius, path=path, name=name)
    if spec.shape == "torus":
        return T.Torus(spec.center, spec.axis, spec.ring_radius, spec.radius, path=path, name=name)
    if spec.center is not None:         # 3-D: revolved about `axis` through `center`
        return T.RevolvedProfile(spec.segments, spec.center, spec.axis, body_side=spec.body_side, path=path,
                                 name=name)
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


