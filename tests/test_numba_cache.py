"""Compiled kernels are cached per version of their sources (fenics_plast/__init__.py).

numba checks a cached kernel against its own file only: a kernel that inlines a kernel of another file
(the return map calling the hardening law, the fused force pass calling the return map) kept running
the old callee after that file changed. The cache folder is now named by a digest of every file that
holds kernels, so a change in any of them starts a new cache, and a change elsewhere keeps it.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import fenics_plast

PACKAGE = Path(fenics_plast.__file__).parent
PRINT_DIR = "import os, fenics_plast; print(os.environ['NUMBA_CACHE_DIR'])"


def cache_dir_of(package_parent: Path, cache_home: Path) -> str:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(package_parent), XDG_CACHE_HOME=str(cache_home))
    p = subprocess.run([sys.executable, "-c", PRINT_DIR], capture_output=True, text=True, env=env,
                       cwd=package_parent, timeout=120, check=True)
    return p.stdout.strip()


def test_a_kernel_file_change_starts_a_new_cache_and_other_changes_do_not(tmp_path):
    copy = tmp_path / "src"
    shutil.copytree(PACKAGE, copy / "fenics_plast", ignore=shutil.ignore_patterns("__pycache__"))
    home = tmp_path / "cache"
    first = cache_dir_of(copy, home)
    assert Path(first).parent == home / "fenics-plast" / "numba"
    assert cache_dir_of(copy, home) == first                         # stable

    with open(copy / "fenics_plast" / "cli.py", "a") as f:             # no kernel in it
        f.write("\n# an edit outside the kernels\n")
    assert cache_dir_of(copy, home) == first

    with open(copy / "fenics_plast" / "material" / "hardening.py", "a") as f:   # kernels inlined elsewhere
        f.write("\n# an edit of a hardening law\n")
    assert cache_dir_of(copy, home) != first


def run_with_cache_home(code: str, cache_home: Path) -> str:
    """stdout of ``python -c code`` in a new process whose caches live under ``cache_home``."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(cache_home)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300,
                          check=True).stdout


def test_kernels_are_cached_in_that_folder(tmp_path):
    code = ("import numpy as np, fenics_plast\n"
            "from fenics_plast.material.hardening import flow_stress\n"
            "print(flow_stress(0, np.array([400.0, 100.0]), 0.5)[0])\n")
    assert float(run_with_cache_home(code, tmp_path)) == 450.0                                    # 400 + 100 * 0.5 MPa
    folder = tmp_path / "fenics-plast" / "numba" / fenics_plast.kernel_source_digest()
    assert any(folder.rglob("hardening.flow_stress-*.nbi")), sorted(folder.rglob("*"))
