#!/usr/bin/env bash
# Regenerates tests/expected/*.out at one rank after an intended change of results, with the same
# extra options as tests/CMakeLists.txt. Review the diff before committing.
set -euo pipefail
cd "$(dirname "$0")/.."
. tools/env.sh
small="-msim_cloth_n 15 -msim_steps 5"
run() { /usr/bin/python3 tests/run_example.py build/msim "$1" 1 --regen -- ${2:-}; }
run cloth "-msim_steps 4000"
run chain
run cloth_ts
run cloth_wind
run cloth_newton "$small"
run cloth_newton_fast "$small -msim_step_atol 1e-10 -snes_max_it 100"
run cloth_bw "$small"
run cloth_pd "$small"
run cloth_anderson "$small -msim_dt 0.005 -snes_max_it 30"
run cloth_lbfgs "$small -msim_dt 0.005 -snes_max_it 30"
run chain_spectrum
