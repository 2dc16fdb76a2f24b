r"""The heat the plastic work releases at the quadrature points (issue 37): per point and reference
volume, beta times the plastic work of the step,

    q_p = beta int_{eqps_n}^{eqps_n+1} sigma_y(e) de        [MPa = mJ/mm^3]

(sigma_y the flow stress of the point's hardening law: for J2 flow with the isochoric model's radial
return, tau : d eps_p = sigma_y d eqps, sigma_y Kirchhoff, per reference volume; beta the material's
Taylor-Quinney coefficient). :func:`flow_stress_integral` is the one definition of that integral: the
static energies' dissipation (:meth:`fenics_plast.static_energy.StaticEnergy.plastic_from_state`)
takes it from 0 to eqps, the heat source from the last heat step's eqps to the present one. A law whose
flow stress depends on the temperature and the rate as well (Johnson-Cook: ``hardening.thermal``) has no
such curve: its plastic work over the step is taken by the trapezoidal rule, (tau_eq,n + tau_eq,n+1) / 2
(eqps_n+1 - eqps_n), tau_eq the point's von Mises Kirchhoff stress at the ends of the step (on the yield
surface where it flows; a point that did not flow in the step before starts at the end's stress, as it may
have been below yield at the start): as the static energies take the internal work (measured on demos/hot_upsetting.toml:
the plastic heat within 0.25 % of beta times their dissipation, against 1.2 % with the end value alone).
"""
from __future__ import annotations

import numpy as np

__all__ = ["flow_stress_integral", "PlasticHeat", "GAUSS_POINTS"]

#: ``tau_last`` of a point that did not flow in the last step
NOT_FLOWING = -1.0
#: Gauss-Legendre points of the integral: exact for flow stresses polynomial in eqps up to degree 7
GAUSS_POINTS = 4


def flow_stress_integral(hardening, eqps_from: np.ndarray, eqps_to: np.ndarray) -> np.ndarray:
    """int sigma_y(e) de from ``eqps_from`` to ``eqps_to`` (arrays of points) [MPa = mJ/mm^3] for a strain-only
    ``hardening`` (callable: eqps -> (sigma_y, slope)), by :data:`GAUSS_POINTS`-point Gauss-Legendre."""
    a, b = np.asarray(eqps_from, dtype=float), np.asarray(eqps_to, dtype=float)
    xg, wg = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    out = np.zeros(np.broadcast(a, b).shape)
    for x, w in zip(xg, wg):
        out += 0.5 * w * (b - a) * hardening(a + 0.5 * (x + 1.0) * (b - a))[0]
    return out


class PlasticHeat:
    """The plastic heat of each step at the owned points of a body.

    materials : [(Material, beta)], one per material of the body.
    point_material : (owned points,) int, the index into ``materials`` of each point's material.
    eqps : (owned points,) the eqps at the start (virgin: zeros).

    ``eqps_last`` and ``tau_last`` (owned points,): the eqps and von Mises Kirchhoff stress [MPa] at the last
    step (:data:`NOT_FLOWING` where the point did not flow in it; the restart state).
    """

    def __init__(self, materials, point_material: np.ndarray, eqps: np.ndarray):
        self.materials = list(materials)
        self.point_material = np.asarray(point_material, dtype=np.int64)
        self.eqps_last = np.array(eqps, dtype=float)
        self.tau_last = np.full_like(self.eqps_last, NOT_FLOWING)

    @property
    def needs_stress(self) -> bool:
        """Whether :meth:`step` needs the points' stress (a material of a temperature-dependent law)."""
        return any(m.hardening is not None and m.hardening.thermal for m, _ in self.materials)

    def step(self, eqps: np.ndarray, tau_eq: np.ndarray | None = None) -> np.ndarray:
        """q_p (owned points,) [mJ/mm^3] from the eqps of the last call (or the start) to ``eqps``; remembers
        ``eqps``. ``tau_eq`` (owned points,) [MPa]: the von Mises Kirchhoff stress at the end of the step (for
        the laws of :attr:`needs_stress`). A purely elastic material releases none."""
        eqps = np.asarray(eqps, dtype=float)
        q = np.zeros_like(eqps)
        for i, (material, beta) in enumerate(self.materials):
            h = material.hardening
            if h is None or beta == 0.0:
                continue
            at = self.point_material == i
            if h.thermal:       # (a point that did not flow in the last step starts at the end's stress)
                start = np.where(self.tau_last[at] >= 0.0, self.tau_last[at], tau_eq[at])
                q[at] = beta * 0.5 * (tau_eq[at] + start) * (eqps[at] - self.eqps_last[at])
            else:
                q[at] = beta * flow_stress_integral(h, self.eqps_last[at], eqps[at])
        if tau_eq is not None:
            self.tau_last = np.where(eqps > self.eqps_last, tau_eq, NOT_FLOWING)
        self.eqps_last = eqps.copy()
        return q
