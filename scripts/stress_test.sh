#!/usr/bin/env bash
# Runs a test N times while CPU-heavy processes (one busy loop per core) share the machine, to catch an
# outcome that depends on timing (issue 40: a resume right after killing an MPI run). Prints each
# run's outcome and the count; exits 1 if any run failed, with that run's failures shown.
#
#   bash scripts/stress_test.sh 20 tests/test_checkpoint.py -k mpi
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
n="${1:?usage: stress_test.sh N PYTEST-ARGS...}"; shift
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
hogs=()
for _ in $(seq "$(nproc)"); do
    (while :; do :; done) &
    hogs+=($!)
done
trap 'kill "${hogs[@]}" 2>/dev/null' EXIT
log="$(mktemp -d)"
failed=0
for i in $(seq "$n"); do
    t0=$SECONDS
    if .venv/bin/python -m pytest -q "$@" > "$log/$i.log" 2>&1; then
        echo "run $i/$n: passed ($((SECONDS - t0)) s, load $(cut -d' ' -f1 /proc/loadavg))"
    else
        failed=$((failed + 1))
        echo "run $i/$n: FAILED ($((SECONDS - t0)) s)"
        grep -E "^(E |FAILED)" "$log/$i.log" | tail -n 30 | sed 's/^/    | /'
    fi
done
echo "stress_test: $((n - failed)) passed, $failed failed"
[ "$failed" -eq 0 ]
