#!/usr/bin/env bash
# test_cli_outputs.sh: the output files of the `ostrich` program (cli_checkOutput,
# cli_openOutput, cli_commitOutput in plugin/cli/ost_cli_util.c). A run killed with SIGKILL while
# it writes leaves the previous file byte-identical (sim streams its trajectory into a temporary
# file, renamed only at the end); an output in a directory that does not exist is refused with
# exit 2 before any work, by every command that writes one, in well under a second, with a
# message naming the path. A few seconds in all.
#   usage: test_cli_outputs.sh OSTRICH_BIN MODEL_DIR COMPARE_DIR
set -u

BIN=$1
MODELS=$2
LOGS=$3/logs
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/lib.sh"
export OSTRICH_QUIET=1

BOX=$MODELS/box_plane.xml
PALLET=$MODELS/robot_pallet.xml


#---------------------------------- a killed run --------------------------------------------------

# kill_mid_run DESC FILE ARGS...: FILE holds earlier results; start `ostrich ARGS...` (which writes
# FILE and would run for minutes), wait until its temporary file has data, kill it with SIGKILL,
# and check that FILE is byte-identical to before
kill_mid_run() {
  local desc=$1 file=$2
  shift 2
  printf 'earlier results\n1,2,3\n' >"$file"
  cp "$file" "$tmp/before"
  "$BIN" "$@" >/dev/null 2>"$tmp/err" &
  local pid=$! waited=0
  # the run is writing once FILE.tmp<pid> has data (at most 10 s)
  while [[ ! -s $file.tmp$pid && $waited -lt 100 ]] && kill -0 "$pid" 2>/dev/null; do
    sleep 0.1
    waited=$((waited + 1))
  done
  local writing=0
  [[ -s $file.tmp$pid ]] && writing=1
  kill -9 "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
  rc=$?
  cmd=("$@" "(killed)")
  : >"$tmp/out"
  if [[ $writing -eq 1 && $rc -eq 137 ]] && cmp -s "$file" "$tmp/before"; then
    pass "$desc: killed mid-run (exit 137), the previous file is byte-identical"
  elif [[ $writing -eq 0 ]]; then
    fail "$desc: the run never wrote its temporary file $file.tmp$pid"
  else
    fail "$desc: the previous file changed (exit $rc)"
  fi
}

kill_mid_run "sim --csv over an existing file" "$tmp/traj.csv" \
  sim "$BOX" --h 0.001 --steps 100000000 --csv "$tmp/traj.csv"

# the same run, finished, replaces the file whole and leaves no temporary file (the killed
# run's stays: a stale temporary is all a kill can leave)
stale=$(ls "$tmp" | grep -c '^traj\.csv\.tmp')
run sim "$BOX" --h 0.05 --steps 10 --csv "$tmp/traj.csv"
if [[ $rc -eq 0 && $(wc -l <"$tmp/traj.csv") -eq 12 ]] && head -n1 "$tmp/traj.csv" |
     grep -q '^time,qpos_0' && [[ $(ls "$tmp" | grep -c '^traj\.csv\.tmp') -eq $stale ]]
then
  pass "sim --csv: a finished run replaces the file (header and 11 rows), no temporary left"
else
  fail "sim --csv: expected the new CSV of 12 lines and no new temporary file"
fi

# a failed simulation keeps its CSV (the steps taken), as before: too_many_contacts.xml (more
# contacts than Ostrich may grow to) fails at step 1
run sim "$MODELS/../tests/models/too_many_contacts.xml" --h 0.05 --steps 10 --csv "$tmp/fail.csv"
if [[ $rc -eq 1 && -s $tmp/fail.csv ]] && head -n1 "$tmp/fail.csv" | grep -q '^time,'; then
  pass "sim --csv: a failed step (exit 1) still writes the CSV of the steps taken"
else
  fail "sim --csv: a failed step: expected exit 1 and the CSV"
fi


#---------------------------------- unwritable outputs --------------------------------------------

# refused DESC PATH ARGS...: exit 2 within 2 s (each run below would take far longer if it
# started its work), nothing on stdout, no progress line, one message that names PATH
refused() {
  local desc=$1 path=$2
  shift 2
  local start=$SECONDS
  OSTRICH_QUIET=0 timeout 60 "$BIN" "$@" >"$tmp/out" 2>"$tmp/err"
  rc=$?
  cmd=("$@")
  local took=$((SECONDS - start))
  if [[ $rc -eq 2 && ! -s $tmp/out && $took -le 2 ]] && grep -qF -- "$path" "$tmp/err" &&
     [[ $(grep -c '^ostrich: ' "$tmp/err") -eq 1 ]]; then
    pass "$desc: exit 2 in ${took} s before any work ($(head -n1 "$tmp/err"))"
  else
    fail "$desc: expected exit 2 within 2 s and one message naming $path (took ${took} s)"
  fi
}

NO=$tmp/no/such/dir
refused "sim --csv" "$NO/t.csv" sim "$BOX" --h 0.001 --steps 100000000 --csv "$NO/t.csv"
refused "synth --csv" "$NO/s.csv" synth "$MODELS/robot_box.xml" --trials 50 --csv "$NO/s.csv"
refused "synth --plot" "$NO/s.png" synth "$MODELS/robot_box.xml" --trials 50 --plot "$NO/s.png"
refused "bench scale --csv" "$NO/b.csv" bench scale --device cpu --worlds 4096 \
  "$MODELS/robot_box.xml" --csv "$NO/b.csv"
refused "bench models --csv" "$NO/m.csv" bench models "$BOX" --duration 1000 --csv "$NO/m.csv"
refused "compare sweep --out" "$NO/sweep" compare sweep "$PALLET" --repeat 50 --out "$NO/sweep"
refused "compare replay --out" "$NO/replay" compare replay "$LOGS/train_02.csv" "$PALLET" \
  --h-mujoco 1e-5 --out "$NO/replay"
refused "compare identify --csv" "$NO/i.csv" compare identify --train "$LOGS/train_02.csv" \
  --test "$LOGS/test_07.csv" "$PALLET" --csv "$NO/i.csv"
refused "compare gen-logs --out" "$NO/logs" compare gen-logs --out "$NO/logs"
refused "compare hard --csv" "$NO/h.csv" compare hard --models "$MODELS" \
  --duration-scale 100 --csv "$NO/h.csv"
refused "compare models --csv" "$NO/c.csv" compare models "$BOX" --duration 1000 \
  --csv "$NO/c.csv"

# a directory where a file is expected
refused "sim --csv DIR" "$tmp" sim "$BOX" --h 0.001 --steps 100000000 --csv "$tmp"


#---------------------------------- summary -------------------------------------------------------

echo "test_cli_outputs: $npass passed, $nfail failed"
[[ $nfail -eq 0 ]]
