#!/usr/bin/env bash
# test_compare_sweep.sh: end-to-end tests of `ostrich compare sweep | replay | identify |
# gen-logs` (compare/compare_sweep.c, compare_replay.c, compare_run.c).
# usage: bash tests/test_compare_sweep.sh PATH/TO/ostrich PATH/TO/mjcf_models PATH/TO/compare
# Checks bad inputs (exit 2, one "ostrich:" line, nothing on stdout); a reduced sweep on the
# pallet (3 step sizes, both engines, 2.5 s) and its CSV, JSON and plots; gen-logs and a replay
# of the generated log at the true parameters (error = the noise floor); a replay of a shipped
# log with both engines; a small identify that must find the true parameters. A few seconds.
# Every check runs; the script exits 1 if any failed.
set -euo pipefail

if [[ $# -ne 3 ]]; then
  echo "usage: bash $0 PATH/TO/ostrich PATH/TO/mjcf_models PATH/TO/compare" >&2
  exit 2
fi
BIN=$1
PALLET=$2/robot_pallet.xml
LOGS=$3/logs
COMMANDS=$3/pallet_commands.csv
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/lib.sh"


# a failure shows 3 lines of stdout and 5 of stderr, less MuJoCo's warnings
fail_out() { head -n 3; }
fail_err() { without_mujoco_warnings | head -n 5; }


# expect_py DESC EXPR [CSV]: exit 0 and python EXPR holds, with j = the single JSON line on
# stdout and rows = the CSV file as dicts (one per data row, '#' lines skipped)
expect_py() {
  local desc=$1 expr=$2 csv=${3:-}
  local why
  if [[ $rc -ne 0 ]]; then
    fail "$desc: expected exit 0"
    return
  fi
  if why=$(python3 - "$tmp/out" "$expr" "$csv" 2>&1 <<'EOF'
import csv, json, math, sys
lines = open(sys.argv[1]).read().splitlines()
if len(lines) != 1:
    sys.exit("stdout has %d lines, expected exactly one JSON line" % len(lines))
j = json.loads(lines[0])
rows = None
if sys.argv[3]:
    rows = list(csv.DictReader(l for l in open(sys.argv[3]) if not l.startswith("#")))
def row(engine, h):  # the sweep row of one engine and step
    return next(r for r in rows if r["engine"] == engine and float(r["h"]) == h)
try:
    ok = eval("(" + sys.argv[2] + ")")
except Exception as e:
    sys.exit("%s: %s" % (type(e).__name__, e))
if not ok:
    sys.exit("json: " + lines[0])
EOF
  ); then
    pass "$desc"
  else
    fail "$desc: $expr"
    echo "$why" | sed 's/^/      /' >&2
  fi
}


#---------------------------------- bad inputs ----------------------------------------------------

printf 'time,v_left,v_right\n0,1,1\n' >"$tmp/two_columns.csv"
printf 'time,v_left,v_right,v_rear\n0,1,1,1\n0.5,nan,1,1\n' >"$tmp/nan.csv"
printf 'time,v_left,v_right,v_rear\n0,1,1\n' >"$tmp/short_row.csv"
printf 'time,cmd_left,cmd_right,cmd_rear,x,y\n0,0,0,0,0,0\n' >"$tmp/bad_log.csv"
printf 'time,cmd_left,cmd_right,cmd_rear,x,y,z,yaw\n0,0,0,0,0,0,0.35,inf\n' >"$tmp/inf_log.csv"

for sub in sweep replay identify gen-logs; do
  run compare "$sub" --help
  if [[ $rc -eq 0 ]] && grep -q usage "$tmp/out"; then pass "compare $sub --help"; else
    fail "compare $sub --help: expected usage on stdout, exit 0"; fi
done
expect_usage_error "sweep: missing model file" compare sweep "$tmp/none.xml" --out "$tmp/s"
expect_usage_error "sweep: missing command file" compare sweep "$PALLET" --ctrl-file "$tmp/none.csv"
expect_usage_error "sweep: command file with nu - 1 controls" compare sweep "$PALLET" \
  --ctrl-file "$tmp/two_columns.csv"
expect_usage_error "sweep: NaN command" compare sweep "$PALLET" --ctrl-file "$tmp/nan.csv"
expect_usage_error "sweep: malformed row" compare sweep "$PALLET" --ctrl-file "$tmp/short_row.csv"
expect_usage_error "sweep: bad h grid" compare sweep "$PALLET" --h-grid 0.01,abc
expect_usage_error "sweep: negative h" compare sweep "$PALLET" --h-grid 0.01,-0.1
expect_usage_error "sweep: unknown engine" compare sweep "$PALLET" --engine ostrich,bullet
expect_usage_error "sweep: malformed reference" compare sweep "$PALLET" --reference \
  "$tmp/two_columns.csv" --h-grid 0.01 --out "$tmp/s"
expect_usage_error "sweep: --key beyond the model's keyframes" compare sweep "$PALLET" --key 3 \
  --out "$tmp/k"
expect_usage_error "replay: missing log" compare replay "$tmp/none.csv" "$PALLET"
expect_usage_error "replay: no model" compare replay "$LOGS/train_02.csv"
expect_usage_error "replay: wrong log columns" compare replay "$tmp/bad_log.csv" "$PALLET"
expect_usage_error "replay: non-finite pose" compare replay "$tmp/inf_log.csv" "$PALLET"
expect_usage_error "identify: no --train" compare identify --test "$LOGS/test_07.csv" "$PALLET"
expect_usage_error "identify: missing test log" compare identify --train "$LOGS/train_02.csv" \
  --test "$tmp/none.csv" "$PALLET"
expect_usage_error "gen-logs: no --out" compare gen-logs


#---------------------------------- sweep ---------------------------------------------------------

# the pallet for 2.5 s (the front wheels meet the edge), h = 2, 10, 50 ms, two repeats (the
# second with commands perturbed by 1e-9); the reference is stock MuJoCo at 2 ms, so that run
# is its own reference
out=$tmp/sweep
run compare sweep "$PALLET" --ctrl-file "$COMMANDS" --h-grid 0.05,0.002,0.01 --h-ref 0.002 \
  --duration 2.5 --repeat 2 --out "$out"
expect_py "sweep: JSON summary" \
  'j["runs"] == 6 and j["repeats"] == 2 and j["h_grid"] == [0.002, 0.01, 0.05] and
   j["duration"] == 2.5 and j["reference"] == {"engine": "mujoco", "h": 0.002}'
expect_py "sweep: one CSV row per engine and h, two repeats each" \
  'len(rows) == 6 and [r["engine"] for r in rows] == ["ostrich"] * 3 + ["mujoco"] * 3 and
   all(r["repeats"] == "2" for r in rows)' "$out/sweep.csv"
expect_py "sweep: the reference run has error 0 against itself" \
  'float(row("mujoco", 0.002)["error_max"]) == 0 and row("mujoco", 0.002)["diverged"] == "0"' \
  "$out/sweep.csv"
# regression baseline (measured: 2.6 to 3.2 cm, the model offset described below): 6 cm
expect_py "sweep: Ostrich completes at every h, errors finite and below 6 cm" \
  'all(r["outcome"] == "completed" and float(r["error_max"]) < 0.06 for r in rows
       if r["engine"] == "ostrich")' "$out/sweep.csv"
# Ostrich (hard contact, exact cylinder-box geometry) and MuJoCo (soft contact, MPR) differ by a
# model offset that does not shrink with h: measured 2.6 cm at 2 ms, 3.1 / 3.2 cm at 10 / 50 ms;
# 4 cm and 1.5x are regression baselines over those values
expect_py "sweep: Ostrich at h = 10 and 50 ms within 4 cm of MuJoCo at 2 ms, and within 1.5x its own 2 ms error" \
  'float(row("ostrich", 0.01)["error_max"]) < 0.04 and
   float(row("ostrich", 0.05)["error_max"]) < 0.04 and
   float(row("ostrich", 0.05)["error"]) < 1.5 * float(row("ostrich", 0.002)["error"])' \
  "$out/sweep.csv"
expect_py "sweep: MuJoCo at h = 10 ms diverges (NaN) on the pallet" \
  'row("mujoco", 0.01)["diverged"] == "1" and row("mujoco", 0.01)["outcome"] == "nan" and
   row("mujoco", 0.01)["diverged_repeats"] == "2"' "$out/sweep.csv"
expect_py "sweep: wall time per simulated second positive, Ostrich faster at larger h" \
  'all(float(r["wall_per_sim_s"]) > 0 for r in rows) and
   float(row("ostrich", 0.05)["wall_per_sim_s"]) < float(row("ostrich", 0.002)["wall_per_sim_s"])' \
  "$out/sweep.csv"
expect_py "sweep: plateaus (MuJoCo its reference 2 ms, Ostrich from 2 ms up to 50 ms) and ratio" \
  'j["mujoco"]["plateau_h"] == 0.002 and j["mujoco"]["min_error"] == 0 and
   j["ostrich"]["plateau_h"] == 0.05 and j["ostrich"]["plateau_lo"] == 0.002 and
   abs(j["plateau_ratio"] - j["ostrich"]["plateau_h"] / 0.002) < 1e-9 and
   j["mujoco"]["diverged"] == 2'
if command -v gnuplot >/dev/null; then
  if [[ -s $out/error_vs_h.png && -s $out/error_vs_walltime.png ]]; then
    pass "sweep: both plots written"
  else
    fail "sweep: expected error_vs_h.png and error_vs_walltime.png"
  fi
else
  expect_py "sweep: without gnuplot, plots skipped" 'j["plots"] == False'
fi


#---------------------------------- gen-logs and replay -------------------------------------------

# the first synthetic log (0.12 m/s, 31 s), replayed by stock MuJoCo at the reference's step and
# "true" parameters: only the noise remains, sqrt(3 * 0.01^2 + (0.5 * 0.01)^2) = 0.018 m
run compare gen-logs --out "$tmp/logs" --logs 1 --seed 7 "$PALLET"
expect_py "gen-logs: one log, labelled synthetic" \
  'j["logs"] == 1 and j["synthetic"] and j["test"] == 1 and
   "SYNTHETIC" in open("'"$tmp"'/logs/test_01.csv").readline()'
expect_py "gen-logs: 100 Hz rows, 8 columns, the default commands written" \
  'len(rows) == 3130 and list(rows[0]) == ["time", "cmd_left", "cmd_right", "cmd_rear", "x",
   "y", "z", "yaw"] and abs(float(rows[1]["time"]) - 0.01) < 1e-12 and
   open("'"$tmp"'/logs/pallet_commands.csv").read() == open("'"$COMMANDS"'").read()' \
  "$tmp/logs/test_01.csv"
run compare replay "$tmp/logs/test_01.csv" "$PALLET" --engine mujoco --h-mujoco 0.0005 \
  --kv 270 --friction 0.85
# the logs' Gaussian noise (sigma 1 cm on x, y, z and 0.01 rad on yaw, GENLOG_SIGMA_* in
# compare/compare_replay.c) is the floor; the bracket is a regression baseline around it
expect_py "replay: the generating engine and parameters give the noise floor" \
  '0.012 < j["mujoco"]["error"] < 0.025 and "ostrich" not in j'

# a shipped log (1.02 m/s, a 90 deg right turn) with both engines at the model's parameters; the
# log comes from MuJoCo, so Ostrich carries the model offset (measured 0.072 m, MuJoCo 0.027 m;
# 10 cm and 5 cm are regression baselines over those)
run compare replay "$LOGS/train_02.csv" "$PALLET" --out "$tmp/replay"
expect_py "replay: MuJoCo within 5 cm, Ostrich within 10 cm on train_02" \
  'j["duration"] == 7.6 and j["ostrich"]["error"] < 0.1 and j["mujoco"]["error"] < 0.05 and
   j["ostrich"]["outcome"] == "completed" and j["ostrich"]["steps"] == 152'
expect_py "replay: trajectory written" 'len(rows) == 153 and float(rows[-1]["x"]) > 5' \
  "$tmp/replay/replay_ostrich.csv"


# --key: every run and the reference start from the keyframe (a ball thrown down at 20 m/s from
# 1.1 m hits the floor within 0.2 s, so both engines move it; from qpos0 it would rest)
run compare sweep "$2/hard_ball_fast.xml" --key 0 --h-grid 0.002,0.01 --repeat 1 \
  --duration 0.2 --out "$tmp/sweep_key"
expect_py "sweep --key 0: runs start from the keyframe (the ball moves in every run)" \
  'j["key"] == 0 and j["runs"] == 4 and j["ostrich"]["diverged"] == 0 and
   j["mujoco"]["min_error"] > 0 and j["ostrich"]["min_error"] > 0'
expect_py "sweep --key 0: every row completed" \
  'len(rows) == 4 and all(r["outcome"] == "completed" for r in rows)' "$tmp/sweep_key/sweep.csv"


#---------------------------------- identify ------------------------------------------------------

# one training and one held-out log, 2 x 2 grids: MuJoCo, which generated the logs, must find
# its true friction and solref; Ostrich (a different contact model) its best-fitting kv (the
# true 270; measured friction 0.7), and identification must not hurt its held-out error
# (measured 0.092 m against 0.098 m at the model's defaults; 10 cm and 4 cm are regression
# baselines, 4 cm a margin over the logs' noise floor)
run compare identify --train "$LOGS/train_02.csv" --test "$LOGS/test_07.csv" \
  --kv-grid 270,330 --friction-grid 0.7,0.85 --solref-grid 0.02 --csv "$tmp/identify.csv" \
  "$PALLET"
expect_py "identify: true parameters found (MuJoCo), true kv (Ostrich)" \
  'j["ostrich"]["kv"] == 270 and j["mujoco"]["friction"] == 0.85 and j["mujoco"]["solref"] == 0.02'
expect_py "identify: held-out errors below 4 cm (MuJoCo) and 10 cm (Ostrich), not above the defaults, no failed run" \
  'j["ostrich"]["test_error"] < 0.1 and j["mujoco"]["test_error"] < 0.04 and
   j["ostrich"]["test_error"] <= j["ostrich"]["test_model_defaults_error"] and
   j["ostrich"]["test_failed"] == 0 and j["common_test_logs"] == 1'
expect_py "identify: CSV has every run (4 + 2 training, 2 + 2 held-out)" \
  'len(rows) == 10 and sum(r["split"] == "train" for r in rows) == 6' "$tmp/identify.csv"


echo "$npass passed, $nfail failed"
[[ $nfail -eq 0 ]]
