"""field: the largest or smallest value of a quadrature-point field over cell regions (or the body):
a written state variable (:mod:`fenics_plast.state_variables`: eqps, temperature [K]) or von_mises
[MPa]."""
from __future__ import annotations

import numpy as np

from fenics_plast.scene_key import REQUIRED, Key
from fenics_plast.state_variables import by_output, outputs

NAME, ORDER = "field", 70
DOC = "field: largest or smallest value of a field over a region (or the body)"
TAKES = ("which", "regions")
KEYS = {
    "field": Key("str", REQUIRED, "eqps: equivalent plastic strain; von_mises: Kirchhoff von Mises "
                 "stress [MPa]; temperature [K] (Johnson-Cook materials; points of other materials "
                 "hold 0).", choices=outputs() + ("von_mises",)),
}


def columns(name, o):
    v = by_output(o.field)
    unit = "MPa" if v is None else v.unit          # None: von_mises
    return [f"{name}_{unit}" if unit else name]


def value(name, o, q, time, row):
    from mpi4py import MPI

    from fenics_plast.quadrature import von_mises
    b, comm = q.body, q.body.comm
    qm = b.qmap
    v = by_output(o.field)
    if v is not None:
        vals = getattr(qm, v.name)
    else:       # the solver's tau is per volume of the mesh's reference: times J_ref, the first mesh's Kirchhoff
        vals = von_mises(qm.tau_values)
        if qm.reference_volume is not None:
            vals = vals * qm.reference_volume
    if o.regions is not None:
        cells = np.concatenate([b.cell_regions[r] for r in o.regions])
        vals = vals.reshape(-1, qm.nq)[cells]
    vals = np.asarray(vals).reshape(-1)
    if o.which == "max":
        return [comm.allreduce(float(vals.max()) if vals.size else -np.inf, op=MPI.MAX)]
    return [comm.allreduce(float(vals.min()) if vals.size else np.inf, op=MPI.MIN)]
