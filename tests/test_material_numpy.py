"""The vectorised numpy reference of the seed model agrees with the numba kernel to round-off (1e-11)."""
import numpy as np
import pytest

from fenics_plast.material import Hardening, Material
from fenics_plast.material.numpy_reference import update_material


def random_state(rng, n, amplitude):
    """Random increments near identity and a previous elastic state b_e^-1 near identity (symmetric)."""
    Fu = np.eye(3) + amplitude * rng.standard_normal((n, 3, 3))
    B = 0.002 * rng.standard_normal((n, 3, 3))
    binv_n = np.eye(3) + B + B.transpose(0, 2, 1)
    eqps_n = np.abs(0.05 * rng.standard_normal(n))
    return Fu, binv_n, eqps_n


def run_both(mat, Fu, binv_n, eqps_n, tangent, chunk):
    n = Fu.shape[0]
    out = []
    for impl in ("numba", "numpy"):
        tau, binv, eqps = np.empty((n, 3, 3)), np.empty((n, 3, 3)), np.empty(n)
        a = np.empty((n, 3, 3, 3, 3)) if tangent else None
        if impl == "numba":
            npl = mat.update_into(Fu, binv_n, eqps_n, tau, binv, eqps, a)
        else:
            npl = update_material(mat, Fu, binv_n, eqps_n, tau, binv, eqps, a, chunk=chunk)
        out.append((npl, tau, binv, eqps, a))
    return out


def close(x, y, rtol=1e-11):
    """Per point: |x - y| <= rtol max|y| (the scale of the point's tensor). The Almansi stress
    tau = lmbda tr(e) I + 2 mu e, e = (I - b)/2 ~ 1e-3, loses ~3 digits to cancellation: two correct
    implementations with different rounding (numpy vs numba with FMA contraction) differ by ~1e-12."""
    n = x.shape[0]
    x, y = x.reshape(n, -1), y.reshape(n, -1)
    scale = np.max(np.abs(y), axis=1, keepdims=True)
    return np.all(np.abs(x - y) <= rtol * scale)


@pytest.mark.parametrize("tangent", [True, False])
@pytest.mark.parametrize("H", [100.0, 0.0])
def test_numpy_reference_matches_numba(tangent, H):
    rng = np.random.default_rng(7)
    mat = Material(117e3, 0.35, Hardening("linear", yield_stress=400.0, modulus=H), "seed")
    n = 5000
    Fu, binv_n, eqps_n = random_state(rng, n, 0.01)
    Fu[::4] = np.eye(3) + 1e-3 * rng.standard_normal((len(Fu[::4]), 3, 3))  # elastic points
    binv_n[::4] = np.eye(3) + 0.1 * (binv_n[::4] - np.eye(3))
    (n1, tau1, b1, e1, a1), (n2, tau2, b2, e2, a2) = run_both(mat, Fu, binv_n, eqps_n, tangent, chunk=1000)
    assert n1 == n2
    assert 0.3 * n < n1 < 0.9 * n  # both elastic and plastic points
    assert close(tau2, tau1) and close(b2, b1)
    assert np.all(np.abs(e2 - e1) <= 1e-12 * np.maximum(np.abs(e1), 1e-3))
    if tangent:
        assert close(a2, a1)


def test_numpy_reference_hyperelastic_and_finite_strain():
    rng = np.random.default_rng(8)
    mat = Material(117e3, 0.35, None, "seed")
    Fu, binv_n, eqps_n = random_state(rng, 777, 0.2)
    Fu[np.linalg.det(Fu) < 0.2] = np.eye(3)
    (n1, tau1, b1, e1, a1), (n2, tau2, b2, e2, a2) = run_both(mat, Fu, binv_n, eqps_n, True, chunk=100)
    assert n1 == n2 == 0
    assert close(tau2, tau1) and close(b2, b1) and close(a2, a1)
    assert np.array_equal(e1, e2)


def test_numpy_reference_rejects_other_models():
    mat = Material(117e3, 0.35, Hardening("swift", K=589.0, eps0=1e-4, n=0.216), "seed")
    z = np.zeros((1, 3, 3))
    with pytest.raises(ValueError):
        update_material(mat, z, z, np.zeros(1), z, z, np.zeros(1))
    with pytest.raises(ValueError):
        update_material(Material(117e3, 0.35, None, "isochoric"), z, z, np.zeros(1), z, z, np.zeros(1))
