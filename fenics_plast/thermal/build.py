"""A scene's ``[thermal]``, ``[thermal_boundary.<name>]`` and materials' thermal keys turned into the
heat conduction of a body and its coupling to the mechanical increments (issue 37).

>>> coupling = thermal_coupling(problem, kin, u, qmap, material, facet_tags, groups, duration)
>>> coupling.after_increment(t)     # t: the converged pseudo-time; one heat step over (t - t_last) duration

The coupling is staggered (isothermal split): each converged mechanical increment from t_last to t
is followed by one backward-Euler heat step over the physical time (t - t_last) x
``analysis.duration`` [s], with the increment's deformation, its plastic heat
(:class:`fenics_plast.thermal.plastic_heat.PlasticHeat`), the tool contacts' nodes in contact and
friction heat; then the field at the points sets the next increment's temperature-dependent flow
stress and thermal stretch (:meth:`ThermalCoupling.to_points`). Scene units converted here: density
kg/m^3 (already tonne/mm^3 in the Problem), specific heat J/(kg K) -> mJ/(tonne K) (x 1e6, so that
rho c is in mJ/(mm^3 K)), conductivity W/(m K) = mW/(mm K) (no factor).
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem

from fenics_plast import dolfinx_compat as dc
from fenics_plast.quadrature import von_mises
from fenics_plast.thermal.body_conductance import BodyConductance
from fenics_plast.thermal.boundaries import TYPES
from fenics_plast.thermal.heat import HeatConduction
from fenics_plast.thermal.plastic_heat import PlasticHeat

__all__ = ["ThermalCoupling", "thermal_coupling", "J_PER_KG_K"]

#: specific heat J/(kg K) x this = mJ/(tonne K): rho [tonne/mm^3] c -> mJ/(mm^3 K)
J_PER_KG_K = 1e6


class ThermalCoupling:
    """The heat conduction of a body (``heat``) and what feeds it after each converged increment, over the
    physical time (pseudo-time x ``duration`` [s]): the plastic heat of the increment (``plastic``), and for
    each contact pair with a tool (``contacts``: [(name, pair, friction_heat_fraction, conductance_pressure or
    None)], the pairs of :func:`fenics_plast.runner_static.add_contact`) which nodes touch the tool (the
    conductance's chi: 1, or p / conductance_pressure up to 1) and the share of the friction's dissipation
    that heats the body. ``node_dofs``: the temperature dof of each
    node (block) of the displacement's CG1 space."""

    def __init__(self, heat: HeatConduction, plastic: PlasticHeat, qmap, duration: float, contacts=(),
                 node_dofs=None, expansion=None, bodies=()):
        self.heat, self.plastic, self.qmap = heat, plastic, qmap
        self.duration = float(duration)
        self.contacts, self.node_dofs = list(contacts), node_dofs
        self.bodies = list(bodies)              # BodyConductance of the pairs between two facet groups
        for b in self.bodies:
            heat.exchanged.setdefault(b.name, 0.0)
            heat.exchange_rate.setdefault(b.name, 0.0)
        self.expansion = expansion              # (owned points,) alpha [1/K], or None: no thermal expansion
        self.t_last = 0.0
        self._at_points = None
        #: (owned points,) T at the points after the last heat step [K] (the thermal stretch's reference)
        self.T_points = np.full(qmap.n, heat.T_initial)

    def after_increment(self, t: float) -> None:
        """One heat step from the last converged pseudo-time to ``t`` (collective). Before the contact's
        commit: the friction's dissipation is that since the last commit."""
        tau_eq = von_mises(self.qmap.tau_values) if self.plastic.needs_stress else None
        q = self.plastic.step(self.qmap.eqps, tau_eq)
        friction = np.zeros(self.heat.V.dofmap.index_map.size_local) if self.contacts else None
        for name, pair, fraction, full_pressure in self.contacts:
            nodes = pair.contact_nodes()
            dofs = self.node_dofs[nodes.nodes]
            chi = self.heat.in_contact.get(name)
            if chi is not None:             # 1 in contact, or p / p_c up to 1 with a conductance_pressure
                chi.x.array[:] = 0.0
                chi.x.array[dofs] = ((nodes.g < 0.0).astype(float) if full_pressure is None
                                     else np.minimum(nodes.p / full_pressure, 1.0))
                chi.x.scatter_forward()
            if pair.friction > 0.0:
                np.add.at(friction, dofs, fraction * pair.friction_dissipation())
        links = None
        if self.bodies:
            parts = [b.links() for b in self.bodies]
            links = (np.concatenate([r for r, _ in parts]), np.concatenate([G for _, G in parts]))
        dt = (t - self.t_last) * self.duration
        self.heat.advance(dt, q, friction, links)
        for b in self.bodies:
            exchanged = b.exchanged(dt)
            self.heat.exchanged[b.name] = self.heat.exchanged.get(b.name, 0.0) + exchanged
            self.heat.exchange_rate[b.name] = exchanged / dt if dt > 0.0 else 0.0
        self.t_last = float(t)
        self.to_points()

    def to_points(self, expand: bool = True) -> None:
        """The temperature field at the quadrature points after a heat step, for the next increment (the
        staggered split): the state of a temperature-dependent law (``qmap.thermal``: Johnson-Cook), and, with
        thermal expansion, the increment's thermal stretch theta = 1 + alpha (T - T_0) taken out of F_u
        (``qmap.stretch`` = theta_last / theta_now) and the stress scaled to the first mesh's reference volume
        (``qmap.volume_scale`` = theta^3, tau = J_e J_theta sigma; a remeshed body's reference, a deformed and
        expanded shape, is ``qmap.reference_volume``); ``expand`` False: the mesh's reference is now (a
        remesh), no stretch pending."""
        if not (self.qmap.thermal or self.expansion is not None):
            return
        values = self.points_temperature()
        if self.qmap.thermal:
            self.qmap.temperature[:] = values
            self.qmap.temperature_trial[:] = values
        if self.expansion is not None:
            theta = self.theta(values)
            self.qmap.stretch = self.theta(self.T_points) / theta if expand else None
            self.qmap.volume_scale = theta ** 3
        self.T_points = values

    def theta(self, T: np.ndarray) -> np.ndarray:
        """The thermal stretch 1 + alpha (T - T_0) of the points at temperatures T (owned points,) [K]."""
        return 1.0 + self.expansion * (T - self.heat.T_initial)

    def points_temperature(self) -> np.ndarray:
        """The temperature field at the owned quadrature points now, (owned points,) [K]."""
        if self._at_points is None:
            self._at_points = fem.Expression(self.heat.T, self.qmap.points)
        return dc.eval_expression(self._at_points, self.heat.mesh, self.qmap.cells).reshape(-1)

    def state_dict(self) -> dict:
        """The restart state (collective; :mod:`fenics_plast.checkpoint`): the field and the heats
        (:meth:`HeatConduction.state_dict`), the eqps, von Mises stress and temperature of the last heat step
        and the pending thermal stretch keyed by point, t_last."""
        from fenics_plast.checkpoint import Keyed
        kT, kq = self.keys()
        stretch = np.ones(self.qmap.n) if self.qmap.stretch is None else self.qmap.stretch
        return dict(**self.heat.state_dict(kT), eqps_last=Keyed(self.plastic.eqps_last.copy(), kq),
                    tau_last=Keyed(self.plastic.tau_last.copy(), kq), T_points=Keyed(self.T_points.copy(), kq),
                    stretch=Keyed(stretch.copy(), kq),
                    t_last=self.t_last)

    def load_state(self, d) -> None:
        """Restore :meth:`state_dict` (collective: CheckpointError on every rank for another mesh)."""
        from fenics_plast import checkpoint as ck
        kT, kq = self.keys()
        self.heat.load_state(d, kT)
        why, rows = None, None
        try:
            rows = {k: np.asarray(d[k].take(kq), dtype=float)
                    for k in ("eqps_last", "tau_last", "T_points", "stretch")}
        except ck.CheckpointError as e:
            why = str(e)
        ck.raise_on_any(self.heat.comm, why)
        self.plastic.eqps_last, self.plastic.tau_last = rows["eqps_last"], rows["tau_last"]
        self.T_points = rows["T_points"]
        if self.expansion is not None:
            self.qmap.stretch = rows["stretch"]
            self.qmap.volume_scale = self.theta(self.T_points) ** 3
        self.t_last = float(d["t_last"])

    def keys(self):
        """(dof keys of the temperature space, quadrature-point keys of the owned points): the checkpoint's."""
        from fenics_plast.checkpoint import dof_keys, qp_keys
        mesh = self.heat.mesh
        n_owned = mesh.topology.index_map(mesh.topology.dim).size_local
        return dof_keys(self.heat.V), qp_keys(mesh, n_owned, self.qmap.nq)


def node_dofs(V_nodes, V) -> np.ndarray:
    """The dof of ``V`` (scalar CG1) at each node (block, owned and ghost) of ``V_nodes`` (CG1 on the same
    mesh, e.g. the displacement's), through the cells' dofs: (blocks of V_nodes,) local indices of V."""
    out = np.full(V_nodes.dofmap.index_map.size_local + V_nodes.dofmap.index_map.num_ghosts, -1, dtype=np.int64)
    out[dc.cell_dofs(V_nodes).reshape(-1)] = dc.cell_dofs(V).reshape(-1)
    return out


def thermal_coupling(problem, kin, u, qmap, material, facet_tags, groups, duration, Vc=None, pairs=None
                     ) -> ThermalCoupling:
    """The heat conduction of ``problem``'s body on ``kin``'s mesh, coupled to the mechanical solver's
    displacement ``u`` (UFL) and quadrature state ``qmap``; ``material``: the body's (a Material, or a
    MaterialRegions whose materials are the scene's in its order, :func:`fenics_plast.build.body_material`);
    ``duration`` [s]: the physical time of a unit of the caller's time (static: analysis.duration, of the
    pseudo-time; explicit: 1, its time is in seconds); ``pairs``: the built contact pairs by name, ``Vc`` the
    displacement's CG1 space (their nodes')."""
    mesh = kin.mesh
    n_owned = mesh.topology.index_map(mesh.topology.dim).size_local
    specs = list(problem.materials.values())
    materials = getattr(material, "materials", [material])
    cell_material = getattr(material, "cell_material", np.zeros(n_owned, dtype=np.int64))
    DG0 = dc.function_space(mesh, "DG", 0)
    cells = dc.cell_dofs(DG0).reshape(-1)[:n_owned]
    rho_c, k = fem.Function(DG0, name="rho_c"), fem.Function(DG0, name="conductivity")
    rho_c.x.array[cells] = np.array([m.density * m.specific_heat * J_PER_KG_K for m in specs])[cell_material]
    k.x.array[cells] = np.array([m.conductivity for m in specs])[cell_material]
    rho_c.x.scatter_forward()
    k.x.scatter_forward()
    boundaries = [(n, TYPES[b.type], b, groups[b.group][1]) for n, b in problem.thermal_boundary.items()]
    tool_pairs = {n: c for n, c in problem.contact.items() if c.get("tool") is not None and pairs}
    body_pairs = {n: c for n, c in problem.contact.items()
                  if c.get("master") is not None and c.conductance is not None and pairs}
    contacts = [(n, groups[c.group][1], c.conductance, problem.tools[c.tool].temperature)
                for n, c in tool_pairs.items() if c.conductance is not None]
    heat = HeatConduction(kin, u, rho_c, k, problem.thermal.initial_temperature, boundaries, facet_tags, contacts)
    plastic = PlasticHeat([(m, spec.taylor_quinney) for m, spec in zip(materials, specs)],
                          np.repeat(cell_material, qmap.nq), qmap.eqps)
    coupled = [(n, pairs[n], c.friction_heat_fraction, c.conductance_pressure) for n, c in tool_pairs.items()
               if c.conductance is not None or c.friction > 0.0]
    alpha = np.array([m.expansion or 0.0 for m in specs])
    expansion = np.repeat(alpha[cell_material], qmap.nq) if alpha.any() else None
    nodes = node_dofs(Vc, heat.V) if coupled or body_pairs else None
    bodies = [BodyConductance(n, [pairs[n].forward, pairs[n].backward] if hasattr(pairs[n], "forward") else [pairs[n]],
                              c.conductance, heat, nodes) for n, c in body_pairs.items()]
    return ThermalCoupling(heat, plastic, qmap, duration, coupled, nodes, expansion, bodies)
