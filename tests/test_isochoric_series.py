"""The isochoric model's series path for full 3-D states (fenics_plast/material/kernels.py).

Without tangent, a trial state bt with a non-zero 02 or 12 component takes ``_isochoric_series``:
ln bt and the exponential map as series in Z = dev(bt) / c, c = tr(bt) / 3, folded by Cayley-Hamilton
(no eigenvectors). The definition is the spectral path (eigen-decomposition of bt), which the update
takes with tangent. Checked here, on random states (random rotations, elastic and plastic, linear,
Swift and Johnson-Cook hardening with rate and heating):

* tau, binv, eqps (and T) of ``update(tangent=False)`` against ``update(tangent=True)`` to round-off:
  tau to 1e-13 |tau| + 1e-15 E, binv to 1e-13 |binv - I| + 2e-15 (either path holds the elastic
  strain to ~1e-16 absolute, in bt - I; the spectral binv is ~1e-15 off the exact one, measured
  with mpmath), eqps and T to 1e-13, up to the largest deviatoric trial strain the series admits
  (J2(Z) just below SERIES_J2_MAX);
* above it (large elastic strains of a hyperelastic body) the series hands back and the update is
  bitwise the spectral one;
* block-diagonal (2-D: plane, axisymmetric) states never take the series: bitwise the spectral path.
"""
from __future__ import annotations

import numpy as np
import pytest

from fenics_plast.material import Hardening, Material
from fenics_plast.material import kernels

E, NU = 117e3, 0.35
OFHC = dict(A=90.0, B=292.0, n=0.31, C=0.025, reference_strain_rate=1.0, m=1.09, melting_temperature=1356.0,
            room_temperature=294.0, specific_heat=383.0, taylor_quinney=0.9, density=8.96e-9)
LAWS = {
    "linear": Hardening("linear", yield_stress=400.0, modulus=100.0),
    "swift": Hardening("swift", K=589.0, eps0=1e-4, n=0.216),
    "johnson_cook": Hardening("johnson_cook", **OFHC),
    "strong": Hardening("linear", yield_stress=1500.0, modulus=1000.0),  # yields only at large elastic strain
    "elastic": None,
}
DT = 1e-7  # [s] the increment's time: Johnson-Cook rate term and heating active


def sym_fun(A, f):
    """f(A) of symmetric matrices A (n,3,3) by eigh."""
    w, V = np.linalg.eigh(A)
    return np.einsum("nij,nj,nkj->nik", V, f(w), V)


def rotations(rng, n, block=False):
    """n random rotations; about the 2-axis only when block (2-D states)."""
    if block:
        a = rng.uniform(0, 2 * np.pi, n)
        R = np.zeros((n, 3, 3))
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a), 1
        return R
    Q, r = np.linalg.qr(rng.standard_normal((n, 3, 3)))
    return Q * np.sign(np.einsum("nii->ni", r))[:, None, :]


def random_states(rng, n, strain, increment, block=False):
    """(Fu, binv_n, eqps_n, T_n): elastic log strain of deviatoric size ~strain (plus a volumetric
    part a third of it) in binv_n = exp(-2 eps), Fu = R (I + increment G), R a random rotation."""
    eps = rng.standard_normal((n, 3, 3)) * strain
    eps = 0.5 * (eps + eps.transpose(0, 2, 1))
    G = rng.standard_normal((n, 3, 3)) * increment
    if block:
        eps[:, 0, 2] = eps[:, 2, 0] = eps[:, 1, 2] = eps[:, 2, 1] = 0.0
        G[:, 0, 2] = G[:, 2, 0] = G[:, 1, 2] = G[:, 2, 1] = 0.0
    binv_n = sym_fun(eps, lambda w: np.exp(-2 * w))
    binv_n = 0.5 * (binv_n + binv_n.transpose(0, 2, 1))
    Fu = rotations(rng, n, block) @ (np.eye(3) + G)
    eqps_n = rng.uniform(0.0, 0.5, n) * (rng.uniform(size=n) < 0.7)
    T_n = rng.uniform(294.0, 700.0, n)
    return Fu, binv_n, eqps_n, T_n


def z_invariant(binv):
    """J2(Z) = tr(Z^2)/2 of Z = dev(b) / c, c = tr(b)/3: the size the series admits up to SERIES_J2_MAX."""
    c = np.einsum("nii->n", binv) / 3
    Z = binv / c[:, None, None] - np.eye(3)
    return 0.5 * np.einsum("nij,nij->n", Z, Z)


def at_j2(rng, n, j2, block=False):
    """Fu = I and binv_n = exp(-2 eps) with J2(Z) = j2 (eps deviatoric, scaled until it holds)."""
    eps = rng.standard_normal((n, 3, 3))
    eps = 0.5 * (eps + eps.transpose(0, 2, 1))
    eps -= np.einsum("nii->n", eps)[:, None, None] * np.eye(3) / 3
    if block:
        eps[:, 0, 2] = eps[:, 2, 0] = eps[:, 1, 2] = eps[:, 2, 1] = 0.0
    eps += 1e-3 * np.eye(3) * rng.standard_normal((n, 1, 1))  # a volumetric part
    dev = eps - np.einsum("nii->n", eps)[:, None, None] * np.eye(3) / 3
    vol = eps - dev
    scale = np.full(n, np.sqrt(j2))
    for _ in range(40):  # J2(Z) ~ scale^2
        b = sym_fun(vol + scale[:, None, None] * dev, lambda w: np.exp(-2 * w))
        scale *= np.sqrt(j2 / z_invariant(b))
    b = 0.5 * (b + b.transpose(0, 2, 1))
    assert np.allclose(z_invariant(b), j2, rtol=1e-6)
    return np.tile(np.eye(3), (n, 1, 1)), b, np.zeros(n), np.full(n, 294.0)


def both_paths(mat, Fu, binv_n, eqps_n, T_n):
    """(tau, binv, eqps, T) without tangent (series where admitted) and with it (the spectral path)."""
    dt = DT if mat.thermal else 0.0
    series = mat.update_thermal(Fu, binv_n, eqps_n, T_n, dt, tangent=False)[:4]
    spectral = mat.update_thermal(Fu, binv_n, eqps_n, T_n, dt, tangent=True)[:4]
    return series, spectral


def round_off(series, spectral):
    """The largest differences of tau, binv, eqps, T between the paths, in units of their bounds:
    1e-13 |tau| + 1e-15 E (bt - I holds the elastic strain to ~1e-16 in either path: below a strain
    of 1e-2 the floor dominates), 1e-13 |binv - I| + 2e-15 (the spectral path's binv is ~1e-15 off the
    exact one, its eigenvectors' round-off; the series' ~4e-16), 1e-13 of eqps + 1 and of T."""
    (t1, b1, e1, T1), (t2, b2, e2, T2) = series, spectral
    bound_tau = 1e-13 * np.linalg.norm(t2, axis=(1, 2)) + 1e-15 * E
    bound_b = 1e-13 * np.linalg.norm(b2 - np.eye(3), axis=(1, 2)) + 2e-15
    return (np.max(np.abs(t1 - t2).max(axis=(1, 2)) / bound_tau), np.max(np.abs(b1 - b2).max(axis=(1, 2)) / bound_b),
            np.max(np.abs(e1 - e2) / (1e-13 * (1.0 + e2))), np.max(np.abs(T1 - T2) / (1e-13 * T2)))


def assert_round_off(series, spectral):
    assert max(round_off(series, spectral)) < 1.0


def admitted(mat, Fu, binv_n, eqps_n, T_n):
    """Per point: does _isochoric_series take it (True) or hand it back to the spectral path?"""
    model, lmbda, mu, law, hp, tol = mat.kernel_args()
    tau, B, e, T = np.empty((1, 3, 3)), np.empty((1, 3, 3)), np.empty(1), np.empty(1)
    out = []
    for q in range(Fu.shape[0]):
        bt = kernels._predictor(Fu, binv_n, q)
        flag = kernels._isochoric_series(*bt, eqps_n[q:q + 1], T_n[q:q + 1], lmbda, mu, law, hp, tol, 0.0,
                                         tau, B, e, T, 0)
        out.append(flag >= 0)
    return np.array(out)


@pytest.mark.parametrize("law", list(LAWS))
@pytest.mark.parametrize("strain, increment", [(1e-4, 1e-4), (1e-3, 1e-3), (3e-3, 2e-3), (6e-3, 5e-3)])
def test_series_is_the_spectral_update(law, strain, increment):
    rng = np.random.default_rng([list(LAWS).index(law), round(strain * 1e5)])
    mat = Material(E, NU, LAWS[law], "isochoric")
    states = random_states(rng, 2000, strain, increment)
    series, spectral = both_paths(mat, *states)
    assert_round_off(series, spectral)
    if law in ("linear", "swift", "johnson_cook") and strain >= 1e-3:
        assert np.mean(spectral[2] > states[2]) > 0.1  # plastic points among them


@pytest.mark.parametrize("law", ["linear", "strong", "johnson_cook", "elastic"])
def test_largest_admitted_elastic_strain(law):
    """Just below SERIES_J2_MAX (rho(Z) up to 0.03, elastic log strains up to 1.5e-2): the series takes
    every point and still meets the spectral path to round-off."""
    rng = np.random.default_rng(7)
    mat = Material(E, NU, LAWS[law], "isochoric")
    states = at_j2(rng, 500, 0.99 * kernels.SERIES_J2_MAX)
    assert admitted(mat, *states).all()
    assert_round_off(*both_paths(mat, *states))


@pytest.mark.parametrize("j2", [1.01 * kernels.SERIES_J2_MAX, 1e-2])
def test_large_elastic_strain_falls_back_to_the_spectral_path(j2):
    rng = np.random.default_rng(8)
    mat = Material(E, NU, None, "isochoric")
    states = at_j2(rng, 300, j2)
    assert not admitted(mat, *states).any()
    series, spectral = both_paths(mat, *states)
    for x, y in zip(series, spectral):
        assert np.array_equal(x, y)


@pytest.mark.parametrize("law", ["linear", "johnson_cook"])
def test_block_diagonal_states_keep_the_spectral_path(law):
    """2-D states (02 = 12 = 0): no series, the result is bitwise that of the spectral path."""
    rng = np.random.default_rng(9)
    mat = Material(E, NU, LAWS[law], "isochoric")
    states = random_states(rng, 2000, 3e-3, 2e-3, block=True)
    series, spectral = both_paths(mat, *states)
    assert np.mean(spectral[2] > states[2]) > 0.3
    for x, y in zip(series, spectral):
        assert np.array_equal(x, y)
