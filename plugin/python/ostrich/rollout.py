"""Differentiable rollouts of one world: Ostrich steps recorded on a tape (ost_tape), and the
adjoint backward pass (ost_tapeBackward) for the start state, every control and the model's
physical parameters.

Cotangents and gradients of qpos are in qpos coordinates (nq per state) by default: backward
takes dL/dqpos as the loss sees the arrays rollout returned, and returns dL/dqpos0 in the same
coordinates. For a ball or free joint's quaternion q, only the part of dL/dq tangent to the unit
sphere at q matters (steps keep |q| = 1), and the returned gradient is tangent there:
g = 4 G G^T dL/dq, where G (4 x 3) is the derivative of q along mj_integratePos's local
rotation vector. With tangent=True both are tangent vectors instead (nv per state: ostrich.h's
convention, as mjd_transitionFD's); for models of hinges and slides only, the two agree.
"""

import warnings

import numpy as np

from . import _lib
from .errors import NotConvergedWarning, OstrichError, check, forward_mujoco_warnings

_lib_ = _lib.lib

# theta's groups, in ostParam order (ostrich.h), and the objects their entries belong to
PARAM_GROUPS = ("friction", "mass", "damping", "gain", "biaspos", "biasvel")
_PARAM_ROWS = ("ngeom", "nbody", "nv", "nu", "nu", "nu")


# each group's entries in the model: (array, column) (ostrich.h, ostParam)
_PARAM_FIELDS = (("geom_friction", 0), ("body_mass", None), ("dof_damping", None),
                 ("actuator_gainprm", 0), ("actuator_biasprm", 1), ("actuator_biasprm", 2))


def _param_views(physics):
  """[(group, theta slice, the model's entries)] for every parameter group."""
  model, out = physics._model_ptr(), []
  for g, (group, (field, col)) in enumerate(zip(PARAM_GROUPS, _PARAM_FIELDS)):
    a, b = _lib_.ost_paramAddress(model, g), _lib_.ost_paramAddress(model, g + 1)
    array = getattr(physics.model, field)
    out.append((group, slice(a, b), array if col is None else array[:, col]))
  return out


def param_slices(physics):
  """Where each parameter group lies in theta: {group: slice} (ost_paramAddress)."""
  return {group: sl for group, sl, _ in _param_views(physics)}


def get_theta(physics):
  """The model's physical parameters theta (ost_nparam) in ostParam order, the vector whose
  gradient Rollout.backward returns (Gradients.theta): a copy."""
  theta = np.zeros(_lib_.ost_nparam(physics._model_ptr()))
  for _, sl, entries in _param_views(physics):
    theta[sl] = entries
  return theta


def set_theta(physics, theta):
  """Write theta (ost_nparam, ostParam order) into the model's arrays (geom_friction[:, 0],
  body_mass, dof_damping, actuator_gainprm[:, 0], actuator_biasprm[:, 1], [:, 2]); steps follow
  the edit at once."""
  theta = np.asarray(theta, dtype=np.float64)
  n = _lib_.ost_nparam(physics._model_ptr())
  if theta.shape != (n,):
    raise ValueError(f"theta: shape {theta.shape}, expected ({n},)")
  for _, sl, entries in _param_views(physics):
    entries[...] = theta[sl]


SPARE_TAPES = 4  # tapes a Physics keeps for reuse per checkpoint interval


class _Tape:
  """Owns an ostpyTape. A tape no Rollout holds goes back to its physics for the next rollout
  (up to SPARE_TAPES of them): a fresh tape costs an mjData and, at its first backward pass, a
  copy of the whole model (textures included), which on small models cost more than a
  50-step rollout and its backward pass together. ostpy_rollout clears a reused tape first."""

  def __init__(self, physics, checkpoint):
    self.physics = physics  # the tape's model lives as long as the physics
    self.checkpoint = int(checkpoint)
    spare = physics._handle.spare_tapes.get(self.checkpoint)
    self.ptr = spare.pop() if spare else _lib_.ostpy_tapeCreate(physics._handle.ptr,
                                                                 self.checkpoint)
    if not self.ptr:
      raise OstrichError("cannot create a tape (out of memory)", 6)

  def __del__(self, free=_lib_.ostpy_tapeFree):  # bound now: module globals may be gone at exit
    ptr = getattr(self, "ptr", None)
    if not ptr:
      return
    self.ptr = None
    spare = self.physics._handle.spare_tapes.setdefault(self.checkpoint, [])
    if len(spare) < SPARE_TAPES:
      spare.append(ptr)
    else:
      free(ptr)

  def error(self):
    return _lib.text(_lib_.ostpy_tapeError(self.ptr))


class Gradients:
  """What backward returns: dL/d of the start state, every control and theta.

  qpos (nq; nv with tangent=True), qvel (nv), ctrl (T x nu), theta (ost_nparam: every
  parameter in ostParam order; None without params), params (theta's groups by name: friction
  (ngeom, geom_friction[:, 0]), mass (nbody, body_mass), damping (nv, dof_damping), gain (nu,
  actuator_gainprm[:, 0]), biaspos (nu, actuator_biasprm[:, 1]), biasvel (nu,
  actuator_biasprm[:, 2])), and named.<group>[name]: the same by geom, body, joint or actuator
  name.
  """

  def __init__(self, physics, qpos, qvel, ctrl, theta):
    self.qpos, self.qvel, self.ctrl, self.theta = qpos, qvel, ctrl, theta
    self.params = {}
    self.named = _NamedParams()
    if theta is None:
      return
    model = physics._model_ptr()
    for g, (group, rowdim) in enumerate(zip(PARAM_GROUPS, _PARAM_ROWS)):
      a, b = _lib_.ost_paramAddress(model, g), _lib_.ost_paramAddress(model, g + 1)
      self.params[group] = theta[a:b]
      from .named import NamedArray
      setattr(self.named, group, NamedArray(theta[a:b], physics._axis(rowdim), group))


class _NamedParams:
  """Gradients.named: each parameter group as a NamedArray."""


class Rollout(tuple):
  """(qpos, qvel) of a recorded rollout, (T + 1) x nq and (T + 1) x nv, the start state first;
  unpacks as a pair. `act` holds the activations ((T + 1) x na, models with activation
  dynamics), `status` each step's ost_step status, `converged` whether all converged.
  backward(...) runs the adjoint over it."""

  def __new__(cls, qpos, qvel, tape, status, act):
    self = super().__new__(cls, (qpos, qvel))
    self.qpos, self.qvel, self.act, self.status, self._tape = qpos, qvel, act, status, tape
    self.converged = bool(np.all(status == _lib.OK))
    return self

  def backward(self, cot_qpos=None, cot_qvel=None, params=True, tangent=False, truncate=False):
    """Gradients of a loss L of the rollout's states (qpos, qvel), given its cotangents. With
    activations the controls' gradient includes their path through them (ost_tapeBackward).

    cot_qpos: dL/dqpos of every state ((T + 1) x nq, or (T + 1) x nv tangent vectors with
    tangent=True); cot_qvel: dL/dqvel ((T + 1) x nv); None = zero. params: also dL/dtheta
    (Gradients.theta, .params, .named). truncate: hold each step's contact geometry fixed
    (ostGradOptions.truncate), for long chaotic horizons. Raises NotConvergedError if a step
    of the rollout did not converge (no gradient is returned then), OstrichError otherwise.
    """
    physics = self._tape.physics
    nq, nv, nu = physics.nq, physics.nv, physics.nu
    steps = len(self.qpos) - 1
    gq = _rows(cot_qpos, steps + 1, nv if tangent else nq, "cot_qpos")
    gv = _rows(cot_qvel, steps + 1, nv, "cot_qvel")
    gctrl = np.zeros((steps, nu))
    gq0 = np.zeros(nv if tangent else nq)
    gv0 = np.zeros(nv)
    theta = np.zeros(_lib_.ost_nparam(physics._model_ptr())) if params else None
    status = _lib_.ostpy_backward(physics._handle.ptr, self._tape.ptr, int(bool(tangent)),
                                  int(bool(params)), int(bool(truncate)), _lib.dptr(gq),
                                  _lib.dptr(gv), _lib.dptr(gctrl), _lib.dptr(gq0),
                                  _lib.dptr(gv0), _lib.dptr(theta))
    forward_mujoco_warnings()
    check(status, self._tape.error(), "backward")
    return Gradients(physics, gq0, gv0, gctrl, theta)


def _rows(a, rows, cols, what):
  """a as a C-contiguous float64 (rows x cols) array; None stays None."""
  if a is None:
    return None
  a = np.ascontiguousarray(a, dtype=np.float64)
  if a.shape != (rows, cols):
    raise ValueError(f"{what}: shape {a.shape}, expected {(rows, cols)}")
  return a


def rollout(physics, actions, qpos0=None, qvel0=None, checkpoint=0, act0=None):
  """Record T Ostrich steps from physics' state with controls actions (T x nu); return a Rollout
  (unpacks as qpos (T + 1) x nq, qvel (T + 1) x nv, the start state first; .act (T + 1) x na).

  qpos0, qvel0, act0: written into physics.data first (else its current state is the start). The
  physics ends at the last state. checkpoint S > 0 keeps every S-th state only and recomputes
  during backward (ost_tapeCreate). A step that does not converge warns (NotConvergedWarning;
  the rollout goes on, backward will refuse it); a failed step raises OstrichError.
  """
  nq, nv, nu = physics.nq, physics.nv, physics.nu
  actions = np.ascontiguousarray(actions, dtype=np.float64)
  if actions.ndim == 1 and nu == 1:
    actions = actions.reshape(-1, 1)
  if actions.ndim != 2 or actions.shape[1] != nu:
    raise ValueError(f"actions: shape {actions.shape}, expected (T, nu = {nu})")
  if qpos0 is not None:
    physics.data.qpos[:] = qpos0
  if qvel0 is not None:
    physics.data.qvel[:] = qvel0
  if act0 is not None:
    physics.data.act[:] = act0
  steps = actions.shape[0]
  tape = _Tape(physics, checkpoint)
  qpos = np.zeros((steps + 1, nq))
  qvel = np.zeros((steps + 1, nv))
  act = np.zeros((steps + 1, physics.data.act.size))
  status = np.zeros(steps, dtype=np.int32)
  result = _lib_.ostpy_rollout(physics._handle.ptr, tape.ptr, steps, _lib.dptr(actions),
                               _lib.dptr(qpos), _lib.dptr(qvel), _lib.dptr(act),
                               _lib.iptr(status))
  forward_mujoco_warnings()
  check(result, tape.error(), "rollout")
  out = Rollout(qpos, qvel, tape, status, act)
  physics._last_rollout = out
  if not out.converged:
    bad = np.flatnonzero(status != _lib.OK) + 1
    warnings.warn(NotConvergedWarning(
        f"{len(bad)} of {steps} steps did not converge (first: step {bad[0]}); the rollout went "
        "on, but backward will refuse it"), stacklevel=2)
  return out


def mujoco_rollout(physics, actions, nsub=1, qpos_out=None, qvel_out=None, snapshots=None):
  """Step stock MuJoCo (mj_step, no gradient) from physics' state through T control steps of nsub
  steps each, actions (T x nu) held over each, in C without a Python call per step; return
  (qpos, qvel), T x nq and T x nv: the state at the end of each control step (written into
  qpos_out, qvel_out if given). snapshots (T x (nq + 2 nv + na), optional) receives the state at
  the start of each control step as qpos, qvel, qacc_warmstart, act. The physics ends at the
  last state; MuJoCo's warnings become MujocoWarning, its errors OstrichError."""
  nq, nv, nu = physics.nq, physics.nv, physics.nu
  actions = np.ascontiguousarray(actions, dtype=np.float64)
  if actions.ndim != 2 or actions.shape[1] != nu:
    raise ValueError(f"actions: shape {actions.shape}, expected (T, nu = {nu})")
  steps = actions.shape[0]
  out = []
  for given, cols, name in ((qpos_out, nq, "qpos_out"), (qvel_out, nv, "qvel_out"),
                            (snapshots, nq + 2 * nv + physics.data.act.size, "snapshots")):
    if given is None:
      out.append(np.zeros((steps, cols)) if name != "snapshots" else None)
      continue
    if (given.shape != (steps, cols) or given.dtype != np.float64
        or not given.flags.c_contiguous):
      raise ValueError(f"{name}: need a C-contiguous float64 array ({steps}, {cols})")
    out.append(given)
  qpos, qvel, snap = out
  status = _lib_.ostpy_mujocoRollout(physics._handle.ptr, steps, int(nsub), _lib.dptr(actions),
                                     _lib.dptr(qpos), _lib.dptr(qvel), _lib.dptr(snap))
  forward_mujoco_warnings()
  check(status, _lib.text(_lib_.ostpy_error(physics._handle.ptr)), "MuJoCo rollout")
  return qpos, qvel
