#!/usr/bin/env bash
# Builds msim and runs the whole test suite (ctest: unit, regression, mpi at 1 and 2 ranks).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
. tools/env.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
cd build
ctest --output-on-failure "$@"
