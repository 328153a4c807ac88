"""The JAX adapter (ostrich.jax): gradients through jax.grad equal the NumPy face's backward
pass, also under jax.jit and when the tape was dropped, a loss's gradient matches central
differences, and an unconverged rollout's gradients are NaN. Skipped where JAX is not installed
(it is not a Debian package: `.ci/run` installs it from PyPI as a test-only package)."""

import os

import numpy as np
import pytest

import ostrich
from conftest import model_path, starved_box_plane

jax = pytest.importorskip("jax")
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402
import ostrich.jax  # noqa: E402  (needs jax)


def _inputs(seed=2, steps=15):
  rng = np.random.default_rng(seed)
  actions = rng.uniform(-0.5, 0.5, (steps, 1))  # inside ctrlrange [-1, 1]: no clamp kink
  weights = rng.uniform(-1, 1, (steps + 1, 2))
  return actions, np.array([0.1, 0.3]), np.array([0.2, -0.5]), weights


def _loss(physics, weights):
  def loss(actions, qpos0, qvel0, theta):
    qpos, qvel = ostrich.jax.rollout(physics, actions, qpos0, qvel0, theta)
    return (weights * qpos).sum() + 0.5 * (qvel[-1] ** 2).sum() + jnp.sin(qpos[-1, 1])
  return loss


def _numpy_gradients(physics, actions, qpos0, qvel0, weights):
  traj = ostrich.rollout(physics, actions, qpos0, qvel0)
  cot_qpos = weights.copy()
  cot_qpos[-1, 1] += np.cos(traj.qpos[-1, 1])
  cot_qvel = np.zeros_like(traj.qvel)
  cot_qvel[-1] = traj.qvel[-1]
  return traj.backward(cot_qpos, cot_qvel)


def test_jax_gradients_equal_the_numpy_backward():
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  actions, qpos0, qvel0, weights = _inputs()
  theta = ostrich.get_theta(physics)
  loss = _loss(physics, weights)
  value, grads = jax.value_and_grad(loss, argnums=(0, 1, 2, 3))(actions, qpos0, qvel0, theta)
  ref = _numpy_gradients(physics, actions, qpos0, qvel0, weights)
  for got, want in zip(grads, (ref.ctrl, ref.qpos, ref.qvel, ref.theta)):
    np.testing.assert_allclose(np.asarray(got), want, rtol=1e-12, atol=1e-300)
  # the same under jit, and the value is the loss of the rollout's states
  jit_grads = jax.jit(jax.grad(loss, argnums=(0, 1, 2, 3)))(actions, qpos0, qvel0, theta)
  for got, want in zip(jit_grads, grads):
    np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
  traj = ostrich.rollout(physics, actions, qpos0, qvel0)
  assert float(value) == pytest.approx((weights * traj.qpos).sum()
                                       + 0.5 * (traj.qvel[-1] ** 2).sum()
                                       + np.sin(traj.qpos[-1, 1]), rel=1e-14)
  # the pole mass's entry against a central difference of the JAX loss
  adr = ostrich.param_slices(physics)["mass"].start + physics.id("body", "pole")
  assert theta[adr] == 0.1  # the pole's 0.1 kg
  losses = []
  for s in (1, -1):
    th = theta.copy()
    th[adr] += s * 1e-6
    losses.append(float(loss(actions, qpos0, qvel0, th)))
  assert float(grads[3][adr]) == pytest.approx((losses[0] - losses[1]) / 2e-6, rel=1e-5)


def test_jax_without_theta_and_with_a_dropped_tape(monkeypatch):
  # theta None: the model as it is, no parameter gradient. With no tape kept, the backward pass
  # records the rollout again from its inputs: the same gradients
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  actions, qpos0, qvel0, weights = _inputs(seed=3)

  def loss(actions, qpos0, qvel0):
    qpos, qvel = ostrich.jax.rollout(physics, actions, qpos0, qvel0)
    return (weights * qpos).sum() + 0.5 * (qvel[-1] ** 2).sum() + jnp.sin(qpos[-1, 1])

  kept = jax.grad(loss, argnums=(0, 1, 2))(actions, qpos0, qvel0)
  monkeypatch.setattr(ostrich.jax, "TAPES_KEPT", 0)
  again = jax.grad(loss, argnums=(0, 1, 2))(actions, qpos0, qvel0)
  ref = _numpy_gradients(physics, actions, qpos0, qvel0, weights)
  for a, b, want in zip(kept, again, (ref.ctrl, ref.qpos, ref.qvel)):
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    np.testing.assert_allclose(np.asarray(a), want, rtol=1e-12)


def test_jax_unconverged_rollout_gives_nan_gradients():
  physics = ostrich.Physics.from_xml_string(starved_box_plane(1))
  qvel0 = np.array([1.0, 0, -2, 0, 0, 0])

  def loss(qvel0):
    qpos, _ = ostrich.jax.rollout(physics, np.zeros((10, 0)), physics.data.qpos.copy(), qvel0)
    return qpos[-1, 2]

  with pytest.warns(ostrich.NotConvergedWarning):
    g = jax.grad(loss)(qvel0)
  assert np.isnan(np.asarray(g)).all()


def test_jax_refuses_32_bit_floats_and_bad_shapes():
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  with pytest.raises(ValueError, match="qpos0: shape"):
    ostrich.jax.rollout(physics, np.zeros((3, 1)), np.zeros(3), np.zeros(2))
  jax.config.update("jax_enable_x64", False)
  try:
    with pytest.raises(ValueError, match="jax_enable_x64"):
      ostrich.jax.rollout(physics, np.zeros((3, 1)), np.zeros(2), np.zeros(2))
  finally:
    jax.config.update("jax_enable_x64", True)


def test_readme_jax_example_runs(monkeypatch, capsys):
  root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")
  with open(os.path.join(root, "plugin", "python", "README.md")) as f:
    readme = f.read()
  code = readme.split("\n## JAX\n")[1].split("```python\n")[1].split("```")[0]
  monkeypatch.chdir(root)
  scope = {}
  exec(compile(code, "plugin/python/README.md", "exec"), scope)
  printed = capsys.readouterr().out
  assert printed.count("[") >= 50  # the (50, 1) gradient
  # the loss sums the pole angle squared over the rollout; every push of the cart but the
  # last moves the pole in a later state, so those controls' gradients are nonzero
  g = np.asarray(jax.grad(scope["loss"])(jnp.full((50, 1), 0.1)))
  assert np.isfinite(g).all() and np.all(g[:-1] != 0)
