"""ostrich.suite.optimize: trajectory optimization on the suite's tasks (adjoint, MuJoCo finite
differences, CEM) and its command line. Short horizons and a few iterations: a few seconds.

Needs dm_control's suite MJCF files (as test_suite.py); skipped, saying so, without them.
"""

import io
import os

import numpy as np
import pytest

from ostrich import suite
from ostrich.suite import optimize

try:
  SUITE_DIR = suite.find_suite_dir()
except FileNotFoundError as e:
  pytest.skip(f"dm_control's suite XML not found: {e}", allow_module_level=True)


def _problem(domain="cartpole", task="swingup", horizon=30):
  return optimize.Problem(domain, task, horizon, seed=0, xml_dir=SUITE_DIR)


def test_adjoint_increases_the_return():
  # cartpole swingup's reward is smooth and exact (reward_fn), so the objective on Ostrich is
  # the Environment's return itself: 15 Adam steps from zero actions must raise it
  problem = _problem()
  result = optimize.run_method(problem, "adjoint", budget=1e9, max_iterations=15,
                               err=io.StringIO())
  initial = result.points[0].ret
  best, _ = result.best()
  assert result.iterations == 15 and result.bad == 0
  # from hanging down the first 0.3 s earn ~3e-4 with zero force; measured 0.235 after 15
  # steps: ask for a tenfold and an absolute 0.1 gain, far above any rounding of the return
  assert best > 10 * initial and best > initial + 0.1
  # the objective is the return: the same engine, start and reward (to rounding of a sum of
  # 30 rewards in [0, 1])
  p = result.points[-1]
  assert p.objective == pytest.approx(p.ret, abs=1e-9)


def test_fd_gradient_agrees_with_the_adjoint():
  # the same objective differentiated two ways: the adjoint of Ostrich's steps, and forward
  # differences of stock MuJoCo's steps. The engines integrate the cart-pole slightly
  # differently (entries differ by up to ~9 % over 20 steps, measured), but the direction must
  # agree: measured cosines 0.9989 to 0.9999 at random actions; 0.99 leaves room for that model
  # difference and FD's O(1e-6) truncation error, while a wrong sign, step or index would give
  # far less
  problem = _problem(horizon=20)
  rng = np.random.RandomState(1)
  for _ in range(3):
    actions = rng.uniform(-1, 1, (20, 1))
    J, g = problem.objective_and_gradient(actions)
    J_fd, g_fd = problem.fd_objective_and_gradient(actions)
    cosine = g.ravel() @ g_fd.ravel() / (np.linalg.norm(g) * np.linalg.norm(g_fd))
    assert cosine > 0.99
    # the objectives agree to the engines' difference (measured relative 1e-2 to 1e-1 of
    # objectives of order 1e-3 near hanging down)
    assert J_fd == pytest.approx(J, rel=0.2)


def test_fdjac_gradient_equals_fd():
  # the two MuJoCo baselines differentiate the same objective of the same MuJoCo steps, fd by
  # whole rollouts and fdjac through the step Jacobians: both forward differences of size 1e-6,
  # so they agree to their truncation error (measured 2.8e-7 relative on the cart-pole, whose
  # RK4 steps MuJoCo 2.2.2's mjd_transitionFD differentiates wrongly, 4.4e-7 on the pendulum);
  # 1e-4 relative leaves a factor 100, far below any error of a Jacobian or its chain
  for domain, task in (("cartpole", "swingup"), ("pendulum", "swingup")):
    problem = _problem(domain, task, horizon=25)
    actions = np.random.RandomState(4).uniform(-0.8, 0.8, (25, problem.nu))
    J_fd, g_fd = problem.fd_objective_and_gradient(actions)
    J, g = problem.fdjac_objective_and_gradient(actions)
    assert J == J_fd  # the same nominal MuJoCo rollout, bit for bit
    assert np.max(np.abs(g - g_fd)) <= 1e-4 * np.max(np.abs(g_fd))


def test_cem_and_fd_run_and_report():
  problem = _problem(horizon=10)
  for method in ("fd", "fdjac", "cem"):
    result = optimize.run_method(problem, method, budget=1e9, max_iterations=3, seed=0,
                                 err=io.StringIO())
    assert result.iterations == 3 and len(result.points) >= 2
    assert all(np.isfinite(p.ret) for p in result.points)


def test_unconverged_rollout_is_reported_not_used(monkeypatch):
  # an iterate whose rollout does not converge is rejected: reported on stderr, counted, and
  # the optimizer goes back to its best actions with half the step
  problem = _problem(horizon=10)
  calls = {"n": 0}
  real = problem.objective_and_gradient

  def flaky(actions):
    calls["n"] += 1
    if calls["n"] == 2:
      raise optimize.Unconverged("3 of 10 Ostrich steps did not converge")
    return real(actions)

  monkeypatch.setattr(problem, "objective_and_gradient", flaky)
  err = io.StringIO()
  result = optimize.run_method(problem, "adjoint", budget=1e9, max_iterations=4, err=err)
  assert result.bad == 1
  assert "rejected: 3 of 10 Ostrich steps did not converge" in err.getvalue()


def test_cli_writes_csv_and_png_atomically(tmp_path, monkeypatch, capsys):
  csv_path, png_path = tmp_path / "out.csv", tmp_path / "out.png"
  replaced = []
  real_replace = os.replace

  def recording_replace(src, dst):
    # the final name appears only by the rename, from a temporary file in the same folder
    assert not os.path.exists(dst)
    assert os.path.dirname(os.path.abspath(src)) == os.path.dirname(os.path.abspath(dst))
    assert os.path.getsize(src) > 0
    replaced.append(os.path.basename(dst))
    real_replace(src, dst)

  monkeypatch.setattr(os, "replace", recording_replace)
  argv = ["--task", "cartpole-swingup", "--horizon", "10", "--iterations", "2", "--budget",
          "1000", "--methods", "adjoint,fd", "--xml-dir", SUITE_DIR, "--csv", str(csv_path)]
  if optimize.shutil.which("gnuplot"):
    argv += ["--plot", str(png_path)]
  assert optimize.main(argv) == 0
  out, err = capsys.readouterr()
  assert "| cartpole-swingup | adjoint | ostrich |" in out
  assert "iter     2" in err
  rows = csv_path.read_text().splitlines()
  assert rows[0] == ",".join(optimize.CSV_FIELDS) and len(rows) == 1 + 4  # 2 evaluations each
  assert "out.csv" in replaced
  if "--plot" in argv:
    assert "out.png" in replaced
    assert png_path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
  assert sorted(os.listdir(tmp_path)) == sorted(replaced)  # no temporary file left


@pytest.mark.parametrize("flag", ["--csv", "--plot"])
def test_cli_refuses_unwritable_output_before_work(tmp_path, monkeypatch, capsys, flag):
  def no_work(*args, **kw):
    raise AssertionError("work started before the output path was checked")

  monkeypatch.setattr(optimize, "Problem", no_work)
  blocker = tmp_path / "file"
  blocker.write_text("")
  for path in (tmp_path / "missing" / "out.x", blocker / "out.x", tmp_path):
    argv = ["--task", "cartpole-swingup", "--xml-dir", SUITE_DIR, flag, str(path)]
    assert optimize.main(argv) == 2
    assert flag in capsys.readouterr().err
  assert optimize.main(["--task", "finger-spin", "--xml-dir", SUITE_DIR]) == 2
  assert "finger-spin" in capsys.readouterr().err
