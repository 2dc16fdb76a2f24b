"""temperature: the temperature field of a run with [thermal] [K]: its largest or smallest nodal value, or
its mean over the current body (``statistic``; the volume mean int T dv / int dv, axisymmetric: of the
revolved body). ``Body.heat``: the run's :class:`fenics_plast.thermal.heat.HeatConduction`."""
from __future__ import annotations

NAME, ORDER = "temperature", 72
DOC = "temperature: largest, smallest or mean temperature of the body ([thermal])"
TAKES = ("statistic",)


def columns(name, o):
    return [f"{name}_K"]


def check(d, o, ctx, fail):
    if not ctx["thermal"]:
        fail(f"{d}.quantity = 'temperature' needs a [thermal] table (heat conduction)")


def setup(name, o, q):
    if o.statistic == "mean":
        from dolfinx import fem
        heat = q.body.heat
        q.nodes[name] = (fem.form(heat.T * heat.current_volume * heat.dx), fem.form(heat.current_volume * heat.dx))


def value(name, o, q, time, row):
    import numpy as np
    from dolfinx import fem
    from mpi4py import MPI
    heat, comm = q.body.heat, q.body.comm
    if o.statistic == "mean":
        num, den = (comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM) for f in q.nodes[name])
        return [num / den]
    n = heat.V.dofmap.index_map.size_local
    values = heat.T.x.array[:n]
    if o.statistic == "max":
        return [comm.allreduce(float(values.max()) if n else -np.inf, op=MPI.MAX)]
    return [comm.allreduce(float(values.min()) if n else np.inf, op=MPI.MIN)]
