"""The hardening-law registry (fenics_plast/hardening_laws/, one module per law) and the Ludwik law.

Ludwik, sigma_y = sigma_0 + K eps_p^n: flow stress and slope against the closed form (and the
safeguarded slope at eps_p = 0), a uniaxial material point against the closed-form curve, and a scene
that selects it with ``--set materials.<m>.hardening.law=ludwik``.
"""
from __future__ import annotations

import json
import pkgutil
from pathlib import Path

import numpy as np
import pytest

from fenics_plast import hardening_laws, schema
from fenics_plast.material import Hardening, Material
from fenics_plast.material.point import uniaxial_stress

REPO = Path(__file__).resolve().parent.parent
S0, K, N = 200.0, 500.0, 0.3      # MPa, MPa, -


def test_every_law_module_is_registered_and_feeds_the_schema():
    modules = {m.name for m in pkgutil.iter_modules(hardening_laws.__path__)}
    laws = hardening_laws.laws()
    assert set(laws) == modules                                   # one module per law, no list to edit
    assert schema.LAWS == tuple(laws) == schema.choices("materials.*.hardening.law")
    assert len({law.code for law in laws.values()}) == len(laws)
    table = schema.SCHEMA["materials"].subtables["hardening"]
    for law in laws.values():
        for name in law.params:
            assert law.name in table.keys[name].when["law"]
    assert table.keys["yield_stress"].when["law"] == tuple(n for n, law in laws.items() if "yield_stress" in law.params)
    assert schema.default("materials.*.hardening.modulus") == laws["linear"].params["modulus"].default


def test_ludwik_flow_stress_and_slope_are_the_closed_form():
    h = Hardening("ludwik", yield_stress=S0, K=K, n=N)
    eps = np.array([1e-6, 1e-3, 0.05, 0.2, 1.0, 3.0])
    s, ds = h(eps)
    np.testing.assert_allclose(s, S0 + K * eps ** N, rtol=1e-14)
    np.testing.assert_allclose(ds, N * K * eps ** (N - 1.0), rtol=1e-13)
    assert h.initial_yield_stress == S0
    assert h(0.0) == (S0, 0.0)                                    # the safeguard: slope 0, not inf or nan
    assert Hardening("ludwik", yield_stress=S0, K=K, n=1.0)(0.0) == (S0, K)       # exact at n = 1
    assert Hardening("ludwik", yield_stress=S0, K=K, n=0.0)(0.0) == (S0 + K, 0.0)  # 0^0 = 1
    with pytest.raises(KeyError):
        Hardening("ludwik", yield_stress=S0, n=N)


@pytest.mark.parametrize("model", ["isochoric", "seed"])
def test_uniaxial_point_follows_the_ludwik_curve(model):
    E = 70e3
    mat = Material(E, 0.3, Hardening("ludwik", yield_stress=S0, K=K, n=N), model)
    out = uniaxial_stress(mat, 0.4, 80)
    plastic = out["eqps"] > 0.0
    assert plastic.sum() >= 75
    tau, eqps = out["kirchhoff_axial_MPa"][plastic], out["eqps"][plastic]
    np.testing.assert_allclose(tau, S0 + K * eqps ** N, rtol=1e-9)       # on the yield surface
    if model == "isochoric":                                              # Hencky: eps = tau / E + eps_p
        np.testing.assert_allclose(eqps, out["log_strain"][plastic] - tau / E, rtol=1e-8)
    np.testing.assert_allclose(out["plastic_volume_ratio"], 1.0, atol=1e-9 if model == "isochoric" else 1e-2)


def test_a_scene_selects_ludwik_from_the_command_line(tmp_path):
    from fenics_plast import cli
    text = (REPO / "demos" / "taylor_bar.toml").read_text()
    text = text.replace('file = "../meshes/round_bar.geo"', f'file = "{REPO / "meshes" / "round_bar.geo"}"')
    lines = [ln for ln in text.splitlines() if not ln.startswith("modulus")]      # a linear-only key
    scene = tmp_path / "taylor_ludwik.toml"
    scene.write_text("\n".join(lines) + "\n")
    h = "materials.copper.hardening."
    out = tmp_path / "res"
    assert cli.main(["run", str(scene), "--out", str(out), "--set", h + "law=ludwik", "--set", h + "K=300",
                     "--set", h + "n=0.3", "--set", "analysis.end_time=4", "--set", "output.plots=false"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["max_eqps"] > 0.0
    assert (out / "history.csv").exists()


def test_a_law_module_is_in_the_kernel_digest(tmp_path):
    import shutil
    import fenics_plast
    from test_numba_cache import cache_dir_of
    copy = tmp_path / "src"
    shutil.copytree(Path(fenics_plast.__file__).parent, copy / "fenics_plast",
                    ignore=shutil.ignore_patterns("__pycache__"))
    home = tmp_path / "cache"
    first = cache_dir_of(copy, home)
    with open(copy / "fenics_plast" / "hardening_laws" / "ludwik.py", "a") as f:   # compiled elsewhere
        f.write("\n# an edit of a law's flow\n")
    assert cache_dir_of(copy, home) != first


def test_a_second_process_reuses_the_compiled_dispatcher(tmp_path):
    from test_numba_cache import run_with_cache_home
    code = ("import numpy as np\n"
            "from fenics_plast.material.hardening import flow_stress\n"
            "s = flow_stress(5, np.array([200.0, 500.0, 0.3]), 0.2)[0]\n"
            "print(s, sum(flow_stress.stats.cache_misses.values()), sum(flow_stress.stats.cache_hits.values()))\n")
    runs = [run_with_cache_home(code, tmp_path).split() for _ in range(2)]
    assert float(runs[0][0]) == pytest.approx(S0 + K * 0.2 ** N, rel=1e-14)
    assert runs[0][1:] == ["1", "0"] and runs[1][1:] == ["0", "1"]                  # compiled once, then loaded
