"""A rendering of the deformed 3-D Taylor bar coloured by the equivalent plastic strain.

Runs a 3-D explicit scene (default demos/taylor_bar_3d.toml, a quarter of the bar with two
symmetry planes) in this process, then draws its outer surface at the end of the run, mirrored
across the symmetry planes x = 0 and y = 0 into the whole bar, each face coloured by the mean ε̄p
of its cell: docs/figures/taylor_3d.png. Serial.

    .venv/bin/python scripts/figures/taylor_3d.py [scene.toml] [--set key=value ...] [--figure PNG]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
FIGURE = ROOT / "docs" / "figures" / "taylor_3d.png"


def outer_faces(mesh, positions_of_vertices):
    """The exterior facets' vertex positions (n, 4, 3) [mm], their cells (n,) and reference centroids (n, 3)."""
    from dolfinx import mesh as dmesh

    from fenics_plast import dolfinx_compat as dc
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    facets = dmesh.exterior_facet_indices(mesh.topology)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    cells = np.array([f2c.links(f)[0] for f in facets])
    nodes = dc.entity_nodes(mesh, tdim - 1, facets)                         # (n, 4), tensor-product order
    nodes = nodes[:, [0, 1, 3, 2]]                                          # cyclic, for drawing
    return positions_of_vertices[nodes], cells, mesh.geometry.x[nodes].mean(axis=1)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", nargs="?", default=str(ROOT / "demos" / "taylor_bar_3d.toml"))
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--figure", default=str(FIGURE))
    a = p.parse_args(argv)

    from mpi4py import MPI
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    from fenics_plast.problem import load_problem
    from fenics_plast.runner_explicit import build_explicit

    problem = load_problem(a.scene, a.set)
    built = build_explicit(problem, MPI.COMM_WORLD)
    s = built.solver
    ana = problem.analysis
    stats = s.run(ana.end_time, dt_safety=ana.dt_safety, progress=0, dt_floor=ana.dt_floor,
                  mass_scaling_dt=ana.mass_scaling_dt)
    mesh = s.mesh
    # displacement at the geometry nodes: match the P1 dofs to the geometry nodes by coordinates
    X_dofs = s.V.tabulate_dof_coordinates()
    order_dofs = np.lexsort(np.round(X_dofs, 9).T)
    order_geom = np.lexsort(np.round(mesh.geometry.x, 9).T)
    u_geom = np.empty_like(mesh.geometry.x)
    u_geom[order_geom] = s.u.x.array.reshape(-1, 3)[order_dofs]
    x_geom = mesh.geometry.x + u_geom
    eqps = s.qmap.cell_mean(s.qmap.eqps, name="eqps").x.array
    faces, cells, centroid = outer_faces(mesh, x_geom)
    inner = np.isclose(centroid[:, 0], 0.0) | np.isclose(centroid[:, 1], 0.0)   # symmetry planes
    faces, values = faces[~inner], eqps[cells[~inner]]
    polys, colours = [], []
    for sx in (1, -1):
        for sy in (1, -1):
            polys.append(faces * np.array([sx, sy, 1.0]))
            colours.append(values)
    polys, colours = np.concatenate(polys), np.concatenate(colours)

    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    cmap = plt.get_cmap("viridis")
    norm = matplotlib.colors.Normalize(0.0, float(colours.max()))
    ax.add_collection3d(Poly3DCollection(polys, facecolors=cmap(norm(colours)), edgecolors="k", linewidths=0.15))
    r = float(np.abs(polys[..., :2]).max())
    zmax = float(polys[..., 2].max())
    ax.set_xlim(-r, r)
    ax.set_ylim(-r, r)
    ax.set_zlim(0.0, zmax)
    ax.set_box_aspect((2 * r, 2 * r, zmax))
    ax.view_init(elev=18, azim=-60)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.6, label="equivalent plastic strain")
    ax.set_title(f"{problem.name}: {s.cells_global} hexahedra (a quarter, mirrored), t = {ana.end_time * 1e6:.0f} µs")
    Path(a.figure).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(a.figure, dpi=130, bbox_inches="tight")
    print(f"{a.figure}: {stats['steps']} steps, max eqps {float(eqps.max()):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
