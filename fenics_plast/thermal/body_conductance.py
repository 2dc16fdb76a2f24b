"""Heat conductance between two facet groups of the body in contact (issue 37): a static contact pair with a
``master`` group and a ``conductance`` h [mW/(mm^2 K)].

Each slave node s in contact (g < 0) exchanges q = h (T_m - T_s) per area with its master point, whose
temperature is the master facet's interpolation T_m = sum_a w_a T_a (the contact's own nearest point and
weights, :meth:`fenics_plast.solvers.static_surface_contact.SurfaceContactTerm.conduction_links`); over a
backward-Euler step of dt the heat equation gains, on the dofs (s, a_1 .. a_k),

    dt h A_s c c^T T,   c = (1, -w_1, .., -w_k)

(symmetric, positive semi-definite: what leaves one side enters the other, so the body's heat balance
is unchanged). A pair taken both ways (two passes) gives each pass half of h: each covers the interface.
Nodes with a prescribed temperature take no part (their rows and columns are left out). Parallel: the
slave is an owned node; the master nodes' temperature dofs are global numbers gathered over the surface
(:meth:`fenics_plast.solvers.body_surface.BodySurface.global_rows`).
"""
from __future__ import annotations

import numpy as np
from mpi4py import MPI

__all__ = ["BodyConductance"]


class BodyConductance:
    """The conductance of one pair: ``name``, its ``passes`` (the SurfaceContactTerms: one, or two for a
    two-pass pair), ``h`` [mW/(mm^2 K)] of the interface, the ``heat`` (HeatConduction) and ``node_dofs``
    (the temperature dof of each node of the displacement's CG1 space). Collective construction."""

    def __init__(self, name, passes, h, heat, node_dofs):
        self.name, self.passes, self.heat, self.node_dofs = name, list(passes), heat, node_dofs
        self.h = float(h) / len(self.passes)
        self.imap = heat.V.dofmap.index_map
        self.constrained = heat.constrained_global()
        self.master_local, self.master_dofs = [], []
        for p in self.passes:
            surf = p.surface
            local = self.node_dofs[surf.dofs[:, 0] // surf.dim]        # the T dofs of this rank's surface rows
            self.master_local.append(local)
            glob = self.imap.local_to_global(local.astype(np.int32)).astype(np.int64)
            self.master_dofs.append(surf.global_rows(np.repeat(glob[:, None], surf.dim, axis=1))[:, 0])
        self._last = []

    def links(self):
        """(rows (m, 1 + k) global temperature dofs, -1 where prescribed; G (m, 1 + k, 1 + k) [mW/K]: h A c c^T)
        of every pass's nodes in contact now (collective)."""
        rows_all, G_all, self._last = [], [], []
        for p, mdofs in zip(self.passes, self.master_dofs):
            blocks, area, nodes, w = p.conduction_links()
            slave = self.node_dofs[blocks]
            s = self.imap.local_to_global(slave.astype(np.int32)).astype(np.int64)
            rows = np.concatenate([s[:, None], mdofs[nodes]], axis=1)
            c = np.concatenate([np.ones((len(w), 1)), -w], axis=1)
            rows_all.append(np.where(np.isin(rows, self.constrained), -1, rows))
            G_all.append(self.h * area[:, None, None] * c[:, :, None] * c[:, None, :])
            self._last.append((slave, area, nodes, w))
        return np.concatenate(rows_all), np.concatenate(G_all)

    def exchanged(self, dt: float) -> float:
        """The heat [mJ] that went from the pair's group side into its master side over the last step of dt
        [s], at the step's end temperatures and the contact of :meth:`links` (collective)."""
        T = self.heat.T.x.array
        total = 0.0
        for k, (p, local, (slave, area, nodes, w)) in enumerate(zip(self.passes, self.master_local, self._last)):
            surf = p.surface
            T_vertex = surf.global_rows(np.repeat(T[local][:, None], surf.dim, axis=1))[:, 0]
            into_slave = dt * self.h * float(np.sum(area * ((w * T_vertex[nodes]).sum(axis=1) - T[slave])))
            total += -into_slave if k == 0 else into_slave        # forward's slaves are the group's side
        return self.heat.comm.allreduce(total, op=MPI.SUM)
