#!/usr/bin/env bash
# Set up fenics-plast on Debian bookworm: Debian FEniCSx stack + a venv that sees it + editable install.
# Idempotent and fast when everything is already in place (no apt, no pip).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

# Every package the install and the two README commands need, named here: a minimal bookworm
# (debootstrap --variant=minbase, the debian:bookworm image) has none of them, and nothing may rely on
# what a development image happens to have (scripts/fresh_root_check.sh proves it).
PKGS=(python3-dolfinx python3-petsc4py python3-mpi4py python3-gmsh python3-numba python3-numpy
      python3-matplotlib python3-pytest openmpi-bin
      python3-venv python3-setuptools python3-wheel        # venv + `pip install -e .` (bdist_wheel)
      python3-nbclient python3-ipykernel python3-nbformat python3-yaml     # the demo notebook
      python3-hypothesis python3-tomli-w   # tests/test_scene_fuzz.py: property-based fuzzing, TOML writer
      python3-scipy)                       # the bar demo's root finding, the Johnson-Cook test's ODE reference

missing=()
for p in "${PKGS[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$p")
    fi
done
if ((${#missing[@]})); then
    echo "install.sh: installing Debian packages: ${missing[*]}"
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

.venv/bin/python -W ignore -c "import dolfinx, numba, numpy, fenics_plast; print(f'install.sh: ok: dolfinx {dolfinx.__version__}, numba {numba.__version__}, numpy {numpy.__version__}, fenics_plast {fenics_plast.__version__}')"
