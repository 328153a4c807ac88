"""The PyTorch adapter (ostrich.torch): gradients through torch.autograd equal the NumPy face's
backward pass, and a loss's gradient matches central differences. Skipped where PyTorch is not
installed (Debian: python3-torch); the NumPy face's own tests never are."""

import numpy as np
import pytest

import ostrich
from conftest import model_path, starved_box_plane

torch = pytest.importorskip("torch")
import ostrich.torch  # noqa: E402  (needs torch)


def test_torch_gradients_equal_the_numpy_backward():
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  rng = np.random.default_rng(2)
  actions = torch.tensor(rng.uniform(-0.5, 0.5, (15, 1)), requires_grad=True)
  qpos0 = torch.tensor([0.1, 0.3], dtype=torch.float64, requires_grad=True)
  qvel0 = torch.tensor([0.2, -0.5], dtype=torch.float64, requires_grad=True)
  theta = torch.tensor(ostrich.get_theta(physics), requires_grad=True)
  qpos, qvel = ostrich.torch.rollout(physics, actions, qpos0, qvel0, theta)
  weights = torch.tensor(rng.uniform(-1, 1, (16, 2)))
  loss = (weights * qpos).sum() + 0.5 * (qvel[-1] ** 2).sum() + torch.sin(qpos[-1, 1])
  loss.backward()
  # the same cotangents through the NumPy face
  traj = ostrich.rollout(physics, actions.detach().numpy(), [0.1, 0.3], [0.2, -0.5])
  cot_qpos = weights.numpy().copy()
  cot_qpos[-1, 1] += np.cos(traj.qpos[-1, 1])
  cot_qvel = np.zeros((16, 2))
  cot_qvel[-1] = traj.qvel[-1]
  grads = traj.backward(cot_qpos, cot_qvel)
  np.testing.assert_allclose(actions.grad.numpy(), grads.ctrl, rtol=1e-12)
  np.testing.assert_allclose(qpos0.grad.numpy(), grads.qpos, rtol=1e-12)
  np.testing.assert_allclose(qvel0.grad.numpy(), grads.qvel, rtol=1e-12)
  np.testing.assert_allclose(theta.grad.numpy(), grads.theta, rtol=1e-12, atol=1e-300)
  # and the pole mass's entry against a central difference of the torch loss
  adr = ostrich.param_slices(physics)["mass"].start + physics.id("body", "pole")
  assert ostrich.get_theta(physics)[adr] == 0.1  # the pole's 0.1 kg
  with torch.no_grad():
    losses = []
    for s in (1, -1):
      th = theta.detach().clone()
      th[adr] += s * 1e-6
      qp, qv = ostrich.torch.rollout(physics, actions, qpos0, qvel0, th)
      losses.append(float((weights * qp).sum() + 0.5 * (qv[-1] ** 2).sum()
                          + torch.sin(qp[-1, 1])))
  fd = (losses[0] - losses[1]) / 2e-6
  assert theta.grad[adr].item() == pytest.approx(fd, rel=1e-5)


def test_torch_unconverged_rollout_raises_in_backward():
  xml = starved_box_plane(1)
  physics = ostrich.Physics.from_xml_string(xml)
  qvel0 = torch.tensor([1.0, 0, -2, 0, 0, 0], dtype=torch.float64, requires_grad=True)
  with pytest.warns(ostrich.NotConvergedWarning):
    qpos, _ = ostrich.torch.rollout(physics, torch.zeros((10, 0), dtype=torch.float64),
                                    qvel0=qvel0)
  with pytest.raises(ostrich.NotConvergedError, match="did not converge"):
    qpos[-1, 2].backward()
