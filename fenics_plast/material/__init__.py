"""Constitutive models: the seed (Simo-Ortiz / García Garino) finite-strain J2 model and its
isochoric variant.  Pure array code: no dolfinx, UFL or MPI here.

>>> mat = Material(E=117e3, nu=0.35, hardening=Hardening("linear", yield_stress=400.0, modulus=100.0))
>>> tau, binv, eqps, a = mat.update(Fu, binv_n, eqps_n)        # shapes (n,3,3), (n,3,3), (n,), (n,3,3,3,3)

A Johnson-Cook material (``Hardening("johnson_cook", ...)``, ``mat.thermal``) has a third state
variable, the temperature T [K], and needs the increment's time dt [s] (plastic strain rate,
adiabatic heating): ``mat.update_thermal(Fu, binv_n, eqps_n, T_n, dt)`` returns (tau, binv, eqps, T,
a); ``update`` is the static convention (dt = 0: no rate term, no heating).

The equations live in :mod:`fenics_plast.material.kernels`. Several materials in one body (one per
set of cells): :class:`~fenics_plast.material.regions.MaterialRegions`, same interface.
"""
from __future__ import annotations

import numpy as np

from fenics_plast.schema import default

from . import kernels
from .hardening import Hardening
from .regions import MaterialRegions
from .update_arrays import AllocatingUpdates

__all__ = ["Material", "MaterialRegions", "Hardening", "MODELS"]

MODELS = {"seed": kernels.SEED, "isochoric": kernels.ISOCHORIC}


class Material(AllocatingUpdates):
    """Finite-strain J2 elastoplastic material.

    Parameters
    ----------
    E, nu : Young's modulus [MPa] and Poisson's ratio.
    hardening : :class:`Hardening` or None (None: hyperelastic, no plasticity).
    model : "isochoric" (exponential map on the logarithmic elastic strain, plastically
        incompressible) or "seed" (Almansi strain, additive update of b_e^-1, seed eqs. 9-14); the
        default is the schema's ``materials.<name>.model``.
    yield_tol : relative tolerance on f > 0 that counts as yielding.
    """

    def __init__(self, E: float, nu: float, hardening: Hardening | None = None,
                 model: str = default("materials.*.model"), yield_tol: float = 1e-12):
        if not E > 0:
            raise ValueError(f"E must be > 0, got {E}")
        if not -1.0 < nu < 0.5:
            raise ValueError(f"nu must satisfy -1 < nu < 0.5, got {nu}")
        if model not in MODELS:
            raise ValueError(f"unknown model {model!r}; allowed: {sorted(MODELS)}")
        self.E, self.nu, self.model, self.hardening = float(E), float(nu), model, hardening
        self.yield_tol = float(yield_tol)
        self._model = MODELS[model]
        self._law = hardening.code if hardening is not None else kernels.ELASTIC
        self._hp = hardening.params if hardening is not None else np.zeros(1)
        self._no_tangent = np.zeros((1, 3, 3, 3, 3))
        self._no_temp = np.zeros(1)

    @property
    def thermal(self) -> bool:
        """True when the material has a temperature state (Johnson-Cook hardening)."""
        return self.hardening is not None and self.hardening.thermal

    @property
    def initial_temperature(self) -> float:
        """Temperature of a virgin point [K]; 0 for a material without temperature state."""
        return self.hardening.initial_temperature if self.thermal else 0.0

    def initial_temperatures(self, n: int) -> np.ndarray:
        """(n,) temperatures of n virgin points [K] (0 without temperature state)."""
        return np.full(int(n), self.initial_temperature)

    @property
    def lame(self) -> tuple[float, float]:
        """Lamé constants (lambda, mu) [MPa]."""
        lmbda = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        return lmbda, self.E / (2 * (1 + self.nu))

    def wave_speed(self, density: float) -> float:
        """Dilatational wave speed sqrt((lambda + 2 mu)/rho) [mm/s] for density in tonne/mm^3."""
        lmbda, mu = self.lame
        return float(np.sqrt((lmbda + 2 * mu) / density))

    def kernel_args(self) -> tuple:
        """(model, lmbda, mu, law, hardening params, yield_tol): the trailing arguments of
        :func:`fenics_plast.material.kernels.update_points` after the state arrays, for callers that
        run the update inside their own compiled loop."""
        lmbda, mu = self.lame
        return self._model, lmbda, mu, self._law, self._hp, self.yield_tol

    def update_into(self, Fu, binv_n, eqps_n, tau, binv, eqps, a=None, temp_n=None, temp=None, dt=0.0) -> int:
        """Constitutive update of n points into preallocated arrays (see :meth:`update`).

        temp_n, temp (n,): temperature in and out [K] (Johnson-Cook; ignored otherwise; None: the
        initial temperature in, the result not kept); dt: the increment's time [s] (<= 0: static
        convention, no rate term and no heating). Returns the number of points that yielded.
        """
        model, lmbda, mu, law, hp, tol = self.kernel_args()
        want = a is not None
        if self.thermal:
            n = Fu.shape[0]
            temp_n = self.initial_temperatures(n) if temp_n is None else temp_n
            temp = np.empty(n) if temp is None else temp
        else:
            temp_n = temp = self._no_temp
        return kernels.update_points(model, Fu, binv_n, eqps_n, temp_n, lmbda, mu, law, hp, tol, float(dt), tau,
                                     binv, eqps, temp, a if want else self._no_tangent, want)

    def energy(self, binv) -> np.ndarray:
        """Stored elastic energy per reference volume [MPa = mJ/mm^3], shape (n,)."""
        binv = np.ascontiguousarray(binv, dtype=float).reshape(-1, 3, 3)
        out = np.empty(binv.shape[0])
        lmbda, mu = self.lame
        kernels.energy_points(self._model, binv, lmbda, mu, out)
        return out

    def __repr__(self):
        return f"Material(E={self.E}, nu={self.nu}, model={self.model!r}, hardening={self.hardening!r})"
