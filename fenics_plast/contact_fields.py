"""Contact results as fields (issue 36): for every contact pair, three CG1 scalar functions on the body's mesh
written with the displacement to fields.xdmf, nonzero on the pair's group nodes only:

* ``contact_pressure_<pair>`` [MPa]: the normal pressure eps <-g> of each node (two passes: each side's nodes
  with their pass's pressures scaled to carry the interface's whole normal force, both sides written);
* ``contact_gap_<pair>`` [mm]: the gap (negative: pressed in; a node with no master facet within reach takes
  the pair's largest gap);
* ``contact_status_<pair>``: 0 apart, 1 stuck, 2 slipping (frictionless: every node in contact slips).

They read each pair's ``contact_nodes()`` (:class:`fenics_plast.solvers.contact_law.ContactNodes`), in either
solver. ``V``: the displacement's CG1 vector space (the static solver's collapsed one, the explicit solver's);
the fields live on its first component's collapsed space, whose dofs map to V's nodes."""
from __future__ import annotations

import numpy as np

__all__ = ["ContactFields"]

QUANTITIES = ("pressure", "gap", "status")


def _sides(pair):
    """The pair's sides as ContactNodes: one, or both passes of a two-pass pair
    (:meth:`~fenics_plast.solvers.body_surface.TwoPassPair.contact_sides`)."""
    sides = getattr(pair, "contact_sides", None)
    return sides() if sides is not None else [pair.contact_nodes()]


class ContactFields:
    """The contact fields of ``pairs`` ({name: pair}) on the mesh of ``V`` (module docstring); :meth:`update`
    then ``functions`` (a list of dolfinx Functions) to write. Collective."""

    def __init__(self, pairs: dict, V):
        from dolfinx import fem
        self.pairs, self.V = pairs, V
        P, to_v = V.sub(0).collapse()
        bs = V.dofmap.index_map_bs
        blocks = np.asarray(to_v, dtype=np.int64) // bs                  # P's dof -> V's node
        imap = V.dofmap.index_map
        self._p_of_node = np.full(imap.size_local + imap.num_ghosts, -1, dtype=np.int64)
        self._p_of_node[blocks] = np.arange(len(blocks))
        self.fields = {name: {k: fem.Function(P, name=f"contact_{k}_{name}") for k in QUANTITIES}
                       for name in pairs}
        self.functions = [f for d in self.fields.values() for f in d.values()]

    def update(self) -> None:
        """Set the fields from the pairs' present state (collective: the pairs' reports are)."""
        for name, pair in self.pairs.items():
            f = self.fields[name]
            for fn in f.values():
                fn.x.array[:] = 0.0
            sides = _sides(pair)
            finite = [c.g[np.isfinite(c.g)] for c in sides]
            largest = max((float(g.max()) for g in finite if g.size), default=0.0)
            largest = self.V.mesh.comm.allreduce(largest, op=_max())
            for c in sides:
                i = self._p_of_node[c.nodes]
                f["pressure"].x.array[i] = c.p
                f["gap"].x.array[i] = np.where(np.isfinite(c.g), c.g, largest)
                f["status"].x.array[i] = np.where(c.g < 0.0, np.where(c.slip, 2.0, 1.0), 0.0)
            for fn in f.values():
                fn.x.scatter_forward()


def _max():
    from mpi4py import MPI
    return MPI.MAX
