#!/usr/bin/env bash
# test_preload.sh: end-to-end test of libostrich_preload.so under the unmodified Debian
# mujoco-testspeed (MuJoCo 2.2.2).
# Usage: test_preload.sh <path to libostrich_preload.so> <mjcf_models dir>
# Checks: the banner and summary appear under the preload (one and several threads) and the
# load-time test step is not counted; no banner without the preload or with OSTRICH_QUIET=1; an
# unsupported model is refused by name and stepped by stock MuJoCo; the stock humanoid steps with
# Ostrich; a wrapper process (timeout) passes LD_PRELOAD on to the MuJoCo program. Exits non-zero
# on the first failure.
set -euo pipefail

fail() {
  echo "test_preload: FAIL: $*" >&2
  exit 1
}

if [[ $# -ne 2 ]]; then
  echo "usage: $0 <libostrich_preload.so> <mjcf_models dir>" >&2
  exit 2
fi
[[ -f "$1" ]] || fail "preload library '$1' not found"
[[ -d "$2" ]] || fail "models directory '$2' not found"
PRELOAD=$(realpath "$1")
MODELS=$(realpath "$2")
TESTSPEED=${MUJOCO_TESTSPEED:-$(command -v mujoco-testspeed || true)}
[[ -n "$TESTSPEED" && -x "$TESTSPEED" ]] \
  || fail "mujoco-testspeed not found (install libmujoco-samples or set MUJOCO_TESTSPEED)"

WORK=$(mktemp -d /tmp/test_preload.XXXXXX)
trap 'rm -rf "$WORK"' EXIT

# run NAME PRELOAD QUIET MODEL NSTEP NTHREAD: testspeed with stdout in $WORK/NAME.out and stderr
# in $WORK/NAME.err; fails unless it exits 0
run() {
  local name=$1 preload=$2 quiet=$3 model=$4 nstep=$5 nthread=$6
  local rc=0
  timeout 300 env ${preload:+LD_PRELOAD="$preload"} ${quiet:+OSTRICH_QUIET="$quiet"} \
    "$TESTSPEED" "$model" "$nstep" "$nthread" \
    > "$WORK/$name.out" 2> "$WORK/$name.err" || rc=$?
  echo "--- ($name) $(basename "$model") $nstep steps, $nthread thread(s)," \
       "preload=$([[ -n $preload ]] && echo on || echo off) quiet=${quiet:-unset}: exit $rc"
  sed 's/^/  stderr: /' "$WORK/$name.err"
  grep -E 'Running|Contacts per step|Steps per second' "$WORK/$name.out" | sed 's/^/  stdout:/' \
    || true
  [[ $rc -eq 0 ]] || fail "($name) mujoco-testspeed exited with status $rc"
}

# assert_ran NAME NSTEP: testspeed's own report is present, so the run really stepped
assert_ran() {
  local name=$1 nstep=$2
  grep -q "Running $nstep steps" "$WORK/$name.out" \
    || fail "($name) testspeed did not report 'Running $nstep steps'"
  grep -Eq '^ Contacts per step +: [0-9]+\.[0-9]+$' "$WORK/$name.out" \
    || fail "($name) testspeed did not report 'Contacts per step'"
}

# banner_count NAME: number of banner lines on stderr
banner_count() {
  grep -c '^ostrich: stepping .* with Ostrich$' "$WORK/$1.err" || true
}

# assert_ostrich NAME MODELNAME NSTEP: exactly one banner naming the model, and a summary line
# counting exactly NSTEP steps (so the load-time test step of mj_loadXML went to stock)
assert_ostrich() {
  local name=$1 model=$2 nstep=$3
  [[ $(banner_count "$name") -eq 1 ]] \
    || fail "($name) expected exactly one 'ostrich: stepping' banner on stderr"
  grep -q "^ostrich: stepping $model with Ostrich$" "$WORK/$name.err" \
    || fail "($name) banner does not name model '$model'"
  grep -Eq "^ostrich: $nstep steps, mean Newton iterations [0-9.]+, mean residual " \
    "$WORK/$name.err" || fail "($name) no summary line 'ostrich: $nstep steps, ...' on stderr"
  if grep -Eq '^ostrich: step .*(failed|did not converge)' "$WORK/$name.err"; then
    fail "($name) an Ostrich step failed"
  fi
}

# assert_silent NAME: no banner and no summary
assert_silent() {
  local name=$1
  [[ $(banner_count "$name") -eq 0 ]] || fail "($name) unexpected 'ostrich: stepping' banner"
  if grep -q '^ostrich: [0-9]* steps' "$WORK/$name.err"; then
    fail "($name) unexpected summary line"
  fi
}

BOX="$MODELS/box_plane.xml"
REFUSED="$MODELS/../tests/models/unsupported_user_gain.xml"
HUMANOID=/usr/share/mujoco/model/humanoid/humanoid.xml
[[ -f "$BOX" ]] || fail "model '$BOX' not found"
[[ -f "$REFUSED" ]] || fail "model '$REFUSED' not found"

# (a) box on a plane under the preload: banner, summary, testspeed report
run a "$PRELOAD" "" "$BOX" 200 1
assert_ran a 200
assert_ostrich a box_plane 200

# (a2) several threads share the counters: 3 x 200 steps
run a2 "$PRELOAD" "" "$BOX" 200 3
assert_ran a2 200
assert_ostrich a2 box_plane 600

# (b) without the preload: stock, no banner
run b "" "" "$BOX" 200 1
assert_ran b 200
assert_silent b
[[ ! -s "$WORK/b.err" ]] || fail "(b) stock run wrote to stderr"

# (c) OSTRICH_QUIET=1: no banner, no summary
run c "$PRELOAD" 1 "$BOX" 200 1
assert_ran c 200
assert_silent c

# (d) an unsupported feature: refused by name, stepped by stock MuJoCo
run d "$PRELOAD" "" "$REFUSED" 200 1
assert_ran d 200
grep -q '^ostrich: refusing model .*gaintype user' "$WORK/d.err" \
  || fail "(d) no 'refusing ... gaintype user' message on stderr"
[[ $(grep -c 'refusing' "$WORK/d.err") -eq 1 ]] || fail "(d) refusal printed more than once"
assert_silent d

# (e) the stock humanoid
if [[ -f "$HUMANOID" ]]; then
  run e "$PRELOAD" "" "$HUMANOID" 100 1
  assert_ran e 100
  assert_ostrich e Humanoid 100
else
  echo "--- (e) skipped: $HUMANOID not found (libmujoco-samples not installed)"
fi

# (f) a wrapper that does not link libmujoco (here timeout) keeps LD_PRELOAD and passes it on
rc=0
LD_PRELOAD="$PRELOAD" timeout 300 "$TESTSPEED" "$BOX" 50 1 > "$WORK/f.out" 2> "$WORK/f.err" \
  || rc=$?
echo "--- (f) LD_PRELOAD on the wrapper: LD_PRELOAD=... timeout 300 mujoco-testspeed: exit $rc"
sed 's/^/  stderr: /' "$WORK/f.err"
[[ $rc -eq 0 ]] || fail "(f) mujoco-testspeed under timeout exited with status $rc"
assert_ran f 50
assert_ostrich f box_plane 50

# (g) a contact capacity overflow (81 spheres, nconmax 1, Ostrich grows to 64): every failed
# step is counted, the first
# is named with its cause, and each is taken by stock MuJoCo instead of freezing the state
OVERFLOW="$MODELS/../tests/models/too_many_contacts.xml"
run g "$PRELOAD" "" "$OVERFLOW" 200 1
assert_ran g 200
grep -q '^ostrich: step at t = .* failed: contact capacity exceeded.*look-ahead.*taken by stock MuJoCo' \
  "$WORK/g.err" || fail "(g) no 'failed: contact capacity exceeded ... look-ahead' message"
[[ $(grep -c 'failed: contact capacity' "$WORK/g.err") -eq 1 ]] \
  || fail "(g) the failure message should be printed once, then counted"
grep -Eq '^ostrich: 200 steps, .* 200 failed and stepped by stock MuJoCo \(last: contact capacity' \
  "$WORK/g.err" || fail "(g) the summary does not count 200 failed steps stepped by stock MuJoCo"

echo "test_preload: all checks passed"
