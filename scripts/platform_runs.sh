#!/usr/bin/env bash
# Run every shipped scene (demos/*.toml) and the punch at mu = 0.15 and 0.3 into OUT/<scene>/, for
# comparing platforms with scripts/compare_results.py (docs/PLATFORMS.md):
#
#   bash scripts/platform_runs.sh OUT            # with .venv/bin/python, or PY=/path/to/python
#
# Runs go on after a failure (its folder then has a failed summary.json); exit 1 at the end if any failed.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out="${1:?usage: bash scripts/platform_runs.sh OUT}"
py="${PY:-.venv/bin/python}"
export FENICS_PLAST_PROGRESS=off
failed=()
run() {   # run NAME SCENE [--set ...]
    local name="$1" scene="$2"; shift 2
    echo "== $name"
    "$py" -m fenics_plast.cli run "$scene" --out "$out/$name" "$@" || failed+=("$name")
}
for s in demos/*.toml; do
    run "$(basename "$s" .toml)" "$s"
done
for mu in 0.15 0.3; do
    run "punch_stretching_mu$mu" demos/punch_stretching.toml --set "contact.*.friction=$mu"
done
if ((${#failed[@]})); then echo "platform_runs: FAILED: ${failed[*]}"; exit 1; fi
