"""Material-point driver: one point through a deformation path, no mesh.

Each function returns a dict of 1-D arrays (one entry per step, step 0 = undeformed), ready
to be written as CSV columns; stresses in MPa.  Used by ``fenics-plast point`` and the tests.
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


def deformation_table(material: Material, F: np.ndarray) -> dict[str, np.ndarray]:
    """Drive a point through the deformation gradients F (m,3,3), F[0] the first step after F = I.

    Columns: step, J, eqps, plastic_volume_ratio, cauchy_11_MPa ... cauchy_33_MPa (symmetric part).
    """
    F = np.asarray(F, dtype=float).reshape(-1, 3, 3)
    binv, eqps, F_old = _I.copy(), 0.0, _I.copy()
    rows = [(0, 1.0, 0.0, 1.0, np.zeros((3, 3)))]
    for k, Fk in enumerate(F, start=1):
        tau, binv, eqps_a, _ = material.update(Fk @ np.linalg.inv(F_old), binv, [eqps], tangent=False)
        binv, eqps, F_old = binv[0], float(eqps_a[0]), Fk
        J = _det(Fk)
        rows.append((k, J, eqps, _plastic_volume_ratio(Fk, binv), tau[0] / J))
    out = {"step": np.array([r[0] for r in rows]), "J": np.array([r[1] for r in rows]),
           "eqps": np.array([r[2] for r in rows]), "plastic_volume_ratio": np.array([r[3] for r in rows])}
    for i, j in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]:
        out[f"cauchy_{i + 1}{j + 1}_MPa"] = np.array([r[4][i, j] for r in rows])
    return out


def uniaxial_stress(material: Material, log_strain: float, steps: int, tol: float = 1e-12,
                    max_iter: int = 30) -> dict[str, np.ndarray]:
    """Uniaxial stress along axis 0 to the axial logarithmic strain `log_strain` in `steps` equal steps.

    The lateral stretch is found by Newton on tau_11 = tau_22 = 0 with the consistent tangent;
    :class:`fenics_plast.errors.RunError` when it does not converge in ``max_iter`` iterations.
    Columns: log_strain, axial_stretch, lateral_stretch, kirchhoff_axial_MPa, cauchy_axial_MPa,
    eqps, J, plastic_volume_ratio.
    """
    binv, eqps = _I[None].copy(), np.zeros(1)
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
            tau, b_new, e_new, a = material.update(Fu, binv, eqps)
            r = tau[0, 1, 1]
            if abs(r) <= tol * scale:
                break
            new_t -= r / ((a[0, 1, 1, 1, 1] + a[0, 1, 1, 2, 2]) / new_t)
        else:
            raise RunError(f"uniaxial_stress: lateral equilibrium not found at step {k} of {steps} (log strain "
                           f"{eps:.4g}, residual {r:.3e} MPa); smaller steps (more of them) may converge")
        lam_a, lam_t, binv, eqps = new_a, new_t, b_new, e_new
        F = np.diag([lam_a, lam_t, lam_t])
        J = lam_a * lam_t ** 2
        for key, v in dict(log_strain=eps, axial_stretch=lam_a, lateral_stretch=lam_t,
                           kirchhoff_axial_MPa=tau[0, 0, 0], cauchy_axial_MPa=tau[0, 0, 0] / J, eqps=eqps[0], J=J,
                           plastic_volume_ratio=_plastic_volume_ratio(F, binv[0])).items():
            cols[key].append(v)
    return {k: np.asarray(v, dtype=float) for k, v in cols.items()}


def simple_shear(material: Material, gamma: float, steps: int) -> dict[str, np.ndarray]:
    """Simple shear F = I + g e_1 (x) e_2 to the amount of shear `gamma` in `steps` equal steps.

    Columns: gamma, shear_stress_MPa (sigma_12), mean_stress_MPa (tr sigma / 3), eqps,
    plastic_volume_ratio, work_MPa (external work per reference volume, trapezoidal, exact
    in the step since the velocity gradient is constant), elastic_energy_MPa,
    dissipation_MPa (work - stored energy).
    """
    g = np.linspace(0.0, gamma, steps + 1)
    F = np.repeat(_I[None], steps, axis=0)
    F[:, 0, 1] = g[1:]
    out = deformation_table(material, F)
    shear = out["cauchy_12_MPa"]  # J = 1 in simple shear, so tau_12 = sigma_12
    work = np.concatenate([[0.0], np.cumsum(0.5 * (shear[1:] + shear[:-1]) * np.diff(g))])
    # stored energy: replay the states (cheap) to evaluate psi(b_e^-1)
    binv, eqps, F_old, psi = _I[None].copy(), np.zeros(1), _I, [0.0]
    for Fk in F:
        _, binv, eqps, _ = material.update((Fk @ np.linalg.inv(F_old))[None], binv, eqps, tangent=False)
        F_old = Fk
        psi.append(material.energy(binv)[0])
    psi = np.asarray(psi)
    mean = (out["cauchy_11_MPa"] + out["cauchy_22_MPa"] + out["cauchy_33_MPa"]) / 3.0
    return dict(gamma=g, shear_stress_MPa=shear, mean_stress_MPa=mean, eqps=out["eqps"],
                plastic_volume_ratio=out["plastic_volume_ratio"], work_MPa=work, elastic_energy_MPa=psi,
                dissipation_MPa=work - psi)
