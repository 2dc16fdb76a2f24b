#!/usr/bin/env bash
# Set up fenics-plast on Debian 12 bookworm or Debian 13 trixie: Debian's FEniCSx stack + a venv that
# sees it + editable install. Idempotent and fast when everything is already in place (no apt, no pip).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

# ---- the release: refuse anything else before installing anything -------------------------------
# FENICS_PLAST_OS_RELEASE: another os-release file, only to test this check.
os_release="${FENICS_PLAST_OS_RELEASE:-/etc/os-release}"
supported="Debian 12 bookworm (dolfinx 0.5.x) and Debian 13 trixie (dolfinx 0.9.x)"
refuse() { echo "install.sh: $*; fenics-plast supports $supported" >&2; exit 1; }
[ -r "$os_release" ] || refuse "no $os_release, cannot tell which system this is; nothing was installed"
osr() { sed -n "s/^$1=//p" "$os_release" | tail -n 1 | sed -e 's/^"\(.*\)"$/\1/' -e "s/^'\(.*\)'$/\1/"; }
ID="$(osr ID)" VERSION_ID="$(osr VERSION_ID)" VERSION_CODENAME="$(osr VERSION_CODENAME)"
found="${ID:-unknown} ${VERSION_ID:-(no VERSION_ID)} ${VERSION_CODENAME:-(no VERSION_CODENAME)} ($(osr PRETTY_NAME))"
case "$ID:$VERSION_ID:$VERSION_CODENAME" in
    debian:12:bookworm) release=bookworm dolfinx_series=0.5 ;;
    debian:13:trixie)   release=trixie   dolfinx_series=0.9 ;;
    *) refuse "this system is $found; nothing was installed" ;;
esac

# Every package the install and the two README commands need, named here: a minimal root
# (debootstrap --variant=minbase, the debian:<release> image) has none of them, and nothing may rely on
# what a development image happens to have (scripts/fresh_root_check.sh proves it). Same names on both.
PKGS=(python3-dolfinx python3-petsc4py python3-mpi4py python3-gmsh python3-numba python3-numpy
      python3-matplotlib python3-pytest openmpi-bin
      python3-venv python3-setuptools python3-wheel        # venv + `pip install -e .` (bdist_wheel)
      python3-nbclient python3-ipykernel python3-nbformat python3-yaml     # the demo notebook
      python3-hypothesis python3-tomli-w   # tests/test_scene_fuzz.py: property-based fuzzing, TOML writer
      python3-scipy                        # the bar demo's root finding, the Johnson-Cook test's ODE reference
      python3-h5py                         # reading fields.h5 in Python (docs/guide/outputs.md, tests/test_fields_h5.py)
      python3-sphinx python3-myst-parser   # `make docs`: the user guide from docs/*.md
      libopenblas0-serial)                 # optimised BLAS/LAPACK for MUMPS (the reference BLAS is ~3x slower)

missing=()
for p in "${PKGS[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$p")
    fi
done
if ((${#missing[@]})); then
    echo "install.sh: installing Debian $release packages: ${missing[*]}"
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
    $SUDO apt-get update
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
fi

# The venv must use Debian's python (dolfinx is only visible to it) and see its site-packages.
if [ ! -x .venv/bin/python ]; then
    echo "install.sh: creating .venv"
    /usr/bin/python3 -m venv --system-site-packages .venv
fi

# Editable install; --no-deps so pip never pulls a second numpy that would shadow Debian's.
stamp=.venv/.fenics_plast_installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ ! -x .venv/bin/fenics-plast ] \
   || ! .venv/bin/python -c "import fenics_plast" >/dev/null 2>&1; then
    echo "install.sh: pip install --no-deps --no-build-isolation -e ."
    .venv/bin/python -m pip install --quiet --no-deps --no-build-isolation -e .
    touch "$stamp"
fi

# The FEniCSx found must be the one this release ships; no "ok" over anything else.
.venv/bin/python -W ignore - "$release" "$dolfinx_series" "$supported" <<'PY'
import sys
release, series, supported = sys.argv[1:4]
try:
    import dolfinx
except Exception as e:
    sys.exit(f"install.sh: Debian {release}, but dolfinx does not import ({e}); fenics-plast supports {supported}")
if not dolfinx.__version__.startswith(series + "."):
    sys.exit(f"install.sh: Debian {release} with dolfinx {dolfinx.__version__} (from {dolfinx.__file__}); "
             f"{release} ships dolfinx {series}.x; fenics-plast supports {supported}")
import numba, numpy, petsc4py, fenics_plast
print(f"install.sh: ok: Debian {release}, dolfinx {dolfinx.__version__}, numba {numba.__version__}, "
      f"numpy {numpy.__version__}, petsc4py {petsc4py.__version__}, fenics_plast {fenics_plast.__version__}")
PY
