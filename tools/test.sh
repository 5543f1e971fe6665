#!/usr/bin/env bash
# Builds msim and runs the whole test suite (ctest: unit, regression, mpi at 1 and 2 ranks).
# Tests run side by side on every core (ctest -j nproc; each test's PROCESSORS, tests/CMakeLists.txt,
# keeps the ranks running at once within the cores) unless the arguments give their own -j.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/build.sh
. tools/env.sh
cd build
jobs=(-j"$(nproc)")
for a in "$@"; do
  case "$a" in
    -j* | --parallel | --parallel=*) jobs=() ;;
  esac
done
ctest --output-on-failure "${jobs[@]}" "$@"
