"""``update`` and ``update_thermal``: the material update into new arrays, for any class with
``update_into`` (:class:`fenics_plast.material.Material`, :class:`fenics_plast.material.MaterialRegions`).

The solvers call ``update_into`` with their own preallocated arrays; these two are for drivers and
tests (the material-point driver, the checks against finite differences and closed forms).
"""
from __future__ import annotations

import numpy as np


class AllocatingUpdates:
    """Mixin: :meth:`update` and :meth:`update_thermal` in terms of ``self.update_into``."""

    def update(self, Fu, binv_n, eqps_n, tangent: bool = True):
        """Return-mapping update from the converged state (binv_n, eqps_n) under the increment Fu.

        Fu : (n,3,3) incremental deformation gradient F_{n+1} F_n^-1.
        binv_n : (n,3,3) elastic Finger tensor b_e^-1 at t_n (identity when virgin).
        eqps_n : (n,) equivalent plastic strain at t_n.
        Returns tau (n,3,3) Kirchhoff stress [MPa], binv (n,3,3), eqps (n,), and the spatial
        consistent tangent a (n,3,3,3,3) [MPa], delta tau_ij = a_ijkl (delta F F^-1)_kl,
        or None when tangent is False. Johnson-Cook: at the initial temperature with no rate term
        and no heating (the static convention; see :meth:`update_thermal`).
        """
        Fu = np.ascontiguousarray(Fu, dtype=float).reshape(-1, 3, 3)
        binv_n = np.ascontiguousarray(binv_n, dtype=float).reshape(-1, 3, 3)
        eqps_n = np.ascontiguousarray(eqps_n, dtype=float).reshape(-1)
        n = Fu.shape[0]
        tau, binv, eqps = np.empty((n, 3, 3)), np.empty((n, 3, 3)), np.empty(n)
        a = np.empty((n, 3, 3, 3, 3)) if tangent else None
        self.update_into(Fu, binv_n, eqps_n, tau, binv, eqps, a)
        return tau, binv, eqps, a

    def update_thermal(self, Fu, binv_n, eqps_n, temp_n, dt: float, tangent: bool = True):
        """:meth:`update` with the temperature state and the increment's time: temp_n (n,) [K] at t_n,
        dt [s] (<= 0: static convention). Returns tau, binv, eqps, temp (n,) [K], a (None if not
        tangent). For a material without temperature state, temp is temp_n (copied)."""
        Fu = np.ascontiguousarray(Fu, dtype=float).reshape(-1, 3, 3)
        binv_n = np.ascontiguousarray(binv_n, dtype=float).reshape(-1, 3, 3)
        eqps_n = np.ascontiguousarray(eqps_n, dtype=float).reshape(-1)
        temp_n = np.ascontiguousarray(temp_n, dtype=float).reshape(-1)
        n = Fu.shape[0]
        tau, binv, eqps, temp = np.empty((n, 3, 3)), np.empty((n, 3, 3)), np.empty(n), temp_n.copy()
        a = np.empty((n, 3, 3, 3, 3)) if tangent else None
        self.update_into(Fu, binv_n, eqps_n, tau, binv, eqps, a, temp_n=temp_n, temp=temp, dt=dt)
        return tau, binv, eqps, temp, a
