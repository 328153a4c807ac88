"""ostrich.suite: dm_control's suite tasks on Ostrich (plugin/python/ostrich/suite/).

The models are dm_control's own MJCF files, found as ostrich.suite.find_suite_dir finds them
(OSTRICH_DM_SUITE_DIR, or the dm_control package installed with `pip install --no-deps
dm_control`, as .ci/run does); without them these tests are skipped, saying so. Expected rewards
are computed here by hand from dm_control's definitions of `tolerance` and of each task's reward.
"""

import math
import unittest
import warnings

import numpy as np
import pytest

import ostrich
from ostrich import suite
from ostrich.suite import tolerance

try:
  SUITE_DIR = suite.find_suite_dir()
except FileNotFoundError as e:
  pytest.skip(f"dm_control's suite XML not found: {e}", allow_module_level=True)

TASKS = list(suite.TASKS)
G = 0.1  # dm_control's default value_at_margin: a gaussian tolerance at d margins is G**(d*d)


def _load(domain, task, **kw):
  return suite.load(domain, task, xml_dir=SUITE_DIR, **kw)


def _state(env, qpos=None, qvel=None, ctrl=None):
  """Write a hand-made state into the environment's physics and refresh its kinematics."""
  p = env.physics
  p.reset()
  for name, value in (("qpos", qpos), ("qvel", qvel), ("ctrl", ctrl)):
    if value is not None:
      for key, v in value.items():
        getattr(p.named.data, name)[key] = v
  p.forward()
  return env.task.get_reward(p)


# ---- tolerance

@pytest.mark.parametrize("kind", suite.rewards.SIGMOIDS)
def test_tolerance_at_bounds_and_margin(kind):
  v = 0.3 if kind not in ("linear", "quadratic", "cosine") else 0.0
  # inside the bounds (ends included) 1; one margin outside, value_at_margin: the definition
  assert tolerance(1.0, (1.0, 2.0), margin=0.5, sigmoid=kind, value_at_margin=v) == 1.0
  assert tolerance(2.0, (1.0, 2.0), margin=0.5, sigmoid=kind, value_at_margin=v) == 1.0
  assert tolerance(2.5, (1.0, 2.0), margin=0.5, sigmoid=kind,
                   value_at_margin=v) == pytest.approx(v, abs=1e-12)
  assert tolerance(0.5, (1.0, 2.0), margin=0.5, sigmoid=kind,
                   value_at_margin=v) == pytest.approx(v, abs=1e-12)
  x = np.array([1.5, 2.25, 0.75, 5.0])
  out = tolerance(x, (1.0, 2.0), margin=0.5, sigmoid=kind, value_at_margin=v)
  assert out.shape == (4,) and out[0] == 1.0 and np.all((out >= 0) & (out <= 1))
  assert out[1] == pytest.approx(out[2], abs=1e-15)  # half a margin above and below alike


def test_tolerance_values_by_hand():
  # half a margin out (d = 0.5): each sigmoid's formula with value_at_1 = v
  v, d = 0.1, 0.5
  cases = {
      "gaussian": v ** (d * d),                          # exp(-d^2/2 * (-2 ln v))
      "long_tail": 1 / (d * d * (1 / v - 1) + 1),
      "reciprocal": 1 / (d * (1 / v - 1) + 1),
      "hyperbolic": 1 / math.cosh(d * math.acosh(1 / v)),
      "tanh_squared": 1 - math.tanh(d * math.atanh(math.sqrt(1 - v))) ** 2,
      "linear": 1 - d * (1 - v),
      "quadratic": 1 - d * d * (1 - v),
      "cosine": (1 + math.cos(math.pi * d * math.acos(2 * v - 1) / math.pi)) / 2,
  }
  for kind, expected in cases.items():
    assert tolerance(2.5, (0, 2), margin=1, sigmoid=kind, value_at_margin=v) == \
        pytest.approx(expected, rel=1e-14), kind
  # margin 0: an indicator of the bounds; infinite bounds; linear and quadratic reach 0
  assert tolerance(2.1, (0, 2)) == 0.0 and tolerance(3.0, (3, 3)) == 1.0
  assert tolerance(1e9, (1, float("inf")), margin=1) == 1.0
  assert tolerance(-3.0, (0, 1), margin=1, sigmoid="linear", value_at_margin=0) == 0.0
  assert tolerance(1.5, (0, 0), margin=1, sigmoid="quadratic", value_at_margin=0) == 0.0
  with pytest.raises(ValueError, match="lower bound"):
    tolerance(0.0, (1, 0))
  with pytest.raises(ValueError, match="margin"):
    tolerance(0.0, margin=-1)
  with pytest.raises(ValueError, match="strictly between"):
    tolerance(2.0, (0, 1), margin=1, sigmoid="gaussian", value_at_margin=0)
  with pytest.raises(ValueError, match="unknown sigmoid"):
    tolerance(2.0, (0, 1), margin=1, sigmoid="logistic")


# ---- each task's reward on hand-made states

def test_cartpole_reward_by_hand():
  for task in ("balance", "swingup"):
    env = _load("cartpole", task)
    r = _state(env, qpos={"slider": 0.5, "hinge_1": 0.3}, qvel={"hinge_1": 2.0},
               ctrl={"slide": 0.5})
    upright = (math.cos(0.3) + 1) / 2                  # pole zz = cos(hinge)
    centered = (1 + G ** (0.25 ** 2)) / 2              # 0.5 out of (0, 0), margin 2
    small_control = (4 + (1 - 0.5 ** 2)) / 5           # quadratic, value 0 at margin 1
    small_velocity = (1 + G ** (0.4 ** 2)) / 2         # 2 rad/s, margin 5
    assert r == pytest.approx(upright * centered * small_control * small_velocity, rel=1e-12)


def test_pendulum_reward_by_hand():
  env = _load("pendulum", "swingup")
  # upright within 8 degrees (0.1396 rad) pays 1, else 0 (margin 0)
  assert _state(env, qpos={"hinge": 0.13}) == 1.0
  assert _state(env, qpos={"hinge": -0.14}) == 0.0
  assert _state(env, qpos={"hinge": math.pi}) == 0.0


def test_reacher_reward_by_hand():
  env = _load("reacher", "easy", seed=0)
  env.reset()  # sets the target's radius to 0.05 and moves it
  model = env.physics.named.model
  # at qpos 0 the finger (radius 0.01) is at x = 0.12 + 0.12: touching when the centres are
  # within 0.05 + 0.01
  model.geom_pos["target", 0], model.geom_pos["target", 1] = 0.24 + 0.059, 0.0
  assert _state(env, qpos={"shoulder": 0.0, "wrist": 0.0}) == 1.0
  model.geom_pos["target", 0] = 0.24 + 0.061
  assert _state(env, qpos={"shoulder": 0.0, "wrist": 0.0}) == 0.0
  # the arm folded back by 90 degrees at the wrist: finger at (0.12, 0.12)
  model.geom_pos["target", 0], model.geom_pos["target", 1] = 0.12, 0.12 - 0.05
  assert _state(env, qpos={"wrist": math.pi / 2}) == 1.0


def test_finger_reward_by_hand():
  env = _load("finger", "spin")
  assert _state(env, qvel={"hinge": -15.5}) == 1.0  # spinning faster than 15 rad/s clockwise
  assert _state(env, qvel={"hinge": -14.5}) == 0.0
  assert _state(env, qvel={"hinge": 20.0}) == 0.0   # the wrong way


def test_cheetah_reward_by_hand():
  env = _load("cheetah", "run")
  # every body moving forward at 5 m/s: the torso subtree's velocity is 5; linear from 0 at 0
  # to 1 at 10 m/s
  assert _state(env, qvel={"rootx": 5.0}) == pytest.approx(0.5, rel=1e-12)
  assert _state(env, qvel={"rootx": 12.0}) == 1.0
  assert _state(env, qvel={"rootx": -1.0}) == 0.0


def test_walker_rewards_by_hand():
  stand = (3 * G ** ((0.2 / 0.6) ** 2) + (1 + math.cos(0.4)) / 2) / 4  # torso at 1.0 m, 0.6 margin
  state = dict(qpos={"rootz": -0.3, "rooty": 0.4})                      # torso origin at 1.3 + z
  assert _state(_load("walker", "stand"), **state) == pytest.approx(stand, rel=1e-12)
  # walking at 0.75 m/s: half a margin (0.5) below 1 m/s, linear with 0.5 at the margin
  move = 1 - 0.5 * 0.5
  r = _state(_load("walker", "walk"), qvel={"rootx": 0.75}, **state)
  assert r == pytest.approx(stand * (5 * move + 1) / 6, rel=1e-12)


def test_hopper_reward_by_hand():
  env = _load("hopper", "stand")
  r = _state(env, ctrl={"waist": 0.5})
  xipos = env.physics.named.data.xipos
  assert 0.6 <= xipos["torso", 2] - xipos["foot", 2] <= 2  # standing straight: within bounds
  small_control = ((1 - 0.5 ** 2) + 3) / 4                # quadratic per actuator, the mean
  assert r == pytest.approx((small_control + 4) / 5, rel=1e-12)
  r = _state(env, qpos={"hip": -2.5, "knee": 2.5})  # crouched: torso 0.38 m above the foot
  h = xipos["torso", 2] - xipos["foot", 2]
  assert h < 0.6 and r == 0  # below the bounds with margin 0: no reward


def test_planar_kinematics_is_mujocos():
  # hopper's torso over its foot, walker's torso over its left foot, and the torso subtree's
  # centre-of-mass velocity (the subtreelinvel sensor) of cheetah, walker and hopper: the
  # planar functions equal MuJoCo's xipos and sensordata after mj_forward at random states
  # (rounding only)
  from ostrich.suite import planar
  rng = np.random.RandomState(4)
  for domain, task, lower in (("hopper", "stand", "foot"), ("walker", "walk", "left_foot"),
                              ("cheetah", "run", None)):
    env = _load(domain, task)
    p = env.physics
    velocity = planar.subtree_com_velocity(p, "torso")
    qs = p.model.qpos0 + rng.uniform(-1.5, 1.5, (20, p.nq))
    vs = rng.uniform(-3, 3, (20, p.nv))
    vx, vz = velocity(qs, vs)
    heights = planar.com_height(p, "torso", lower)(qs) if lower else None
    for i, (q, v) in enumerate(zip(qs, vs)):
      p.data.qpos[:], p.data.qvel[:] = q, v
      p.forward()
      assert vx[i] == pytest.approx(p.named.data.sensordata["torso_subtreelinvel"][0], abs=1e-13)
      assert vz[i] == pytest.approx(p.named.data.sensordata["torso_subtreelinvel"][2], abs=1e-13)
      if lower:
        xipos = p.named.data.xipos
        assert heights[i] == pytest.approx(xipos["torso", 2] - xipos[lower, 2], abs=1e-14)
  with pytest.raises(ValueError, match="not planar"):
    planar.com_height(_load("reacher", "easy").physics, "finger", "arm")  # hinges about z


# ---- rewards as functions of (qpos, qvel, ctrl)

@pytest.mark.parametrize("domain,task", suite.REWARD_FNS)
def test_reward_fn_equals_the_environments_reward(domain, task):
  env = _load(domain, task, seed=3)
  env.reset()
  fn = env.reward_fn(np)
  p, rng = env.physics, np.random.RandomState(0)
  qs, vs, us, expected = [], [], [], []
  for k in range(50):
    p.data.qpos[:] = p.data.qpos + rng.normal(0, 0.6, p.nq)
    p.data.qvel[:] = rng.normal(0, 3, p.nv)
    p.data.ctrl[:] = rng.uniform(-1.2, 1.2, p.nu)
    if domain == "reacher" and k % 2:  # half the states on the target, where the reward is 1
      p.data.qpos[:] = 0
      p.named.model.geom_pos["target", :2] = [0.24 - 0.03, 0.0]
      fn = env.reward_fn(np)  # the function reads the target when it is made
    p.forward()
    qs.append(p.data.qpos.copy()), vs.append(p.data.qvel.copy()), us.append(p.data.ctrl.copy())
    expected.append(env.task.get_reward(p))
    assert float(fn(qs[-1], vs[-1], us[-1])) == pytest.approx(expected[-1], abs=1e-12)
  if domain == "reacher":
    assert 0 < sum(expected) < len(expected)  # both sides of the sparse reward were seen
  else:  # a batch of states at once (leading dimensions) gives each state's reward
    np.testing.assert_allclose(fn(np.array(qs), np.array(vs), np.array(us)), expected,
                               atol=1e-12)


def test_reward_fn_in_torch():
  torch = pytest.importorskip("torch", reason="PyTorch is not installed")
  env = _load("cartpole", "swingup", seed=0)
  env.reset()
  q = torch.tensor([0.3, 0.4], dtype=torch.float64, requires_grad=True)
  v = torch.tensor([0.0, 1.0], dtype=torch.float64)
  u = torch.tensor([0.2], dtype=torch.float64)
  r = env.reward_fn(torch)(q, v, u)
  r.backward()
  f = env.reward_fn(np)
  assert float(r) == pytest.approx(float(f(q.detach().numpy(), v.numpy(), u.numpy())), rel=1e-14)
  eps = 1e-6  # central differences: error O(eps^2) on a smooth reward
  for i in range(2):
    dq = np.zeros(2)
    dq[i] = eps
    fd = (f(q.detach().numpy() + dq, v.numpy(), u.numpy())
          - f(q.detach().numpy() - dq, v.numpy(), u.numpy())) / (2 * eps)
    assert float(q.grad[i]) == pytest.approx(float(fd), rel=1e-6, abs=1e-10)


# ---- dm_env conformance

def _check_episode(env, rng):
  """An episode with random actions within the action spec: the TimeSteps' types, rewards,
  discounts and observations against the specs (what dm_env's EnvironmentTestMixin checks)."""
  obs_spec, act_spec = env.observation_spec(), env.action_spec()
  ts = env.reset()
  assert ts.step_type == suite.StepType.FIRST and ts.first()
  assert ts.reward is None and ts.discount is None
  assert list(ts.observation) == list(obs_spec)
  for key, spec in obs_spec.items():
    spec.validate(ts.observation[key])
  n = 0
  while True:
    action = rng.uniform(act_spec.minimum, act_spec.maximum)
    act_spec.validate(action)
    ts = env.step(action)
    n += 1
    assert ts.step_type != suite.StepType.FIRST
    env.reward_spec().validate(ts.reward)
    env.discount_spec().validate(ts.discount)
    assert 0.0 <= ts.reward <= 1.0 and ts.discount == 1.0  # the suite's rewards lie in [0, 1]
    for key, spec in obs_spec.items():
      spec.validate(ts.observation[key])
      assert np.all(np.isfinite(ts.observation[key]))
    if ts.last():
      break
  # the suite's episode length: time limit / control timestep; a step after LAST begins anew
  assert n == round(env.task.time_limit / env.control_timestep())
  assert env.step(act_spec.generate_value()).first()
  return n


@pytest.mark.parametrize("domain,task", TASKS)
@pytest.mark.parametrize("engine", suite.ENGINES)
def test_episode_conforms_to_specs(domain, task, engine):
  env = _load(domain, task, engine=engine, seed=1)
  spec = env.action_spec()
  assert spec.shape == (env.physics.nu,) and spec.dtype == np.float64
  np.testing.assert_array_equal(spec.minimum, -1)  # every suite actuator has ctrlrange -1 1
  np.testing.assert_array_equal(spec.maximum, 1)
  with warnings.catch_warnings():
    # a step whose residual ends just above tol warns and goes on; the episode's checks stand
    warnings.simplefilter("ignore", ostrich.NotConvergedWarning)
    n = _check_episode(env, np.random.RandomState(0))
  expected = {"cartpole": 1000, "pendulum": 1000, "reacher": 1000, "finger": 1000,
              "cheetah": 1000, "walker": 1000, "hopper": 1000}[domain]  # dm_control's lengths
  assert n == expected


def test_suite_tables():
  env = _load("walker", "walk")
  assert env.control_timestep() == 0.025 and env.n_sub_steps == 10  # 0.0025 s model steps
  assert _load("finger", "spin").n_sub_steps == 2 and _load("hopper", "stand").n_sub_steps == 4
  assert _load("cheetah", "run").n_sub_steps == 1
  with pytest.raises(KeyError, match="no suite task 'walker' 'run'"):
    _load("walker", "run")
  with pytest.raises(ValueError, match="engine 'bullet'"):
    _load("walker", "walk", engine="bullet")
  with pytest.raises(FileNotFoundError, match="cartpole.xml"):
    suite.load("cartpole", "balance", xml_dir="/nonexistent")


def test_larger_physics_step_keeps_the_control_timestep():
  # Ostrich steps the walker once per control step (0.025 s, ten times MuJoCo's 0.0025)
  env = _load("walker", "stand", physics_timestep=0.025, seed=0)
  assert env.n_sub_steps == 1 and env.physics.timestep == 0.025
  with warnings.catch_warnings():
    warnings.simplefilter("ignore", ostrich.NotConvergedWarning)
    assert _check_episode(env, np.random.RandomState(0)) == 1000
  assert env.physics.timestep == 0.025  # episode resets keep the option
  with pytest.raises(ValueError, match="integer multiple"):
    _load("walker", "stand", physics_timestep=0.01)
  with pytest.raises(ValueError, match="cannot be smaller"):
    _load("cartpole", "balance", physics_timestep=0.02)
  mj = _load("hopper", "stand", physics_timestep=0.01, engine="mujoco")
  assert mj.n_sub_steps == 2 and mj.physics.model.timestep == 0.01


if hasattr(suite.environment, "_dm_env") and suite.environment._dm_env is not None:
  try:
    from dm_env import test_utils as _dm_env_test_utils  # needs absl and dm-tree
  except ImportError:
    _dm_env_test_utils = None
else:
  _dm_env_test_utils = None

def _mixin_case(domain, task):
  """dm_env's own conformance tests on one task, with an episode of 8 control steps so that
  the mixin's 20 actions cross its LAST step and the reset after it."""

  class Case(_dm_env_test_utils.EnvironmentTestMixin, unittest.TestCase):
    def make_object_under_test(self):
      env = _load(domain, task, seed=0)
      return _load(domain, task, seed=0, time_limit=8 * env.control_timestep())

  Case.__name__ = Case.__qualname__ = f"TestDmEnvMixin_{domain}_{task}"
  return Case


if _dm_env_test_utils is not None:
  for _domain, _task in suite.TASKS:
    globals()[f"TestDmEnvMixin_{_domain}_{_task}"] = _mixin_case(_domain, _task)


def test_uses_dm_envs_classes_when_installed():
  try:
    import dm_env
  except ImportError:
    pytest.skip("dm_env is not installed: the package's own TimeStep and specs are used")
  ts = _load("pendulum", "swingup", seed=0).reset()
  assert isinstance(ts, dm_env.TimeStep) and ts.step_type is dm_env.StepType.FIRST
  assert isinstance(_load("pendulum", "swingup").action_spec(), dm_env.specs.BoundedArray)


# ---- initial states

@pytest.mark.parametrize("domain,task", TASKS)
def test_reset_is_deterministic_by_seed(domain, task):
  with warnings.catch_warnings():
    warnings.simplefilter("ignore", ostrich.NotConvergedWarning)  # cheetah's settling steps
    a, b = _load(domain, task, seed=7), _load(domain, task, seed=7)
    c = _load(domain, task, seed=8)
    for _ in range(2):  # and the next episode: the seed seeds one stream across episodes
      oa, ob, oc = a.reset().observation, b.reset().observation, c.reset().observation
      for key in oa:
        np.testing.assert_array_equal(oa[key], ob[key])
      assert any(not np.array_equal(oa[k], oc[k]) for k in oa)
      np.testing.assert_array_equal(a.physics.data.qpos, b.physics.data.qpos)


def test_initial_states_follow_dm_control():
  env = _load("cartpole", "swingup", seed=0)
  env.reset()
  rng = np.random.RandomState(0)  # dm_control's draws, in its order
  slider, hinge = .01 * rng.randn(), np.pi + .01 * rng.randn()
  qvel = .01 * rng.randn(2)
  np.testing.assert_array_equal(env.physics.data.qpos, [slider, hinge])
  np.testing.assert_array_equal(env.physics.data.qvel, qvel)
  env = _load("reacher", "easy", seed=0)
  env.reset()
  rng = np.random.RandomState(0)
  shoulder = rng.uniform(-np.pi, np.pi)
  wrist = rng.uniform(*np.radians([-160, 160]))
  angle, radius = rng.uniform(0, 2 * np.pi), rng.uniform(.05, .20)
  np.testing.assert_allclose(env.physics.data.qpos, [shoulder, wrist], rtol=1e-12)
  np.testing.assert_allclose(env.physics.named.model.geom_pos["target", :2],
                             [radius * np.sin(angle), radius * np.cos(angle)], rtol=1e-12)
  assert env.physics.named.model.geom_size["target", 0] == 0.05
  env = _load("finger", "spin", seed=0)
  env.reset()
  assert env.physics.data.ncon == 0  # a collision-free start, as dm_control draws it
  assert env.physics.named.model.dof_damping["hinge"] == 0.03


# ---- A/B: Ostrich against MuJoCo at the suite's own timestep

AB_STEPS = 200  # control steps per episode: a short, seeded random-policy episode


def _random_return(domain, task, engine, seed=0):
  env = _load(domain, task, engine=engine, seed=seed, time_limit=None)
  env.reset()
  spec, rng, total = env.action_spec(), np.random.RandomState(seed + 100), 0.0
  for _ in range(AB_STEPS):
    total += env.step(rng.uniform(spec.minimum, spec.maximum)).reward
  return total


def test_ab_random_policy_returns():
  returns = {}
  with warnings.catch_warnings():
    warnings.simplefilter("ignore", ostrich.NotConvergedWarning)
    for key in TASKS:
      returns[key] = [np.mean([_random_return(*key, engine, seed) for seed in range(3)])
                      for engine in suite.ENGINES]
  print("\nmean return of a random policy over", AB_STEPS, "control steps (ostrich, mujoco):")
  for (domain, task), (ost, mj) in returns.items():
    print(f"  {domain:9s}{task:9s}{ost:9.3f}{mj:9.3f}")
    assert 0 <= ost <= AB_STEPS and 0 <= mj <= AB_STEPS  # rewards lie in [0, 1]
  # cartpole balance has no contacts: the two engines differ only by their integrators
  # (Ostrich's implicit step, MuJoCo's RK4 of the suite's model) and must agree within 5%
  ost, mj = returns["cartpole", "balance"]
  assert abs(ost - mj) <= 0.05 * mj
  # pendulum and reacher, from random starts under random torques, almost never earn their
  # sparse rewards; both engines see that alike (no contacts in either model)
  for key in (("pendulum", "swingup"), ("reacher", "easy")):
    ost, mj = returns[key]
    assert abs(ost - mj) <= 0.05 * AB_STEPS


def test_readme_example_runs(monkeypatch, capsys):
  import os
  readme = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "README.md")
  with open(readme) as f:
    code = f.read().split("\n## dm_control suite\n")[1].split("```python\n")[1].split("```")[0]
  monkeypatch.setenv("OSTRICH_DM_SUITE_DIR", SUITE_DIR)
  scope = {}
  exec(compile(code, "plugin/python/README.md", "exec"), scope)
  ret, n_sub = capsys.readouterr().out.split()
  assert 0 < float(ret) <= 1000 and n_sub == "10"  # walker: 0.025 s control, 0.0025 s model
  assert scope["fast"].n_sub_steps == 1
