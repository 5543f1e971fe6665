#!/usr/bin/env bash
# Fuzzes each of msim's mesh readers (OFF, OBJ, STL, TetGen, Gmsh ASCII and binary), the options-to-scene
# path (an options file) and the checkpoint reader with libFuzzer,
# AddressSanitizer and UndefinedBehaviorSanitizer for SECONDS each (default 600), from the seed
# corpus of runs/fuzz/seeds.py. Builds build-fuzz/ with clang. Findings (crash-*, oom-*, timeout-*)
# go to build-fuzz/findings/<format>/; each run's statistics to build-fuzz/<format>.log and a line
# per format to runs/fuzz/results.csv. allocator_may_return_null: an absurd request (a negative size in a
# third-party reader) fails as it does outside ASan, and the reader reports it; libFuzzer's
# -malloc_limit_mb still catches any request over 1 GB.
# Usage: bash runs/fuzz/run.sh [SECONDS] [formats...]   (MSIM_FUZZ_JOBS: harnesses at once, default nproc)
set -euo pipefail
cd "$(dirname "$0")/../.."
each=${1:-600}
shift || true
formats=${*:-off obj stl tetgen gmsh medit options checkpoint}
target() { case $1 in options | checkpoint) echo fuzz_$1 ;; *) echo fuzz_mesh_$1 ;; esac; }
cmake -S . -B build-fuzz -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DMSIM_FUZZ=ON -DMSIM_SANITIZE=ON \
  -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo > /dev/null
targets=msim # the checkpoint seeds are written by msim
for fmt in $formats; do targets+=" $(target "$fmt")"; done
cmake --build build-fuzz -j"$(nproc)" --target $targets > /dev/null
MSIM_EXE=$PWD/build-fuzz/msim ASAN_OPTIONS=detect_leaks=0 /usr/bin/python3 runs/fuzz/seeds.py build-fuzz/seeds $formats > /dev/null
. tools/env.sh
# one harness per core at once (each is single-threaded)
fuzz_one() {
  fmt=$1
  mkdir -p build-fuzz/corpus/$fmt build-fuzz/findings/$fmt
  b=$PWD/build-fuzz # absolute: the options harness works in a scratch directory
  ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=1 UBSAN_OPTIONS=print_stacktrace=1 $b/runs/fuzz/$(target "$fmt") $b/corpus/$fmt $b/seeds/$fmt \
    -max_total_time="$each" -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=20 -max_len=65536 \
    -artifact_prefix=$b/findings/$fmt/ -print_final_stats=1 > build-fuzz/$fmt.log 2>&1 || true
  runs=$(grep -o "stat::number_of_executed_units: *[0-9]*" build-fuzz/$fmt.log | grep -o "[0-9]*$" || echo 0)
  found=$(ls build-fuzz/findings/$fmt | wc -l)
  corpus=$(ls build-fuzz/corpus/$fmt | wc -l)
  echo "$fmt,$each,$runs,$corpus,$found" > build-fuzz/$fmt.result
  echo "fuzz $fmt: $runs executions in $each s, corpus $corpus, findings $found"
}
jobs_max=${MSIM_FUZZ_JOBS:-$(nproc)}
for fmt in $formats; do
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do sleep 1; done
  fuzz_one "$fmt" &
done
wait
# results.csv: this run's rows replace those of the same harnesses, the others' rows stay
old=$(tail -n +2 runs/fuzz/results.csv 2>/dev/null || true)
{
  echo "format,seconds,executions,corpus,findings"
  for fmt in $formats; do cat build-fuzz/$fmt.result; done
  echo "$old" | while IFS= read -r row; do
    if [ -n "$row" ] && ! grep -qx "${row%%,*}" <(printf '%s\n' $formats); then echo "$row"; fi
  done
} > runs/fuzz/results.csv.new
mv runs/fuzz/results.csv.new runs/fuzz/results.csv
