"""fenics-plast: finite-strain elastoplasticity after Simo-Ortiz and Garcia Garino, Oliver & Botello.

Units everywhere inside the package: mm, N, MPa, s, tonne/mm^3 (a consistent set).

Compiled kernels (numba, ``cache=True``) are cached in ``$XDG_CACHE_HOME/fenics-plast/numba/<digest>``
(default ``~/.cache``), ``<digest>`` a hash of the package's source files that hold compiled kernels:
numba notices that a cached kernel is stale only when the kernel's own file changes, not when a kernel
it calls (and inlines) from another file does, so a cache shared across versions of the package could
run old code. One folder per version of the kernels' sources cannot. ``NUMBA_CACHE_DIR``, when set, is used as it is.
"""
import hashlib
import os
import sys
from pathlib import Path

__version__ = "0.1.0"


#: package folders whose modules hold plain-Python functions that another module compiles with numba
#: (they need not mention it): the hardening laws' flow functions, the tool shapes' gap formulas
COMPILED_ELSEWHERE = ("hardening_laws", "tool_shapes")


def kernel_source_digest() -> str:
    """16 hex digits of the SHA-256 of the package's ``.py`` files that mention numba or njit or lie in
    a folder of :data:`COMPILED_ELSEWHERE` (their relative paths and contents): every compiled kernel
    and everything a kernel can call."""
    root = Path(__file__).parent
    h = hashlib.sha256()
    for f in sorted(root.rglob("*.py")):
        text = f.read_bytes()
        if b"numba" in text or b"njit" in text or f.parent.name in COMPILED_ELSEWHERE:
            h.update(f.relative_to(root).as_posix().encode() + b"\0" + text + b"\0")
    return h.hexdigest()[:16]


def numba_cache_dir() -> str:
    """Where this version of the sources caches its compiled kernels (see the module docstring)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "fenics-plast", "numba", kernel_source_digest())


if "NUMBA_CACHE_DIR" not in os.environ:
    os.environ["NUMBA_CACHE_DIR"] = numba_cache_dir()
    if "numba" in sys.modules:          # imported before us: its config has already read the environment
        sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
