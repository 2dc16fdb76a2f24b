"""Where compiled code is cached (fenics_plast.cache_home, issue 34): an empty, relative or unwritable
``XDG_CACHE_HOME`` is treated as unset (dolfinx wrote a ``./fenics`` folder into the current folder for
an empty one and failed with a FileNotFoundError traceback for an unwritable one), with a warning for
one that was given."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PROBE = ("import os, fenics_plast, dolfinx.jit as j; "
         "p = getattr(j, 'DOLFINX_DEFAULT_JIT_OPTIONS', None) or j.DOLFINX_DEFAULT_JIT_PARAMETERS; "
         "c = p['cache_dir']; c = c[0] if isinstance(c, tuple) else c; "
         "print(os.environ['XDG_CACHE_HOME']); print(os.environ['NUMBA_CACHE_DIR']); print(c)")


def _probe(cwd, xdg):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = xdg
    r = subprocess.run([sys.executable, "-c", PROBE], cwd=cwd, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return r.stdout.split("\n")[:3], r.stderr


@pytest.mark.parametrize("xdg", ["", "relative/cache", "/proc/no-such-folder", "/dev/null"])
def test_an_unusable_cache_home_is_replaced(tmp_path, xdg):
    (xdg_now, numba, dolfinx_cache), err = _probe(tmp_path, xdg)
    assert xdg_now != xdg and os.path.isabs(xdg_now) and os.access(xdg_now, os.W_OK)
    assert numba.startswith(os.path.join(xdg_now, "fenics-plast", "numba"))
    assert str(dolfinx_cache).startswith(xdg_now)
    assert list(tmp_path.iterdir()) == []                    # nothing made in the current folder
    if xdg:
        assert f"warning: XDG_CACHE_HOME={xdg} is not" in err and f"compiled code is cached in {xdg_now}" in err
    else:
        assert "warning" not in err


def test_a_usable_cache_home_is_kept(tmp_path):
    (xdg_now, numba, dolfinx_cache), err = _probe(tmp_path, str(tmp_path / "c"))
    assert xdg_now == str(tmp_path / "c") and numba.startswith(xdg_now) and "warning" not in err
