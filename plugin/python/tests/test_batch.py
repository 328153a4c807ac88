"""Batches (plugin/python/ostrich/batch.py over ost_batch*, cpu device): every world's rollout
and gradient equal the single-world ones (which test_rollout.py checks against central
differences), qpos gradients of free joints in coordinates, and the refusal of worlds whose
rollout did not converge."""

import numpy as np
import pytest

import ostrich
from conftest import ACT_ARM, FREE_BALL, model_path, starved_box_plane


def single(physics, actions, qpos0, qvel0, cot_qpos, cot_qvel):
  traj = ostrich.rollout(physics, actions, qpos0, qvel0)
  return traj, traj.backward(cot_qpos, cot_qvel, params=False)


def test_batch_worlds_equal_single_rollouts_and_gradients():
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  nworld, steps = 4, 20
  rng = np.random.default_rng(0)
  qpos0 = rng.uniform(-0.2, 0.2, (nworld, 2))
  qvel0 = rng.uniform(-0.2, 0.2, (nworld, 2))
  actions = rng.uniform(-0.5, 0.5, (steps, nworld, 1))
  batch = ostrich.Batch(physics, nworld, "cpu:2")
  traj = batch.rollout(actions, qpos0, qvel0)
  assert traj.qpos.shape == (steps + 1, nworld, 2) and not traj.unconverged.any()
  np.testing.assert_array_equal(traj.qpos[0], qpos0)
  np.testing.assert_array_equal(batch.state()[0], traj.qpos[-1])
  cot_qpos = rng.uniform(-1, 1, traj.qpos.shape)
  cot_qvel = rng.uniform(-1, 1, traj.qvel.shape)
  grads = traj.backward(cot_qpos, cot_qvel)
  assert grads.ctrl.shape == (steps, nworld, 1) and not grads.refused.any()
  for w in range(nworld):
    one, g = single(physics, actions[:, w], qpos0[w], qvel0[w], cot_qpos[:, w], cot_qvel[:, w])
    np.testing.assert_allclose(traj.qpos[:, w], one.qpos, rtol=0, atol=1e-13)
    np.testing.assert_allclose(traj.qvel[:, w], one.qvel, rtol=0, atol=1e-12)
    for batch_g, single_g in [(grads.qpos[w], g.qpos), (grads.qvel[w], g.qvel),
                              (grads.ctrl[:, w], g.ctrl)]:
      np.testing.assert_allclose(batch_g, single_g, rtol=1e-10, atol=1e-12 * abs(single_g).max())


def test_batch_activations_equal_single_rollouts():
  # each world's activations start from its act0 and move as a single rollout's; the state
  # and the controls' gradients (through the activations) agree with it
  physics = ostrich.Physics.from_xml_string(ACT_ARM)
  nworld, steps = 3, 15
  rng = np.random.default_rng(1)
  qpos0 = rng.uniform(-0.3, 0.3, (nworld, 2))
  act0 = rng.uniform(-0.5, 0.5, (nworld, 2))
  actions = rng.uniform(-0.5, 0.5, (steps, nworld, 2))
  batch = ostrich.Batch(physics, nworld, "cpu:2")
  traj = batch.rollout(actions, qpos0, np.zeros((nworld, 2)), act0=act0)
  assert traj.act.shape == (steps + 1, nworld, 2)
  np.testing.assert_array_equal(traj.act[0], act0)
  np.testing.assert_array_equal(batch.act, traj.act[-1])
  cot_qpos = rng.uniform(-1, 1, traj.qpos.shape)
  cot_qvel = rng.uniform(-1, 1, traj.qvel.shape)
  grads = traj.backward(cot_qpos, cot_qvel)
  for w in range(nworld):
    one = ostrich.rollout(physics, actions[:, w], qpos0[w], np.zeros(2), act0=act0[w])
    g = one.backward(cot_qpos[:, w], cot_qvel[:, w], params=False)
    # the filter and integrator are the same closed forms in both; the dynamics differ by
    # provider (native against MuJoCo's) to rounding
    np.testing.assert_allclose(traj.act[:, w], one.act, rtol=0, atol=1e-13)
    np.testing.assert_allclose(traj.qpos[:, w], one.qpos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(grads.ctrl[:, w], g.ctrl, rtol=1e-10,
                               atol=1e-12 * abs(g.ctrl).max())
  assert np.abs(traj.act[-1] - act0).max() > 0.1
  # set_state zeroes the activations; set_act broadcasts one row
  batch.set_state()
  np.testing.assert_array_equal(batch.act, 0)
  batch.set_act([0.1, 0.2])
  np.testing.assert_array_equal(batch.act, [[0.1, 0.2]] * nworld)


def test_batch_free_joint_gradient_in_coordinates():
  physics = ostrich.Physics.from_xml_string(FREE_BALL)
  steps = 8
  qpos0 = np.array([[0, 0, 1, 1, 0, 0, 0], [0, 0, 2, np.cos(0.3), 0, np.sin(0.3), 0]])
  qvel0 = np.array([[0.3, 0, 1, 2, -3, 1], [0, 0.2, 0, -1, 0, 4]])
  batch = ostrich.Batch(physics, 2, "cpu:1")
  traj = batch.rollout(np.zeros((steps, 2, 0)), qpos0, qvel0)
  rng = np.random.default_rng(5)
  cot_qpos = rng.uniform(-1, 1, traj.qpos.shape)
  cot_qvel = rng.uniform(-1, 1, traj.qvel.shape)
  cot_qpos[0] = 0  # no loss on the start state (its radial part is not a gradient)
  grads = traj.backward(cot_qpos, cot_qvel)
  tangent = traj.backward(np.zeros((steps + 1, 2, 6)), cot_qvel, tangent=True)
  assert grads.qpos.shape == (2, 7) and tangent.qpos.shape == (2, 6)
  for w in range(2):
    _, g = single(physics, np.zeros((steps, 0)), qpos0[w], qvel0[w], cot_qpos[:, w],
                  cot_qvel[:, w])
    np.testing.assert_allclose(grads.qpos[w], g.qpos, rtol=1e-10, atol=1e-12)
    assert abs(grads.qpos[w, 3:] @ qpos0[w, 3:]) < 1e-10


def test_batch_refuses_unconverged_worlds():
  xml = starved_box_plane(2)
  physics = ostrich.Physics.from_xml_string(xml)
  batch = ostrich.Batch(physics, 2, "cpu:1")
  qpos0 = np.tile(physics.model.qpos0, (2, 1))
  qpos0[0, 2] = 3.0                       # world 0 in flight all along: converges
  qvel0 = np.array([[0.0] * 6, [1, 0, -2, 0, 0, 0]])  # world 1 thrown at its floor
  with pytest.warns(ostrich.NotConvergedWarning, match=r"worlds \[1\]"):
    traj = batch.rollout(np.zeros((10, 2, 0)), qpos0, qvel0)
  assert traj.unconverged[0] == 0 and traj.unconverged[1] > 0
  cot = (np.ones((11, 2, 7)), np.ones((11, 2, 6)))
  with pytest.raises(ostrich.NotConvergedError, match="1 of 2 worlds.*world 1: not converged"):
    traj.backward(*cot)
  grads = traj.backward(*cot, strict=False)
  np.testing.assert_array_equal(grads.refused, [False, True])
  assert np.isnan(grads.qpos[1]).all() and np.isfinite(grads.qpos[0]).all()
  # world 0 alone: ballistic flight, the same gradient as a single-world rollout
  _, g = single(physics, np.zeros((10, 0)), qpos0[0], qvel0[0], cot[0][:, 0], cot[1][:, 0])
  np.testing.assert_allclose(grads.qvel[0], g.qvel, rtol=1e-10)


def test_batch_argument_errors():
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  with pytest.raises(ostrich.OstrichError, match="cannot create a batch of 2 worlds on 'gpu'"):
    ostrich.Batch(physics, 2, "gpu")
  batch = ostrich.Batch(physics, 2, "cpu:1")
  with pytest.raises(ValueError, match=r"actions: shape \(5, 3, 1\)"):
    batch.rollout(np.zeros((5, 3, 1)))
  traj = batch.rollout(np.zeros((5, 1)))  # (T, nu): the same controls in every world
  assert traj.qpos.shape == (6, 2, 2)
  with pytest.raises(ValueError, match="cot_qvel: shape"):
    traj.backward(cot_qvel=np.zeros((6, 2)))


def test_batch_parameter_gradients_equal_single():
  # the robot on the box: contacts with friction, masses, damping and servo gains; each world's
  # dL/dtheta equals its single rollout's (same native geometry, which the batch uses), which
  # test_rollout.py checks against central differences
  physics = ostrich.Physics.from_xml_path(model_path("robot_box.xml"))
  physics.set_options(geometry="native")
  nworld, steps = 2, 6
  qpos0 = np.tile(physics.data.qpos, (nworld, 1))
  qpos0[:, 0] = [-0.2, -0.35]
  qvel0 = np.zeros((nworld, physics.nv))
  actions = np.full((steps, nworld, physics.nu), 3.0)
  traj = ostrich.Batch(physics, nworld, "cpu:2").rollout(actions, qpos0, qvel0)
  rng = np.random.default_rng(3)
  cot_qpos = rng.uniform(-1, 1, traj.qpos.shape)
  cot_qvel = rng.uniform(-1, 1, traj.qvel.shape)
  grads = traj.backward(cot_qpos, cot_qvel, params=True)
  plain = traj.backward(cot_qpos, cot_qvel)
  assert plain.theta is None and grads.theta.shape == (nworld, len(ostrich.get_theta(physics)))
  np.testing.assert_array_equal(grads.ctrl, plain.ctrl)
  for w in range(nworld):
    one = ostrich.rollout(physics, actions[:, w], qpos0[w], qvel0[w])
    g = one.backward(cot_qpos[:, w], cot_qvel[:, w], params=True)
    assert abs(g.theta).max() > 0
    # the batch and the single rollout step the same physics along different code paths (their
    # states agree to rounding, 1e-13); 1e-9 of the largest entry bounds what rounding explains
    np.testing.assert_allclose(grads.theta[w], g.theta, rtol=0, atol=1e-9 * abs(g.theta).max())
    for group, value in g.params.items():
      np.testing.assert_array_equal(grads.params[group][w], grads.theta[w][
          ostrich.param_slices(physics)[group]])
