#!/usr/bin/env bash
# test_cli_grammar.sh: the one flag grammar of the `ostrich` program (plugin/cli/, compare/).
# A table of (command, canonical flag) pairs: every `--help` shows its flags and the positional
# model, and none shows a deprecated spelling. Each deprecated spelling of the previous release
# (cli_parseArgs' alias table) is still accepted by the commands that had it, prints one
# deprecation note on stderr, and gives the same result as the canonical spelling on a short run.
# A few seconds in all.
#   usage: test_cli_grammar.sh OSTRICH_BIN MODEL_DIR COMPARE_DIR
set -u

BIN=$1
MODELS=$2
LOGS=$3/logs
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/lib.sh"
export OSTRICH_QUIET=1


#---------------------------------- canonical flags in every --help -------------------------------

# command (words joined by '_'), then its canonical flags; MODEL.xml: a positional model
TABLE=(
  "sim MODEL.xml --engine --csv --key --duration --steps"
  "check MODEL.xml --states --seed"
  "gradcheck MODEL.xml --steps --key --ctrl"
  "synth MODEL.xml --engine --csv --plot --trials"
  "bench_scale MODEL.xml --device --repeat --csv --plot --steps"
  "bench_models MODEL.xml --csv --plot --key --duration"
  "compare_sweep MODEL.xml --engine --repeat --out --key --duration"
  "compare_replay MODEL.xml --engine --out"
  "compare_identify MODEL.xml --engine --csv --train --test"
  "compare_gen-logs MODEL.xml --out --seed --logs"
  "compare_hard --engine --csv --h-grid"
  "compare_models --engine --csv --plot --key --duration"
)

for row in "${TABLE[@]}"; do
  read -r -a words <<<"$row"
  read -r -a command <<<"${words[0]//_/ }"
  run "${command[@]}" --help
  for flag in "${words[@]:1}"; do
    # a flag at the start of an option line, or the positional model in the usage line
    if [[ $flag == MODEL.xml ]]; then
      found=$(grep -c "^usage: .*MODEL\.xml" "$tmp/out")
    else
      found=$(grep -c -- "^  $flag " "$tmp/out")
    fi
    if [[ $rc -eq 0 && $found -ge 1 ]]; then
      pass "ostrich ${command[*]} --help shows $flag"
    else
      fail "ostrich ${command[*]} --help: expected $flag"
    fi
  done

  # no deprecated spelling anywhere in the help (--out is canonical only for directories)
  deprecated='--engines|--repeats|--model( |$|[^s])'
  if ! grep -q -- '^  --out DIR' "$tmp/out"; then
    deprecated="$deprecated|--out( |$)"
  fi
  if grep -Eq -- "$deprecated" "$tmp/out"; then
    fail "ostrich ${command[*]} --help shows a deprecated spelling: $(grep -Eo -- "$deprecated" \
      "$tmp/out" | head -n1)"
  else
    pass "ostrich ${command[*]} --help shows no deprecated spelling"
  fi
done

run --help
if [[ $rc -eq 0 ]] && ! grep -Eq -- '--engines|--repeats|--model( |$)' "$tmp/out"; then
  pass "ostrich --help shows no deprecated spelling"
else
  fail "ostrich --help: a deprecated spelling"
fi


#---------------------------------- deprecated spellings ------------------------------------------

# deprecated OLD NEW DESC: the last run succeeded and printed exactly one note naming OLD and NEW
deprecated() {
  local note="^ostrich: .*'$1' is deprecated and will be removed in the next release; use '$2'"
  if [[ $rc -eq 0 && $(grep -c -- "$note" "$tmp/err") -eq 1 ]]; then
    pass "$3: accepted with a deprecation note"
  else
    fail "$3: expected exit 0 and one note \"'$1' is deprecated ... use '$2'\""
  fi
}

# canonical DESC: the last run succeeded without any deprecation note
canonical() {
  if [[ $rc -eq 0 ]] && ! grep -q 'deprecated' "$tmp/err"; then
    pass "$1: no deprecation note"
  else
    fail "$1: expected exit 0 and no deprecation note"
  fi
}

# same_csv DESC A B [COLUMN...]: two CSV files equal once the named columns (timings) are dropped
same_csv() {
  local desc=$1 a=$2 b=$3
  shift 3
  if python3 - "$a" "$b" "$@" <<'EOF'
import csv, sys
def rows(path, drop):
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    return [{k: v for k, v in r.items() if k not in drop} for r in csv.DictReader(lines)]
a, b = rows(sys.argv[1], sys.argv[3:]), rows(sys.argv[2], sys.argv[3:])
sys.exit(0 if a and a == b else 1)
EOF
  then
    pass "$desc"
  else
    fail "$desc: $a and $b differ"
  fi
}

BOX=$MODELS/box_plane.xml
PALLET=$MODELS/robot_pallet.xml
ROBOT_BOX=$MODELS/robot_box.xml

# sim: --out FILE.csv is --csv FILE.csv (byte-identical trajectories)
run sim "$BOX" --h 0.05 --steps 40 --csv "$tmp/sim_new.csv"
canonical "sim --csv"
run sim "$BOX" --h 0.05 --steps 40 --out "$tmp/sim_old.csv"
deprecated --out --csv "sim --out"
if cmp -s "$tmp/sim_new.csv" "$tmp/sim_old.csv" && [[ -s $tmp/sim_new.csv ]]; then
  pass "sim: --out and --csv write byte-identical CSVs"
else
  fail "sim: --out and --csv CSVs differ"
fi

# compare sweep: --engines and --repeats are --engine and --repeat
sweep=(compare sweep "$MODELS/hard_ball_fast.xml" --key 0 --h-grid 0.002,0.01 --duration 0.2)
run "${sweep[@]}" --engine mujoco --repeat 2 --out "$tmp/sweep_new"
canonical "compare sweep --engine --repeat"
run "${sweep[@]}" --engines mujoco --repeats 2 --out "$tmp/sweep_old"
deprecated --engines --engine "compare sweep --engines"
deprecated --repeats --repeat "compare sweep --repeats"
same_csv "compare sweep: the same rows with the old and new spellings (timings aside)" \
  "$tmp/sweep_new/sweep.csv" "$tmp/sweep_old/sweep.csv" wall_s wall_per_sim_s
if [[ $(grep -c '^mujoco,' "$tmp/sweep_old/sweep.csv") -eq 2 ]] &&
   ! grep -q '^ostrich,' "$tmp/sweep_old/sweep.csv" &&
   [[ $(cut -d, -f14 "$tmp/sweep_old/sweep.csv" | sort -u | head -n1) == 2 ]]; then
  pass "compare sweep --engines mujoco --repeats 2: mujoco rows only, 2 repeats each"
else
  fail "compare sweep --engines mujoco --repeats 2: expected two mujoco rows of 2 repeats"
fi

# compare replay: --engines is --engine (the same error, one engine only)
replay=(compare replay "$LOGS/train_02.csv" "$PALLET" --h-mujoco 0.002)
run "${replay[@]}" --engine mujoco
canonical "compare replay --engine"
cp "$tmp/out" "$tmp/replay_new.json"
run "${replay[@]}" --engines mujoco
deprecated --engines --engine "compare replay --engines"
if python3 -c '
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:])
sys.exit(0 if "ostrich" not in b and a["mujoco"]["error"] == b["mujoco"]["error"] else 1)' \
  "$tmp/replay_new.json" "$tmp/out"; then
  pass "compare replay: --engines and --engine give the same error, mujoco only"
else
  fail "compare replay: --engines and --engine results differ"
fi

# compare identify: --engines and --out FILE.csv are --engine and --csv FILE.csv
identify=(compare identify --train "$LOGS/train_02.csv" --test "$LOGS/test_07.csv"
          --h-mujoco 0.002 --friction-grid 0.85 --solref-grid 0.02 "$PALLET")
run "${identify[@]}" --engine mujoco --csv "$tmp/identify_new.csv"
canonical "compare identify --engine --csv"
run "${identify[@]}" --engines mujoco --out "$tmp/identify_old.csv"
deprecated --engines --engine "compare identify --engines"
deprecated --out --csv "compare identify --out"
same_csv "compare identify: --out and --csv write the same table" \
  "$tmp/identify_new.csv" "$tmp/identify_old.csv"

# compare hard: --engines is --engine
hard=(compare hard --cases ball_20ms --h-grid 0.1 --models "$MODELS")
run "${hard[@]}" --engine mujoco --csv "$tmp/hard_new.csv"
canonical "compare hard --engine"
run "${hard[@]}" --engines mujoco --csv "$tmp/hard_old.csv"
deprecated --engines --engine "compare hard --engines"
same_csv "compare hard: --engines and --engine give the same rows (timings aside)" \
  "$tmp/hard_new.csv" "$tmp/hard_old.csv" wall_s

# bench scale: --model FILE is the positional model (the same world counts, nothing failed)
scale=(bench scale --device cpu --worlds 1,2 --steps 2 --repeat 1)
run "${scale[@]}" "$ROBOT_BOX" --csv "$tmp/scale_new.csv"
canonical "bench scale MODEL.xml"
run "${scale[@]}" --model "$ROBOT_BOX" --csv "$tmp/scale_old.csv"
deprecated --model "MODEL.xml (positional)" "bench scale --model"
same_csv "bench scale: --model and the positional model give the same rows (timings aside)" \
  "$tmp/scale_new.csv" "$tmp/scale_old.csv" rollout_s world_rollouts_per_s world_steps_per_s \
  iter_s world_iters_per_s mem_gb fwd_ratio_vs_cpu iter_ratio_vs_cpu

# synth: --model FILE is the positional model (a bad model: the same refusal either way)
run synth "$BOX"
new_err=$(grep -v deprecated "$tmp/err")
new_rc=$rc
run synth --model "$BOX"
old_err=$(grep -v deprecated "$tmp/err")
if [[ $new_rc -eq 2 && $rc -eq 2 && -n $new_err && $new_err == "$old_err" ]] &&
   grep -q "'--model' is deprecated" "$tmp/err"; then
  pass "synth: --model and the positional model give the same refusal ($new_err)"
else
  fail "synth: --model and the positional model differ (exit $new_rc/$rc)"
fi

# compare gen-logs: --model FILE is the positional model (the same log, byte for byte)
run compare gen-logs --out "$tmp/logs_new" --logs 1 "$PALLET"
canonical "compare gen-logs MODEL.xml"
run compare gen-logs --out "$tmp/logs_old" --logs 1 --model "$PALLET"
deprecated --model "MODEL.xml (positional)" "compare gen-logs --model"
if [[ -s $tmp/logs_new/test_01.csv ]] && cmp -s "$tmp/logs_new/test_01.csv" \
     "$tmp/logs_old/test_01.csv"; then
  pass "compare gen-logs: --model and the positional model write the same log"
else
  fail "compare gen-logs: the logs differ"
fi

# a deprecated spelling is an alias only in the commands that had it
for args in "check $BOX --out $tmp/x.csv" "compare hard --out $tmp/x.csv" \
            "compare models $BOX --model $BOX" "bench models $BOX --engines mujoco"; do
  read -r -a words <<<"$args"
  run "${words[@]}"
  if [[ $rc -eq 2 ]] && grep -q "unknown option" "$tmp/err" && ! grep -q deprecated "$tmp/err"
  then
    pass "${words[*]:0:2}: a spelling it never had is an unknown option"
  else
    fail "${words[*]:0:2}: expected exit 2, unknown option, no deprecation note"
  fi
done


#---------------------------------- summary -------------------------------------------------------

echo "test_cli_grammar: $npass passed, $nfail failed"
[[ $nfail -eq 0 ]]
