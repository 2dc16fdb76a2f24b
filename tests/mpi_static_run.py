"""Helper for tests/test_static.py: a small plastic run (serial or under mpirun).

argv[2] = "bar" (axisymmetric necking bar, constant end displacement) or "ring" (plane-strain
thick cylinder, displacement BC varying along a curved boundary that crosses the partition).
Writes JSON {"reactions": [...], "nodes": {"x,y": [u_x, u_y]}} to argv[1].
"""
import json
import sys

from mpi4py import MPI

from fenics_plast.material import Hardening, Material
from fenics_plast.scenes.bar_tension import build
from fenics_plast.scenes.thick_cylinder import solve as solve_ring


def main(path, case):
    comm = MPI.COMM_WORLD
    reactions = []
    if case == "ring":
        mat = Material(200e3, 0.3, Hardening("linear", yield_stress=200.0, modulus=1000.0), model="isochoric")
        out = solve_ring(comm, 1.0, 2.0, 4, 8, mat, element="q1p0", increments=6, max_increment=0.2,
                         min_increment=1e-3, solver_options=dict(rtol=1e-10, atol=1e-8), verbose=False)
        s = out["solver"]
        reactions = out["history"]["pressure_MPa"]
    else:
        mat = Material(206.9e3, 0.29, Hardening("voce", yield_stress=450.0, Q=265.0, b=16.93, modulus=129.24),
                       model="isochoric")
        s, info = build(comm, 6.413, 26.667, 4, 12, 0.018, mat, element="q1p0",
                        solver_options=dict(rtol=1e-10, atol=1e-8), verbose=False)
        for bc, g, g0 in s._bcs:
            g0 *= 3.0
        s.run(increments=6, max_increment=0.2, min_increment=1e-3,
              callback=lambda sv: reactions.append(sv.reaction(info["top_dofs"])) and False)
    u = s.displacement_function()
    X = u.function_space.tabulate_dof_coordinates()
    n_owned = u.function_space.dofmap.index_map.size_local
    vals = u.x.array.reshape(-1, 2)
    local = {f"{X[i, 0]:.6f},{X[i, 1]:.6f}": vals[i].tolist() for i in range(n_owned)}
    gathered = comm.gather(local, root=0)
    if comm.rank == 0:
        nodes = {}
        for d in gathered:
            nodes.update(d)
        with open(path, "w") as f:
            json.dump(dict(reactions=reactions, nodes=nodes,
                           load_factors=[r["load_factor"] for r in s.increments]), f)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "bar")
