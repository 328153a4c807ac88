# lib.sh: the check helpers of the end-to-end scripts that drive the `ostrich` program
# (test_cli.sh, test_bench_models.sh, test_compare_hard.sh, test_compare_models.sh,
# test_compare_sweep.sh). Each sources it after setting BIN (the program) and tmp (its scratch
# directory):
#   source "$(dirname "$0")/lib.sh"
# A check prints "ok:   DESC" on stdout, or "FAIL: DESC" and what the last run left on stderr.
# Every check runs and is counted (npass, nfail); the script's last lines turn nfail into its
# exit status.
# What a failure shows is each script's choice: after sourcing this it may redefine fail_report
# (the whole report) or only fail_out / fail_err (the excerpts of the last run's stdout / stderr).

nfail=0   # failed checks
npass=0   # passed checks


# pass DESC: a check passed
pass() { npass=$((npass + 1)); echo "ok:   $1"; }


# fail DESC: a check failed; fail_report says so on stderr
fail() {
  nfail=$((nfail + 1))
  fail_report "$1" >&2
}


# fail_report DESC: DESC, the last run's command and exit code, and excerpts of its output
fail_report() {
  echo "FAIL: $1"
  echo "      command: ostrich ${cmd[*]} (exit $rc)"
  fail_output
}


# fail_output: the last run's stdout and stderr, cut by fail_out and fail_err, each line labelled
fail_output() {
  fail_out <"$tmp/out" | sed 's/^/      stdout: /'
  fail_err <"$tmp/err" | sed 's/^/      stderr: /'
}
fail_out() { head -n 5; }
fail_err() { head -n 5; }


# without_mujoco_warnings: stdin without MuJoCo's warning lines (for a fail_err)
without_mujoco_warnings() { grep -v '^mujoco warning' || true; }


# run ARGS...: run the program; sets cmd and rc, leaves stdout and stderr in $tmp/out and $tmp/err
run() {
  cmd=("$@")
  rc=0
  "$BIN" "$@" >"$tmp/out" 2>"$tmp/err" || rc=$?
}


# expect_rc WANT DESC: the last run exited with WANT
expect_rc() {
  if [[ $rc -eq $1 ]]; then pass "$2 (exit $1)"; else fail "$2: expected exit $1"; fi
}


# expect_usage_error DESC ARGS...: exit 2, nothing on stdout, an "ostrich:" message on stderr
expect_usage_error() {
  local desc=$1
  shift
  run "$@"
  if [[ $rc -ne 2 ]]; then
    fail "$desc: expected exit 2"
  elif [[ -s $tmp/out ]]; then
    fail "$desc: expected nothing on stdout"
  elif ! grep -q '^ostrich: ' "$tmp/err"; then
    fail "$desc: expected a message starting with 'ostrich: ' on stderr"
  else
    pass "$desc (exit 2: $(grep -m1 '^ostrich: ' "$tmp/err"))"
  fi
}
