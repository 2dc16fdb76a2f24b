"""fenics-plast: finite-strain elastoplasticity after Simo-Ortiz and Garcia Garino, Oliver & Botello.

Units everywhere inside the package: mm, N, MPa, s, tonne/mm^3 (a consistent set).

Compiled kernels (numba, ``cache=True``) are cached in ``$XDG_CACHE_HOME/fenics-plast/numba/<digest>``
(default ``~/.cache``), ``<digest>`` a hash of the package's source files that hold compiled kernels:
numba notices that a cached kernel is stale only when the kernel's own file changes, not when a kernel
it calls (and inlines) from another file does, so a cache shared across versions of the package could
run old code. One folder per version of the kernels' sources cannot. ``NUMBA_CACHE_DIR``, when set, is used as it is.

``XDG_CACHE_HOME`` is used only when it is an absolute path (as the XDG specification says) of a folder
that exists or can be made, and can be written; otherwise (empty: dolfinx would cache its compiled forms
in ``./fenics`` of the current folder; unwritable: dolfinx and numba would fail) ``~/.cache`` is, or failing
that a private folder in the temporary directory, and the environment is set to it before dolfinx reads it
(:func:`cache_home`).
"""
import hashlib
import os
import sys
import tempfile
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


def _writable_folder(path: str) -> bool:
    """Whether ``path`` is an absolute path of a folder that exists or can be made, and can be written."""
    if not path or not os.path.isabs(path):
        return False
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return False
    return os.path.isdir(path) and os.access(path, os.W_OK | os.X_OK)


def cache_home() -> str:
    """The cache folder of compiled code [absolute path]: ``$XDG_CACHE_HOME`` when usable, else ``~/.cache``,
    else ``<tmp>/fenics-plast-cache-<uid>``; an unusable ``XDG_CACHE_HOME`` is replaced in the environment
    (dolfinx's form compiler reads it) and, when it was not empty, a warning goes to stderr (rank 0)."""
    given = os.environ.get("XDG_CACHE_HOME", "")
    if _writable_folder(given):
        return given
    home = os.path.join(os.path.expanduser("~"), ".cache")
    private = os.path.join(tempfile.gettempdir(), f"fenics-plast-cache-{os.getuid()}")
    chosen = home if _writable_folder(home) else private
    os.makedirs(chosen, mode=0o700, exist_ok=True)
    if "XDG_CACHE_HOME" in os.environ:
        os.environ["XDG_CACHE_HOME"] = chosen
        rank = next((os.environ[v] for v in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK") if v in os.environ), "0")
        if given and rank == "0":
            what = "a writable folder" if os.path.isabs(given) else "an absolute path"
            print(f"warning: XDG_CACHE_HOME={given} is not {what}: compiled code is cached in {chosen}",
                  file=sys.stderr, flush=True)
    return chosen


def numba_cache_dir() -> str:
    """Where this version of the sources caches its compiled kernels (see the module docstring)."""
    return os.path.join(cache_home(), "fenics-plast", "numba", kernel_source_digest())


cache_home()                            # before dolfinx reads XDG_CACHE_HOME
if "NUMBA_CACHE_DIR" not in os.environ:
    os.environ["NUMBA_CACHE_DIR"] = numba_cache_dir()
    if "numba" in sys.modules:          # imported before us: its config has already read the environment
        sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
