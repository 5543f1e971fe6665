#!/usr/bin/env bash
# Runs each named ctest test alone (ctest -R '^NAME$') under /usr/bin/time and appends one CSV row:
# label,test,wall_s,user_s,sys_s,cpu_s,load1_before,passed
# usage: runs/ci_time/measure.sh BUILD_DIR LABEL OUT.csv TEST...
set -u
build=$1 label=$2 out=$3; shift 3
out=$(realpath -m "$out")
[ -s "$out" ] || echo "label,test,wall_s,user_s,sys_s,cpu_s,load1_before,passed" >"$out"
cd "$build"
. ../tools/env.sh
export OMPI_MCA_pml=ob1
for t in "$@"; do
  load=$(cut -d' ' -f1 /proc/loadavg)
  tf=$(mktemp)
  if /usr/bin/time -o "$tf" -f '%e %U %S' ctest -R "^$t\$" --output-on-failure >"$tf.log" 2>&1; then ok=1; else ok=0; fi
  read -r e u s < <(tail -n 1 "$tf")
  echo "$label,$t,$e,$u,$s,$(echo "$u + $s" | bc),$load,$ok" >>"$out"
  [ "$ok" = 1 ] || cp "$tf.log" "/tmp/ci_time_failed_${label}_$t.log"
  rm -f "$tf" "$tf.log"
done
