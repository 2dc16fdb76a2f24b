"""Checkpoints of a remeshed body (issue 35): what a checkpoint holds besides the solver's state once
the body has been meshed anew, and the resumed run's mesh made again from it. Both runners use it
(:mod:`fenics_plast.runner_static`, :mod:`fenics_plast.runner_explicit`); the solvers' own state is
keyed by the new mesh's input nodes and cells, which :func:`~fenics_plast.remeshing.new_mesh.mesh_from_record`
gives back unchanged on as many ranks."""
from __future__ import annotations

import numpy as np

__all__ = ["checkpoint_groups", "resumed_mesh", "restore_u_before"]


def checkpoint_groups(b, remesher, space, **extra) -> tuple[dict, dict]:
    """(the runner's ``remesh`` entry: JSON-able, rank 0's: the current mesh's record, the remesher's
    records and ``extra``; the keyed group ``remesh_state``: the displacement carried from the first mesh
    at the owned nodes of ``space``, the CG1 vector space it lives on)."""
    from fenics_plast.checkpoint import Keyed, dof_keys
    n = space.dofmap.index_map.size_local * space.dofmap.index_map_bs
    entry = dict(record=b.remesh_record, remesher=remesher.state_dict(), **extra)
    return entry, dict(u_before=Keyed(np.asarray(b.u_before)[:n], dof_keys(space)[:n]))


def resumed_mesh(comm, saved, remesher):
    """The mesh of a checkpoint written on a remeshed body (``saved``: the loaded checkpoint), made again,
    and the remesher's records restored; returns (:class:`~fenics_plast.remeshing.new_mesh.Remeshed`, the
    runner's ``remesh`` entry). Collective."""
    from .new_mesh import mesh_from_record
    entry = saved["runner"]["remesh"]
    remesher.load_state(entry["remesher"])
    return mesh_from_record(comm, entry["record"]), entry


def restore_u_before(nb, space, saved, new) -> None:
    """Set the resumed build ``nb`` on the mesh ``new``: its carried displacement (owned and ghost nodes of
    ``space``) from the checkpoint, the outputs' reference (``nb.body.X``), its groups' facets and record."""
    from dolfinx import fem
    from fenics_plast.checkpoint import dof_keys
    from .remesher import carry_displacement
    n = space.dofmap.index_map.size_local * space.dofmap.index_map_bs
    u = fem.Function(space)
    u.x.array[:n] = saved["remesh_state"]["u_before"].take(dof_keys(space)[:n])
    u.x.scatter_forward()
    carry_displacement(nb, u.x.array)
    nb.group_facets, nb.remesh_record = new.group_facets, new.record
