"""Material-point driver: one point through a deformation path, no mesh.

Each function returns a dict of 1-D arrays (one entry per step, step 0 = undeformed), ready
to be written as CSV columns; stresses in MPa.  Used by ``fenics-plast point`` and the tests.

Rate: ``rate=None`` (the default) drives the point without physical time (the static convention
of the kernels: a Johnson-Cook law has no rate term and no heating). ``rate`` > 0 [1/s] gives
each step the time dt = (strain increment) / rate: a constant log-strain rate (uniaxial), shear
rate (shear) or dt = 1 / rate per table row; a Johnson-Cook material then sees its plastic strain
rate and heats adiabatically, and the tables get the columns ``time_s`` and (Johnson-Cook)
``temperature_K``.
"""
from __future__ import annotations

import numpy as np

from ..errors import RunError
from . import Material

_I = np.eye(3)


def _det(A):
    return np.linalg.det(A)


def _plastic_volume_ratio(F, binv):
    """J_p = det F / det F_e = det F * sqrt(det b_e^-1): 1 for plastically incompressible flow."""
    return _det(F) * np.sqrt(_det(binv))


def _check_rate(rate):
    if rate is not None and not (np.isfinite(rate) and rate > 0):
        raise RunError(f"the strain rate must be a positive number [1/s], got {rate}")


def _thermal_columns(material, out: dict, times, temps):
    """Add time_s (when driven in time) and temperature_K (Johnson-Cook) columns."""
    if times is not None:
        out["time_s"] = np.asarray(times, dtype=float)
        if getattr(material, "thermal", False):
            out["temperature_K"] = np.asarray(temps, dtype=float)
    return out


def deformation_table(material: Material, F: np.ndarray, rate: float | None = None) -> dict[str, np.ndarray]:
    """Drive a point through the deformation gradients F (m,3,3), F[0] the first step after F = I.

    Columns: step, J, eqps, plastic_volume_ratio, cauchy_11_MPa ... cauchy_33_MPa (symmetric part);
    with ``rate`` [1/s] each row takes the time 1 / rate (columns time_s, temperature_K: see the
    module docstring).
    """
    _check_rate(rate)
    F = np.asarray(F, dtype=float).reshape(-1, 3, 3)
    dt = 0.0 if rate is None else 1.0 / rate
    binv, eqps, F_old = _I.copy(), 0.0, _I.copy()
    temp = material.initial_temperatures(1)
    rows = [(0, 1.0, 0.0, 1.0, np.zeros((3, 3)))]
    times, temps = [0.0], [temp[0]]
    for k, Fk in enumerate(F, start=1):
        tau, binv, eqps_a, temp, _ = material.update_thermal(Fk @ np.linalg.inv(F_old), binv, [eqps], temp, dt,
                                                             tangent=False)
        binv, eqps, F_old = binv[0], float(eqps_a[0]), Fk
        J = _det(Fk)
        rows.append((k, J, eqps, _plastic_volume_ratio(Fk, binv), tau[0] / J))
        times.append(k * dt)
        temps.append(temp[0])
    out = {"step": np.array([r[0] for r in rows]), "J": np.array([r[1] for r in rows]),
           "eqps": np.array([r[2] for r in rows]), "plastic_volume_ratio": np.array([r[3] for r in rows])}
    for i, j in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]:
        out[f"cauchy_{i + 1}{j + 1}_MPa"] = np.array([r[4][i, j] for r in rows])
    return _thermal_columns(material, out, None if rate is None else times, temps)


def uniaxial_stress(material: Material, log_strain: float, steps: int, tol: float = 1e-12,
                    max_iter: int = 30, rate: float | None = None) -> dict[str, np.ndarray]:
    """Uniaxial stress along axis 0 to the axial logarithmic strain `log_strain` in `steps` equal steps.

    The lateral stretch is found by Newton on tau_11 = tau_22 = 0 with the consistent tangent;
    :class:`fenics_plast.errors.RunError` when it does not converge in ``max_iter`` iterations.
    Columns: log_strain, axial_stretch, lateral_stretch, kirchhoff_axial_MPa, cauchy_axial_MPa,
    eqps, J, plastic_volume_ratio; with ``rate`` [1/s], the constant axial log-strain rate
    |d ln(lambda)/dt| (each step takes dt = |log_strain| / (steps rate)), also time_s and, for a
    Johnson-Cook material, temperature_K.
    """
    _check_rate(rate)
    dt = 0.0 if rate is None else abs(log_strain) / (steps * rate)
    binv, eqps = _I[None].copy(), np.zeros(1)
    temp = material.initial_temperatures(1)
    times, temps = [0.0], [temp[0]]
    lam_a, lam_t = 1.0, 1.0
    scale = max(material.E, 1.0)
    cols = {k: [v] for k, v in dict(log_strain=0.0, axial_stretch=1.0, lateral_stretch=1.0, kirchhoff_axial_MPa=0.0,
                                     cauchy_axial_MPa=0.0, eqps=0.0, J=1.0, plastic_volume_ratio=1.0).items()}
    for k in range(1, steps + 1):
        eps = log_strain * k / steps
        new_a = np.exp(eps)
        new_t = lam_t * (lam_a / new_a) ** 0.5  # incompressible guess
        for _ in range(max_iter):
            Fu = np.diag([new_a / lam_a, new_t / lam_t, new_t / lam_t])[None]
            tau, b_new, e_new, T_new, a = material.update_thermal(Fu, binv, eqps, temp, dt)
            r = tau[0, 1, 1]
            if abs(r) <= tol * scale:
                break
            new_t -= r / ((a[0, 1, 1, 1, 1] + a[0, 1, 1, 2, 2]) / new_t)
        else:
            raise RunError(f"uniaxial_stress: lateral equilibrium not found at step {k} of {steps} (log strain "
                           f"{eps:.4g}, residual {r:.3e} MPa); smaller steps (more of them) may converge")
        lam_a, lam_t, binv, eqps, temp = new_a, new_t, b_new, e_new, T_new
        times.append(k * dt)
        temps.append(temp[0])
        F = np.diag([lam_a, lam_t, lam_t])
        J = lam_a * lam_t ** 2
        for key, v in dict(log_strain=eps, axial_stretch=lam_a, lateral_stretch=lam_t,
                           kirchhoff_axial_MPa=tau[0, 0, 0], cauchy_axial_MPa=tau[0, 0, 0] / J, eqps=eqps[0], J=J,
                           plastic_volume_ratio=_plastic_volume_ratio(F, binv[0])).items():
            cols[key].append(v)
    out = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    return _thermal_columns(material, out, None if rate is None else times, temps)


def simple_shear(material: Material, gamma: float, steps: int, rate: float | None = None) -> dict[str, np.ndarray]:
    """Simple shear F = I + g e_1 (x) e_2 to the amount of shear `gamma` in `steps` equal steps.

    Columns: gamma, shear_stress_MPa (sigma_12), mean_stress_MPa (tr sigma / 3), eqps,
    plastic_volume_ratio, work_MPa (external work per reference volume, trapezoidal, exact
    in the step since the velocity gradient is constant), elastic_energy_MPa,
    dissipation_MPa (work - stored energy); with ``rate`` [1/s] the constant shear rate dg/dt
    (each step dt = |gamma| / (steps rate)), also time_s and (Johnson-Cook) temperature_K.
    """
    _check_rate(rate)
    g = np.linspace(0.0, gamma, steps + 1)
    F = np.repeat(_I[None], steps, axis=0)
    F[:, 0, 1] = g[1:]
    row_rate = None if rate is None else rate * steps / abs(gamma) if gamma != 0 else None
    out = deformation_table(material, F, rate=row_rate)
    shear = out["cauchy_12_MPa"]  # J = 1 in simple shear, so tau_12 = sigma_12
    work = np.concatenate([[0.0], np.cumsum(0.5 * (shear[1:] + shear[:-1]) * np.diff(g))])
    # stored energy: replay the states (cheap) to evaluate psi(b_e^-1)
    binv, eqps, F_old, psi = _I[None].copy(), np.zeros(1), _I, [0.0]
    temp, dt = material.initial_temperatures(1), 0.0 if row_rate is None else 1.0 / row_rate
    for Fk in F:
        _, binv, eqps, temp, _ = material.update_thermal((Fk @ np.linalg.inv(F_old))[None], binv, eqps, temp, dt,
                                                         tangent=False)
        F_old = Fk
        psi.append(material.energy(binv)[0])
    psi = np.asarray(psi)
    mean = (out["cauchy_11_MPa"] + out["cauchy_22_MPa"] + out["cauchy_33_MPa"]) / 3.0
    res = dict(gamma=g, shear_stress_MPa=shear, mean_stress_MPa=mean, eqps=out["eqps"],
               plastic_volume_ratio=out["plastic_volume_ratio"], work_MPa=work, elastic_energy_MPa=psi,
               dissipation_MPa=work - psi)
    res.update({k: out[k] for k in ("time_s", "temperature_K") if k in out})
    return res
