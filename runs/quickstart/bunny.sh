#!/usr/bin/env bash
# The README's bunny picture: examples/bunny.opts on 2 ranks, rendered from the side (+y up).
# Usage (after a build): bash runs/quickstart/bunny.sh  ->  runs/quickstart/bunny.png, bunny.gif
set -euo pipefail
cd "$(dirname "$0")/../.."
. tools/env.sh
mpirun -n 2 ./build/msim -options_file examples/bunny.opts -msim_output out/bunny
/usr/bin/python3 runs/tools/render.py out/bunny/series.pvd --up y --view 15,-60 --frames 50 \
  --png runs/quickstart/bunny.png --gif runs/quickstart/bunny.gif
