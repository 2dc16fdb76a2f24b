"""The stable step of one element from its stiffness and its share of the lumped mass: 2 / omega_max.

Shared by the element steps of quadrilaterals (:mod:`fenics_plast.solvers.quad_step`) and of
hexahedra (:mod:`fenics_plast.solvers.hex_step`). Stiffness N/mm, masses tonne, step s.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def element_step(K, mass_c, bs):
    """2 / omega_max [s] of an element of stiffness K (n, n) [N/mm] and nodal masses mass_c (n / bs,)
    [tonne] (bs dofs per node): omega_max^2 the largest eigenvalue of M^-1/2 K M^-1/2 (inf if none is
    positive). K is overwritten. Quadrilaterals
    (:func:`fenics_plast.solvers.quad_step.quad_eig_dt`) and hexahedra
    (:func:`fenics_plast.solvers.hex_step.hex_eig_dt`)."""
    n = K.shape[0]
    for i in range(n):
        for j in range(n):
            K[i, j] /= np.sqrt(mass_c[i // bs] * mass_c[j // bs])
    w2 = np.linalg.eigvalsh(K)[-1]
    return 2.0 / np.sqrt(w2) if w2 > 0.0 else np.inf
