"""Rigid unilateral walls of the explicit solver (boundary type "wall").

A wall is a plane normal to a coordinate axis, x_c = position, that a set of nodes (every node, by
default) cannot pass: LS-DYNA's planar rigid wall on a node set, frictionless. The body starts on
one side of it; a node that reaches it stops there and may leave it again. The stop itself is the
compiled :func:`fenics_plast.solvers.integrator.stop_at_walls`, called after each drift by the
step kernels of every route: a dof past its wall is put back on it and its half-step velocity becomes
the one that lands it there. The energy this takes (an inelastic stop: a node that lands stays) is a
term of the energy balance, ``wall_energy``.

Why a wall on every node and not a sliding support on the impact face: on a frictionless support the
centre of the face is a stagnation point, and the node above it (on the axis, not on the support)
can pass through the support's plane as the layer there thins; the wall stops it.

Lengths mm, energies N mm.
"""
from __future__ import annotations

import numpy as np
from mpi4py import MPI


class RigidWalls:
    """The walls of one explicit solver: the owned dofs they stop, each with the displacement at
    which it touches its wall and the side the body is on (see the module doc).

    ``args``: the tuple (dofs, limit, side, lost, pending, hit) of
    :func:`~fenics_plast.solvers.integrator.stop_at_walls`.
    """

    def __init__(self, solver):
        self.s = solver
        self.names = []
        self.args = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0), np.zeros(1), np.zeros(0),
                     np.zeros(0, dtype=np.uint8))

    def add(self, component, position, nodes=None, name=None):
        """A wall x_component = position [mm] stopping ``nodes`` (local node indices, owned or ghost;
        None: every node), except their dofs held by velocity constraints (``solver.fixed``). The side
        is that of the nodes' reference positions (on the plane, to round-off, counts as either side);
        raises ValueError (on every rank) when they lie on both sides. Collective."""
        s = self.s
        name = name or f"wall {len(self.names)}"
        n_nodes = s.n_own // s.bs
        nodes = np.arange(n_nodes) if nodes is None else np.asarray(nodes, dtype=np.int64)
        nodes = nodes[nodes < n_nodes]
        if not 0 <= component < s.bs:
            raise ValueError(f"{name}: component {component} out of range for {s.bs} components")
        X = s.reference_positions
        gap = X[nodes, component] - float(position)
        tol = 1e-9 * max(float(np.ptp(X)) if X.size else 1.0, 1.0)
        lo = s.comm.allreduce(float(gap.min()) if gap.size else np.inf, op=MPI.MIN)
        hi = s.comm.allreduce(float(gap.max()) if gap.size else -np.inf, op=MPI.MAX)
        if lo >= -tol:
            side = 1.0
        elif hi <= tol:
            side = -1.0
        else:
            axis = ("r", "z")[component] if s.kin.axisymmetric else "xyz"[component]
            raise ValueError(f"{name}: the body lies on both sides of the wall at {axis} = "
                             f"{position:g} mm (its nodes span {lo + position:g} to {hi + position:g} mm): "
                             f"a wall must start with the whole body on one side")
        dofs = nodes * s.bs + component
        # a node within round-off of the plane's far side touches it where it is (no jump at the start)
        limit = float(position) - X[nodes, component]
        limit = np.minimum(limit, 0.0) if side > 0 else np.maximum(limit, 0.0)
        keep = ~np.isin(dofs, s.fixed)                  # held dofs (sliding supports) do not move
        dofs, limit = dofs[keep], limit[keep]
        d, lim, sd, lost, _, _ = self.args
        d = np.concatenate([d, dofs]).astype(np.int64)
        self.args = (d, np.concatenate([lim, limit]), np.concatenate([sd, np.full(dofs.size, side)]), lost,
                     np.zeros(d.size), np.zeros(d.size, dtype=np.uint8))
        self.names.append(name)

    @property
    def active(self):
        return bool(self.names)

    def energy(self):
        """Energy the stops have taken so far [N mm], summed over the ranks (collective)."""
        return self.s.allreduce(float(self.args[3][0]), MPI.SUM)

    def restore(self, energy, root):
        """Set the accumulated energy of a checkpoint (the sum goes to rank 0)."""
        self.args[3][0] = float(energy) if root else 0.0
