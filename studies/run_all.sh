#!/usr/bin/env bash
# Re-run the shipped parameter studies and refresh docs/studies/ and docs/STUDIES.md.
#   bash studies/run_all.sh                 # all studies (about 20 min on 2 cores)
#   bash studies/run_all.sh punch_penalty   # some of them; --list shows names and commands
set -euo pipefail
cd "$(dirname "$0")/.."
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
exec .venv/bin/python studies/run_all.py "$@"
