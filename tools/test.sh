#!/usr/bin/env bash
# Builds msim and runs the whole test suite (ctest: unit, regression, mpi at 1 and 2 ranks).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/build.sh
. tools/env.sh
cd build
ctest --output-on-failure "$@"
