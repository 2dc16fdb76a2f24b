"""The scene's mesh: meshed from its file and checked against what the scene asks of it, before anything
is written (every refusal a SceneError naming the key: exit 2, no file).

:func:`read_mesh` checks the mesh parameters and the mesh's estimated size before meshing
(:func:`check_mesh_parameters`), meshes the file (:func:`fenics_plast.meshing.mesh_from_file`), checks
that every group and region the scene names exists with the right dimension (2-D: regions are
surfaces, groups curves; 3-D: regions are volumes, groups surfaces), that every cell has one material
(:func:`check_material_regions`) and what the scene's values ask of the nodes
(:func:`check_on_mesh`: coordinates finite, r >= 0 in axisymmetry, values of x, y, z finite, symmetry
groups straight, reactions where a condition holds). :func:`symmetry_component`: the component normal
to a symmetry group. Lengths in mm; collective calls.
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.errors import SceneError
from fenics_plast.expressions import ExpressionError
from fenics_plast.meshing import MeshError, mesh_from_file
from fenics_plast.schema import component_index

__all__ = ["read_mesh", "check_mesh_parameters", "check_on_mesh", "check_material_regions", "symmetry_component",
           "MIN_BYTES_PER_CELL", "MAX_PARAMETER"]


def read_mesh(problem, comm, trust_mesh_script=False):
    """Mesh + tags + groups; checks every group and region the scene names (SceneError, exit 2).
    The mesh file is screened first unless ``trust_mesh_script`` (:mod:`fenics_plast.geo_screen`;
    Include and Merge may read the scene file's folder and the package's meshes/). The names are checked
    in the order of :func:`scene_groups` (boundary conditions first); a facet group the scene names that
    shares a facet with another group (mesh.file, both groups and the key named: a facet has one tag), or
    that holds no facet of the body, is refused (issue 34)."""
    m = problem.mesh
    where = f"{problem.path}"
    gdim = 3 if m.geometry == "3d" else 2     # cell regions have dim gdim, facet groups gdim - 1
    check_mesh_parameters(problem, comm, gdim, trust_mesh_script)
    fdim = gdim - 1
    named = scene_groups(problem, gdim)
    used = {}                                   # facet group -> the first key naming it
    for dotted, name, dim in named:
        if dim == fdim:
            used.setdefault(name, dotted)
    try:
        mesh, ct, ft, groups = mesh_from_file(comm, problem.mesh_file, m.parameters, m.refine, gdim=gdim,
                                              trust_script=trust_mesh_script, scene_dir=problem.path.parent,
                                              used_groups=used)
    except MeshError as e:
        raise SceneError(f"{where}: mesh.file: {e}") from None
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
    for dotted, name, dim in named:
        need(dotted, name, dim)
    n_owned = mesh.topology.index_map(fdim).size_local
    counts = np.array([int((ft.find(groups[n][1]) < n_owned).sum()) for n in used], dtype=np.int64)
    counts = comm.allreduce(counts, op=MPI.SUM) if comm.size > 1 else counts
    for (n, dotted), count in zip(used.items(), counts):
        if count == 0:
            raise SceneError(f"{where}: {dotted} = {n!r}: the group has no facet on the body (its elements are no "
                             f"cell's {'edges' if gdim == 2 else 'faces'}): name a group on the body's boundary")
    check_material_regions(problem, ct, groups, mesh)
    check_on_mesh(problem, mesh, ct, ft, groups)
    return mesh, ct, ft, groups


def scene_groups(problem, gdim):
    """[(scene key, group or region name, dimension)] of every group and region the scene names, in the
    order their names are checked: boundary conditions first (a misspelt boundary group is named as
    such), then thermal boundaries, contact, outputs, materials and initial velocities."""
    fdim = gdim - 1
    out = []
    for n, b in problem.boundary.items():
        if b.group is not None:                 # (a wall without group stops every node)
            out.append((f"boundary.{n}.group", b.group, fdim))
    for n, b in problem.thermal_boundary.items():
        out.append((f"thermal_boundary.{n}.group", b.group, fdim))
    for n, c in problem.contact.items():
        out.append((f"contact.{n}.group", c.group, fdim))
        if c.get("master") is not None:
            out.append((f"contact.{n}.master", c.master, fdim))
    for n, o in problem.outputs.items():
        for k in ("group", "opposite"):
            if o.get(k) is not None:
                out.append((f"outputs.{n}.{k}", o.get(k), fdim))
        for r in o.get("regions") or ():
            out.append((f"outputs.{n}.regions", r, gdim))
    for n, mat in problem.materials.items():
        for r in mat.regions or ():
            out.append((f"materials.{n}.regions", r, gdim))
    for n, iv in problem.initial_velocity.items():
        for r in iv.regions or ():
            out.append((f"initial_velocity.{n}.regions", r, gdim))
    return out


#: the memory a run needs at the least per cell [bytes] (2-D, 3-D): half what the cheapest run takes,
#: measured on explicit runs of 2e4 to 3e4 cells (8 kB per quadrilateral, 11 kB per hexahedron; a static
#: run with MUMPS took 20 kB per quadrilateral at 1.5e4 cells, Gmsh's and dolfinx's meshes alone 0.7 and
#: 1.2 kB), so that a refused mesh could not have run
MIN_BYTES_PER_CELL = {2: 4000, 3: 5000}
#: the largest magnitude of a mesh parameter (that is not a cell count) without a Max in its .geo, and of a
#: node coordinate [mm]: 1000 km
MAX_PARAMETER = 1e9
#: the smallest span of the body along any axis [mm]: 1 nm (cell areas and volumes of a thinner body underflow)
MIN_SPAN = 1e-6


def check_mesh_parameters(problem, comm, gdim, trust_mesh_script=False):
    """Before meshing (SceneError, exit 2, collective): every mesh parameter that is not a cell count
    lies within the Min and Max its .geo's DefineConstant gives, or is > 0 where it gives no Min and at
    most :data:`MAX_PARAMETER` where it gives no Max (cell counts: integers >= 1, checked by
    validation); and the mesh the parameters and mesh.refine ask for
    (:func:`fenics_plast.mesh_size.estimate_cells`, on the screened file) fits in the machine's memory at
    :data:`MIN_BYTES_PER_CELL`."""
    from fenics_plast.geo_screen import GeoScreenError, mesh_file_kind, screen
    from fenics_plast.gmsh_child import machine_memory
    from fenics_plast.mesh_size import estimate_cells, estimate_cells_from_sizes, geo_parameters
    from fenics_plast.meshing import refined
    from fenics_plast.schema import is_cell_count
    m, where, path = problem.mesh, problem.path, problem.mesh_file
    opened, kind = mesh_file_kind(path)             # links resolved: Gmsh runs the file screened (issue 34)
    if kind != ".geo" or not opened.is_file():
        return                                      # (mesh_from_file reports what is wrong with the file)
    declared = geo_parameters(opened)
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
    cells, sizes, died = None, None, None
    if comm.rank == 0:
        try:
            if not trust_mesh_script:
                screen(path, problem.path.parent)   # Gmsh reads no file the screen refuses
            cells = estimate_cells(opened, values, gdim)
            sizes = estimate_cells_from_sizes(opened, values, gdim)
        except GeoScreenError:
            cells = None                            # mesh_from_file reports it
        except MeshError as e:                      # Gmsh died in a trial meshing
            died = f"{where}: mesh.file: {e}"
    cells, sizes, died = comm.bcast((cells, sizes, died), root=0) if comm.size > 1 else (cells, sizes, died)
    if died:
        raise SceneError(died)
    memory = machine_memory()
    if sizes is not None and memory is not None and sizes[0] * MIN_BYTES_PER_CELL[gdim] > memory:
        n, what = sizes
        raise SceneError(f"{where}: mesh.file: {path.name} sets {what} mm: about {n:.3g} cells, which need at "
                         f"least {n * MIN_BYTES_PER_CELL[gdim] / 2**30:.3g} GiB of memory "
                         f"({MIN_BYTES_PER_CELL[gdim] / 1e3:g} kB per cell, half what the cheapest run takes); this "
                         f"machine has {memory / 2**30:.3g} GiB: set a larger size in the file")
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
    collective): node coordinates finite, the body at least MIN_SPAN across along each axis and, in
    axisymmetry, every node at r = x >= 0; every value of
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
    spans = [comm.allreduce(float(X[:, i].max()) if len(X) else -np.inf, op=MPI.MAX)
             - comm.allreduce(float(X[:, i].min()) if len(X) else np.inf, op=MPI.MIN) for i in range(gdim)]
    axis = int(np.argmin(spans))
    if spans[axis] < MIN_SPAN:
        name = ("r", "z")[axis] if geometry == "axisymmetric" else "xyz"[axis]
        raise SceneError(f"{where}: {key}: the body spans {spans[axis]:.3g} mm along {name}: lengths are in mm, "
                         f"and a body thinner than {MIN_SPAN:g} mm (1 nm) is refused (its cells' sizes underflow)")
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
    labels = {"3d": "xyz", "plane_strain": "xy"}.get(geometry, "rz")
    for n, b in problem.boundary.items():      # a load on a held component would be ignored
        if b.type not in ("traction", "pressure") or b.group is None:
            continue
        if b.type == "traction":
            held = [component_index(k, geometry) for k in b.components
                    if (b.group, component_index(k, geometry)) in holder]
        else:                                   # a pressure on a straight group: its normal component
            V = V if V is not None else dc.vector_space(mesh)
            c = _straight_normal(V, facet_tags, groups[b.group][1])
            held = [c] if c is not None and (b.group, c) in holder else []
        if held:
            other = holder[(b.group, held[0])]
            raise SceneError(f"{where}: boundary.{n}: component {labels[held[0]]} of group {b.group!r} is held by "
                             f"boundary.{other} (type = {problem.boundary[other].type!r}): a {b.type} there would be "
                             f"ignored (the condition takes it as a reaction): one condition per component of a group")
    for n, o in problem.outputs.items():
        if o.quantity == "reaction" and (o.group, component_index(o.component, geometry)) not in holder:
            raise SceneError(f"{where}: outputs.{n}: group {o.group!r} has no boundary condition on component "
                             f"{o.component}: there is no reaction to record")


def check_material_regions(problem, cell_tags, groups, mesh):
    """Every cell in exactly one material (SceneError naming ``materials.<name>.regions``; collective).

    A single material without ``regions`` fills the mesh. Otherwise a region of the mesh that no
    material lists is refused (its cells would have no material; a region listed twice, validation
    refuses). Each cell of a Gmsh mesh lies in one physical surface, so this is a check on names."""
    mats = problem.materials
    if len(mats) == 1 and next(iter(mats.values())).regions is None:
        return
    owner = {r: n for n, m in mats.items() for r in m.regions or ()}    # (validation refuses a region twice)
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


def group_spans(V, facet_tags, tag):
    """The extent of a facet group's nodes along each axis [mm] (gdim,), over all ranks (collective;
    -inf for an empty group)."""
    gdim = V.mesh.geometry.dim
    nodes = fem.locate_dofs_topological(V, V.mesh.topology.dim - 1, facet_tags.find(tag))
    X = V.tabulate_dof_coordinates()[nodes, :gdim]
    comm = V.mesh.comm
    lo = X.min(axis=0) if len(X) else np.full(gdim, np.inf)
    hi = X.max(axis=0) if len(X) else np.full(gdim, -np.inf)
    comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)        # buffer form: element-wise on arrays
    comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    return hi - lo


def _straight_normal(V, facet_tags, tag):
    """The coordinate constant over the group's nodes (0: x, 1: y, 2: z), or None when none is (the group
    is not straight, or is empty) (collective)."""
    span = group_spans(V, facet_tags, tag)
    if not np.isfinite(span).all():
        return None
    scale = max(span.max(), 1e-300)
    return next((c for c in range(len(span)) if span[c] <= 1e-9 * scale), None)


def symmetry_component(V, facet_tags, tag, where):
    """The component normal to a symmetry group: the coordinate that is constant over its nodes (0: x,
    1: y, 2: z in 3-D). The group must lie in a line (2-D) or plane (3-D) normal to an axis, e.g. x = 0
    or z = 5 (collective; SceneError naming ``where`` otherwise)."""
    c = _straight_normal(V, facet_tags, tag)
    if c is not None:
        return c
    span, gdim = group_spans(V, facet_tags, tag), V.mesh.geometry.dim
    spans = ", ".join(f"{span[c]:.4g} mm in {'xyz'[c]}" for c in range(gdim))
    shape = "a straight group normal to x or y" if gdim == 2 else "a plane group normal to x, y or z"
    raise SceneError(f"{where}: type = 'symmetry' needs {shape}; this one spans {spans}")
