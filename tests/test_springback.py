"""Springback: elastic unloading after plastic stretching, checked in closed form and on the punch.

**Closed form (tests/scenes/bar_unloading.toml).** A round bar without imperfection, pulled at its
end with the lateral surface free, is in uniform uniaxial stress; Q1/P0 represents the homogeneous
deformation exactly, so every quadrature point is the same material point. For the isochoric
model (Hencky elasticity tau = lam tr(eps_e) I + 2 mu eps_e on the logarithmic elastic strain,
exponential-map return, plastic flow n = 3/2 s/q) in uniaxial Kirchhoff stress tau along z:

* elastic log strains: axial tau/E, lateral -nu tau/E (exactly: the law is linear in log strain);
* plastic log strains: axial eps_p, lateral -eps_p/2 (n = (1, -1/2, -1/2)); the principal axes
  never rotate, so log strains add and backward Euler is exact for any increment size;
* yield: tau = sigma_y(eps_p) = K (eps0 + eps_p)^n (Swift);
* total axial log strain eps = ln(1 + u/L) = eps_p + tau/E, lateral ln(1 + u_r/R) = -eps_p/2 - nu tau/E;
* end force F = tau A0 / lambda_z = pi R^2 tau exp(-eps) (Cauchy tau/J on the current area).

Unloading is elastic (no reverse yielding as long as tau > -sigma_y(eps_p)), so at zero force
the residual axial log strain is eps_p = eps_max - tau_max/E and the lateral one -eps_p/2: the
whole elastic strain, volume change included, is recovered; there is no approximation "for small
elastic strain" in this model.

Tolerances: the FE answer differs from the closed form only by the Newton tolerance (rtol 1e-10
of the force scale: ~1e-11 relative in the force, ~1e-15 in strain) and round-off; measured
errors are 1e-13. The zero-force point of the displacement-controlled run is found by cubic
inverse interpolation of (force, elongation) through the 4 history rows around the sign change
(0.003 mm apart): its error is ~(h/L)^4 ~ 1e-12 relative (linear interpolation would be 6e-7).
Asserted: 1e-9 relative, three orders above what is measured, four below the elastic strain
tau/E = 0.004 that the check is about.

**Punch (demos/springback.toml).** Hemispherical punch stretching to 40 mm (mu = 0.15), then the
punch retracted to its start: the dome height (pole displacement) drops, the punch force goes to
exactly zero (contact lost), and the thickness strain changes by an elastic amount: less than
sigma_y/E at the largest plastic strain of the blank (plane stress at yield: |d ln t| <= 2 nu sigma_y / E;
measured 0.0045 against sigma_y/E = 0.0075).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import scene_runs

ROOT = Path(__file__).resolve().parent.parent
BAR = ROOT / "tests" / "scenes" / "bar_unloading.toml"
SPRINGBACK = ROOT / "demos" / "springback.toml"
PUNCH = ROOT / "demos" / "punch_stretching.toml"

# the material and geometry of bar_unloading.toml (Swift aluminium of the punch scene)
E, NU, K, EPS0, N_SWIFT = 69.0e3, 0.3, 589.0, 1.0e-4, 0.216
LENGTH, RADIUS = 10.0, 5.0
PULL_MM = 0.35            # end displacement at t = 1 (displacement control)
NOMINAL_MPA = 265.0       # end traction at t = 1 (force control)
RTOL = 1e-9


def run_scene(scene, out, *sets):
    return scene_runs.run_scene(scene, out, *sets), scene_runs.history(out)


def sigma_y(eps_p):
    return K * (EPS0 + eps_p) ** N_SWIFT


def bisect(g, lo, hi):
    """The root of an increasing g on [lo, hi] to round-off."""
    assert g(lo) < 0 < g(hi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        lo, hi = (mid, hi) if g(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


def plastic_strain_at_strain(eps):
    """eps_p with eps_p + sigma_y(eps_p)/E = eps (total axial log strain eps, uniaxial stress)."""
    return bisect(lambda ep: ep + sigma_y(ep) / E - eps, 0.0, eps)


def plastic_strain_at_nominal_stress(p):
    """eps_p with sigma_y(eps_p) = p exp(eps_p + sigma_y/E) (tau = P lambda_z; stable while H > tau)."""
    return bisect(lambda ep: sigma_y(ep) - p * math.exp(ep + sigma_y(ep) / E), 0.0, 0.2)


def row_at(history, t):
    i = int(np.argmin(abs(history["time"] - t)))
    assert abs(history["time"][i] - t) < 1e-12
    return history[i]


def check_loaded_state(row, eps_p):
    """The state at the end of loading against the closed form (eps_p: plastic strain reached)."""
    tau = sigma_y(eps_p)
    eps = eps_p + tau / E
    assert row["eqps"] == pytest.approx(eps_p, rel=RTOL)
    assert math.log(1 + row["elongation_mm"] / LENGTH) == pytest.approx(eps, rel=RTOL)
    assert math.log(1 + row["radius_change_mm"] / RADIUS) == pytest.approx(-eps_p / 2 - NU * tau / E, rel=RTOL)
    # the reaction at the symmetry plane is minus the force on the end
    assert -row["force_N"] == pytest.approx(math.pi * RADIUS ** 2 * tau * math.exp(-eps), rel=RTOL)


def test_bar_unloading_displacement_control(tmp_path):
    """Pulled to 0.35 mm, pushed back past zero force: the residual strain is eps_max - tau_max/E."""
    summary, h = run_scene(BAR, tmp_path / "bar")
    assert summary["converged"] and summary["final_time"] == 2.0
    eps_max = math.log(1 + PULL_MM / LENGTH)
    eps_p = plastic_strain_at_strain(eps_max)
    assert 0.02 < eps_p < 0.05                                   # a few percent of plastic strain
    check_loaded_state(row_at(h, 1.0), eps_p)
    unload = h[h["time"] > 1.0 + 1e-12]
    # elastic unloading: no further plastic strain, and no reverse yielding at the end (-124 MPa)
    assert np.all(unload["eqps"] == row_at(h, 1.0)["eqps"])
    assert unload["force_N"][0] < 0 < unload["force_N"][-1]      # tension -> compression
    k = int(np.nonzero(np.diff(np.sign(unload["force_N"])))[0][0])
    assert 1 <= k <= len(unload) - 3
    near = slice(k - 1, k + 3)                                    # 2 rows either side of F = 0

    def at_zero_force(col):
        return float(np.polyval(np.polyfit(unload["force_N"][near], unload[col][near], 3), 0.0))

    residual = math.log(1 + at_zero_force("elongation_mm") / LENGTH)
    tau_max = sigma_y(eps_p)
    assert residual == pytest.approx(eps_max - tau_max / E, rel=RTOL)
    assert residual == pytest.approx(eps_p, rel=RTOL)
    assert math.log(1 + at_zero_force("radius_change_mm") / RADIUS) == pytest.approx(-eps_p / 2, rel=RTOL)
    # the springback itself: the elastic strain tau_max/E recovered, to RTOL of the total strain
    assert eps_max - residual == pytest.approx(tau_max / E, abs=RTOL * eps_max)


def test_bar_unloading_force_control(tmp_path):
    """The same bar under a dead end traction 0 -> 265 MPa -> 0: at t = 2 the end is exactly
    traction-free and the residual length is read directly (no interpolation)."""
    summary, h = run_scene(BAR, tmp_path / "bar", 'boundary.pull.type="traction"',
                           f"boundary.pull.value={{ t = [0.0, 1.0, 2.0], value = [0.0, {NOMINAL_MPA}, 0.0] }}")
    assert summary["converged"]
    eps_p = plastic_strain_at_nominal_stress(NOMINAL_MPA)
    assert 0.02 < eps_p < 0.05
    loaded = row_at(h, 1.0)
    check_loaded_state(loaded, eps_p)
    assert -loaded["force_N"] == pytest.approx(math.pi * RADIUS ** 2 * NOMINAL_MPA, rel=RTOL)
    end = row_at(h, 2.0)
    assert abs(end["force_N"]) < RTOL * abs(loaded["force_N"])
    assert end["eqps"] == loaded["eqps"]
    assert math.log(1 + end["elongation_mm"] / LENGTH) == pytest.approx(eps_p, rel=RTOL)
    assert math.log(1 + end["radius_change_mm"] / RADIUS) == pytest.approx(-eps_p / 2, rel=RTOL)


def thickness_profiles(out):
    th = np.genfromtxt(Path(out) / "thickness_strain.csv", delimiter=",", names=True)
    return {float(t): th[th["time"] == t] for t in np.unique(th["time"])}


def check_springback(summary, h, profiles):
    """What every springback run must show (coarse or full)."""
    assert summary["converged"] and summary["final_time"] == 2.0
    loaded, end = row_at(h, 1.0), row_at(h, 2.0)
    assert loaded["punch_displacement_mm"] == pytest.approx(40.0)
    assert end["punch_displacement_mm"] == pytest.approx(0.0, abs=1e-9)
    # the dome height drops on unloading by a positive amount, small against the height
    springback = loaded["dome_height_mm"] - end["dome_height_mm"]
    assert 0.2 < springback < 2.0, springback
    assert np.all(np.diff(h["dome_height_mm"][h["time"] >= 1.0]) <= 1e-9)   # never rises again
    # contact lost: no force from punch or die at the end (penalty: exactly zero once the gap opens)
    assert loaded["punch_force_kN"] > 60.0
    assert end["punch_force_kN"] == 0.0 and end["die_force_kN"] == 0.0
    # unloading is elastic: the largest plastic strain does not change
    assert end["max_eqps"] == pytest.approx(loaded["max_eqps"], rel=1e-9)
    # thickness: the elastic recovery is positive at the pole (biaxial tension released) and
    # nowhere larger than sigma_y/E at the blank's largest plastic strain
    before, after = profiles[1.0], profiles[2.0]
    assert np.array_equal(before["s0_mm"], after["s0_mm"])
    change = after["value"] - before["value"]
    bound = sigma_y(loaded["max_eqps"]) / E
    assert 0.0 < change[0] < bound
    assert np.abs(change).max() < bound
    return springback, change


def test_springback_coarse(tmp_path):
    """The punch scene on 30 x 2 cells with fewer increments: the first retraction increment cuts
    back a few times (the loaded state released from the punch in Newton's first iterate) and goes on."""
    out = tmp_path / "springback"
    summary, h = run_scene(SPRINGBACK, out, "mesh.parameters.cells_radial=30", "steps.to_20mm.increments=10",
                           "steps.to_40mm.increments=10", "steps.release.increments=5",
                           "steps.unload.increments=1", "steps.unload.max_increment=1.0", "output.xdmf=false",
                           "output.plots=false")
    check_springback(summary, h, thickness_profiles(out))


@pytest.mark.slow
def test_springback_full(tmp_path):
    """The shipped scene: its loading reproduces the punch scene with mu = 0.15 (the retraction
    leg of the punch path changes nothing before t = 1) and the springback is as in docs/guide/results.md."""
    out = tmp_path / "springback"
    summary, h = run_scene(SPRINGBACK, out)
    springback, change = check_springback(summary, h, thickness_profiles(out))
    punch, _ = run_scene(PUNCH, tmp_path / "punch", "contact.punch.friction=0.15", "contact.die.friction=0.15",
                         "output.xdmf=false", "output.plots=false")
    assert summary["max_punch_force_kN"] == pytest.approx(punch["max_punch_force_kN"], rel=1e-8)
    assert summary["min_thickness_strain_at_t_1"] == pytest.approx(punch["min_thickness_strain"], rel=1e-8)
    assert summary["thickness_strain_at_start_at_t_1"] == pytest.approx(punch["thickness_strain_at_start"],
                                                                         rel=1e-8)
    assert summary["max_eqps"] == pytest.approx(punch["max_eqps"], rel=1e-8)
    # measured (docs/guide/results.md): 39.999 mm at 40 mm, 39.294 mm after, pole ln(t/t0) -0.3893 -> -0.3851
    assert springback == pytest.approx(0.70528, abs=1e-4)
    assert summary["dome_height_mm"] == pytest.approx(39.29385, abs=1e-4)
    assert change[0] == pytest.approx(0.00414, abs=1e-5)
    for png in ("punch_force.png", "dome_height.png", "thickness_strain.png"):
        assert (out / png).exists(), png
