#!/usr/bin/env bash
# test_compare_models.sh: end-to-end tests of `ostrich compare models` (compare/compare_models*.c).
# usage: bash tests/test_compare_models.sh PATH/TO/ostrich PATH/TO/mjcf_models PATH/TO/tests/models
#            MODE [SAMPLE_MODEL...]
# MODE run:     box_plane and cartpole, both engines, both kinds of controls, h x 1,2,5,10: the
#               CSV's columns and the physics of its numbers, the table and summary, the plot.
# MODE refused: a refused model and a malformed one are rows with their reasons (exit 0), a
#               failed Ostrich step on an accepted model makes the exit status 1.
# MODE outputs: bad output paths are rejected before any run (exit 2); a run killed with -9
#               leaves the previous CSV whole.
# MODE corpus:  the sample models given (Debian's libmujoco-samples that Ostrich accepts),
#               briefly (0.2 s at h x 1 and 5): no Ostrich run diverges or fails, and the share of
#               converged steps per model is at least the bound stated below.
# Every check runs; the script exits 1 if any failed.
set -euo pipefail

if [[ $# -lt 4 ]]; then
  echo "usage: bash $0 PATH/TO/ostrich PATH/TO/mjcf_models PATH/TO/tests/models MODE [MODEL...]" >&2
  exit 2
fi
BIN=$1
MODELS=$2
TEST_MODELS=$3
MODE=$4
shift 4
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/lib.sh"


# a failure shows the last 12 lines of stdout and 5 of stderr, less MuJoCo's warnings
fail_out() { tail -n 12; }
fail_err() { without_mujoco_warnings | head -n 5; }


# expect_py DESC EXPR CSV: python EXPR holds, with rows = the CSV's rows as dicts, row(model,
# engine, ctrl, scale) one of them, num(r, column) a number (NaN if empty), out = stdout's text
expect_py() {
  local desc=$1 expr=$2 csv=$3
  local why
  if why=$(python3 - "$csv" "$expr" "$tmp/out" 2>&1 <<'EOF'
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
header = open(sys.argv[1]).readline().strip().split(",")
out = open(sys.argv[3]).read()
def row(model, engine, ctrl, scale):
    return next(r for r in rows if r["model"] == model and r["engine"] == engine and
                r["ctrl"] == ctrl and float(r["h_scale"]) == scale)
def num(r, column):
    return float(r[column]) if r[column] != "" else float("nan")
try:
    ok = eval("(" + sys.argv[2] + ")")
except Exception as e:
    sys.exit("%s: %s" % (type(e).__name__, e))
if not ok:
    sys.exit("false")
EOF
  ); then
    pass "$desc"
  else
    fail "$desc: $expr"
    echo "$why" | sed 's/^/      /' >&2
  fi
}


HEADER="model,engine,ctrl,h_scale,h,status,steps,simulated_s,converged_pct,unconverged_steps,\
failed_steps,max_penetration,wall_per_sim_s,error,reason"

case $MODE in

#---------------------------------- run -----------------------------------------------------------
run)
  csv=$tmp/models.csv
  run compare models "$MODELS/box_plane.xml" "$MODELS/cartpole.xml" --duration 0.5 --csv "$csv" \
    --plot "$tmp/models.png"
  expect_rc 0 "run: two accepted models, no failure"
  expect_py "run: the CSV header" "','.join(header) == '$HEADER'" "$csv"
  expect_py "run: one row per model, engine, controls and h-scale, all completed" \
    'len(rows) == 2 * 2 * 2 * 4 and all(r["status"] == "ok" and r["failed_steps"] == "0" and
     r["reason"] == "" and num(r, "simulated_s") == 0.5 for r in rows)' "$csv"
  expect_py "run: h = scale x opt.timestep (2 ms), steps = 0.5 s / h" \
    'all(abs(num(r, "h") - 0.002 * num(r, "h_scale")) < 1e-12 and
     int(r["steps"]) == round(0.5 / num(r, "h")) for r in rows)' "$csv"
  # a box resting on a plane and a contact-free cart-pole are the easy cases: every Ostrich step
  # converges (measured 100 %); MuJoCo has no convergence status
  expect_py "run: every Ostrich step converged, MuJoCo's share empty" \
    'all(num(r, "converged_pct") == 100 and r["unconverged_steps"] == "0" for r in rows
         if r["engine"] == "ostrich") and
     all(r["converged_pct"] == "" for r in rows if r["engine"] == "mujoco")' "$csv"
  # hard contact: the box does not sink (measured 4e-11 m at h x 1); MuJoCo's soft contact lets
  # it sink 0.18 mm at 2 ms, and more at larger h
  expect_py "run: box_plane: Ostrich penetrates < 1 um, MuJoCo > 0.1 mm, growing with h" \
    'all(num(r, "max_penetration") < 1e-6 for r in rows
         if r["model"] == "box_plane" and r["engine"] == "ostrich") and
     1e-4 < num(row("box_plane", "mujoco", "zero", 1), "max_penetration") <
            num(row("box_plane", "mujoco", "zero", 10), "max_penetration")' "$csv"
  # the reference (MuJoCo at h/4) sinks into the plane; Ostrich's box sits on it: the error is
  # that sink, 0.1 mm, at every h (hard contact has no h-dependent sink)
  expect_py "run: box_plane: Ostrich's error is the reference's sink (< 0.3 mm) at every h" \
    'all(num(r, "error") < 3e-4 for r in rows
         if r["model"] == "box_plane" and r["engine"] == "ostrich")' "$csv"
  # the cart-pole starts upright at rest, an equilibrium: with zero controls nothing moves
  expect_py "run: cartpole at rest stays at rest (error 0)" \
    'all(num(r, "error") == 0 for r in rows
         if r["model"] == "cartpole" and r["ctrl"] == "zero")' "$csv"
  # smooth dynamics, semi-implicit Euler: the error grows about linearly in h, so at h x 10 it
  # is (10 h - h/4) / (h - h/4) = 13x that at h x 1 (measured 13x); at least 5x
  expect_py "run: cartpole with random controls: error at h x 10 > 5x error at h x 1" \
    'all(num(row("cartpole", e, "random", 10), "error") >
         5 * num(row("cartpole", e, "random", 1), "error") > 0 for e in ("ostrich", "mujoco"))' \
    "$csv"
  expect_py "run: wall time per simulated second positive" \
    'all(num(r, "wall_per_sim_s") > 0 for r in rows)' "$csv"
  expect_py "run: the table (a line per row) and the summary on stdout" \
    'len([l for l in out.splitlines() if l.startswith(("box_plane ", "cartpole "))]) == 32 and
     "summary: 2 models, 0 refused" in out and "all models" in out and
     "100.0% of 1800 steps" in out' "$csv"
  if command -v gnuplot >/dev/null; then
    if [[ -s $tmp/models.png ]]; then pass "run: plot written"; else fail "run: no plot"; fi
  fi
  ;;

#---------------------------------- refused -------------------------------------------------------
refused)
  csv=$tmp/models.csv
  printf '<mujoco><worldbody><body></worldbody></mujoco>\n' >"$tmp/malformed.xml"
  run compare models "$TEST_MODELS/unsupported_user_gain.xml" "$tmp/malformed.xml" \
    "$MODELS/cartpole.xml" --duration 0.1 --h-scale 1 --csv "$csv"
  expect_rc 0 "refused: a refusal and a load failure are results, not failures"
  expect_py "refused: the refused model is one row with ost_checkModel's reason" \
    'len([r for r in rows if r["model"] == "unsupported_user_gain"]) == 1 and
     [(r["engine"], r["status"]) for r in rows if r["model"] == "unsupported_user_gain"] ==
     [("ostrich", "refused")] and "gaintype user" in rows[0]["reason"]' "$csv"
  expect_py "refused: the malformed model is a load failure with MuJoCo's message" \
    '[(r["engine"], r["status"]) for r in rows if r["model"] == "malformed"] ==
     [("mujoco", "load_failed")] and
     next(r for r in rows if r["model"] == "malformed")["reason"] != ""' "$csv"
  expect_py "refused: the next model still runs" \
    'len([r for r in rows if r["model"] == "cartpole" and r["status"] == "ok"]) == 4' "$csv"
  expect_py "refused: the summary ranks the refusal reason" \
    '"1 refused by Ostrich, 1 failed to load" in out and
     any(l.strip().startswith("1 ") and "gaintype user" in l for l in
         out.split("refusal reasons")[1].splitlines())' "$csv"
  # 81 resting spheres where Ostrich may grow to 64 contacts: its step fails (capacity), which
  # an accepted model must not do, so the exit status says so
  run compare models "$TEST_MODELS/too_many_contacts.xml" --duration 0.1 --h-scale 1 \
    --ctrl zero --engine ostrich --csv "$csv"
  expect_rc 1 "refused: a failed Ostrich step makes the exit status 1"
  expect_py "refused: the failed step is counted and its message kept" \
    'rows[0]["status"] == "failed" and rows[0]["failed_steps"] == "1" and
     rows[0]["reason"] != ""' "$csv"
  ;;

#---------------------------------- outputs -------------------------------------------------------
outputs)
  for bad in "$tmp/no/such/dir/x.csv" "$tmp"; do
    run compare models "$MODELS/cartpole.xml" --csv "$bad"
    if [[ $rc -eq 2 && ! -s $tmp/out ]] && grep -q '^ostrich: --csv' "$tmp/err" &&
       ! grep -q 'models: 1/' "$tmp/err"; then
      pass "outputs: --csv $bad rejected before any run ($(head -n1 "$tmp/err"))"
    else
      fail "outputs: --csv $bad: expected exit 2 before any run"
    fi
  done
  run compare models "$MODELS/cartpole.xml" --plot "$tmp/no/such/dir/x.png"
  expect_rc 2 "outputs: a bad --plot path rejected"
  run compare models "$MODELS/cartpole.xml" --h-scale 1,x
  expect_rc 2 "outputs: a bad --h-scale rejected"

  # a run of about a minute, killed after a second: the previous CSV must be intact
  printf 'previous results\n' >"$tmp/keep.csv"
  "$BIN" compare models "$MODELS/box_plane.xml" --duration 100 --csv "$tmp/keep.csv" \
    >/dev/null 2>&1 &
  pid=$!
  sleep 1
  kill -9 "$pid"
  wait "$pid" 2>/dev/null || true
  cmd=(compare models box_plane.xml --duration 100 --csv keep.csv "(killed)")
  rc=137
  : >"$tmp/out"
  : >"$tmp/err"
  if [[ $(cat "$tmp/keep.csv") == "previous results" ]]; then
    pass "outputs: a run killed with -9 leaves the previous CSV whole"
  else
    fail "outputs: the previous CSV changed"
  fi
  ;;

#---------------------------------- corpus --------------------------------------------------------
corpus)
  if [[ $# -eq 0 ]]; then
    echo "corpus: no sample model installed (libmujoco-samples); nothing to check"
    echo "0 passed, 0 failed"
    exit 0
  fi
  csv=$tmp/corpus.csv
  run compare models "$@" --duration 0.2 --h-scale 1,5 --csv "$csv"
  expect_rc 0 "corpus: no Ostrich run diverged or failed on an accepted sample model"
  expect_py "corpus: every model given is accepted and every run completed" \
    'len(rows) == '$#' * 2 * 2 * 2 and all(r["status"] == "ok" for r in rows)' "$csv"
  # the converged share: every run of a model must converge in at least half its steps (below
  # that the solver stalls on the scene as a whole, not on a few hard contact events), and the
  # corpus as a whole in at least 99.5 % of its Ostrich steps, the product's goal for models
  # nobody here wrote (measured: 100 %, compare/results/compare_models.md)
  expect_py "corpus: per model and h-scale, at least 50 % of Ostrich steps converged" \
    'all(num(r, "converged_pct") >= 50 for r in rows if r["engine"] == "ostrich")' "$csv"
  expect_py "corpus: at least 99.5 % of all Ostrich steps converged" \
    'sum(num(r, "steps") - num(r, "unconverged_steps") for r in rows if r["engine"] == "ostrich")
     >= 0.995 * sum(num(r, "steps") for r in rows if r["engine"] == "ostrich")' "$csv"
  ;;

*)
  echo "unknown mode $MODE" >&2
  exit 2
  ;;
esac

echo "$npass passed, $nfail failed"
[[ $nfail -eq 0 ]]
