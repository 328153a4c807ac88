"""ostrich.suite.mpc: receding-horizon control of suite tasks (adjoint, MuJoCo finite
differences, MPPI) and its command line. Short episodes: a few seconds.

Needs dm_control's suite MJCF files (as test_suite.py); skipped, saying so, without them.
"""

import io
import os

import numpy as np
import pytest

from ostrich import suite
from ostrich.suite import mpc, optimize

try:
  SUITE_DIR = suite.find_suite_dir()
except FileNotFoundError as e:
  pytest.skip(f"dm_control's suite XML not found: {e}", allow_module_level=True)


def _zero_return(domain, task, steps):
  env = suite.load(domain, task, xml_dir=SUITE_DIR, seed=0)
  env.reset()
  return sum(env.step(np.zeros(env.action_spec().shape)).reward for _ in range(steps))


def test_adjoint_mpc_balances_the_cartpole():
  # balance's reward is the product of upright, centred, small-control and small-velocity
  # terms, each 1 at rest upright: a controller that holds the pole there earns nearly 1 per
  # step (measured 0.9989). Without control the pole starts near upright and falls (measured
  # 225 of 300), so 0.99 per step separates holding from falling by far
  steps = 300
  planner = mpc.Planner("cartpole", "balance", xml_dir=SUITE_DIR)
  episode = mpc.run_episode(planner, "adjoint", 1, steps=steps, err=io.StringIO())
  assert episode.steps == steps and episode.iterations == steps
  assert episode.bad == 0 and episode.plant_unconverged == 0
  assert episode.ret > 0.99 * steps
  assert _zero_return("cartpole", "balance", steps) < 0.9 * steps


def test_control_cost_frees_the_reacher_from_its_wrist_limit():
  # the reacher's reward is 1 while the finger touches the target. In 2 s at full torque the
  # arm crosses its 0.22 m reach many times, so a planner that heads for the target touches it
  # (measured: 56 of 100 steps). With C = 0 the planner folds the wrist against its hard limit,
  # where a torque into the limit moves nothing: its gradient is 0 and the finger stays off the
  # target (measured 0). The control cost pulls that torque back, the wrist leaves the limit
  planner = mpc.Planner("reacher", "easy", xml_dir=SUITE_DIR)
  assert planner.horizon == 50  # 1 s of 0.02 s control steps
  touched = mpc.run_episode(planner, "adjoint", 2, steps=100, err=io.StringIO())
  assert touched.ret > 20
  stuck = mpc.run_episode(mpc.Planner("reacher", "easy", xml_dir=SUITE_DIR, control_cost=0),
                          "adjoint", 2, steps=100, err=io.StringIO())
  assert stuck.ret < touched.ret


def test_objective_carries_the_control_cost():
  planner = mpc.Planner("cartpole", "swingup", horizon=5, xml_dir=SUITE_DIR, control_cost=0.5)
  base = optimize.Problem("cartpole", "swingup", 5, seed=0, xml_dir=SUITE_DIR)
  qpos, qvel = np.zeros((3, 2)), np.zeros((3, 2))
  ctrl = np.array([[0.0], [0.5], [-1.0]])
  np.testing.assert_allclose(planner.problem.f(qpos, qvel, ctrl),
                             base.f(qpos, qvel, ctrl) - 0.5 * ctrl[:, 0] ** 2, rtol=0, atol=0)


def test_unconverged_iterations_leave_the_plan(monkeypatch):
  # an iteration whose rollout did not converge gives no gradient: the plan is not moved by
  # it, the step still acts (the plan's first action), and `bad` counts it
  planner = mpc.Planner("cartpole", "balance", horizon=10, xml_dir=SUITE_DIR)

  def unconverged(actions):
    raise optimize.Unconverged("1 of 10 Ostrich steps did not converge")
  monkeypatch.setattr(planner.problem, "objective_and_gradient", unconverged)
  episode = mpc.run_episode(planner, "adjoint", 3, steps=4, err=io.StringIO())
  assert episode.bad == 12
  assert episode.ret == pytest.approx(_zero_return("cartpole", "balance", 4), abs=0)


def test_larger_physics_step_plans_and_plays_at_it():
  # walker's control step is 0.025 s, ten of dm_control's 0.0025 s steps; at the control step
  # itself the plant and the Ostrich planners take one step per action
  planner = mpc.Planner("walker", "stand", horizon=4, xml_dir=SUITE_DIR, physics_timestep=0.025)
  assert planner.problem.n_sub == 1 and planner.problem.env.physics.timestep == 0.025
  episode = mpc.run_episode(planner, "adjoint", 1, steps=3, err=io.StringIO())
  assert episode.steps == 3 and np.isfinite(episode.ret)


def test_shifted_plan_and_moments():
  x = np.arange(6.0).reshape(3, 2)
  np.testing.assert_array_equal(mpc._shift(x), [[2, 3], [4, 5], [4, 5]])


def test_fd_and_mppi_run_and_the_table_compares(monkeypatch):
  planner = mpc.Planner("cartpole", "balance", horizon=8, xml_dir=SUITE_DIR)
  episodes = [mpc.run_episode(planner, m, s, steps=5, err=io.StringIO())
              for m, s in (("adjoint", 1), ("fd", 1), ("fdjac", 1), ("mppi", 8))]
  assert [e.method for e in episodes] == ["adjoint", "fd", "fdjac", "mppi"]
  assert all(e.steps == 5 and e.ret > 0 for e in episodes)
  # fd and fdjac take the same steps on gradients equal to ~1e-7: the same episode's return
  assert episodes[2].ret == pytest.approx(episodes[1].ret, rel=1e-6)
  rows, speed = mpc.table(episodes)
  assert rows.count("\n") == 5 and "cartpole-balance: fd's" in speed
  assert "cartpole-balance: fdjac's" in speed
  # the comparison line: the cheapest adjoint episode within 2 % of fd's best return
  fake = [e._replace(method=m, setting=k, ret=r, plan_s=t) for e, (m, k, r, t) in zip(
      episodes * 2, [("fd", 1, 100.0, 10.0), ("fd", 2, 101.0, 20.0), ("adjoint", 1, 95.0, 0.5),
                     ("adjoint", 2, 99.5, 1.0)])]
  _, speed = mpc.table(fake)
  assert "fd K = 1 in 10.00 s" in speed and "adjoint K = 2 (99.5) in 1.00 s: 10.0x" in speed


def test_mppi_on_another_device_is_labelled_and_plans_alike():
  # MPPI on a two-thread batch: its rows say the device, and a batch's worlds step alike on any
  # number of threads (the batch is bitwise the same on cpu:N and cuda), so the episode is the
  # one-thread episode
  one = mpc.Planner("cartpole", "balance", horizon=6, xml_dir=SUITE_DIR)
  two = mpc.Planner("cartpole", "balance", horizon=6, xml_dir=SUITE_DIR, device="cpu:2")
  a = mpc.run_episode(one, "mppi", 8, steps=4, err=io.StringIO())
  b = mpc.run_episode(two, "mppi", 8, steps=4, err=io.StringIO())
  assert (a.method, b.method) == ("mppi", "mppi@cpu:2")
  assert b.ret == a.ret and b.steps == a.steps == 4


def test_cli_writes_csv_and_png_atomically(tmp_path, capsys):
  csv_path, png = tmp_path / "mpc.csv", tmp_path / "mpc.png"
  status = mpc.main(["--task", "cartpole-balance", "--methods", "adjoint,mppi", "--iters", "1",
                     "--samples", "4", "--steps", "3", "--horizon", "5", "--xml-dir",
                     str(SUITE_DIR), "--csv", str(csv_path), "--plot", str(png)],
                    err=io.StringIO())
  assert status == 0
  lines = csv_path.read_text().splitlines()
  assert lines[0].split(",") == list(mpc.CSV_FIELDS) and len(lines) == 3
  episodes = mpc.read_csv(csv_path)
  assert [(e.method, e.setting, e.steps) for e in episodes] == [("adjoint", 1, 3), ("mppi", 4, 3)]
  assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
  assert sorted(os.listdir(tmp_path)) == ["mpc.csv", "mpc.png"]  # no temporary left
  assert "| cartpole-balance | adjoint | 1 |" in capsys.readouterr().out


@pytest.mark.parametrize("args", [["--task", "nope-task"], ["--methods", "sgd"],
                                  ["--iters", "0"], ["--samples", "x"], ["--steps", "0"],
                                  ["--control-cost", "-1"], ["--csv", "/nonexistent/a.csv"],
                                  ["--physics-timestep", "0"], ["--device", "tpu"],
                                  ["--physics-timestep", "0.003"]])  # 0.01 s is no multiple
def test_cli_refuses_bad_arguments_before_work(args):
  argv = ["--task", "cartpole-balance", "--xml-dir", str(SUITE_DIR)] + args
  err = io.StringIO()
  assert mpc.main(argv, out=io.StringIO(), err=err) == 2
  assert err.getvalue().startswith("ostrich.suite.mpc: ")
