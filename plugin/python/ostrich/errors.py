"""Ostrich's exceptions and warnings, and the translation of C statuses into them."""

import warnings

from . import _lib


class OstrichError(RuntimeError):
  """A failed call: a refused or malformed model, a failed step or backward pass.

  `status` is the ostStatus of the C call (ostrich.h: 1 model, 2 input, 3 overflow, 4 numeric,
  5 version, 6 memory, 7 not converged; < 0 a bad argument); the message is Ostrich's or
  MuJoCo's own.
  """

  def __init__(self, message, status=None):
    super().__init__(message)
    self.status = status


class NotConvergedError(OstrichError):
  """A gradient was asked of a rollout with a step that did not converge (OST_ERR_NOT_CONVERGED):
  the implicit function theorem holds only at a solved step, so no gradient is returned."""


class NotConvergedWarning(RuntimeWarning):
  """A step was taken but its residual stayed above the tolerance (OST_WARN_NOT_CONVERGED)."""


class MujocoWarning(RuntimeWarning):
  """A warning MuJoCo raised (mju_warning), e.g. a contact buffer full under stock MuJoCo."""


def check(status, message, what=""):
  """Raise OstrichError for an error status; return the status otherwise (OK or a warning)."""
  if status == _lib.OK or status >= _lib.WARN_FIRST:
    return status
  text = f"{what}: {message}" if what and message else (message or what or f"status {status}")
  if status == _lib.ERR_NOT_CONVERGED:
    raise NotConvergedError(text, status)
  raise OstrichError(text, status)


def forward_mujoco_warnings(stacklevel=3):
  """Turn the MuJoCo warning recorded since the last call, if any, into a MujocoWarning."""
  msg = _lib.text(_lib.lib.ostpy_takeWarning())
  if msg:
    warnings.warn(MujocoWarning(msg), stacklevel=stacklevel)
