"""Ostrich for Python: MuJoCo 2.2.2 models stepped by Ostrich's implicit hard-contact solver,
with zero-copy NumPy views, dm_control-style named indexing and differentiable rollouts.

  import ostrich
  physics = ostrich.Physics.from_xml_path("mjcf_models/cartpole.xml")
  physics.named.data.qpos["hinge"] = 0.1
  physics.step()                               # Ostrich; step(engine="mujoco") for mj_step
  qpos, qvel = traj = ostrich.rollout(physics, actions)      # actions: T x nu
  grads = traj.backward(cot_qpos, cot_qvel)    # .qpos, .qvel, .ctrl, .theta, .params
  batch = ostrich.Batch(physics, 64)           # many worlds: rollout and backward as above

ostrich.torch (imported on its own, needs PyTorch) wraps rollout as a torch.autograd.Function.
The API is described in plugin/python/README.md.
"""

from ._lib import MUJOCO_VERSION
from .batch import Batch, BatchGradients, BatchRollout
from .errors import MujocoWarning, NotConvergedError, NotConvergedWarning, OstrichError
from .linearized import LinearizedRollout, mujoco_linearized_rollout
from .physics import Physics
from .rollout import (PARAM_GROUPS, Gradients, Rollout, get_theta, mujoco_rollout, param_slices,
                      rollout, set_theta)

__all__ = [
    "Physics", "rollout", "Rollout", "Gradients", "PARAM_GROUPS", "OstrichError",
    "NotConvergedError", "NotConvergedWarning", "MujocoWarning", "MUJOCO_VERSION", "Batch",
    "BatchRollout", "BatchGradients", "get_theta", "set_theta",
    "param_slices", "mujoco_rollout", "mujoco_linearized_rollout", "LinearizedRollout",
]
