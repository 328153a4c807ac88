#!/usr/bin/env bash
# test_cli.sh: end-to-end tests of the `ostrich` command-line tool (plugin/cli/ost_cli*.c).
# usage: bash tests/test_cli.sh PATH/TO/ostrich PATH/TO/mjcf_models
# Checks usage errors (exit 2, one "ostrich:" line on stderr, nothing on stdout), then runs
# `ostrich sim` on box_plane.xml (both engines) and robot_pallet.xml and checks the JSON line and
# the CSV; `check`; refusals that name every unsupported feature (the same from sim and check);
# the start state (qpos0, or --key K); `synth` (the mujoco engine, then with the gradient API
# the ostrich engine; the derivatives of its loss are checked by tests/test_ost_cli_synth.c) and
# `gradcheck`. Every check runs; the script exits 1 if any failed.
set -euo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: bash $0 PATH/TO/ostrich PATH/TO/mjcf_models" >&2
  exit 2
fi
BIN=$1
MODELS=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/lib.sh"


# a failure shows the command and its exit code on lines of their own
fail_report() {
  echo "FAIL: $1"
  echo "      command: ostrich ${cmd[*]}"
  echo "      exit code: $rc"
  fail_output
}


# expect_mentions DESC WORD...: every WORD appears in the stdout of the last run
expect_mentions() {
  local desc=$1 word missing=""
  shift
  for word in "$@"; do
    grep -q -e "$word" "$tmp/out" || missing="$missing $word"
  done
  if [[ -z $missing ]]; then pass "$desc"; else fail "$desc: missing:$missing"; fi
}


# expect_py DESC EXPR [CSV]: python EXPR holds, with j = the single JSON line on stdout and
# rows = the CSV file as lists of strings (header first); prints the values on failure
expect_py() {
  local desc=$1 expr=$2 csv=${3:-}
  local why
  if why=$(python3 - "$tmp/out" "$expr" "$csv" 2>&1 <<'EOF'
import csv, json, sys
lines = open(sys.argv[1]).read().splitlines()
if len(lines) != 1:
    sys.exit("stdout has %d lines, expected exactly one JSON line" % len(lines))
j = json.loads(lines[0])
rows = list(csv.reader(open(sys.argv[3]))) if sys.argv[3] else None
try:
    ok = eval("(" + sys.argv[2] + ")")
except Exception as e:
    sys.exit("%s: %s" % (type(e).__name__, e))
if not ok:
    info = "json: " + lines[0]
    if rows:
        info += "\ncsv: %d lines, %d columns; last: %s" % (
            len(rows), len(rows[0]), ",".join(rows[-1]))
    sys.exit(info)
EOF
  ); then
    pass "$desc"
  else
    fail "$desc: $expr"
    echo "$why" | sed 's/^/      /' >&2
  fi
}


KEYS='["engine","model","h","steps","wall_s","nan","max_penetration","mean_residual",
       "mean_newton_iter","final_qpos"]'
OPTIONS=(--engine --h --duration --steps --ctrl --newton --pcr --geometry --key --csv)
BOX=$MODELS/box_plane.xml
PALLET=$MODELS/robot_pallet.xml


#---------------------------------- help ----------------------------------------------------------

run --help
expect_rc 0 "ostrich --help"
expect_mentions "ostrich --help lists every command" "sim" "check" "synth" "gradcheck"
run -h
expect_rc 0 "ostrich -h"
run sim --help
expect_rc 0 "ostrich sim --help"
expect_mentions "ostrich sim --help mentions every option" "${OPTIONS[@]}"
run
if [[ $rc -eq 2 && ! -s $tmp/out ]] && grep -q 'usage' "$tmp/err"; then
  pass "no subcommand: usage on stderr (exit 2)"
else
  fail "no subcommand: expected usage on stderr and exit 2"
fi


#---------------------------------- usage errors --------------------------------------------------

printf '<mujoco>\n  <worldbody>\n    <geom type="sphere" size="0.1">\n  </worldbody>\n</mujoco>\n' \
  >"$tmp/broken.xml"

expect_usage_error "unknown subcommand" frobnicate
expect_usage_error "unknown option" sim "$BOX" --frobnicate 1
expect_usage_error "missing value" sim "$BOX" --h
expect_usage_error "non-numeric value" sim "$BOX" --h abc
expect_usage_error "non-integer --steps" sim "$BOX" --steps 2.5
expect_usage_error "unknown engine" sim "$BOX" --engine bullet
expect_usage_error "missing model argument" sim
expect_usage_error "missing model file" sim "$tmp/no_such_model.xml"
expect_usage_error "malformed XML" sim "$tmp/broken.xml"
expect_usage_error "--ctrl with the wrong count" sim "$PALLET" --ctrl 1,2 --steps 1
expect_usage_error "--ctrl with a non-number" sim "$PALLET" --ctrl 1,x,2 --steps 1
expect_usage_error "--duration and --steps together" sim "$BOX" --duration 1 --steps 10


#---------------------------------- box on a plane (ostrich) --------------------------------------

run sim "$BOX" --h 0.1 --steps 20 --csv "$tmp/a.csv"
expect_rc 0 "box_plane, ostrich, h = 0.1, 20 steps"
expect_py "box_plane: JSON has every key" "all(k in j for k in $KEYS)"
expect_py "box_plane: engine ostrich, h 0.1, 20 steps, no NaN" \
  'j["engine"] == "ostrich" and j["h"] == 0.1 and j["steps"] == 20 and j["nan"] is False'
expect_py "box_plane: CSV has a header and 21 rows of nq + nv + 1 = 14 columns" \
  'len(rows) == 22 and all(len(r) == 14 for r in rows) and
   rows[0][:2] == ["time", "qpos_0"] and rows[0][-1] == "qvel_5" and float(rows[1][0]) == 0' \
  "$tmp/a.csv"
# 1 mm: sinking that would be visible; hard contact keeps far below it
expect_py "box_plane: the box rests (|z_final - z_0| < 1e-3)" \
  'abs(float(rows[-1][3]) - float(rows[1][3])) < 1e-3 and abs(j["final_qpos"][2] - 0.1) < 1e-3' \
  "$tmp/a.csv"


expect_py "box_plane: every step converged, none depenetrated" \
  'j["unconverged_steps"] == 0 and j["worst_residual"] <= 1e-10 and j["depenetrated_steps"] == 0'

# a box placed 5 cm into its floor: the start depth is reported, it is removed at the bounded
# depenetration speed (1 m/s: 25 steps of 2 mm at h = 2 ms), and the box never moves faster
sed 's|<body name="box" pos="0 0 0.1">|<body name="box" pos="0 0 0.05">|' "$BOX" > "$tmp/sunk.xml"
run sim "$tmp/sunk.xml" --steps 30 --csv "$tmp/sunk.csv"
expect_rc 0 "sunk box, ostrich, 30 steps"
expect_py "sunk box: start depth 0.05 m reported, 25 bounded steps, speeds <= 1 m/s" \
  'abs(j["max_penetration"] - 0.05) < 1e-6 and j["depenetrated_steps"] == 25 and
   abs(j["worst_initial_violation"] - 0.05) < 1e-6 and
   max(abs(float(v)) for r in rows[1:] for v in r[8:11]) <= 1 + 1e-6' "$tmp/sunk.csv"

# a Newton budget of 1 on the pallet at h = 0.1 s does not reach tol: counted, not hidden
run sim "$PALLET" --h 0.1 --steps 5 --ctrl 3,3,3 --newton 1
expect_rc 0 "pallet, newton 1: the steps are taken"
expect_py "pallet, newton 1: unconverged steps counted with their worst residual" \
  'j["unconverged_steps"] > 0 and j["worst_residual"] > 1e-10'


#---------------------------------- box on a plane (mujoco) ---------------------------------------

run sim "$BOX" --engine mujoco --h 0.002 --steps 100
expect_rc 0 "box_plane, mujoco, h = 0.002, 100 steps"
expect_py "box_plane mujoco: engine mujoco, 100 steps, no NaN" \
  'j["engine"] == "mujoco" and j["h"] == 0.002 and j["steps"] == 100 and j["nan"] is False'


#---------------------------------- the wheeled robot ---------------------------------------------
# Ostrich drives the robot on flat ground at h = 0.01 s (w r = 1.05 m/s for 2 s); stock MuJoCo
# climbs the pallet at h = 2 ms (the reference); Ostrich climbs it at h = 0.05 s, the main job.

ROBOT=$MODELS/wheeled_robot.xml
run sim "$ROBOT" --h 0.01 --duration 2 --ctrl 3,3,3 --csv "$tmp/r.csv"
expect_rc 0 "wheeled_robot, ostrich, h = 0.01, 2 s, ctrl 3,3,3"
# rolling without slip: w r = 1.05 m/s for 2 s is 2.1 m, less the start from rest
expect_py "wheeled_robot: 200 steps, no NaN, drives ~2.1 m forward" \
  'j["steps"] == 200 and j["nan"] is False and 1.9 < j["final_qpos"][0] < 2.2'

run sim "$PALLET" --engine mujoco --h 0.002 --duration 6 --ctrl 3,3,3 --csv "$tmp/pm.csv"
expect_rc 0 "robot_pallet, mujoco, h = 0.002, 6 s, ctrl 3,3,3"
expect_py "robot_pallet (mujoco): the robot drives over the pallet (final chassis x > 2.0)" \
  'j["final_qpos"][0] > 2.0 and float(rows[-1][1]) > 2.0' "$tmp/pm.csv"

run sim "$PALLET" --h 0.05 --duration 6 --ctrl 3,3,3 --csv "$tmp/po.csv"
expect_rc 0 "robot_pallet, ostrich, h = 0.05, 6 s, ctrl 3,3,3"
# on the pallet: ride height 0.35 m + pallet 0.144 m = 0.494 m; its far edge is at x = 2.2 m;
# 2 cm of penetration is a regression baseline (measured: 8e-8 m, test_ost_robot)
expect_py "robot_pallet (ostrich): 120 steps, no NaN, on the pallet on the way, over it at the end" \
  'j["steps"] == 120 and j["nan"] is False and j["max_penetration"] < 0.02
   and max(float(r[3]) for r in rows[1:]) > 0.48 and j["final_qpos"][0] > 3.0' "$tmp/po.csv"


#---------------------------------- native geometry -----------------------------------------------
# `ostrich check` compares native geometry with MuJoCo (JSON, exit 0 within tolerance); a model
# native cannot represent is refused (exit 2, named); `sim --geometry native` drives the robot
# over the mesh terrain (Ostrich-only: MuJoCo 2.2.2 collides a mesh as its convex hull).

run check "$PALLET" --states 20 --seed 3
expect_rc 0 "check robot_pallet: native equals MuJoCo"
expect_py "check robot_pallet: every error within tolerance" \
  'j["ok"] is True and j["states"] == 20 and j["contacts"] > 0 and j["mass_matrix"] < 1e-10
   and j["jacobian"] < 1e-10 and j["contact_count"] == 0 and j["contact_dist"] < 1e-9'
run check --help
expect_rc 0 "ostrich check --help"
expect_mentions "ostrich check --help mentions its options" --states --seed
cat > "$tmp/eq.xml" <<'XML'
<mujoco><worldbody><body><joint name="a" type="hinge"/><geom size=".1"/></body>
<body><joint name="b" type="hinge"/><geom size=".1"/></body></worldbody>
<equality><joint name="couple" joint1="a" joint2="b"/></equality></mujoco>
XML
run check "$tmp/eq.xml"
expect_rc 2 "check refuses a model native cannot represent"
if grep -q "couple" "$tmp/err"; then pass "the refusal names the equality"; else fail "refusal names it"; fi
expect_usage_error "bad --geometry" sim "$BOX" --geometry fast

run sim "$MODELS/terrain_mesh.xml" --duration 4 --ctrl 3,3,3
expect_rc 0 "terrain_mesh, ostrich native, h = 0.05, 4 s"
# w r = 1.05 m/s for 4 s is 4.2 m on flat ground; the bracket allows for the bumps (a regression
# baseline, like the 0.3 m off its line)
expect_py "terrain_mesh: drives about 4 m along its line over the mesh" \
  'j["nan"] is False and 3.8 < j["final_qpos"][0] < 4.5 and abs(j["final_qpos"][1]) < 0.3'


#---------------------------------- refusals: every feature, the same in sim and check ------------
# unsupported_three_features.xml has two actuators with a user gain, a contact pair with
# anisotropic friction and an actuator with a user bias: one refusal names all three (the actuators in
# one entry); `check` refuses it with the same stderr line and exit code as `sim`, and says so in
# its JSON line (accepted false).

TESTMODELS=$(cd "$(dirname "$0")" && pwd)/models
THREE=$TESTMODELS/unsupported_three_features.xml
run sim "$THREE" --steps 1
expect_rc 2 "sim refuses a model with three unsupported features"
cp "$tmp/err" "$tmp/sim_refusal"
if grep -q "(3 features)" "$tmp/err" && grep -q "contact pair 'rub': anisotropic friction" \
     "$tmp/err" && grep -q "2 actuators ('shoulder_user', 'elbow_user'): a non-fixed gain" \
     "$tmp/err" && grep -q "actuator 'grip': a user bias" "$tmp/err"; then
  pass "sim's refusal names all three features and their elements"
else
  fail "sim's refusal names all three features and their elements"
fi
run check "$THREE"
expect_rc 2 "check refuses it too"
if cmp -s "$tmp/err" "$tmp/sim_refusal"; then
  pass "check's stderr equals sim's: $(head -c 100 "$tmp/err")..."
else
  fail "check's stderr equals sim's"
fi
expect_py "check's JSON: accepted false, the refusal is sim's message" \
  'j["accepted"] is False and j["ok"] is False and j["native"] is None and
   "ostrich: " + j["refusal"] + "\n" == open("'"$tmp/sim_refusal"'").read()'
run check "$PALLET" --states 2
expect_py "check on an accepted model: accepted true, native true, refusal null" \
  'j["accepted"] is True and j["native"] is True and j["refusal"] is None and j["ok"] is True'


#---------------------------------- start state: qpos0, or --key K --------------------------------
# pendulum_two_keyframes.xml: qpos0 = 0 at rest; keyframe 1 is qpos 1.0, qvel 0.5. Without --key
# every subcommand starts from qpos0 (the same result as the model with its keyframes removed);
# --key 1 starts from keyframe 1 (the CSV's first row is the keyframe); --key 5 is refused
# before any work.

KEYS2=$TESTMODELS/pendulum_two_keyframes.xml
python3 -c 'import re, sys; open(sys.argv[2], "w").write(re.sub(r"<keyframe>.*</keyframe>", "",
  open(sys.argv[1]).read(), flags=re.S))' "$KEYS2" "$tmp/nokey.xml"
for engine in ostrich mujoco; do
  run sim "$KEYS2" --engine "$engine" --steps 10 --key 1 --csv "$tmp/k1.csv"
  expect_rc 0 "sim --key 1 ($engine)"
  expect_py "sim --key 1 ($engine): first CSV row is keyframe 1 (t 0, qpos 1, qvel 0.5), key 1" \
    'j["key"] == 1 and rows[1] == ["0", "1", "0.5"] and j["steps"] == 10' "$tmp/k1.csv"
  run sim "$tmp/nokey.xml" --engine "$engine" --steps 10
  cp "$tmp/out" "$tmp/nokey.json"
  run sim "$KEYS2" --engine "$engine" --steps 10 --csv "$tmp/k0.csv"
  expect_py "sim without --key ($engine): starts from qpos0 (0, at rest), as without keyframes" \
    'j["key"] is None and rows[1] == ["0", "0", "0"] and
     j["final_qpos"] == json.load(open("'"$tmp/nokey.json"'"))["final_qpos"]' "$tmp/k0.csv"
done
expect_usage_error "sim --key 5 on a model with two keyframes" sim "$KEYS2" --key 5
if grep -q "2 keyframes" "$tmp/err"; then pass "--key 5: names the keyframe count"; else
  fail "--key 5: names the keyframe count"; fi
expect_usage_error "sim --key 0 on a model without keyframes" sim "$BOX" --key 0
expect_usage_error "sim --key -1" sim "$KEYS2" --key -1
expect_usage_error "gradcheck --key 5" gradcheck "$KEYS2" --key 5
run sim --help
expect_mentions "sim --help documents --key" "--key K" "qpos0"

# --perturb SEED moves the start's qvel by at most 5e-7 (the CSV's first row shows it), the same
# for the same seed in both engines, and reports the seed; 0 leaves the start as it was
for engine in ostrich mujoco; do
  run sim "$KEYS2" --engine "$engine" --steps 10 --key 1 --perturb 3 --csv "$tmp/p3.csv"
  expect_rc 0 "sim --perturb 3 ($engine)"
  cp "$tmp/p3.csv" "$tmp/p3_$engine.csv"
  expect_py "sim --perturb 3 ($engine): qvel of the start within 5e-7 of keyframe 1's, not equal" \
    'j["perturb"] == 3 and 0 < abs(float(rows[1][2]) - 0.5) <= 5e-7' "$tmp/p3.csv"
done
if [ "$(sed -n 2p "$tmp/p3_ostrich.csv")" = "$(sed -n 2p "$tmp/p3_mujoco.csv")" ]; then
  pass "sim --perturb 3: both engines start from the same perturbed state"
else
  fail "sim --perturb 3: both engines start from the same perturbed state"
fi
run sim "$KEYS2" --steps 10 --key 1 --perturb 0 --csv "$tmp/p0.csv"
expect_py "sim --perturb 0: the keyframe's start, perturb 0" \
  'j["perturb"] == 0 and rows[1] == ["0", "1", "0.5"]' "$tmp/p0.csv"
expect_usage_error "sim --perturb -1" sim "$KEYS2" --perturb -1
run sim --help
expect_mentions "sim --help documents --perturb" "--perturb SEED" "5e-7"
run gradcheck --help
expect_mentions "gradcheck --help documents --key" "--key K" "qpos0"


#---------------------------------- synth and gradcheck: no gradient at run time -----------------
# Usage errors, help, and the mujoco engine (finite differences of mj_step rollouts), none of
# which calls the gradient API (the binary still links it).

BOXM=$MODELS/robot_box.xml
SYNTH_OPTIONS=(--scene --trials --iters --seed --lr --engine --grad --fd --eps --csv --plot)
GRADCHECK_OPTIONS=(--steps --h --seed --wrt --eps --tol --newton --ctrl --key)
run synth --help
expect_rc 0 "ostrich synth --help"
expect_mentions "ostrich synth --help mentions every option" "${SYNTH_OPTIONS[@]}"
run gradcheck --help
expect_rc 0 "ostrich gradcheck --help"
expect_mentions "ostrich gradcheck --help mentions every option and the normwise error" \
  "${GRADCHECK_OPTIONS[@]}" "normwise"

expect_usage_error "synth: unknown option" synth --frobnicate
expect_usage_error "synth: two positional arguments" synth "$BOXM" "$BOXM"
expect_usage_error "synth: --trials 0" synth --trials 0 "$BOXM"
expect_usage_error "synth: --iters not an integer" synth --iters 2.5 "$BOXM"
expect_usage_error "synth: --lr not positive" synth --lr -0.3 "$BOXM"
expect_usage_error "synth: unknown engine" synth --engine bullet "$BOXM"
expect_usage_error "synth: unknown --fd" synth --fd sideways "$BOXM"
expect_usage_error "synth: unknown --grad" synth --grad exact "$BOXM"
expect_usage_error "synth: missing model file" synth "$tmp/no_such_model.xml"
expect_usage_error "synth: a model without a free joint and actuators" synth "$BOX" \
  --engine mujoco
expect_usage_error "synth: unknown --scene" synth --scene moon "$BOXM"
expect_usage_error "synth --scene terrain: a scene without a terrain mesh" synth \
  --scene terrain "$BOXM"
mkdir -p "$tmp/mesh_only"
cp "$MODELS/terrain_mesh.xml" "$MODELS/terrain_sinusoid.obj" "$MODELS/wheeled_robot_body.xml" \
  "$tmp/mesh_only/"
expect_usage_error "synth --scene terrain: no terrain_hfield.xml next to the model" synth \
  --scene terrain --engine mujoco "$tmp/mesh_only/terrain_mesh.xml"
expect_usage_error "synth --scene terrain: unknown --grad" synth --scene terrain --grad exact \
  "$MODELS/terrain_mesh.xml"
expect_usage_error "synth --scene terrain: --csv in a missing folder" synth --scene terrain \
  "$MODELS/terrain_mesh.xml" --csv "$tmp/no_such_dir/t.csv"
expect_usage_error "gradcheck: missing model argument" gradcheck
expect_usage_error "gradcheck: unknown option" gradcheck "$BOX" --frobnicate 1
expect_usage_error "gradcheck: unknown --wrt" gradcheck "$BOX" --wrt everything
expect_usage_error "gradcheck: --steps 0" gradcheck "$BOX" --steps 0
expect_usage_error "gradcheck: --eps 0" gradcheck "$BOX" --eps 0
expect_usage_error "gradcheck: --ctrl with the wrong count" gradcheck "$PALLET" --ctrl 1,2
expect_usage_error "gradcheck: malformed XML" gradcheck "$tmp/broken.xml"
run gradcheck "$tmp/eq.xml"
expect_rc 2 "gradcheck refuses a model native cannot represent"
if grep -q "couple" "$tmp/err"; then
  pass "gradcheck's refusal names the equality"
else
  fail "gradcheck's refusal names the equality"
fi

# one iteration of the mujoco engine: 1 + 30 rollouts of 3000 steps (about a second)
SUMMARY_KEYS='["engine","trials","successes","success_rate","median_final_error",
               "median_final_speed","median_warm_iter_ms","total_s"]'
OSTRICH_QUIET=1 run synth --engine mujoco --trials 1 --iters 1 "$BOXM" \
  --csv "$tmp/sm.csv" --plot "$tmp/sm.png"
expect_rc 0 "synth --engine mujoco, 1 trial, 1 iteration"
expect_py "synth mujoco: JSON summary keys, 3000 steps of 2 ms, forward differences" \
  "all(k in j for k in $SUMMARY_KEYS) and j['engine'] == 'mujoco' and j['steps'] == 3000 and
   j['trials'] == 1 and 'forward' in j['gradient'] and j['failed_trials'] == 0"
expect_py "synth mujoco: one CSV row, the robot drove towards the target (x > 2 m)" \
  'len(rows) == 2 and rows[0] == ["engine", "trial", "iter", "loss", "pos_err", "speed",
   "heading_err", "time_ms", "x", "y"] and rows[1][0] == "mujoco" and float(rows[1][8]) > 2' \
  "$tmp/sm.csv"
expect_py "synth mujoco: trajectory CSV with 61 samples (0 to 6 s)" \
  'len(rows) == 62 and float(rows[-1][3]) == 6.0' "$tmp/sm_traj.csv"
if [[ -s $tmp/sm.png ]] && head -c 8 "$tmp/sm.png" | grep -q PNG; then
  pass "synth mujoco: wrote a PNG"
else
  fail "synth mujoco: expected a PNG at $tmp/sm.png"
fi


#---------------------------------- NEEDS THE GRADIENT API (ost_tape*) ----------------------------
# gradcheck on smooth models (a hinge chain; position servos at h = 0.1 s: ctrl and servo
# parameters) must agree with central differences; an impossible --tol fails (exit 1, JSON
# still printed); synth's ostrich engine runs (adjoint through ost_tapeBackward), alone and next
# to the mujoco engine.

run gradcheck "$MODELS/pendulum_chain.xml" --steps 10
expect_rc 0 "gradcheck pendulum_chain: adjoint equals central differences"
# smooth models: central differences agree with an exact gradient to round-off, so 1e-6
# (tighter than --tol's default 1e-3) catches a wrong term
expect_py "gradcheck pendulum_chain: ok, every group below 1e-6, 16 parameters compared" \
  'j["ok"] is True and max(j["qpos"], j["qvel"], j["ctrl"], j["params"]) < 1e-6 and
   j["n_params"] == 16 and j["params_nonzero"] > 0'
# the resting box at default settings (2 ms, 10 steps, the default budget and difference step):
# every step converges, so the finite differences are of solved rollouts, and the mass group
# edits m->body_mass at run time on a free ("simple") body. Below gradcheck's own --tol 1e-3
# (central differences of contact rollouts, round-off over eps = 1e-4)
run gradcheck "$BOX"
expect_rc 0 "gradcheck box_plane at default settings"
expect_py "gradcheck box_plane: ok at the default tolerance, every group compared" \
  'j["ok"] is True and j["tol"] == 1e-3 and max(j["qpos"], j["qvel"], j["params"]) < 1e-3
   and j["param_groups"]["mass"] < 1e-3 and j["params_nonzero"] > 0'
run gradcheck "$MODELS/arm_position_servo.xml" --ctrl 0.1,0.2,0.3
expect_rc 0 "gradcheck arm_position_servo (h = 0.1 s, ctrl and servo gains)"
expect_py "gradcheck arm_position_servo: ok, 30 controls compared" \
  'j["ok"] is True and j["n_ctrl"] == 30 and j["ctrl"] < 1e-6'
run gradcheck "$tmp/nokey.xml" --steps 5
cp "$tmp/out" "$tmp/gc_nokey.json"
run gradcheck "$KEYS2" --steps 5
expect_rc 0 "gradcheck without --key on a model with keyframes"
expect_py "gradcheck without --key: starts from qpos0 (the loss of the model without keyframes)" \
  'j["key"] is None and j["ok"] is True and
   j["loss"] == json.load(open("'"$tmp/gc_nokey.json"'"))["loss"]'
run gradcheck "$KEYS2" --steps 5 --key 1
expect_rc 0 "gradcheck --key 1: adjoint equals central differences from keyframe 1"
expect_py "gradcheck --key 1: another start state (another loss), key 1 in the JSON line" \
  'j["key"] == 1 and j["ok"] is True and
   j["loss"] != json.load(open("'"$tmp/gc_nokey.json"'"))["loss"]'
run gradcheck "$MODELS/pendulum_chain.xml" --wrt qvel --tol 1e-15
expect_rc 1 "gradcheck with an impossible --tol fails"
expect_py "gradcheck --tol 1e-15: JSON printed with ok false, only qvel compared" \
  'j["ok"] is False and j["qvel"] is not None and j["qpos"] is None and j["params"] is None'

OSTRICH_QUIET=1 run synth --trials 1 --iters 3 "$BOXM" --csv "$tmp/so.csv" \
  --plot "$tmp/so.png"
expect_rc 0 "synth --engine ostrich, 1 trial, 3 iterations"
expect_py "synth ostrich: 60 steps of 0.1 s, adjoint gradients, 3 CSV rows" \
  "all(k in j for k in $SUMMARY_KEYS) and j['engine'] == 'ostrich' and j['steps'] == 60 and
   j['h'] == 0.1 and 'adjoint' in j['gradient'] and len(rows) == 4" "$tmp/so.csv"
if [[ -s $tmp/so.png ]] && head -c 8 "$tmp/so.png" | grep -q PNG; then
  pass "synth ostrich: wrote a PNG"
else
  fail "synth ostrich: expected a PNG at $tmp/so.png"
fi
OSTRICH_QUIET=1 run synth --engine both --trials 1 --iters 2 "$BOXM"
expect_rc 0 "synth --engine both, 1 trial, 2 iterations"
expect_py "synth both: a summary per engine and the ratio of warm iteration times" \
  "j['engine'] == 'both' and all(k in j[e] for e in ('ostrich', 'mujoco') for k in $SUMMARY_KEYS)
   and j['warm_iter_ratio'] > 0"

# the terrain scene: 3 iterations of the truncated adjoint from seed 4's guess (one per-seed
# terrain, 125 steps of 0.08 s), then both engines for 2 iterations (mujoco: 2 x 31 rollouts of
# 5000 steps on terrain_hfield.xml, about 7 s)
TERRAIN_KEYS='["engine","trials","successes","below_0.2m","median_best_rmse",
               "median_initial_rmse","median_warm_iter_ms","failed_trials","bad_rollouts"]'
OSTRICH_QUIET=1 run synth --scene terrain --seed 4 --trials 1 --iters 3 \
  "$MODELS/terrain_mesh.xml" --csv "$tmp/st.csv" --plot "$tmp/st.png"
expect_rc 0 "synth --scene terrain, 1 trial, 3 iterations"
expect_py "synth terrain: 125 steps of 0.08 s, truncated adjoint, best RMSE <= the guess's" \
  "all(k in j for k in $TERRAIN_KEYS) and j['scene'] == 'terrain' and j['steps'] == 125 and
   j['h'] == 0.08 and j['gradient'] == 'adjoint, truncated' and j['failed_trials'] == 0 and
   0 < j['median_best_rmse'] <= j['median_initial_rmse'] and len(rows) == 4 and
   rows[0] == ['engine', 'trial', 'iter', 'loss', 'rmse', 'time_ms']" "$tmp/st.csv"
expect_py "synth terrain: trajectory CSV, the target path (iter 0) and 3 iterates of 126 samples" \
  "len(rows) == 1 + 4 * 126 and rows[1][2] == '0' and float(rows[126][3]) == 10.0 and
   float(rows[126][4]) > 3" "$tmp/st_traj.csv"
if [[ -s $tmp/st.png ]] && head -c 8 "$tmp/st.png" | grep -q PNG; then
  pass "synth terrain: wrote a PNG"
else
  fail "synth terrain: expected a PNG at $tmp/st.png"
fi
OSTRICH_QUIET=1 run synth --scene terrain --engine both --seed 4 --trials 1 --iters 2 \
  "$MODELS/terrain_mesh.xml"
expect_rc 0 "synth --scene terrain --engine both, 1 trial, 2 iterations"
expect_py "synth terrain both: mujoco on terrain_hfield.xml (5000 steps, 31 rollouts), ratio" \
  "j['engine'] == 'both' and all(k in j[e] for e in ('ostrich', 'mujoco') for k in $TERRAIN_KEYS)
   and j['mujoco']['steps'] == 5000 and j['mujoco']['model'].endswith('terrain_hfield.xml') and
   '31 rollouts' in j['mujoco']['gradient'] and j['warm_iter_ratio'] > 0 and
   j['ostrich']['median_initial_rmse'] > 0.05 and j['mujoco']['median_initial_rmse'] > 0.05"


#---------------------------------- bench scale ---------------------------------------------------

expect_usage_error "bench: unknown benchmark" bench speed
expect_usage_error "bench scale: unknown device" bench scale --device tpu "$BOXM"
expect_usage_error "bench scale: a world count of 0" bench scale --worlds 1,0 "$BOXM"
expect_usage_error "bench scale: missing model" bench scale "$tmp/no_such_model.xml"
OSTRICH_QUIET=1 run bench scale --device cpu --worlds 1,3 --steps 4 --repeat 1 "$BOXM" \
  --csv "$tmp/bs.csv"
expect_rc 0 "bench scale on the cpu, 1 and 3 worlds"
if [[ $(grep -c '^cpu,' "$tmp/bs.csv") -eq 2 ]] && grep -q 'world_iters_per_s' "$tmp/bs.csv"; then
  pass "bench scale: a CSV row per world count, with world-iterations per second"
else
  fail "bench scale: expected two cpu rows in $tmp/bs.csv"
fi
if OSTRICH_QUIET=1 "$BIN" bench scale --device cuda --worlds 1 --steps 2 --repeat 1 \
     "$BOXM" >/dev/null 2>"$tmp/err"; then
  pass "bench scale --device cuda ran (a CUDA build with a GPU)"
elif grep -q "without CUDA\|cuda" "$tmp/err"; then
  pass "bench scale --device cuda without a GPU build: $(head -c 120 "$tmp/err")"
else
  rc=1; fail "bench scale --device cuda: expected a message naming CUDA"
fi


#---------------------------------- bench adjoint -------------------------------------------------

expect_usage_error "bench adjoint: no model" bench adjoint --steps 5
expect_usage_error "bench adjoint: missing model" bench adjoint "$tmp/no_such_model.xml"
expect_usage_error "bench adjoint: --steps 0" bench adjoint --steps 0 "$MODELS/cartpole.xml"
OSTRICH_QUIET=1 run bench adjoint --steps 10 --repeat 1 "$MODELS/cartpole.xml" \
  --csv "$tmp/ba.csv"
expect_rc 0 "bench adjoint on the cart-pole, 10 steps"
expect_py "bench adjoint: the backward pass and MuJoCo's finite differences timed in one run" \
  "len(j['models']) == 1 and all(j['models'][0][k] > 0 for k in ('fwd_us', 'tape_us', 'bwd_us',
   'bwd_over_fwd', 'mj_step_us', 'transitionFD_us', 'fd_over_bwd_sim', 'tape_bytes_per_step'))
   and j['models'][0]['error'] == '' and j['models'][0]['unconverged'] == 0
   and len(rows) == 2 and rows[0][7] == 'bwd_us'" "$tmp/ba.csv"


#---------------------------------- summary -------------------------------------------------------

echo "test_cli: $npass passed, $nfail failed"
[[ $nfail -eq 0 ]]
