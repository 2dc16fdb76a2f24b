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

Steps 1 and 2 run before the CLI creates the output folder (:func:`read_mesh`, :func:`prepare`): what
they refuse (a mesh parameter out of range, a mesh too large for the memory, a value of x, y, z that
is not finite at a node, a symmetry group that is not straight, a fixed time step above the stable
limit, ...) is a SceneError, exit 2 with the key named and no file written.

Times: static t is the pseudo-time (the load factor of the solver); explicit t is in seconds
inside the package and in µs in scene files, tables and expressions, history.csv (``time_us``).
"""
from __future__ import annotations

import sys

import numpy as np
import ufl
from dolfinx import fem, io
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.checkpoint import Checkpointer, scene_settings
from fenics_plast.material import Hardening, Material, MaterialRegions
from fenics_plast.meshing import MeshError, mesh_from_file
from fenics_plast.errors import SceneError
from fenics_plast.expressions import ExpressionError
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


def read_mesh(problem, comm, trust_mesh_script=False):
    """Mesh + tags + groups; checks every group and region the scene names (SceneError, exit 2).
    The mesh file is screened first unless ``trust_mesh_script`` (:mod:`fenics_plast.geo_screen`;
    Include and Merge may read the scene file's folder and the package's meshes/)."""
    m = problem.mesh
    where = f"{problem.path}"
    gdim = 3 if m.geometry == "3d" else 2     # cell regions have dim gdim, facet groups gdim - 1
    check_mesh_parameters(problem, comm, gdim, trust_mesh_script)
    try:
        mesh, ct, ft, groups = mesh_from_file(comm, problem.mesh_file, m.parameters, m.refine, gdim=gdim,
                                              trust_script=trust_mesh_script, scene_dir=problem.path.parent)
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
    check_on_mesh(problem, mesh, ct, ft, groups)
    return mesh, ct, ft, groups


#: the memory a run needs at the least per cell [bytes] (2-D, 3-D): half what the cheapest run takes,
#: measured on explicit runs of 2e4 to 3e4 cells (8 kB per quadrilateral, 11 kB per hexahedron; a static
#: run with MUMPS took 20 kB per quadrilateral at 1.5e4 cells, Gmsh's and dolfinx's meshes alone 0.7 and
#: 1.2 kB), so that a refused mesh could not have run
MIN_BYTES_PER_CELL = {2: 4000, 3: 5000}
#: the largest magnitude of a mesh parameter (that is not a cell count) without a Max in its .geo, and of a
#: node coordinate [mm]: 1000 km
MAX_PARAMETER = 1e9


def check_mesh_parameters(problem, comm, gdim, trust_mesh_script=False):
    """Before meshing (SceneError, exit 2, collective): every mesh parameter that is not a cell count
    lies within the Min and Max its .geo's DefineConstant gives, or is > 0 where it gives no Min and at
    most :data:`MAX_PARAMETER` where it gives no Max (cell counts: integers >= 1, checked by
    validation); and the mesh the parameters and mesh.refine ask for
    (:func:`fenics_plast.meshing.estimate_cells`, on the screened file) fits in the machine's memory at
    :data:`MIN_BYTES_PER_CELL`."""
    from fenics_plast.geo_screen import GeoScreenError, screen
    from fenics_plast.meshing import estimate_cells, geo_parameters, machine_memory, refined
    from fenics_plast.schema import is_cell_count
    m, where, path = problem.mesh, problem.path, problem.mesh_file
    if path.suffix.lower() != ".geo" or not path.is_file():
        return                                      # (mesh_from_file reports what is wrong with the file)
    declared = geo_parameters(path)
    for k, x in m.parameters.items():
        if is_cell_count(k):
            continue
        d = declared.get(k, {})
        lo, hi = d.get("min"), d.get("max")
        if lo is None and not x > 0:
            raise SceneError(f"{where}: mesh.parameters.{k} = {x:g} is out of range: must be > 0 (a length; "
                             f"{path.name} may allow other values with Min in its DefineConstant)")
        if hi is None and abs(x) > MAX_PARAMETER:       # (Gmsh crashes on coordinates near 1e300)
            raise SceneError(f"{where}: mesh.parameters.{k} = {x:g} is out of range: must be at most "
                             f"{MAX_PARAMETER:g} (mm; {path.name} may allow more with Max in its DefineConstant)")
        if lo is not None and x < lo or hi is not None and x > hi:
            raise SceneError(f"{where}: mesh.parameters.{k} = {x:g} is out of range: {path.name} allows "
                             f"{lo if lo is not None else '-inf'} <= {k} <= {hi if hi is not None else 'inf'} "
                             f"(Min and Max of its DefineConstant)")
    values = refined(m.parameters, m.refine)
    cells = None
    if comm.rank == 0:
        try:
            if not trust_mesh_script:
                screen(path, problem.path.parent)   # Gmsh reads no file the screen refuses
            cells = estimate_cells(path, values, gdim)
        except GeoScreenError:
            cells = None                            # mesh_from_file reports it
    cells = comm.bcast(cells, root=0) if comm.size > 1 else cells
    memory = machine_memory()
    if cells is None or memory is None or cells * MIN_BYTES_PER_CELL[gdim] <= memory:
        return
    counts = ", ".join(f"{k} = {v:g}" for k, v in m.parameters.items() if is_cell_count(k))
    given = (f"mesh.refine = {m.refine} (times mesh.parameters {counts})" if m.refine != 1 else
             f"mesh.parameters: {counts}")
    if np.isfinite(cells):
        need = (f"about {cells:.3g} cells, which need at least {cells * MIN_BYTES_PER_CELL[gdim] / 2**30:.3g} GiB "
                f"of memory ({MIN_BYTES_PER_CELL[gdim] / 1e3:g} kB per cell, half what the cheapest run takes)")
    else:
        need = "more than 1e15 cells, more than any machine's memory holds"
    raise SceneError(f"{where}: {given}: {need}; this machine has {memory / 2**30:.3g} GiB: lower mesh.refine or "
                     f"the cell counts")


def _collective_raise(comm, msg):
    """Raise SceneError(msg) on every rank when any rank has a message (the first rank's)."""
    msgs = comm.allgather(msg) if comm.size > 1 else [msg]
    first = next((m for m in msgs if m), None)
    if first:
        raise SceneError(first)


def check_on_mesh(problem, mesh, cell_tags, facet_tags, groups):
    """What the scene asks of the mesh, checked before anything is written (SceneError naming the key,
    collective): node coordinates finite and, in axisymmetry, every node at r = x >= 0; every value of
    x, y, z (boundary values over their group's nodes, from t = 0 to the end of the analysis;
    initial velocities over their regions' nodes) finite; each symmetry group straight, and its normal
    component held by no other condition of the group; a reaction output on a component its group
    holds."""
    from fenics_plast.expressions import check_times
    from fenics_plast.validation import analysis_end, held_components
    comm, where = mesh.comm, problem.path
    geometry, gdim, tdim = problem.mesh.geometry, mesh.geometry.dim, mesh.topology.dim
    key = "mesh.parameters" if problem.mesh.parameters else "mesh.file"
    X = mesh.geometry.x[:, :gdim]
    msg = None
    if not np.isfinite(X).all() or np.abs(X).max(initial=0.0) > MAX_PARAMETER:
        msg = f"{where}: {key}: the mesh has node coordinates that are not finite or beyond {MAX_PARAMETER:g} mm"
    _collective_raise(comm, msg)
    if geometry == "axisymmetric":
        rmin = comm.allreduce(float(X[:, 0].min()) if len(X) else np.inf, op=MPI.MIN)
        size = comm.allreduce(float(np.abs(X).max()) if len(X) else 0.0, op=MPI.MAX)
        if rmin < -1e-9 * max(size, 1e-300):
            raise SceneError(f"{where}: {key}: with mesh.geometry = 'axisymmetric' x is the radius: every node "
                             f"must lie at x >= 0, and this mesh reaches x = {rmin:.6g} mm")
    V1 = dc.function_space(mesh, "Lagrange", 1)
    Xn = V1.tabulate_dof_coordinates()
    times = check_times(analysis_end(problem.tables))

    def coords(dofs):
        return dict(x=Xn[dofs, 0], y=Xn[dofs, 1], z=Xn[dofs, 2])
    msg = None
    try:
        for n, b in problem.boundary.items():
            val = b.get("value")
            if val is None or b.group is None:
                continue
            dofs = fem.locate_dofs_topological(V1, tdim - 1, facet_tags.find(groups[b.group][1]))
            for v in (val if isinstance(val, tuple) else (val,)):
                if v.depends_on_space and len(dofs):
                    v.check_finite(times, **coords(dofs))
        for n, iv in problem.initial_velocity.items():
            if iv.regions is None:
                dofs = np.arange(Xn.shape[0])
            else:
                cells = np.concatenate([cell_tags.find(groups[r][1]) for r in iv.regions]).astype(np.int32)
                dofs = dc.locate_cell_dofs(V1, cells)
            for v in iv.value:
                if v.depends_on_space and len(dofs):
                    v.check_finite(times[:1], **coords(dofs))
    except ExpressionError as e:
        msg = f"{where}: {e}"
    _collective_raise(comm, msg)
    holder = {}
    for n, b in problem.boundary.items():
        for c in held_components(b, geometry):
            holder[(b.group, c)] = n
    V = None
    for n, b in problem.boundary.items():
        if b.type != "symmetry":
            continue
        V = V if V is not None else dc.vector_space(mesh)
        c = symmetry_component(V, facet_tags, groups[b.group][1], f"{where}: boundary.{n}")
        if (b.group, c) in holder:
            other = holder[(b.group, c)]
            raise SceneError(f"{where}: boundary.{n}: the component normal to symmetry group {b.group!r} "
                             f"({({'3d': 'xyz', 'plane_strain': 'xy'}.get(geometry, 'rz'))[c]}) is also held by "
                             f"boundary.{other} (type = "
                             f"{problem.boundary[other].type!r}): one condition per component of a group")
        holder[(b.group, c)] = n
    for n, o in problem.outputs.items():
        if o.quantity == "reaction" and (o.group, component_index(o.component, geometry)) not in holder:
            raise SceneError(f"{where}: outputs.{n}: group {o.group!r} has no boundary condition on component "
                             f"{o.component}: there is no reaction to record")


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


#: a contact pair whose largest penetration exceeds this fraction of the depth of the cells along its
#: group is reported as not to be trusted (log and summary.json "warnings")
PENETRATION_WARNING = 0.05


def warn(comm, msg: str) -> None:
    """A warning line on stderr (rank 0), whatever the progress display (FENICS_PLAST_PROGRESS=off too)."""
    if comm is None or comm.rank == 0:
        print(f"warning: {msg}", file=sys.stderr, flush=True)


def penetration_report(name, penetration, depth, penalty, default_penalty, comm) -> dict:
    """summary.json entries of contact pair ``name``: its largest penetration [mm] over the depth [mm]
    of the cells along its group (``<name>_penetration_per_cell_depth``) and, above
    PENETRATION_WARNING, a warning (:func:`warn`, and in the list "warnings") naming the penalty used
    and the pair's default one [N/mm^3]."""
    ratio = penetration / depth if depth > 0 else 0.0
    out = {f"{name}_penetration_per_cell_depth": ratio, "warnings": []}
    if ratio > PENETRATION_WARNING:
        if penalty < default_penalty:
            cause = (f"the penalty {penalty:.3g} N/mm^3 is too soft for this load (this pair's default is "
                     f"{default_penalty:.3g} N/mm^3)")
        else:
            cause = (f"the penalty {penalty:.3g} N/mm^3 ({penalty / default_penalty:.3g} times this pair's default) "
                     f"is still too soft for this load: a stiffer one (explicit: a shorter stable step) or finer "
                     f"cells along the group lower it")
        msg = (f"contact.{name}: the largest penetration, {penetration:.3g} mm, is {100 * ratio:.3g} % of the "
               f"depth of the cells along its group ({depth:.3g} mm; more than {100 * PENETRATION_WARNING:g} %): "
               f"{cause}; its forces and the shape near it cannot be trusted to better than that")
        warn(comm, msg)
        out["warnings"].append(msg)
    return out


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


def prepare(problem, comm, mesh_data):
    """The run's set-up from the checked mesh (``mesh_data``: :func:`read_mesh`'s): the solver with its
    conditions, loads, contact pairs and initial state, built before anything is written, so that every
    rule the set-up enforces (a symmetry group that is not straight, a reaction without a condition, a
    wall with the body on both sides, a fixed time step above the stable limit, ...) refuses the scene
    with SceneError (exit 2) and no file. Returns what :func:`run` takes as ``mesh_data``; progress lines
    of the set-up go to stdout (rank 0). Collective."""
    import time
    t0 = time.perf_counter()

    def log(msg):
        if comm.rank == 0:
            print(msg, flush=True)
    try:
        if problem.explicit:
            from fenics_plast.runner_explicit import build_explicit, checked_steps
            built = build_explicit(problem, comm, mesh_data, log=log)
            built.history_rows = checked_steps(problem, built.solver)
        else:
            from fenics_plast.runner_static import build_static
            built = build_static(problem, comm, mesh_data, log=log)
    except ExpressionError as e:
        raise SceneError(f"{problem.path}: {e}") from None
    built.setup_s = time.perf_counter() - t0
    return built


def run(problem, output, mesh_data=None) -> dict:
    """CLI entry point: runs the problem, returns the results for summary.json. ``mesh_data``: the
    result of :func:`read_mesh` when the caller has read (and checked) the mesh already, or of
    :func:`prepare` (the solver built), or the exception :func:`prepare` raised (raised here, where
    the CLI reports a failed run)."""
    if isinstance(mesh_data, BaseException):
        raise mesh_data
    comm = output.comm if output.comm is not None else MPI.COMM_WORLD
    if problem.explicit:
        from fenics_plast.runner_explicit import run_explicit
        return run_explicit(problem, output, comm, mesh_data)
    from fenics_plast.runner_static import run_static
    return run_static(problem, output, comm, mesh_data)


