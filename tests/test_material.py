"""Material-point verification of the seed model and its isochoric variant (no mesh).

Copper of the Taylor bar (seed, Table 3): E = 117 GPa, nu = 0.35, sigma_y = 400 MPa, H = 100 MPa.
"""
import numpy as np
import pytest

from fenics_plast.material import Hardening, Material
from fenics_plast.material.point import deformation_table, simple_shear, uniaxial_stress

MODELS = ["seed", "isochoric"]
LAWS = [
    Hardening("linear", yield_stress=400.0, modulus=100.0),
    Hardening("linear", yield_stress=400.0, modulus=0.0),  # perfect plasticity
    Hardening("swift", K=589.0, eps0=1e-4, n=0.216),
    Hardening("voce", yield_stress=300.0, Q=200.0, b=10.0, modulus=50.0),
    Hardening("table", strain=[0.0, 0.1, 1.0], stress=[200.0, 300.0, 400.0]),
]


def copper(model, H=100.0):
    return Material(117e3, 0.35, Hardening("linear", yield_stress=400.0, modulus=H), model)


def random_F(rng, n, amplitude):
    return np.eye(3) + amplitude * rng.standard_normal((n, 3, 3))


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def closed_form_kirchhoff(model, F, lmbda, mu):
    """tau = d psi/d e of psi = lmbda/2 (tr e)^2 + mu e:e, by complex step on psi, for strain e(F)."""
    b = F @ F.T
    if model == "seed":
        e = 0.5 * (np.eye(3) - np.linalg.inv(b))  # Almansi
    else:
        w, Q = np.linalg.eigh(b)
        e = Q @ np.diag(0.5 * np.log(w)) @ Q.T  # Hencky

    def psi(e):
        return 0.5 * lmbda * np.trace(e) ** 2 + mu * np.sum(e * e)

    tau = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            de = np.zeros((3, 3), complex)
            de[i, j] = 1e-30j
            tau[i, j] = psi(e + de).imag / 1e-30
    return 0.5 * (tau + tau.T)


@pytest.mark.parametrize("model", MODELS)
def test_elastic_response_is_the_energy_derivative_and_path_independent(model):
    rng = np.random.default_rng(1)
    mat = Material(117e3, 0.35, None, model)
    lmbda, mu = mat.lame
    F = random_F(rng, 8, 0.25)  # general, finite F (stretches ~ 0.5..1.5, rotations)
    F[np.linalg.det(F) < 0.2] = np.eye(3)
    tau, _, eqps, _ = mat.update(F, np.repeat(np.eye(3)[None], 8, 0), np.zeros(8))
    for k in range(8):
        ref = closed_form_kirchhoff(model, F[k], lmbda, mu)
        assert np.linalg.norm(tau[k] - ref) <= 1e-10 * np.linalg.norm(ref)
    # hyperelastic: no rate integration, 20 sub-steps give the same stress
    binv, ep, Fold = np.repeat(np.eye(3)[None], 8, 0), np.zeros(8), np.repeat(np.eye(3)[None], 8, 0)
    for t in np.linspace(0.05, 1.0, 20):
        Ft = np.eye(3) + t * (F - np.eye(3))
        tau_t, binv, ep, _ = mat.update(Ft @ np.linalg.inv(Fold), binv, ep, tangent=False)
        Fold = Ft
    assert np.max(np.abs(tau_t - tau)) <= 1e-10 * np.max(np.abs(tau))
    assert np.all(eqps == 0)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("law", LAWS, ids=lambda h: f"{h.law}{h.params[1] if h.law == 'linear' else ''}")
def test_consistent_tangent_matches_central_differences(model, law):
    rng = np.random.default_rng(2)
    mat = Material(117e3, 0.35, law, model)
    n = 30
    Fu = random_F(rng, n, 0.02)
    binv_n = np.eye(3) + 0.002 * rng.standard_normal((n, 3, 3))
    binv_n = 0.5 * (binv_n + binv_n.transpose(0, 2, 1))
    eqps_n = 0.2 * rng.random(n)
    Fu[:5] = np.eye(3) + 1e-5 * rng.standard_normal((5, 3, 3))  # elastic points
    binv_n[:5] = np.eye(3)
    tau, _, eqps, a = mat.update(Fu, binv_n, eqps_n)
    plastic = eqps > eqps_n
    assert plastic[5:].all() and not plastic[:5].any()
    h = 1e-6
    a_fd = np.zeros_like(a)
    for k in range(3):
        for l in range(3):
            E = np.zeros((3, 3))
            E[k, l] = h
            tp = mat.update((np.eye(3) + E) @ Fu, binv_n, eqps_n, tangent=False)[0]
            tm = mat.update((np.eye(3) - E) @ Fu, binv_n, eqps_n, tangent=False)[0]
            a_fd[..., k, l] = (tp - tm) / (2 * h)
    err = np.linalg.norm((a - a_fd).reshape(n, -1), axis=1) / np.linalg.norm(a.reshape(n, -1), axis=1)
    assert err.max() < 1e-6, err.max()


@pytest.mark.parametrize("model", MODELS)
def test_objectivity_under_superposed_rotation(model):
    rng = np.random.default_rng(3)
    mat = copper(model)
    steps = 12
    t = np.linspace(1, steps, steps) / steps
    G = 0.3 * rng.standard_normal((3, 3))
    F = np.array([np.eye(3) + s * G for s in t])
    R = np.array([rotation([1, 2, 3], 2.0 * s) for s in t])
    base = deformation_table(mat, F)
    rotated = deformation_table(mat, R @ F)
    assert base["eqps"][-1] > 0.05  # plastic path
    np.testing.assert_allclose(rotated["eqps"], base["eqps"], rtol=1e-10, atol=1e-14)

    def sigma(d, k):
        s = np.empty((3, 3))
        for i, j in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]:
            s[i, j] = s[j, i] = d[f"cauchy_{i + 1}{j + 1}_MPa"][k]
        return s

    for k in range(1, steps + 1):
        expected = R[k - 1] @ sigma(base, k) @ R[k - 1].T
        assert np.linalg.norm(sigma(rotated, k) - expected) <= 1e-10 * np.linalg.norm(expected)


def test_uniaxial_isochoric_meets_flow_stress_and_converges_in_increments():
    mat = copper("isochoric")
    coarse, fine = uniaxial_stress(mat, 1.0, 50), uniaxial_stress(mat, 1.0, 5000)
    plastic = coarse["eqps"] > 0
    flow = 400.0 + 100.0 * coarse["eqps"][plastic]
    np.testing.assert_allclose(coarse["kirchhoff_axial_MPa"][plastic], flow, rtol=1e-10)
    rel = abs(coarse["kirchhoff_axial_MPa"][-1] - fine["kirchhoff_axial_MPa"][-1]) / fine["kirchhoff_axial_MPa"][-1]
    print(f"\nisochoric uniaxial, log strain 1: tau(50) = {coarse['kirchhoff_axial_MPa'][-1]:.6f} MPa, "
          f"tau(5000) = {fine['kirchhoff_axial_MPa'][-1]:.6f} MPa, relative difference {rel:.2e}")
    assert rel < 1e-3
    # plastic volume change below 1e-10
    for run in (coarse, fine):
        assert abs(run["plastic_volume_ratio"][-1] - 1.0) < 1e-10


def test_uniaxial_seed_is_first_order_and_not_volume_preserving():
    mat = copper("seed")
    runs = {n: uniaxial_stress(mat, 1.0, n) for n in (50, 500, 5000)}
    print("\nseed model, uniaxial stress to log strain 1 (copper):")
    print(" increments  kirchhoff_axial_MPa  plastic_volume_change  J")
    for n, r in runs.items():
        print(f" {n:10d}  {r['kirchhoff_axial_MPa'][-1]:19.6f}  {r['plastic_volume_ratio'][-1] - 1:21.4e}"
              f"  {r['J'][-1]:.6f}")
    ref = runs[5000]
    e_stress = [abs(runs[n]["kirchhoff_axial_MPa"][-1] - ref["kirchhoff_axial_MPa"][-1]) for n in (50, 500)]
    e_volume = [abs(runs[n]["plastic_volume_ratio"][-1] - ref["plastic_volume_ratio"][-1]) for n in (50, 500)]
    # converges as increments grow, at first order: error(50)/error(500) ~ 10
    assert e_stress[0] > 5 * e_stress[1] and e_volume[0] > 5 * e_volume[1]
    # and is not plastically incompressible: ~1 % dilatation per unit plastic strain
    assert 0.005 < ref["plastic_volume_ratio"][-1] - 1 < 0.02
    # the stress still meets the flow stress at each converged state (radial return is exact)
    np.testing.assert_allclose(ref["kirchhoff_axial_MPa"][-1], 400 + 100 * ref["eqps"][-1], rtol=1e-9)


@pytest.mark.parametrize("model", MODELS)
def test_simple_shear_monotone_dissipative_and_pressure(model):
    mat = copper(model)
    r = simple_shear(mat, 5.0, 5000)
    shear = r["shear_stress_MPa"]
    assert np.all(np.diff(shear) > 0), "shear stress must grow monotonically with linear hardening"
    assert r["dissipation_MPa"].min() >= -1e-6 * r["work_MPa"][-1]
    assert r["dissipation_MPa"][-1] > 0.9 * r["work_MPa"][-1]
    p = r["mean_stress_MPa"][-1]
    print(f"\n{model}: simple shear to gamma = 5: shear stress {shear[-1]:.1f} MPa, mean stress {p:.1f} MPa")
    if model == "isochoric":
        assert abs(p) < 1e-6  # log strain: tr(eps_e) = ln J_e = ln J = 0, no pressure at all
    else:
        assert p < -1000.0  # the seed flow rule is not plastically incompressible: GPa of spurious pressure
