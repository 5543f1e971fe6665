#!/usr/bin/env bash
# Quick start: install what is missing, build (Release), run the default cloth on 2 ranks, and
# render it: out/cloth/series.pvd (ParaView), out/cloth/cloth.png and out/cloth/cloth.gif.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/build.sh
. tools/env.sh
mpirun -n 2 ./build/msim -options_file examples/cloth.opts -msim_monitor_csv out/cloth/energy.csv
/usr/bin/python3 runs/tools/render.py out/cloth/series.pvd --png out/cloth/cloth.png --gif out/cloth/cloth.gif
echo "ParaView series: out/cloth/series.pvd; pictures: out/cloth/cloth.png, out/cloth/cloth.gif"
