"""Helper for tests/test_static.py: a small plastic run (serial or under mpirun).

argv[2] = "bar" (axisymmetric necking bar, constant end displacement) or "ring" (plane-strain
thick cylinder, displacement BC varying along a curved boundary that crosses the partition); both
are scene files built in-process (tests/static_cases.py).
Writes JSON {"reactions": [...], "nodes": {"x,y": [u_x, u_y]}, "load_factors": [...]} to argv[1].
"""
import json
import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent))
from static_cases import necking_bar, solve_ring, top_force  # noqa: E402


def main(path, case):
    comm = MPI.COMM_WORLD
    reactions = []
    if case == "ring":
        out = solve_ring(1.0, 2.0, 4, 8, nu=0.3, yield_stress=200.0, modulus=1000.0, increments=6,
                         max_increment=0.2, min_increment=1e-3, rtol=1e-10, atol=1e-8, comm=comm)
        s = out["solver"]
        reactions = out["history"]["pressure_MPa"]
    else:
        b = necking_bar(4, 12, 3.0, rtol=1e-10, atol=1e-8, comm=comm)
        s = b.solver
        s.run(increments=6, max_increment=0.2, min_increment=1e-3,
              callback=lambda sv: reactions.append(top_force(b)) and False)
    u = s.displacement_function()
    X = u.function_space.tabulate_dof_coordinates()
    n_owned = u.function_space.dofmap.index_map.size_local
    vals = u.x.array.reshape(-1, 2)
    # node keys: coordinates to 1e-6 mm; "+ 0.0" turns a -0.0 into 0.0 (the partitions of dolfinx 0.9
    # give a node on x = 0 the coordinate -0.0 on one rank count and 0.0 on the other)
    key = lambda v: f"{round(float(v), 6) + 0.0:.6f}"    # noqa: E731
    local = {f"{key(X[i, 0])},{key(X[i, 1])}": vals[i].tolist() for i in range(n_owned)}
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
