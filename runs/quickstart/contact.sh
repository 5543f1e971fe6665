#!/usr/bin/env bash
# The README's contact pictures: examples/cloth_sphere.opts, cloth_table.opts and bunny_drop.opts
# (the bunny on 2 ranks), each rendered with its obstacles drawn from its options file.
# Usage (after a build): bash runs/quickstart/contact.sh  ->  runs/quickstart/{cloth_sphere,cloth_table,bunny_drop}.png and .gif
set -euo pipefail
cd "$(dirname "$0")/../.."
. tools/env.sh
for name in cloth_sphere cloth_table; do
  ./build/msim -options_file examples/$name.opts -msim_output out/$name
  /usr/bin/python3 runs/tools/render.py out/$name/series.pvd --view 25,-60 --frames 40 --obstacles examples/$name.opts \
    --png runs/quickstart/$name.png --gif runs/quickstart/$name.gif
done
mpirun -n 2 ./build/msim -options_file examples/bunny_drop.opts -msim_output out/bunny_drop
/usr/bin/python3 runs/tools/render.py out/bunny_drop/series.pvd --up y --view 15,-60 --frames 40 --obstacles examples/bunny_drop.opts \
  --png runs/quickstart/bunny_drop.png --gif runs/quickstart/bunny_drop.gif
