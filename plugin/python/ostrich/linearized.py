"""Stock MuJoCo rollouts linearized by MuJoCo's own finite differences: the Jacobian-chain
baseline for Ostrich's adjoint gradients.

mujoco_linearized_rollout steps stock MuJoCo (mj_step) in C and takes, at every step, the
Jacobians of the next state by the state and the controls by forward differences of size eps
(MuJoCo's mjd_transitionFD with the Euler integrator; with RK4, whose Jacobians 2.2.2's
mjd_transitionFD gets wrong, a column per perturbed mj_step); backward chains them (the
controls held over a control step of nsub steps). A gradient then costs 1 + 2 nv + na + nu
MuJoCo steps per step, against H (H + 1) / 2 * nu control steps for finite
differences of whole rollouts over a horizon of H: the way gradient-based planners on MuJoCo
(iLQR, DDP) get their derivatives. The state's tangent is mjd_transitionFD's: (dq, qvel, act).
"""

import numpy as np

from . import _lib
from .errors import check, forward_mujoco_warnings

_lib_ = _lib.lib


class LinearizedRollout:
  """States at the end of each control step (qpos T x nq, qvel T x nv) and each control step's
  Jacobians A (T x n x n) and B (T x n x nu), n = 2 nv + na, of the physics it came from."""

  def __init__(self, physics, qpos, qvel, A, B):
    self._physics, self.qpos, self.qvel, self.A, self.B = physics, qpos, qvel, A, B

  def backward(self, cot_qpos, cot_qvel, cot_act=None):
    """(dL/dctrl (T x nu), dL/dx0 (n, tangent)) for cotangents of the end states: qpos in
    qpos coordinates (T x nq, pulled to tangents at each state as Rollout.backward does), qvel
    (T x nv), act (T x na, default 0)."""
    p = self._physics
    T, n, nu = self.A.shape[0], self.A.shape[1], self.B.shape[2]
    nq, nv = p.nq, p.nv
    cq = np.ascontiguousarray(cot_qpos, dtype=np.float64)
    cv = np.asarray(cot_qvel, dtype=np.float64)
    if cq.shape != (T, nq) or cv.shape != (T, nv):
      raise ValueError(f"cotangents: shapes {cq.shape} and {cv.shape}, expected ({T}, {nq}) and "
                       f"({T}, {nv})")
    g = np.zeros((T, n))
    gt = np.zeros((T, nv))
    _lib_.ostpy_coordToTangent(p._handle.ptr, T, _lib.dptr(self.qpos), _lib.dptr(cq),
                               _lib.dptr(gt))
    g[:, :nv] = gt
    g[:, nv:2 * nv] = cv
    if cot_act is not None:
      g[:, 2 * nv:] = cot_act
    gctrl, g0 = np.zeros((T, nu)), np.zeros(n)
    check(_lib_.ostpy_linearBackward(T, n, nu, _lib.dptr(self.A), _lib.dptr(self.B),
                                     _lib.dptr(g), _lib.dptr(gctrl), _lib.dptr(g0)),
          "out of memory", "linearized backward")
    return gctrl, g0


def mujoco_linearized_rollout(physics, actions, nsub=1, eps=1e-6):
  """Step stock MuJoCo from physics' state through T control steps of nsub steps, actions
  (T x nu) held over each, taking each step's Jacobians by forward differences; return a
  LinearizedRollout. The physics ends at the last state; MuJoCo's warnings become
  MujocoWarning, its errors OstrichError."""
  nq, nv, nu, na = physics.nq, physics.nv, physics.nu, physics.data.act.size
  actions = np.ascontiguousarray(actions, dtype=np.float64)
  if actions.ndim != 2 or actions.shape[1] != nu:
    raise ValueError(f"actions: shape {actions.shape}, expected (T, nu = {nu})")
  if not eps > 0:
    raise ValueError(f"eps: {eps}, need > 0")
  T, n = actions.shape[0], 2 * nv + na
  qpos, qvel = np.zeros((T, nq)), np.zeros((T, nv))
  A, B = np.zeros((T, n, n)), np.zeros((T, n, nu))
  status = _lib_.ostpy_mujocoLinearRollout(physics._handle.ptr, T, int(nsub), _lib.dptr(actions),
                                           float(eps), _lib.dptr(qpos),
                                           _lib.dptr(qvel), _lib.dptr(A), _lib.dptr(B))
  forward_mujoco_warnings()
  check(status, _lib.text(_lib_.ostpy_error(physics._handle.ptr)), "MuJoCo linearized rollout")
  return LinearizedRollout(physics, qpos, qvel, A, B)
