#!/usr/bin/env bash
# test_compare_hard.sh: end-to-end tests of `ostrich compare hard` (compare/compare_hard*.c).
# usage: bash tests/test_compare_hard.sh PATH/TO/ostrich PATH/TO/mjcf_models run|usage
#   run:   the incline pair, the fast ball and the 1:1000 stack at h = 0.01 and 0.1 s with both
#          engines; checks the JSON line, the CSV and the physics of Ostrich's rows against
#          numbers computed here (the sliding acceleration g (sin 27 - 0.5 cos 27), the ball's
#          rest height), and that a MuJoCo-only run exits 0 whatever MuJoCo does.
#   usage: bad input (unknown case, bad --h-grid, unknown engine, missing models) exits 2 with
#          one "ostrich:" line on stderr and nothing on stdout; --help exits 0.
# Every check runs; the script exits 1 if any failed.
set -euo pipefail

if [[ $# -ne 3 || ( $3 != run && $3 != usage ) ]]; then
  echo "usage: bash $0 PATH/TO/ostrich PATH/TO/mjcf_models run|usage" >&2
  exit 2
fi
BIN=$1
MODELS=$2
MODE=$3
export OSTRICH_QUIET=0            # the progress lines are checked
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/lib.sh"


# a failure shows the first 600 bytes of stdout and the last 5 lines of stderr
fail_out() { head -c 600; }
fail_err() { tail -n 5; }


# expect_usage_error DESC ARGS...: exit 2, nothing on stdout, an "ostrich:" line on stderr (this
# script's own, in place of lib.sh's: ARGS follow `compare hard`, and one message for any miss)
expect_usage_error() {
  local desc=$1
  shift
  run compare hard "$@"
  if [[ $rc -eq 2 && ! -s $tmp/out ]] && grep -q '^ostrich: ' "$tmp/err"; then
    pass "$desc ($(grep -m1 '^ostrich: ' "$tmp/err"))"
  else
    fail "$desc: expected exit 2, empty stdout, an 'ostrich:' message"
  fi
}


# expect_py DESC EXPR: python EXPR holds, with j = the JSON line on stdout, rows = the CSV as
# dicts, osts / mjs = j's Ostrich / MuJoCo results and r(case, engine, h) one result
expect_py() {
  local desc=$1 expr=$2 why
  if why=$(python3 - "$tmp/out" "$tmp/hard.csv" "$expr" 2>&1 <<'EOF'
import csv, json, math, sys
lines = open(sys.argv[1]).read().splitlines()
assert len(lines) == 1, "stdout has %d lines" % len(lines)
j = json.loads(lines[0])
rows = list(csv.DictReader(open(sys.argv[2]))) if sys.argv[2] else []
osts = [x for x in j["results"] if x["engine"] == "ostrich"]
mjs = [x for x in j["results"] if x["engine"] == "mujoco"]
def r(case, engine, h):
    return next(x for x in j["results"] if (x["case"], x["engine"], x["h"]) == (case, engine, h))
if not eval(sys.argv[3]):
    sys.exit("false")
EOF
  ); then
    pass "$desc"
  else
    fail "$desc: $expr: $why"
  fi
}


if [[ $MODE == run ]]; then
  # the four cases at two step sizes, both engines
  run compare hard --cases incline_stick,incline_slide,ball_20ms,stack --h-grid 0.01,0.1 \
      --models "$MODELS" --csv "$tmp/hard.csv"
  if [[ $rc -eq 0 ]]; then pass "4 cases x 2 h x 2 engines (exit 0)"; else fail "expected exit 0"; fi
  expect_py "JSON: 16 runs, 8 expected, none failed" \
    'j["runs"] == 16 and j["ostrich_expected"] == 8 and j["ostrich_failed"] == 0 and j["ok"]'
  # the bounds of compare/compare_hard_cases.c, each with its reason there: hard contact shows
  # no visible (1 mm) sinking, creep (0.1 mm) or energy gain; Coulomb sliding is exact in
  # backward Euler, so the 1 % on the analytic acceleration is margin
  expect_py "Ostrich: every run finished, expected, within bounds, penetration < 1 mm" \
    'len(osts) == 8 and all(x["status"] == "finished" and x["expected"] and x["within_bounds"]
     and x["max_penetration"] < 1e-3 and x["energy_gain"] < 1e-3 for x in osts)'
  expect_py "Ostrich: sliding acceleration = g (sin 27 - 0.5 cos 27) within 1 %" \
    'all(abs(r("incline_slide", "ostrich", h)["aux"] / (9.81 * (math.sin(math.radians(27))
     - 0.5 * math.cos(math.radians(27)))) - 1) < 0.01 for h in (0.01, 0.1))'
  expect_py "Ostrich: the box at 26 deg moves < 0.1 mm" \
    'all(r("incline_stick", "ostrich", h)["metric"] < 1e-4 for h in (0.01, 0.1))'
  expect_py "Ostrich: the ball rests on the floor (z = r), rebound < 1 mm" \
    'all(abs(r("ball_20ms", "ostrich", h)["aux"] - 0.1) < 1e-3
     and r("ball_20ms", "ostrich", h)["metric"] < 1e-3 for h in (0.01, 0.1))'
  expect_py "Ostrich: the stack sinks < 1 mm and does not drift" \
    'all(r("stack", "ostrich", h)["metric"] < 1e-3 and r("stack", "ostrich", h)["aux"] < 1e-3
     for h in (0.01, 0.1))'
  expect_py "MuJoCo: 8 runs, reported, never expected" \
    'len(mjs) == 8 and not any(x["expected"] for x in mjs) and all(x["status"] in
     ("finished", "nan", "diverged", "failed") for x in mjs)'
  expect_py "CSV: one row per run, same numbers as the JSON line" \
    'len(rows) == 16 and all(row["case"] == x["case"] and row["engine"] == x["engine"]
     and row["status"] == x["status"] and float(row["h"]) == x["h"]
     and math.isclose(float(row["max_penetration"]), x["max_penetration"], rel_tol=1e-8)
     and math.isclose(float(row["metric"]), x["metric"], rel_tol=1e-8, abs_tol=1e-300)
     for row, x in zip(rows, j["results"]))'
  if grep -q '^ostrich: \[16/16\] ball_20ms h=0.1 mujoco: ' "$tmp/err" &&
     grep -q 'incline_slide: box on a 27 deg incline' "$tmp/err"; then
    pass "stderr: progress per run and the table"
  else
    fail "stderr: expected progress lines and the table"
  fi

  # MuJoCo alone is never expected to pass: exit 0 even where it breaks every bound
  run compare hard --cases ball_20ms --h-grid 0.1 --engine mujoco --models "$MODELS"
  if [[ $rc -eq 0 ]]; then pass "MuJoCo only (exit 0)"; else fail "MuJoCo only: expected exit 0"; fi
  expect_py "MuJoCo only: nothing expected" \
    'j["runs"] == 1 and j["ostrich_expected"] == 0 and not mjs[0]["within_bounds"]'
else
  expect_usage_error "unknown case" --cases incline_stick,nope --models "$MODELS"
  expect_usage_error "--h-grid not a number" --h-grid 0.01,abc --models "$MODELS"
  expect_usage_error "--h-grid zero" --h-grid 0,0.1 --models "$MODELS"
  expect_usage_error "--h-grid empty item" --h-grid 0.01,,0.1 --models "$MODELS"
  expect_usage_error "--h-grid empty" --h-grid "" --models "$MODELS"
  expect_usage_error "unknown engine" --engine ostrich,bullet --models "$MODELS"
  expect_usage_error "missing models directory" --cases stack --models "$tmp/none"
  expect_usage_error "unknown option" --h 0.01
  run compare hard --help
  if [[ $rc -eq 0 ]] && grep -q 'grazing' "$tmp/out"; then pass "--help (exit 0)"; else
    fail "--help: expected exit 0 and the case list"; fi
fi

if [[ $nfail -gt 0 ]]; then
  echo "$nfail check(s) failed" >&2
  exit 1
fi
echo "all checks passed"
