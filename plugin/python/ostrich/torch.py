"""PyTorch adapter: ostrich.rollout as a torch.autograd.Function, so that a loss written in torch
of the rollout's states backpropagates to the actions, the start state and the model's physical
parameters. Import it on its own (`import ostrich.torch`); it needs PyTorch, which the rest of
the package does not.

  qpos, qvel = ostrich.torch.rollout(physics, actions, qpos0, qvel0, theta)

actions (T x nu), qpos0 (nq), qvel0 (nv) and theta (ost_nparam, ostrich.get_theta's order) are
tensors; any of qpos0, qvel0, theta may be None (the physics' current state and model). Given,
theta is written into the model (ostrich.set_theta) before the rollout. The outputs are float64
tensors (T + 1) x nq and (T + 1) x nv on the inputs' device (computed on the CPU). Gradients
follow rollout.py: qpos in coordinates (for free and ball joints, tangent to the unit
quaternion's sphere). A rollout with an unconverged step warns in the forward pass, and its
backward pass raises ostrich.NotConvergedError.
"""

import numpy as np
import torch as _torch

from .rollout import rollout as _rollout
from .rollout import set_theta as _set_theta


def _numpy(t):
  return None if t is None else t.detach().to("cpu", _torch.float64).numpy()


class Rollout(_torch.autograd.Function):
  """The autograd Function behind rollout(); apply(physics, actions, qpos0, qvel0, theta,
  checkpoint)."""

  @staticmethod
  def forward(ctx, physics, actions, qpos0, qvel0, theta, checkpoint):
    if theta is not None:
      _set_theta(physics, _numpy(theta))
    traj = _rollout(physics, _numpy(actions), _numpy(qpos0), _numpy(qvel0), checkpoint)
    ctx.traj = traj
    ctx.want_theta = theta is not None and theta.requires_grad
    ctx.device = actions.device
    ctx.dtypes = tuple(None if t is None else t.dtype for t in (actions, qpos0, qvel0, theta))
    device = actions.device
    return (_torch.from_numpy(traj.qpos.copy()).to(device),
            _torch.from_numpy(traj.qvel.copy()).to(device))

  @staticmethod
  def backward(ctx, cot_qpos, cot_qvel):
    grads = ctx.traj.backward(_numpy(cot_qpos), _numpy(cot_qvel), params=ctx.want_theta)

    def out(a, i):
      if ctx.dtypes[i] is None or not ctx.needs_input_grad[i + 1]:
        return None
      return _torch.from_numpy(np.ascontiguousarray(a)).to(ctx.device, ctx.dtypes[i])

    return (None, out(grads.ctrl, 0), out(grads.qpos, 1), out(grads.qvel, 2),
            out(grads.theta, 3) if ctx.want_theta else None, None)


def rollout(physics, actions, qpos0=None, qvel0=None, theta=None, checkpoint=0):
  """Differentiable ostrich.rollout on tensors: returns (qpos, qvel) tensors."""
  return Rollout.apply(physics, actions, qpos0, qvel0, theta, checkpoint)
