#!/usr/bin/env bash
# Regenerates tests/expected/*.out at one rank after an intended change of results, with the extra
# options of tests/examples.txt (the table ctest runs). Review the diff before committing.
# Usage: tests/regen_expected.sh [NAME ...]   (default: every example of the table)
set -euo pipefail
cd "$(dirname "$0")/.."
. tools/env.sh
want=" $* "
while IFS='|' read -r name extra more needs; do
  name=$(echo "$name" | xargs); needs=$(echo "${needs:-}" | xargs)
  [ -z "$name" ] && continue
  [ $# -gt 0 ] && [[ "$want" != *" $name "* ]] && continue
  if [ "$needs" = tetgen ] && ! grep -q "MSIM_WITH_TETGEN:BOOL=ON" build/CMakeCache.txt 2>/dev/null; then
    echo "skipped $name: build/ has no TetGen"; continue
  fi
  # shellcheck disable=SC2086  (the extra options are words)
  /usr/bin/python3 tests/run_example.py build/msim "$name" 1 --regen -- $extra
done < <(grep -v '^#' tests/examples.txt)
