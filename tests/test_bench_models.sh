#!/usr/bin/env bash
# test_bench_models.sh: end-to-end test of `ostrich bench models`
# (plugin/cli/ost_cli_bench_models.c).
# usage: bash tests/test_bench_models.sh PATH/TO/ostrich PATH/TO/mjcf_models PATH/TO/humanoid.xml
# Runs two small models, a model Ostrich refuses (an actuator with a user gain) and --scaling 1,2 of
# the humanoid, and checks the CSV: its columns, one row per engine and h, positive finite ratios,
# converged shares in [0, 1], the refusal with its message (exit 0: a refusal is a result), the
# scaling rows (nv 27 and 54) and both fits. Then: --repeat times runs several times; --max-wall
# stops runs and says so; a failed
# step is reported and exits 1; a missing model, an unwritable --csv directory and bad lists
# exit 2 before measuring. Every check runs; the script exits 1 if any failed.
set -euo pipefail

if [[ $# -ne 3 ]]; then
  echo "usage: bash $0 PATH/TO/ostrich PATH/TO/mjcf_models PATH/TO/humanoid.xml" >&2
  exit 2
fi
BIN=$1
MODELS=$2
HUMANOID=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export OSTRICH_QUIET=1
source "$(dirname "$0")/lib.sh"


# a failure shows the exit code on its FAIL line, then the last run's output (not the command)
fail_report() {
  echo "FAIL: $1 (exit $rc)"
  fail_output
}


# expect_csv DESC EXPR: python EXPR holds, with rows = the CSV as dicts and head = its header
expect_csv() {
  local why
  if why=$(python3 - "$tmp/out.csv" "$2" 2>&1 <<'EOF'
import csv, math, sys
reader = csv.DictReader(open(sys.argv[1]))
head = reader.fieldnames
rows = list(reader)
def num(s):
    return float(s) if s not in ("", None) else float("nan")
def positive(s):
    return math.isfinite(num(s)) and num(s) > 0
if not eval("(" + sys.argv[2] + ")"):
    sys.exit("\n".join(",".join(r[k] or "" for k in head) for r in rows))
EOF
  ); then
    pass "$1"
  else
    fail "$1: $2"
    echo "$why" | sed 's/^/      csv: /' | head -n 20 >&2
  fi
}


#---------------------------------- a run with a refusal and the scaling --------------------------

cat >"$tmp/refused.xml" <<'EOF'
<mujoco model="refused">
  <worldbody>
    <body>
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05"/>
    </body>
  </worldbody>
  <actuator>
    <general joint="hinge" gaintype="user"/>
  </actuator>
</mujoco>
EOF

run bench models "$MODELS/cartpole.xml" "$MODELS/box_plane.xml" "$tmp/refused.xml" --duration 0.05 \
  --scaling 1,2 --scaling-steps 3 --humanoid "$HUMANOID" --csv "$tmp/out.csv"
if [[ $rc -eq 0 && -s $tmp/out.csv ]] && ! compgen -G "$tmp/out.csv.tmp*" >/dev/null; then
  pass "two models, a refusal and --scaling 1,2: exit 0, CSV written and renamed"
else
  fail "two models, a refusal and --scaling 1,2: expected exit 0 and the CSV"
fi
expect_csv "CSV columns" 'head == ["kind", "model", "copies", "nv", "engine", "h", "h_scale",
  "steps", "sim_s", "wall_s", "us_per_step", "us_per_sim_s", "ratio_step", "ratio_sim_s",
  "converged_share", "status", "slope", "message"]'
expect_csv "CSV rows: 4 + 4 + 2 models, 2 x 2 scaling, 2 fits" \
  '[r["kind"] for r in rows] == ["model"] * 10 + ["scaling"] * 4 + ["fit"] * 2'
expect_csv "each accepted model: mujoco at h, ostrich at h, 5 h and 10 h, all ok" \
  'all([(r["engine"], r["h_scale"], r["status"]) for r in rows if r["model"].endswith(m)]
       == [("mujoco", "1", "ok"), ("ostrich", "1", "ok"), ("ostrich", "5", "ok"),
           ("ostrich", "10", "ok")] for m in ("cartpole.xml", "box_plane.xml"))'
expect_csv "every model run covers the duration (0.05 s); every accepted run was timed" \
  'all(num(r["sim_s"]) >= 0.05 - 1e-9 for r in rows[:8]) and all(positive(r["us_per_step"])
       and positive(r["us_per_sim_s"]) for r in rows[:9] + rows[10:14])'
expect_csv "ratios are positive finite numbers (every ostrich run)" \
  'all(positive(r["ratio_step"]) and positive(r["ratio_sim_s"]) for r in rows
       if r["kind"] != "fit" and r["engine"] == "ostrich" and r["status"] == "ok")'
# an identity between printed columns: 1e-3 covers their rounding (%.3f) on these models
expect_csv "ratio per simulated second = ratio per step x MuJoCo's h / Ostrich's h" \
  'all(abs(num(r["ratio_sim_s"]) * num(r["h"]) / (num(r["ratio_step"]) * num(rows[4 * (i // 4)]["h"])) - 1) < 1e-3
       for i, r in enumerate(rows[:8]) if r["engine"] == "ostrich")'
expect_csv "converged shares in [0, 1]" \
  'all(0 <= num(r["converged_share"]) <= 1 for r in rows if r["kind"] != "fit"
       and r["engine"] == "ostrich" and r["status"] == "ok")'
expect_csv "the refused model: mujoco measured, ostrich refused with the feature named" \
  '[(r["engine"], r["status"]) for r in rows[8:10]] == [("mujoco", "ok"), ("ostrich", "refused")]
   and "gaintype user" in rows[9]["message"]'
expect_csv "scaling: 1 and 2 humanoids (nv 27, 54), both engines at the same h" \
  '[(r["copies"], r["nv"], r["engine"]) for r in rows[10:14]] == [("1", "27", "mujoco"),
   ("1", "27", "ostrich"), ("2", "54", "mujoco"), ("2", "54", "ostrich")]
   and len({r["h"] for r in rows[10:14]}) == 1 and positive(rows[11]["ratio_step"])'
expect_csv "fits: a finite slope for each engine" \
  '[r["engine"] for r in rows[14:]] == ["mujoco", "ostrich"]
   and all(math.isfinite(num(r["slope"])) for r in rows[14:])'
if grep -q "refused by Ostrich: .*gaintype user" "$tmp/out" && grep -q "^fit of log" "$tmp/out"; then
  pass "the table names the refusal and prints the fit"
else
  fail "the table should name the refusal and print the fit"
fi


#---------------------------------- stopped runs and usage errors ---------------------------------

run bench models "$MODELS/cartpole.xml" --duration 0.05 --max-wall 1e-9 --h-scale 2 \
  --csv "$tmp/out.csv"
if [[ $rc -eq 0 ]]; then pass "--max-wall: exit 0"; else fail "--max-wall: expected exit 0"; fi
expect_csv "--max-wall: every run stopped after one step, and says so" \
  '[r["status"] for r in rows] == ["stopped"] * 3 and all(r["steps"] == "1" and
   "--max-wall" in r["message"] for r in rows)'

# --repeat: each run timed 3 times from the same start, the median kept; the step counts are
# those of one run (the same start every time)
run bench models "$MODELS/cartpole.xml" --duration 0.05 --h-scale 2 --repeat 3 --csv "$tmp/out.csv"
if [[ $rc -eq 0 ]]; then pass "--repeat 3: exit 0"; else fail "--repeat 3: expected exit 0"; fi
expect_csv "--repeat 3: every run ok, the steps of one run, a positive time" \
  '[r["status"] for r in rows] == ["ok"] * 3 and all(abs(num(r["sim_s"]) - 0.05) < 0.02
   and positive(r["us_per_step"]) for r in rows) and positive(rows[1]["ratio_step"])'

# a failed step (81 resting contacts where Ostrich may grow to 64) stops that run, is reported,
# and exits 1
run bench models "$MODELS/../tests/models/too_many_contacts.xml" --duration 0.01 --h-scale 2 \
  --csv "$tmp/out.csv"
if [[ $rc -eq 1 ]]; then pass "a failed step: exit 1"; else fail "a failed step: expected exit 1"; fi
expect_csv "a failed step: ostrich runs failed with the message, MuJoCo's warnings noted" \
  '[r["status"] for r in rows] == ["ok", "failed", "failed"] and all("capacity" in r["message"]
   for r in rows[1:]) and "contact full" in rows[0]["message"]'

# expect_usage DESC ARGS...: exit 2, nothing measured (empty stdout), one "ostrich:" line
expect_usage() {
  local desc=$1
  shift
  rm -f "$tmp/out.csv"
  run bench models "$@"
  if [[ $rc -eq 2 && ! -s $tmp/out && ! -e $tmp/out.csv ]] && grep -q '^ostrich: ' "$tmp/err"
  then
    pass "$desc (exit 2: $(head -n 1 "$tmp/err"))"
  else
    fail "$desc: expected exit 2, nothing on stdout"
  fi
}

expect_usage "a missing model" "$MODELS/cartpole.xml" "$tmp/missing.xml" --csv "$tmp/out.csv"
expect_usage "an unwritable --csv directory" "$MODELS/cartpole.xml" --csv "$tmp/no/dir/x.csv"
expect_usage "a bad --h-scale" "$MODELS/cartpole.xml" --h-scale 5,-1
expect_usage "a bad --scaling" --scaling 1,x
expect_usage "--repeat 0" "$MODELS/cartpole.xml" --repeat 0
expect_usage "no model and no --scaling" --duration 1
run bench models --help
if [[ $rc -eq 0 ]] && grep -q -- "--scaling-steps" "$tmp/out"; then
  pass "--help (exit 0)"
else
  fail "--help: expected exit 0 and the options"
fi

if [[ $nfail -gt 0 ]]; then
  echo "$nfail check(s) failed" >&2
  exit 1
fi
echo "all checks passed"
