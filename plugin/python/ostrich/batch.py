"""Many worlds of one model stepped together (ost_batch*: core's native geometry on the CPU's
threads, or a GPU in a CUDA build), and the batch's differentiable rollouts.

Arrays are world-major within a step: state (nworld x nq), controls of a rollout
(T x nworld x nu), its states ((T + 1) x nworld x nq, the start first). A model with activation
dynamics (na > 0) also carries each world's activations (nworld x na), integrated implicitly
with the step as Physics.step does. The batch takes its
options from the model's ostrich/* numerics (Physics.set_options does not reach it), and the
model must pass ost_checkNative. Cotangents and gradients of qpos follow rollout.py's
convention: qpos coordinates unless tangent=True.
"""

import ctypes
import warnings

import numpy as np

from . import _lib
from .errors import NotConvergedError, NotConvergedWarning, OstrichError, check
from .rollout import PARAM_GROUPS

_lib_ = _lib.lib


class Batch:
  """nworld worlds of physics' model, at qpos0 and at rest, on device 'cpu' (all cores),
  'cpu:N' (N threads) or 'cuda' (a CUDA build). The batch keeps a reference to the physics,
  whose model it steps."""

  def __init__(self, physics, nworld, device="cpu"):
    self.physics = physics
    err = ctypes.create_string_buffer(1024)
    self._ptr = _lib_.ost_batchCreate(physics._model_ptr(), int(nworld), device.encode(), err,
                                      len(err))
    if not self._ptr:
      raise OstrichError(f"cannot create a batch of {nworld} worlds on {device!r}: "
                         f"{_lib.text(err.value)}", 1)
    self.nworld = int(nworld)
    self.device = device
    self._free = _lib_.ost_batchDelete

  def __del__(self):
    if getattr(self, "_ptr", None):
      self._free(self._ptr)
      self._ptr = None

  def _check(self, status, what):
    return check(status, _lib.text(_lib_.ost_batchError(self._ptr)), what)

  def _array(self, a, shape, what):
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.shape != shape:
      if a.size == np.prod(shape[1:]) and len(shape) >= 2:  # one row for every world
        a = np.ascontiguousarray(np.broadcast_to(a.reshape(shape[1:]), shape))
      else:
        raise ValueError(f"{what}: shape {a.shape}, expected {shape}")
    return a

  def set_state(self, qpos=None, qvel=None):
    """Set every world's state (nworld x nq, nworld x nv; one row is broadcast; None: qpos0 /
    rest). Activations are reset to 0 (set_act sets them); time, warm start and outcome bits
    are reset."""
    p = self.physics
    qpos = None if qpos is None else self._array(qpos, (self.nworld, p.nq), "qpos")
    qvel = None if qvel is None else self._array(qvel, (self.nworld, p.nv), "qvel")
    self._check(_lib_.ost_batchSetState(self._ptr, _lib.dptr(qpos), _lib.dptr(qvel)),
                "set_state")

  def state(self):
    """Every world's (qpos, qvel): nworld x nq, nworld x nv."""
    qpos = np.zeros((self.nworld, self.physics.nq))
    qvel = np.zeros((self.nworld, self.physics.nv))
    self._check(_lib_.ost_batchGetState(self._ptr, _lib.dptr(qpos), _lib.dptr(qvel)), "state")
    return qpos, qvel

  def set_act(self, act):
    """Set every world's activations (nworld x na; one row is broadcast)."""
    act = self._array(act, (self.nworld, self.physics.na), "act")
    self._check(_lib_.ost_batchSetAct(self._ptr, _lib.dptr(act)), "set_act")

  @property
  def act(self):
    """Every world's activations: nworld x na."""
    out = np.zeros((self.nworld, self.physics.na))
    self._check(_lib_.ost_batchGetAct(self._ptr, _lib.dptr(out)), "act")
    return out

  def set_ctrl(self, ctrl):
    """Set every world's controls (nworld x nu) for the following steps."""
    ctrl = self._array(ctrl, (self.nworld, self.physics.nu), "ctrl")
    self._check(_lib_.ost_batchSetCtrl(self._ptr, _lib.dptr(ctrl)), "set_ctrl")

  def step(self):
    """Advance every world by one step; return each world's outcome bits (status)."""
    self._check(_lib_.ost_batchStep(self._ptr), "step")
    return self.status

  @property
  def status(self):
    """Outcome bits of every world's last step (ostStatusBit; 1: not converged, a warning)."""
    out = np.zeros(self.nworld, dtype=np.int32)
    self._check(_lib_.ost_batchStatus(self._ptr, _lib.iptr(out)), "status")
    return out

  @property
  def unconverged(self):
    """Each world's steps, since its state was last set, that did not converge."""
    out = np.zeros(self.nworld, dtype=np.int32)
    self._check(_lib_.ost_batchUnconverged(self._ptr, _lib.iptr(out)), "unconverged")
    return out

  def rollout(self, actions, qpos0=None, qvel0=None, act0=None):
    """Set the state (qpos0, qvel0: nworld x nq, nworld x nv; act0: nworld x na; one row
    broadcast; None: the worlds' current state), run T = len(actions) steps with actions
    (T x nworld x nu), and return a BatchRollout (unpacks as qpos (T + 1) x nworld x nq, qvel
    (T + 1) x nworld x nv; .act (T + 1) x nworld x na). Worlds with unconverged steps warn;
    their gradients will be refused."""
    p = self.physics
    if qpos0 is None or qvel0 is None:
      qpos_now, qvel_now = self.state()
      qpos0 = qpos_now if qpos0 is None else qpos0
      qvel0 = qvel_now if qvel0 is None else qvel0
    act0 = self.act if act0 is None else act0
    self.set_state(qpos0, qvel0)
    if p.na:
      self.set_act(act0)
    actions = np.asarray(actions, dtype=np.float64)
    if actions.ndim == 2:  # the same controls for every world
      actions = np.broadcast_to(actions[:, None, :], (len(actions), self.nworld, actions.shape[1]))
    if actions.ndim != 3 or actions.shape[1:] != (self.nworld, p.nu):
      raise ValueError(f"actions: shape {actions.shape}, expected (T, nworld = {self.nworld}, "
                       f"nu = {p.nu}) or (T, nu)")
    actions = np.ascontiguousarray(actions)
    steps = len(actions)
    qpos = np.zeros((steps + 1, self.nworld, p.nq))
    qvel = np.zeros((steps + 1, self.nworld, p.nv))
    act = np.zeros((steps + 1, self.nworld, p.na))
    qpos[0], qvel[0] = self.state()
    act[0] = self.act
    self._check(_lib_.ost_batchRolloutAct(self._ptr, steps, _lib.dptr(actions),
                                          _lib.dptr(qpos[1:]), _lib.dptr(qvel[1:]),
                                          _lib.dptr(act[1:])), "rollout")
    out = BatchRollout(qpos, qvel, self, act)
    bad = np.flatnonzero(out.unconverged)
    if len(bad):
      warnings.warn(NotConvergedWarning(
          f"worlds {bad.tolist()} had steps that did not converge; their gradients will be "
          "refused"), stacklevel=2)
    return out


class BatchRollout(tuple):
  """(qpos, qvel) of a batch rollout; backward(...) differentiates it. act: the activations
  ((T + 1) x nworld x na); unconverged: each world's unconverged steps; status: each world's
  outcome bits (0 if its rollout went through)."""

  def __new__(cls, qpos, qvel, batch, act):
    self = super().__new__(cls, (qpos, qvel))
    self.qpos, self.qvel, self.act, self._batch = qpos, qvel, act, batch
    self.unconverged = batch.unconverged
    self.status = batch.status
    return self

  def backward(self, cot_qpos=None, cot_qvel=None, tangent=False, truncate=False, checkpoint=0,
               strict=True, params=False):
    """Gradients of a loss of every world's states: cot_qpos ((T + 1) x nworld x nq, or x nv
    with tangent=True), cot_qvel ((T + 1) x nworld x nv); None = zero. Returns BatchGradients:
    qpos (nworld x nq, or nv), qvel (nworld x nv), ctrl (T x nworld x nu), refused (nworld
    bools) and bits (each world's outcome bits); with params=True also theta (nworld x
    ost_nparam, each world's dL/dtheta in ostParam order, as ostrich.rollout's) and params (its
    groups by name, nworld rows each). A world whose rollout had an unconverged or failed step
    gets NaN gradients: with strict (default) that raises NotConvergedError naming the worlds;
    strict=False returns them with `refused` set. This must be the batch's last rollout."""
    batch = self._batch
    p = batch.physics
    rows, nw, nq, nv, nu = len(self.qpos), batch.nworld, p.nq, p.nv, p.nu
    gq = None
    if cot_qpos is not None:
      cot = np.ascontiguousarray(cot_qpos, dtype=np.float64)
      want = (rows, nw, nv if tangent else nq)
      if cot.shape != want:
        raise ValueError(f"cot_qpos: shape {cot.shape}, expected {want}")
      if tangent:
        gq = cot
      else:
        gq = np.zeros((rows, nw, nv))
        _lib_.ostpy_coordToTangent(p._handle.ptr, rows * nw, _lib.dptr(self.qpos),
                                   _lib.dptr(cot), _lib.dptr(gq))
    gv = None
    if cot_qvel is not None:
      gv = np.ascontiguousarray(cot_qvel, dtype=np.float64)
      if gv.shape != (rows, nw, nv):
        raise ValueError(f"cot_qvel: shape {gv.shape}, expected {(rows, nw, nv)}")
    gctrl = np.zeros((rows - 1, nw, nu))
    gq0 = np.zeros((nw, nv))
    gv0 = np.zeros((nw, nv))
    theta = np.zeros((nw, _lib_.ost_nparam(p._model_ptr()))) if params else None
    status = _lib_.ostpy_batchBackward(batch._ptr, int(bool(truncate)), int(checkpoint),
                                       _lib.dptr(gq), _lib.dptr(gv), _lib.dptr(gctrl),
                                       _lib.dptr(gq0), _lib.dptr(gv0), _lib.dptr(theta))
    batch._check(status, "backward")
    if not tangent:
      coords = np.zeros((nw, nq))
      _lib_.ostpy_tangentToCoord(p._handle.ptr, nw, _lib.dptr(np.ascontiguousarray(self.qpos[0])),
                                 _lib.dptr(gq0), _lib.dptr(coords))
      gq0 = coords
    bits = batch.status
    refused = ~(np.isfinite(gq0).all(1) & np.isfinite(gv0).all(1) &
                np.isfinite(gctrl).all((0, 2)))
    if strict and refused.any():
      why = "; ".join(f"world {w}: " + (", ".join(t for b, t in _lib.STATUS_BITS.items()
                                                   if bits[w] & b) or "refused")
                      for w in np.flatnonzero(refused)[:8])
      raise NotConvergedError(f"backward: no gradient for {refused.sum()} of {nw} worlds, "
                              f"whose rollouts were not solved to tolerance ({why})",
                              _lib.ERR_NOT_CONVERGED)
    return BatchGradients(gq0, gv0, gctrl, refused, bits, theta, p)


class BatchGradients:
  """What BatchRollout.backward returns: qpos, qvel (start states, per world), ctrl (T x
  nworld x nu), refused (worlds with NaN gradients), bits (their outcome bits), theta (nworld x
  ost_nparam; None without params) and params (theta's groups by name, as
  ostrich.rollout.Gradients.params, with a leading world axis)."""

  def __init__(self, qpos, qvel, ctrl, refused, bits, theta=None, physics=None):
    self.qpos, self.qvel, self.ctrl, self.refused, self.bits = qpos, qvel, ctrl, refused, bits
    self.theta = theta
    self.params = {}
    if theta is not None:
      model = physics._model_ptr()
      for g, group in enumerate(PARAM_GROUPS):
        a, b = _lib_.ost_paramAddress(model, g), _lib_.ost_paramAddress(model, g + 1)
        self.params[group] = theta[:, a:b]
