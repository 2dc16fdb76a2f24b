"""UFL kinematics carrying 3x3 tensors, in 2-D models and in 3-D.

geometry "axisymmetric": x[0] = r, x[1] = z, tensor axes (r, z, theta), hoop gradient w_r / r,
weight 2 pi r (integrals are totals over the full revolution).
geometry "plane_strain": axes (x, y, z), zero out-of-plane gradient, weight 1 (per unit depth).
geometry "3d": axes (x, y, z), the full gradient of a 3-vector field, weight 1.

This module holds the definition of the internal force, ``internal_virtual_work``:
R_u = int (J/theta) tau : (Grad v F^-1) w dV (theta = J for plain Q1). The static solver assembles
it (and its derivative) with dolfinx. The explicit solver's default route is the fused compiled
pass of :mod:`fenics_plast.solvers.fused_force` (kinematics, material update and nodal force in
one numba loop); this UFL residual is the definition that pass is held to
(``tests/test_fused_force.py``: same force, stress and state to 1e-12, same Taylor run to 1e-10)
and the explicit solver's ``internal_force="ufl"`` route assembles it directly.
"""
from __future__ import annotations

import math

import ufl

from fenics_plast.schema import GEOMETRIES, default

QUADRATURE_DEGREE = 2


class Kinematics:
    def __init__(self, mesh, geometry: str = default("mesh.geometry"), degree: int = QUADRATURE_DEGREE):
        if geometry not in GEOMETRIES:
            raise ValueError(f"geometry must be one of {GEOMETRIES}, got {geometry!r}")
        self.mesh = mesh
        self.geometry = geometry
        self.degree = degree
        self.x = ufl.SpatialCoordinate(mesh)
        self.axisymmetric = geometry == "axisymmetric"
        self.three_d = geometry == "3d"
        self.gdim = 3 if self.three_d else 2     # components of the displacement field
        self.weight = 2.0 * math.pi * self.x[0] if self.axisymmetric else 1.0
        self.metadata = {"quadrature_degree": degree, "quadrature_scheme": "default"}
        self.dx = ufl.Measure("dx", domain=mesh, metadata=self.metadata)
        self.I = ufl.Identity(3)

    # -- gradients -------------------------------------------------------------------------
    def grad(self, w):
        """3x3 reference gradient of a displacement-like field (2-vector in 2-D, 3-vector in 3-D)."""
        g = ufl.grad(w)
        if self.three_d:
            return g
        hoop = w[0] / self.x[0] if self.axisymmetric else 0.0
        return ufl.as_matrix([[g[0, 0], g[0, 1], 0.0],
                              [g[1, 0], g[1, 1], 0.0],
                              [0.0, 0.0, hoop]])

    def F(self, u):
        return self.I + self.grad(u)

    def J(self, u):
        return ufl.det(self.F(u))

    def Fbar(self, u, theta=None):
        """F-bar: (theta / J)^(1/3) F; theta=None gives F."""
        F = self.F(u)
        if theta is None:
            return F
        return (theta / ufl.det(F)) ** (1.0 / 3.0) * F

    def Fu(self, u, theta, u_n, theta_n):
        """Incremental deformation gradient Fbar(u, theta) Fbar(u_n, theta_n)^-1 (seed eq. 10).

        Written as ((theta J_n) / (theta_n J))^(1/3) F F_n^-1: one cube root per point instead of
        one per component of each Fbar, which makes the compiled Expression 2-3x cheaper to
        evaluate (150 vs 320-530 us per call on 216 cells).
        """
        F, F_n = self.F(u), self.F(u_n)
        Fu = ufl.dot(F, ufl.inv(F_n))
        if theta is None:
            return Fu
        return ((theta * ufl.det(F_n)) / (theta_n * ufl.det(F))) ** (1.0 / 3.0) * Fu

    # -- weak forms --------------------------------------------------------------------------
    def internal_virtual_work(self, u, theta, tau, v):
        """R_u = int (J/theta) tau : (Grad v F^-1) w dV  (theta None: plain, factor 1)."""
        F = self.F(u)
        gv = ufl.dot(self.grad(v), ufl.inv(F))
        factor = 1.0 if theta is None else ufl.det(F) / theta
        return factor * ufl.inner(tau, gv) * self.weight * self.dx

    def internal_virtual_work_derivative(self, u, theta, tau, a, v, du, dtheta=None):
        """delta R_u along (du, dtheta); a is the spatial tangent, delta tau = a : (dFbar Fbar^-1).

        ``a`` has shape (3,3,3,3) or (9,9) (row 3i+j, column 3k+l; what QuadratureMap stores).
        """
        i, j, k, l_ = ufl.indices(4)
        F = self.F(u)
        Finv = ufl.inv(F)
        gv = ufl.dot(self.grad(v), Finv)
        lu = ufl.dot(self.grad(du), Finv)
        if theta is None:
            lbar = lu
            factor = 1.0
            dfactor = 0.0
        else:
            J = ufl.det(F)
            factor = J / theta
            lbar = lu - (ufl.tr(lu) / 3.0) * self.I + (dtheta / (3.0 * theta)) * self.I
            dfactor = factor * (ufl.tr(lu) - dtheta / theta)
        if ufl.shape(a) == (9, 9):    # tangent stored as a 9x9 matrix a[3i+j, 3k+l]
            lvec = ufl.as_vector([lbar[m // 3, m % 3] for m in range(9)])
            dvec = ufl.dot(a, lvec)
            dtau = ufl.as_matrix([[dvec[3 * r + c] for c in range(3)] for r in range(3)])
        else:
            dtau = ufl.as_tensor(a[i, j, k, l_] * lbar[k, l_], (i, j))
        integrand = (dfactor * ufl.inner(tau, gv) + factor * ufl.inner(dtau, gv)
                     - factor * ufl.inner(tau, ufl.dot(gv, lu)))
        return integrand * self.weight * self.dx

    def dilatation_residual(self, u, theta, q):
        """R_theta = int (theta - J) q w dV."""
        return (theta - ufl.det(self.F(u))) * q * self.weight * self.dx

    def dilatation_residual_derivative(self, u, q, du, dtheta):
        """delta R_theta = int (dtheta - J tr(Grad du F^-1)) q w dV."""
        F = self.F(u)
        lu = ufl.dot(self.grad(du), ufl.inv(F))
        return (dtheta - ufl.det(F) * ufl.tr(lu)) * q * self.weight * self.dx
