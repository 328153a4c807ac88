"""Differentiable rollouts (plugin/python/ostrich/rollout.py, ost_python.c): the adjoint gradient
of a whole rollout against central finite differences of the same rollout, for every action,
the start state and physical parameters; the qpos convention of free joints; and the refusal to
differentiate a rollout with an unconverged step."""

import numpy as np
import pytest

import ostrich
from conftest import ACT_ARM, FREE_BALL, model_path, starved_box_plane

TOL = 1e-4  # normwise relative error of each gradient group


def rel_err(adjoint, fd):
  adjoint, fd = np.ravel(adjoint), np.ravel(fd)
  return np.max(np.abs(adjoint - fd)) / max(np.max(np.abs(fd)), 1e-300)


class Problem:
  """A rollout of `steps` steps from (qpos0, qvel0) with actions, and a seeded smooth loss of
  every state: L = sum_k (a_k . qpos_k + b_k . qvel_k) + 1/2 |qvel_T|^2."""

  def __init__(self, physics, steps, qpos0, qvel0, actions, seed=1, skip_first=False):
    self.physics = physics
    self.qpos0, self.qvel0, self.actions = np.array(qpos0), np.array(qvel0), np.array(actions)
    rng = np.random.default_rng(seed)
    self.a = rng.uniform(-1, 1, (steps + 1, physics.nq))
    self.b = rng.uniform(-1, 1, (steps + 1, physics.nv))
    if skip_first:  # no loss on the start state itself
      self.a[0] = 0
      self.b[0] = 0

  def loss(self, qpos0=None, qvel0=None, actions=None):
    qpos, qvel = ostrich.rollout(
        self.physics, self.actions if actions is None else actions,
        self.qpos0 if qpos0 is None else qpos0, self.qvel0 if qvel0 is None else qvel0)
    return np.sum(self.a * qpos) + np.sum(self.b * qvel) + 0.5 * qvel[-1] @ qvel[-1]

  def adjoint(self, **kw):
    traj = ostrich.rollout(self.physics, self.actions, self.qpos0, self.qvel0)
    assert traj.converged
    cot_qvel = self.b.copy()
    cot_qvel[-1] += traj.qvel[-1]
    return traj.backward(self.a, cot_qvel, **kw)

  def fd(self, which, eps):
    """Central differences of the loss along every entry of qpos0, qvel0 or actions."""
    base = {"qpos0": self.qpos0, "qvel0": self.qvel0, "actions": self.actions}[which]
    grad = np.zeros(base.shape)
    for i in np.ndindex(base.shape):
      plus, minus = base.copy(), base.copy()
      plus[i] += eps
      minus[i] -= eps
      grad[i] = (self.loss(**{which: plus}) - self.loss(**{which: minus})) / (2 * eps)
    return grad

  def fd_model(self, array, index, eps):
    """Central difference of the loss along one entry of a model array (restored after)."""
    value = array[index]
    array[index] = value + eps
    plus = self.loss()
    array[index] = value - eps
    minus = self.loss()
    array[index] = value
    return (plus - minus) / (2 * eps)


@pytest.fixture
def cartpole():
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  steps = 25
  rng = np.random.default_rng(7)
  actions = rng.uniform(-0.5, 0.5, (steps, 1))  # inside ctrlrange [-1, 1]: no clamp kink
  return Problem(physics, steps, [0.1, 0.3], [0.2, -0.5], actions)


def test_rollout_states_are_the_steps(cartpole):
  physics = cartpole.physics
  qpos, qvel = ostrich.rollout(physics, cartpole.actions, cartpole.qpos0, cartpole.qvel0)
  assert qpos.shape == (26, 2) and qvel.shape == (26, 2)
  np.testing.assert_array_equal(qpos[0], cartpole.qpos0)
  np.testing.assert_array_equal(physics.data.qpos, qpos[-1])  # the physics ends at the last state
  # the same steps taken one by one
  physics.reset()
  physics.data.qpos[:] = cartpole.qpos0
  physics.data.qvel[:] = cartpole.qvel0
  for k, u in enumerate(cartpole.actions):
    physics.data.ctrl[:] = u
    physics.step()
    np.testing.assert_array_equal(physics.data.qpos, qpos[k + 1])
    np.testing.assert_array_equal(physics.data.qvel, qvel[k + 1])


def test_reused_tapes_keep_each_rollout_its_own(cartpole):
  # rollouts take spare tapes from their physics (rollout.py, _Tape): a rollout still held must
  # keep its own tape, and a reused tape must give the bits of a fresh one
  physics, a = cartpole.physics, cartpole.actions
  cot = np.ones((len(a) + 1, 2))

  def gradient(rollout):
    return rollout.backward(cot, cot, params=False).ctrl

  first = ostrich.rollout(physics, a, cartpole.qpos0, cartpole.qvel0)
  reference = gradient(first)
  second = ostrich.rollout(physics, -a, cartpole.qpos0, cartpole.qvel0)  # another tape
  assert second._tape.ptr != first._tape.ptr
  np.testing.assert_array_equal(gradient(first), reference)
  other = gradient(second)
  del first, second
  physics._last_rollout = None  # the last rollout is kept by its physics; let it go too
  spare = list(physics._handle.spare_tapes[0])
  assert len(spare) == 2
  again = ostrich.rollout(physics, -a, cartpole.qpos0, cartpole.qvel0)
  assert again._tape.ptr in spare  # reused
  np.testing.assert_array_equal(gradient(again), other)


def test_mujoco_rollout_is_mj_step_and_restarts_from_its_snapshots(cartpole):
  # the C loop equals Physics.step(engine="mujoco") per control step, bit for bit, and a rollout
  # restarted from a snapshot continues as the first did
  physics, a = cartpole.physics, cartpole.actions
  physics.data.qpos[:], physics.data.qvel[:] = cartpole.qpos0, cartpole.qvel0
  start = (physics.data.qpos.copy(), physics.data.qvel.copy(),
           physics.data.qacc_warmstart.copy())
  snap = np.zeros((len(a), 3 * 2))
  qpos, qvel = ostrich.mujoco_rollout(physics, a, 3, snapshots=snap)
  physics.data.qpos[:], physics.data.qvel[:], physics.data.qacc_warmstart[:] = start
  for k, u in enumerate(a):
    np.testing.assert_array_equal(snap[k], np.concatenate(
        (physics.data.qpos, physics.data.qvel, physics.data.qacc_warmstart)))
    physics.data.ctrl[:] = u
    physics.step(3, engine="mujoco")
    np.testing.assert_array_equal(physics.data.qpos, qpos[k])
    np.testing.assert_array_equal(physics.data.qvel, qvel[k])
  k = 10
  physics.data.qpos[:], physics.data.qvel[:] = snap[k, :2], snap[k, 2:4]
  physics.data.qacc_warmstart[:] = snap[k, 4:]
  again, _ = ostrich.mujoco_rollout(physics, a[k:], 3)
  np.testing.assert_array_equal(again, qpos[k:])
  with pytest.raises(ValueError, match="snapshots"):
    ostrich.mujoco_rollout(physics, a, 3, snapshots=np.zeros((len(a), 5)))


def test_gradient_matches_central_differences(cartpole):
  grads = cartpole.adjoint(params=True)
  errors = {
      "actions": rel_err(grads.ctrl, cartpole.fd("actions", 1e-5)),
      "qpos0": rel_err(grads.qpos, cartpole.fd("qpos0", 1e-6)),
      "qvel0": rel_err(grads.qvel, cartpole.fd("qvel0", 1e-6)),
  }
  model = cartpole.physics.model
  pole, slider = cartpole.physics.id("body", "pole"), cartpole.physics.id("joint", "slider")
  for name, array, index, adjoint in [
      ("mass[pole]", model.body_mass, pole, grads.named.mass["pole"]),
      ("damping[slider]", model.dof_damping, slider, grads.named.damping["slider"]),
      ("gain[push]", model.actuator_gainprm, (0, 0), grads.named.gain["push"])]:
    errors[name] = rel_err(adjoint, cartpole.fd_model(array, index, 1e-6))
  print("relative errors:", {k: f"{v:.1e}" for k, v in errors.items()})
  for name, err in errors.items():
    assert err <= TOL, f"{name}: relative error {err:.2e} > {TOL}"
  # the parameter groups' shapes and names
  assert grads.theta.shape == (sum(grads.params[g].size for g in ostrich.PARAM_GROUPS),)
  assert grads.params["mass"].shape == (3,) and grads.params["mass"][0] == 0  # the world body
  assert grads.ctrl.shape == (25, 1)


def test_activation_rollout_and_its_gradient():
  # activations are part of the rollout's state: they start from act0, follow Physics.step's
  # implicit integration, and the controls' gradient through them matches central
  # differences of the loss (act0 held fixed)
  physics = ostrich.Physics.from_xml_string(ACT_ARM)
  steps, act0 = 20, np.array([0.3, -0.2])
  qpos0, qvel0 = np.array([0.2, -0.4]), np.array([0.5, 0.0])
  actions = np.stack([0.4 * np.sin(0.3 * np.arange(steps)), 0.5 * np.cos(0.2 * np.arange(steps))], 1)
  traj = ostrich.rollout(physics, actions, qpos0, qvel0, act0=act0)
  assert traj.act.shape == (steps + 1, 2) and traj.converged
  np.testing.assert_array_equal(traj.act[0], act0)
  physics.data.qpos[:], physics.data.qvel[:], physics.data.act[:] = qpos0, qvel0, act0
  for k in range(steps):
    physics.data.ctrl[:] = actions[k]
    physics.step()
    np.testing.assert_array_equal(physics.data.act, traj.act[k + 1])  # closed forms of ctrl
    # (Physics.step and the tape may start Newton from different warm starts: the same
    # solution to rounding)
    np.testing.assert_allclose(physics.data.qpos, traj.qpos[k + 1], rtol=0, atol=1e-12)
  assert np.abs(traj.act[-1] - act0).max() > 0.1  # the activations moved

  rng = np.random.default_rng(3)
  a, b = rng.uniform(-1, 1, traj.qpos.shape), rng.uniform(-1, 1, traj.qvel.shape)

  def loss(u):
    q, v = ostrich.rollout(physics, u, qpos0, qvel0, act0=act0)
    return np.sum(a * q) + np.sum(b * v)

  grads = ostrich.rollout(physics, actions, qpos0, qvel0, act0=act0).backward(a, b, params=False)
  fd = np.zeros(actions.shape)
  for i in np.ndindex(actions.shape):
    plus, minus = actions.copy(), actions.copy()
    plus[i] += 1e-6
    minus[i] -= 1e-6
    fd[i] = (loss(plus) - loss(minus)) / 2e-6
  err = rel_err(grads.ctrl, fd)
  print(f"activation rollout: controls' gradient vs central differences {err:.1e}")
  assert err <= TOL
  # the last step's controls reach the state only through act+ and its force (eq. 8b)
  assert np.abs(grads.ctrl[-1]).max() > 0


def test_free_joint_gradient_in_qpos_coordinates():
  # a spinning ball in flight: its quaternion's gradient, coordinates and tangent
  physics = ostrich.Physics.from_xml_string(FREE_BALL)
  steps = 10
  qpos0 = np.array([0, 0, 1, np.cos(0.2), np.sin(0.2) * 0.6, 0, np.sin(0.2) * 0.8])
  qvel0 = np.array([0.3, 0, 1, 2, -3, 1])
  problem = Problem(physics, steps, qpos0, qvel0, np.zeros((steps, 0)), seed=3, skip_first=True)
  grads = problem.adjoint(params=False)
  assert grads.qpos.shape == (7,) and grads.theta is None
  # differences of L(normalize(qpos0 + eps e_i)): the gradient tangent to the unit sphere
  fd = np.zeros(7)
  for i in range(7):
    losses = []
    for s in (1, -1):
      q = qpos0.copy()
      q[i] += s * 1e-6
      q[3:] /= np.linalg.norm(q[3:])
      losses.append(problem.loss(qpos0=q))
    fd[i] = (losses[0] - losses[1]) / 2e-6
  err = rel_err(grads.qpos, fd)
  print(f"free joint qpos0 relative error: {err:.1e}")
  assert err <= TOL
  assert abs(grads.qpos[3:] @ qpos0[3:]) < 1e-10  # no component along the quaternion
  # tangent=True: nv entries, the same derivative along a rotation (q' = q * exp(delta / 2))
  traj = ostrich.rollout(physics, problem.actions, qpos0, qvel0)
  cot_v = problem.b.copy()
  cot_v[-1] += traj.qvel[-1]
  cot_q_tangent = np.zeros((steps + 1, 6))
  tangent = traj.backward(cot_q_tangent, cot_v, params=False, tangent=True)
  coords = traj.backward(np.zeros((steps + 1, 7)), cot_v, params=False)
  assert tangent.qpos.shape == (6,)
  np.testing.assert_allclose(coords.qpos[:3], tangent.qpos[:3], rtol=1e-12, atol=1e-12)
  # rotation delta_x: dq = 1/2 q * (0, 1, 0, 0), so dL/d delta_x = grad_q . dq
  w, x, y, z = qpos0[3:]
  dq = 0.5 * np.array([-x, w, z, -y])
  assert coords.qpos[3:] @ dq == pytest.approx(tangent.qpos[3], rel=1e-10)


def test_unconverged_rollout_refuses_its_gradient():
  xml = starved_box_plane(1)
  physics = ostrich.Physics.from_xml_string(xml)
  assert physics.options["newton_iter"] == 1
  physics.named.data.qvel["box_free"] = [1, 0, -2, 0, 0, 0]  # thrown at its floor
  with pytest.warns(ostrich.NotConvergedWarning, match="did not converge"):
    traj = ostrich.rollout(physics, np.zeros((10, 0)))
  assert not traj.converged and (traj.status == 100).any()
  with pytest.raises(ostrich.NotConvergedError, match="did not converge") as e:
    traj.backward(np.ones((11, 7)), np.ones((11, 6)))
  assert e.value.status == 7


def test_rollout_argument_errors(cartpole):
  with pytest.raises(ValueError, match=r"actions: shape \(5, 2\), expected \(T, nu = 1\)"):
    ostrich.rollout(cartpole.physics, np.zeros((5, 2)))
  traj = ostrich.rollout(cartpole.physics, np.zeros((5, 1)))
  with pytest.raises(ValueError, match="cot_qpos: shape"):
    traj.backward(np.zeros((5, 2)))


def test_theta_reads_and_writes_the_model(cartpole):
  physics = cartpole.physics
  slices = ostrich.param_slices(physics)
  assert list(slices) == list(ostrich.PARAM_GROUPS)
  theta = ostrich.get_theta(physics)
  pole = slices["mass"].start + physics.id("body", "pole")
  slider = slices["damping"].start + physics.id("joint", "slider")
  assert theta[pole] == 0.1 and theta[slider] == 0.1 and theta[slices["gain"]][0] == 1
  theta[pole] = 0.2
  ostrich.set_theta(physics, theta)
  assert physics.named.model.body_mass["pole"] == 0.2
  with pytest.raises(ValueError, match="theta: shape"):
    ostrich.set_theta(physics, theta[:-1])
