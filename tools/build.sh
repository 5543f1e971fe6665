#!/usr/bin/env bash
# Installs what is missing and builds msim (Release) into build/. Sourced environment: tools/env.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
