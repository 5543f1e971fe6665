#!/usr/bin/env bash
# Strong scaling of contact (issue 34) and self-contact (issue 35) on a many-core machine, each case
# with and without the feature, at every rank count, inside one time budget.
#
#   OUT=out-device BUDGET=480 bash runs/device/study.sh        (then: /usr/bin/python3 runs/device/report.py out-device)
#
# msim comes from PATH (or $MSIM); mpirun from PATH ($MPIRUN, default "mpirun --bind-to core";
# e.g. MPIRUN="srun --cpu-bind=cores" on a cluster). Every mesh is made here by msim's own
# generators. Bash, coreutils and awk only: the machine needs no Python.
#
# Cases (CASES, default "box fold box_explicit"; box_jacobi when named):
#  box          the 52^3 Kuhn tet box (148,877 vertices, 1,008,748 springs, 1000 kg, E = 1 MPa), free,
#               implicit Euler (h = 10 ms) with msim's default Newton (CG + block Jacobi ICC), BOX_STEPS
#               steps; "contact": resting 5 mm above the plane z >= -0.005 with friction 0.5, so its
#               whole bottom face (2,809 vertices) is inside the barrier's range dhat = 17 mm from
#               step 1 and pressed by the fall; "free": the same run with no obstacle.
#  fold         examples/cloth_fold.opts at CLOTH_N x CLOTH_N (the perturbation scaled to a fifth of an
#               edge, as at 21 x 21), Newton with at most CLOTH_NEWTON_MAX iterations per step. One
#               run at the largest rank count first takes the cloth, with self-contact, to
#               PREFOLD_STEPS (where it has started to fold onto itself) and checkpoints it; every
#               measured run restarts from that state and makes CLOTH_STEPS steps "self" (with
#               -msim_self_contact) or "noself" (without).
#  box_jacobi   the box case with BOXJ_PC (default -pc_type jacobi) added to both variants: CG with a
#               preconditioner whose iteration count does not depend on the partition (block Jacobi
#               ICC's does: 123 -> 204 CG iterations from 1 to 2 ranks on the free box), so that the
#               speed-ups with and without contact compare the steps' own parallel work.
#  box_explicit the box by symplectic Euler (h = 50 us, EXPL_STEPS steps) with the penalty on the plane
#               z >= -1e-5 (touched after ~28 steps) or without: the step the scaling model predicts.
#
# Each run: mpirun -n p, its own `timeout`, -log_view (stages: setup apart from stepping) and
# -msim_monitor_csv under $OUT/<case>/<variant>_np<p>/, one row in $OUT/runs.csv. Order: the
# checkpoint, then p = 1 and 2 of every case (the issues' targets), then the larger p; runs whose
# estimate (from the same series' smaller p) no longer fits the budget are skipped and listed; with
# time left, p = 1 and 2 are repeated in the opposite order (report.py keeps the fastest).
set -u
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
OUT=${OUT:-./out-device}
BUDGET=${BUDGET:-480}
RANKS=${RANKS:-"1 2 4 8 16"}
CASES=${CASES:-"box fold box_explicit"}
MSIM=${MSIM:-msim}
MPIRUN=${MPIRUN:-"mpirun --bind-to core"}
RUN_MAX=${RUN_MAX:-150}
REPEAT=${REPEAT:-1}
PACK=${PACK:-}   # a .tar.gz path: the whole of $OUT packed there after every run (for a machine that returns only a few files)
BOX_N=${BOX_N:-52}
BOXJ_PC=${BOXJ_PC:-"-pc_type jacobi"}
BOX_STEPS=${BOX_STEPS:-3}
EXPL_STEPS=${EXPL_STEPS:-200}
CLOTH_N=${CLOTH_N:-101}
CLOTH_STEPS=${CLOTH_STEPS:-3}
CLOTH_NEWTON_MAX=${CLOTH_NEWTON_MAX:-10}
PREFOLD_STEPS=${PREFOLD_STEPS:-14}
PREFOLD_MAX=${PREFOLD_MAX:-90}

command -v "$MSIM" >/dev/null || { echo "study.sh: msim not found (PATH or \$MSIM)" >&2; exit 2; }
command -v ${MPIRUN%% *} >/dev/null || { echo "study.sh: ${MPIRUN%% *} not found (PATH or \$MPIRUN)" >&2; exit 2; }
mkdir -p "$OUT" || exit 2
MAXP=$(echo $RANKS | tr ' ' '\n' | sort -n | tail -1)
# can mpirun start the largest rank count this way? If not (fewer cores than ranks, or hardware
# threads counted as CPUs), fall back to hardware threads, then to unbound oversubscription: the
# run goes on, and machine.txt and runs.csv say which launcher each run had.
if ! timeout 60 $MPIRUN -n "$MAXP" true >/dev/null 2>&1; then
  for alt in "${MPIRUN%% *} --use-hwthread-cpus --bind-to hwthread" "${MPIRUN%% *} --oversubscribe --bind-to none"; do
    if timeout 60 $alt -n "$MAXP" true >/dev/null 2>&1; then echo "study.sh: '$MPIRUN -n $MAXP' cannot start here; using '$alt'"; MPIRUN=$alt; break; fi
  done
fi
OUT=$(cd "$OUT" && pwd)
T0=$(date +%s)
CSV=$OUT/runs.csv
echo "case,variant,ranks,rep,status,rc,wall_s,steps,first_step,setup_s,stepping_s,nonlinear_its,linear_its,contact_n_last,cmd" > "$CSV"
{ echo "date $(date -u +%FT%TZ)"; echo "host $(hostname) cores $(nproc)"; lscpu 2>/dev/null | grep -E '^(Model name|Socket|Core|Thread|CPU\(s\)|L3|NUMA node\(s\))'; echo "msim $(command -v "$MSIM")";
  echo "mpirun $(command -v ${MPIRUN%% *}) ($MPIRUN)"; echo "budget $BUDGET s, ranks $RANKS, cases $CASES";
  echo "BOXJ_PC=$BOXJ_PC"; echo "BOX_N=$BOX_N BOX_STEPS=$BOX_STEPS EXPL_STEPS=$EXPL_STEPS CLOTH_N=$CLOTH_N CLOTH_STEPS=$CLOTH_STEPS CLOTH_NEWTON_MAX=$CLOTH_NEWTON_MAX PREFOLD_STEPS=$PREFOLD_STEPS"; } > "$OUT/machine.txt"
cat "$OUT/machine.txt"

elapsed() { echo $(( $(date +%s) - T0 )); }
left() { echo $(( BUDGET - $(elapsed) )); }
declare -A T1   # wall seconds of a series' smallest-p run, for the estimates
declare -A P1

BOX="-msim_scene box -msim_box_n $BOX_N,$BOX_N,$BOX_N -msim_fix none -msim_density 1000 -msim_young 1e6"
BOX_IMPL="$BOX -msim_integrator implicit_euler -msim_dt 0.01 -msim_steps $BOX_STEPS"
BOX_CONTACT="-msim_contact_plane 0,0,1,-0.005 -msim_friction 0.5"
BOX_EXPL="$BOX -msim_integrator symplectic_euler -msim_dt 5e-5 -msim_steps $EXPL_STEPS -msim_spectrum_check 0"
PERTURB=$(awk -v n="$CLOTH_N" 'BEGIN { p = 0.2 / (n - 1); printf "%.6g", p < 0.01 ? p : 0.01 }')  # a fifth of an edge, at most the 1 cm gap to the floor
FOLD="-options_file $ROOT/examples/cloth_fold.opts -msim_cloth_n $CLOTH_N -msim_perturb $PERTURB -snes_max_it $CLOTH_NEWTON_MAX"
CKPT=$OUT/fold/prefold.bin

# stage time (s) from a -log_view file
stage() { awk -v s="$2:" '$1 ~ /^[0-9]+:$/ && $2 == s { print $3; exit }' "$1" 2>/dev/null; }
# run CASE VARIANT P REP TIMEOUT ARGS...: one mpirun, its row in runs.csv
run() {
  local case=$1 variant=$2 p=$3 rep=$4 lim=$5; shift 5
  local dir=$OUT/$case/${variant}_np$p; [ "$rep" -gt 1 ] && dir=${dir}_rep$rep
  mkdir -p "$dir"
  # NOMON=steps: no monitor (its energies are a sweep over the springs, as costly as an explicit step)
  local cmd="$MPIRUN -n $p $MSIM $* -msim_scene_view -log_view :$dir/log_view.txt"
  [ -z "${NOMON:-}" ] && cmd="$cmd -msim_monitor_csv $dir/monitor.csv"
  echo "$cmd" > "$dir/cmd.txt"
  local t=$(date +%s)
  timeout -k 15 "$lim" $cmd > "$dir/stdout.txt" 2>&1
  local rc=$? wall=$(( $(date +%s) - t ))
  local status=ok; [ $rc -ne 0 ] && status=failed; [ $rc -eq 124 ] || [ $rc -eq 137 ] && status=timeout
  local setup=0 s
  for s in Read Partition Distribution Refinement Setup; do
    setup=$(awk -v a="$setup" -v b="$(stage "$dir/log_view.txt" $s)" 'BEGIN { printf "%.6g", a + (b == "" ? 0 : b) }')
  done
  local stepping; stepping=$(stage "$dir/log_view.txt" Stepping)
  # steps made, first step, Newton and CG iterations and vertices in contact, from the monitor
  # (a fresh run's first row is its initial state, step 0; a restarted run's is its first step)
  local mon; mon=$(awk -F, 'NR > 1 && $1 > 0 { if (!n) first = $1; n++; nl += $6; li += $7; c = $13 } END { printf "%d,%d,%d,%d,%d", n, first, nl, li, c }' "$dir/monitor.csv" 2>/dev/null)
  [ -z "$mon" ] && mon="0,0,0,0,0"
  [ -n "${NOMON:-}" ] && [ "$status" = ok ] && mon="$NOMON,1,0,0,0"
  local steps=${mon%%,*} rest=${mon#*,}
  local first=${rest%%,*}; rest=${rest#*,}
  echo "$case,$variant,$p,$rep,$status,$rc,$wall,$steps,$first,$setup,${stepping:-},$rest,\"$cmd\"" >> "$CSV"
  printf '[%4ds] %-12s %-8s np %-3s rep %s: %-7s rc %-3s wall %4ss  steps %s  setup %ss  stepping %ss\n' \
    "$(elapsed)" "$case" "$variant" "$p" "$rep" "$status" "$rc" "$wall" "$steps" "$setup" "${stepping:--}"
  if [ "$status" = ok ] && [ -z "${T1[$case/$variant]:-}" ]; then T1[$case/$variant]=$wall; P1[$case/$variant]=$p; fi
  pack
  return 0
}
# $OUT as one archive at $PACK (checkpoints left out), replaced whole so that a killed run leaves the last one
pack() {
  [ -z "$PACK" ] && return 0
  tar -czf "$PACK.part" --exclude='*.bin' --exclude='*.bin.tmp' -C "$(dirname "$OUT")" "$(basename "$OUT")" 2>/dev/null && mv -f "$PACK.part" "$PACK"
}
# try CASE VARIANT P REP ARGS...: run it if its estimate fits what is left of the budget
try() {
  local case=$1 variant=$2 p=$3 rep=$4; shift 4
  local l; l=$(left)
  local est=0
  if [ -n "${T1[$case/$variant]:-}" ]; then
    # the smallest-p run's wall time shared by p / p1 ranks at 60% efficiency, plus start-up
    est=$(awk -v t="${T1[$case/$variant]}" -v p1="${P1[$case/$variant]}" -v p="$p" 'BEGIN { printf "%d", t * p1 / p / 0.6 + 3 }')
  fi
  if [ "$l" -lt 10 ] || [ "$est" -gt "$l" ]; then
    echo "$case,$variant,$p,$rep,skipped,,,,,,,,,,\"estimate ${est}s, ${l}s left\"" >> "$CSV"
    printf '[%4ds] %-12s %-8s np %-3s rep %s: skipped (estimate %ss, %ss left)\n' "$(elapsed)" "$case" "$variant" "$p" "$rep" "$est" "$l"
    return 0
  fi
  local lim=$RUN_MAX; [ "$l" -lt "$lim" ] && lim=$l
  run "$case" "$variant" "$p" "$rep" "$lim" "$@"
}

has() { case " $CASES " in *" $1 "*) return 0;; esac; return 1; }

# the folded state every fold run starts from (SIGTERM at the time limit still leaves a checkpoint)
FOLD_FROM=0
if has fold; then
  l=$(left); lim=$PREFOLD_MAX; [ "$l" -lt "$lim" ] && lim=$l
  mkdir -p "$OUT/fold"
  run fold prefold "$MAXP" 1 "$lim" $FOLD -msim_steps "$PREFOLD_STEPS" -msim_checkpoint "$CKPT" -msim_checkpoint_every 1
  FOLD_FROM=$(awk -F, 'NR > 1 { s = $1 } END { print s + 0 }' "$OUT/fold/prefold_np$MAXP/monitor.csv" 2>/dev/null)
  if [ ! -s "$CKPT" ] || [ "${FOLD_FROM:-0}" -lt 1 ]; then echo "study.sh: no checkpoint; the fold runs start flat"; FOLD_FROM=0; fi
  echo "fold: measured runs go from step $FOLD_FROM to $((FOLD_FROM + CLOTH_STEPS))"
fi
FOLD_RUN="$FOLD -msim_steps $((FOLD_FROM + CLOTH_STEPS))"
[ "$FOLD_FROM" -gt 0 ] && FOLD_RUN="$FOLD_RUN -msim_restart $CKPT"

# one rank count of every case; a repetition (rep 2) runs each pair in the opposite order
round() {
  local p=$1 rep=$2 only=${3:-}
  if has box; then
    if [ "$rep" -eq 1 ]; then try box free "$p" "$rep" $BOX_IMPL; try box contact "$p" "$rep" $BOX_IMPL $BOX_CONTACT
    else try box contact "$p" "$rep" $BOX_IMPL $BOX_CONTACT; try box free "$p" "$rep" $BOX_IMPL; fi
  fi
  if has box_jacobi; then
    if [ "$rep" -eq 1 ]; then try box_jacobi free "$p" "$rep" $BOX_IMPL $BOXJ_PC; try box_jacobi contact "$p" "$rep" $BOX_IMPL $BOX_CONTACT $BOXJ_PC
    else try box_jacobi contact "$p" "$rep" $BOX_IMPL $BOX_CONTACT $BOXJ_PC; try box_jacobi free "$p" "$rep" $BOX_IMPL $BOXJ_PC; fi
  fi
  if has fold; then
    if [ "$rep" -eq 1 ]; then try fold noself "$p" "$rep" $FOLD_RUN -msim_self_contact 0; try fold self "$p" "$rep" $FOLD_RUN -msim_self_contact 1
    else try fold self "$p" "$rep" $FOLD_RUN -msim_self_contact 1; try fold noself "$p" "$rep" $FOLD_RUN -msim_self_contact 0; fi
  fi
  if has box_explicit && [ -z "$only" ]; then
    NOMON=$EXPL_STEPS try box_explicit free "$p" "$rep" $BOX_EXPL
    NOMON=$EXPL_STEPS try box_explicit contact "$p" "$rep" $BOX_EXPL -msim_contact_plane 0,0,1,-1e-5
  fi
}
for p in $RANKS; do round "$p" 1; done
if [ "$REPEAT" -gt 0 ]; then
  for p in $RANKS; do [ "$p" -le 2 ] && round "$p" 2 no_explicit; done
fi
pack
echo "study.sh: done in $(elapsed) s of a $BUDGET s budget; $(grep -c ',ok,' "$CSV") runs ok, $(grep -c ',skipped,' "$CSV") skipped, $(grep -cE ',(failed|timeout),' "$CSV") failed or timed out; results in $OUT"
