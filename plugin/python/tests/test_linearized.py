"""Stock MuJoCo rollouts linearized by finite differences (plugin/python/ostrich/linearized.py,
ost_python_mujoco.c), the Jacobian-chain baseline of ostrich.suite: its states are mj_step's,
and its chained gradient equals central differences of whole MuJoCo rollouts, with the Euler
and the RK4 integrator (whose step Jacobians MuJoCo 2.2.2's mjd_transitionFD gets wrong) and
with a free joint's quaternion in qpos coordinates."""

import numpy as np
import pytest

import ostrich

# a free-flying base with an arm on a motorized hinge, no gravity, no contact: smooth dynamics
# whose qpos has a quaternion; the arm's torque turns the base through the reaction
FLYER = """
<mujoco>
  <option timestep="0.01" gravity="0 0 0" integrator="{integrator}"/>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint name="free"/>
      <geom type="box" size="0.2 0.1 0.05" mass="2" contype="0" conaffinity="0"/>
      <body name="arm" pos="0.2 0 0">
        <joint name="shoulder" type="hinge" axis="0 1 0" damping="0.1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5" contype="0"
              conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="torque" joint="shoulder" gear="1"/>
  </actuator>
</mujoco>
"""
STEPS, NSUB = 15, 2


def _start(physics):
  d = physics.data
  d.qpos[:] = [0, 0, 1, np.cos(0.3), 0.3, np.sin(0.3) * 0.5, 0.2, 0.4]
  d.qpos[3:7] /= np.linalg.norm(d.qpos[3:7])
  d.qvel[:] = [0.1, 0, -0.2, 0.5, -1, 0.3, 2]
  d.qacc_warmstart[:] = 0


def _loss(qpos, qvel, a, b):
  return float(np.sum(a * qpos) + np.sum(b * qvel))


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_chained_gradient_equals_rollout_differences(integrator):
  physics = ostrich.Physics.from_xml_string(FLYER.format(integrator=integrator))
  rng = np.random.default_rng(2)
  actions = rng.uniform(-1, 1, (STEPS, 1))
  a, b = rng.uniform(-1, 1, (STEPS, physics.nq)), rng.uniform(-1, 1, (STEPS, physics.nv))
  _start(physics)
  lin = ostrich.mujoco_linearized_rollout(physics, actions, NSUB)
  # the states are mj_step's, bit for bit (the differences restore the data each time)
  _start(physics)
  qpos, qvel = ostrich.mujoco_rollout(physics, actions, NSUB)
  np.testing.assert_array_equal(lin.qpos, qpos)
  np.testing.assert_array_equal(lin.qvel, qvel)
  gctrl, _ = lin.backward(a, b)
  # central differences of the loss of whole rollouts, one per action
  fd = np.zeros_like(actions)
  for k in range(STEPS):
    losses = []
    for s in (1, -1):
      moved = actions.copy()
      moved[k, 0] += s * 1e-6
      _start(physics)
      losses.append(_loss(*ostrich.mujoco_rollout(physics, moved, NSUB), a, b))
    fd[k, 0] = (losses[0] - losses[1]) / 2e-6
  err = np.max(np.abs(gctrl - fd)) / np.max(np.abs(fd))
  print(f"{integrator}: relative error {err:.1e}")
  # the step Jacobians are forward differences of size 1e-6 (truncation ~1e-6 of the
  # curvature, relative), the reference central ones (~1e-10 relative rounding): 1e-4 leaves
  # a factor 100 for their accumulation over 30 steps, while a wrong step Jacobian (RK4's from
  # mjd_transitionFD: velocity columns -5.5 instead of 1) is off by orders of magnitude
  assert err <= 1e-4


def test_start_state_gradient_and_argument_errors():
  physics = ostrich.Physics.from_xml_string(FLYER.format(integrator="Euler"))
  rng = np.random.default_rng(3)
  actions = rng.uniform(-1, 1, (STEPS, 1))
  a, b = rng.uniform(-1, 1, (STEPS, physics.nq)), rng.uniform(-1, 1, (STEPS, physics.nv))
  _start(physics)
  lin = ostrich.mujoco_linearized_rollout(physics, actions, NSUB)
  _, g0 = lin.backward(a, b)
  assert g0.shape == (2 * physics.nv,)
  # the start velocity's gradient against central differences (tangent = qvel for velocities)
  for i in (0, 3, 6):
    losses = []
    for s in (1, -1):
      _start(physics)
      physics.data.qvel[i] += s * 1e-6
      losses.append(_loss(*ostrich.mujoco_rollout(physics, actions, NSUB), a, b))
    fd = (losses[0] - losses[1]) / 2e-6
    assert g0[physics.nv + i] == pytest.approx(fd, rel=1e-4, abs=1e-8)
  with pytest.raises(ValueError, match="actions"):
    ostrich.mujoco_linearized_rollout(physics, np.zeros((3, 2)))
  with pytest.raises(ValueError, match="eps"):
    ostrich.mujoco_linearized_rollout(physics, actions, eps=0)
  with pytest.raises(ValueError, match="cotangents"):
    lin.backward(a[:-1], b)
