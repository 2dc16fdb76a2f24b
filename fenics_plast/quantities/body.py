"""What the output quantities read of a running solver: :class:`Body`, filled by the runner from
either solver. Units: mm, N."""
from __future__ import annotations

from dolfinx import fem

from fenics_plast.schema import component_index

__all__ = ["Body"]


class Body:
    """What the quantities need from a solver (filled by the runner).

    * ``V``: the CG1 vector space of the displacement ``u`` (a Function on V, owned + ghosts);
    * ``X``: reference coordinates of V's nodes (n, gdim); ``positions()``: current ones (n, gdim), gdim 2
      or 3 (``geometry``: the scene's mesh.geometry, which names the components);
    * ``qmap``: the :class:`fenics_plast.quadrature.QuadratureMap` (eqps, temperature, tau per owned
      point);
    * ``reaction(dofs)`` [N] for owned V-dof indices of one component (unrolled, V numbering);
    * ``tool_force(tool)`` -> (Fx, Fy[, Fz]) [N]; ``tool_translation(tool, t)`` -> (dx, dy[, dz]) [mm];
      ``contact_force(pair)`` -> (Fx, Fy[, Fz]) [N] of a contact pair's master surface on its group;
      ``contact_nodes(pair)`` -> its owned group nodes' positions, gaps, pressures, areas, indices and slip
      (:class:`fenics_plast.solvers.contact_law.ContactNodes`, the pairs' ``contact_nodes``);
      ``energies()`` -> dict [N mm] (explicit only); ``heat``: the run's
      :class:`fenics_plast.thermal.heat.HeatConduction` (the temperature field, the heat balance) or None;
    * what the automatic quantities read (:data:`fenics_plast.quantities.registry.AUTOMATIC`), each None
      when the run has none: ``mass_scaling`` (``stats()``: the solver's mass-scaling statistics,
      ``target_us``), ``wall_energy()`` [N mm] (rigid walls), ``erosion`` (``stats()``: the solver's
      erosion statistics, ``ratio``, ``cells()``: the eroded cells, (index, reference centre [mm])).
    """

    def __init__(self, comm, V, X, positions, qmap, cell_regions, *, geometry, reaction=None, tool_force=None,
                 energies=None, tool_translation=None, mass_scaling=None, wall_energy=None, erosion=None,
                 contact_force=None, contact_nodes=None, heat=None):
        self.comm, self.V, self.X, self.positions, self.qmap = comm, V, X, positions, qmap
        self.geometry = geometry
        self.cell_regions = cell_regions           # region name -> owned cell indices
        self.reaction, self.tool_force, self.energies = reaction, tool_force, energies
        self.tool_translation, self.contact_force = tool_translation, contact_force
        self.contact_nodes = contact_nodes
        self.heat = heat                           # the HeatConduction of a run with [thermal], else None
        self.mass_scaling, self.wall_energy, self.erosion = mass_scaling, wall_energy, erosion
        self.n_owned_nodes = V.dofmap.index_map.size_local

    def component(self, name: str) -> int:
        """Index of the component ``name`` (x, y, z; r, z in 2-D) in this body's geometry."""
        return component_index(name, self.geometry)

    def group_nodes(self, facet_tags, tag, owned=True):
        nodes = fem.locate_dofs_topological(self.V, self.V.mesh.topology.dim - 1, facet_tags.find(tag))
        return nodes[nodes < self.n_owned_nodes] if owned else nodes
