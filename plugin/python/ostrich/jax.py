"""JAX adapter: ostrich.rollout as a jax.custom_vjp function, so that a loss written in JAX of
the rollout's states differentiates (jax.grad, jax.vjp, inside jax.jit) to the actions, the
start state and the model's physical parameters. Import it on its own (`import ostrich.jax`);
it needs JAX, which the rest of the package does not, with 64-bit floats enabled:

  jax.config.update("jax_enable_x64", True)
  qpos, qvel = ostrich.jax.rollout(physics, actions, qpos0, qvel0, theta)

actions (T x nu), qpos0 (nq), qvel0 (nv) and theta (ost_nparam, ostrich.get_theta's order; may
be None: the model as it is) are float64 arrays; the outputs are (T + 1) x nq and (T + 1) x nv,
the start state first. Given, theta is written into the model (ostrich.set_theta) before the
rollout. Gradients follow rollout.py: qpos in coordinates (for free and ball joints, tangent to
the unit quaternion's sphere).

The steps run on the CPU through jax.pure_callback (under jax.vmap one world after another). The
forward pass keeps the rollout's tape for its backward pass (the last TAPES_KEPT of them); a
backward pass whose tape is gone records the rollout again from the same inputs. A rollout with
an unconverged step warns (NotConvergedWarning) in the forward pass, and its gradients are NaN:
never a silent gradient.
"""

import collections
import itertools
import warnings

import jax
import jax.numpy as jnp
import numpy as np

from .errors import NotConvergedError, NotConvergedWarning
from .rollout import rollout as _rollout
from .rollout import set_theta as _set_theta

TAPES_KEPT = 16
_tapes = collections.OrderedDict()  # token -> Rollout, oldest first
_tokens = itertools.count(1)


def _record(physics, actions, qpos0, qvel0, theta):
  if theta is not None:
    _set_theta(physics, np.asarray(theta, np.float64))
  return _rollout(physics, np.asarray(actions, np.float64), np.asarray(qpos0, np.float64),
                  np.asarray(qvel0, np.float64))


def _shapes(physics, actions):
  steps = actions.shape[0]
  return (jax.ShapeDtypeStruct((steps + 1, physics.nq), jnp.float64),
          jax.ShapeDtypeStruct((steps + 1, physics.nv), jnp.float64))


def _primal(physics, actions, qpos0, qvel0, theta):
  """The rollout's states, no tape kept (nothing will differentiate it)."""
  def run(actions, qpos0, qvel0, theta):
    traj = _record(physics, actions, qpos0, qvel0, theta)
    return traj.qpos.copy(), traj.qvel.copy()
  return jax.pure_callback(run, _shapes(physics, actions), actions, qpos0, qvel0, theta)


def _forward(physics, actions, qpos0, qvel0, theta):
  """The states and a token naming the kept tape."""
  def run(actions, qpos0, qvel0, theta):
    traj = _record(physics, actions, qpos0, qvel0, theta)
    token = next(_tokens)
    _tapes[token] = traj
    while len(_tapes) > TAPES_KEPT:
      _tapes.popitem(last=False)
    return traj.qpos.copy(), traj.qvel.copy(), np.int64(token)
  shapes = _shapes(physics, actions) + (jax.ShapeDtypeStruct((), jnp.int64),)
  qpos, qvel, token = jax.pure_callback(run, shapes, actions, qpos0, qvel0, theta)
  return (qpos, qvel), (token, actions, qpos0, qvel0, theta)


def _backward(physics, residuals, cotangents):
  token, actions, qpos0, qvel0, theta = residuals
  cot_qpos, cot_qvel = cotangents
  want_theta = theta is not None

  def run(token, actions, qpos0, qvel0, theta, cot_qpos, cot_qvel):
    traj = _tapes.pop(int(token), None)
    if traj is None:  # dropped (more than TAPES_KEPT rollouts since): record it again
      with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotConvergedWarning)  # the forward pass warned
        traj = _record(physics, actions, qpos0, qvel0, theta)
    try:
      g = traj.backward(np.asarray(cot_qpos), np.asarray(cot_qvel), params=want_theta)
      out = (g.ctrl, g.qpos, g.qvel) + ((g.theta,) if want_theta else ())
    except NotConvergedError:
      out = tuple(np.full(np.shape(a), np.nan) for a in (actions, qpos0, qvel0)
                  + ((theta,) if want_theta else ()))
    return tuple(np.asarray(a, np.float64) for a in out)

  shapes = tuple(jax.ShapeDtypeStruct(np.shape(a), jnp.float64)
                 for a in (actions, qpos0, qvel0) + ((theta,) if want_theta else ()))
  grads = jax.pure_callback(run, shapes, token, actions, qpos0, qvel0, theta, cot_qpos,
                            cot_qvel)
  return tuple(grads) + (() if want_theta else (None,))


_rollout_vjp = jax.custom_vjp(_primal, nondiff_argnums=(0,))
_rollout_vjp.defvjp(_forward, _backward)


def rollout(physics, actions, qpos0, qvel0, theta=None):
  """Differentiable ostrich.rollout on JAX arrays: returns (qpos, qvel)."""
  if not jax.config.jax_enable_x64:
    raise ValueError("ostrich.jax needs 64-bit floats: jax.config.update('jax_enable_x64', "
                     "True) before making arrays")
  args = [jnp.asarray(a, jnp.float64) for a in (actions, qpos0, qvel0)]
  if args[0].ndim == 1 and physics.nu == 1:
    args[0] = args[0].reshape(-1, 1)
  expected = ((None, physics.nu), (physics.nq,), (physics.nv,))
  for a, shape, name in zip(args, expected, ("actions", "qpos0", "qvel0")):
    if a.ndim != len(shape) or (shape[-1] is not None and a.shape[-1] != shape[-1]):
      raise ValueError(f"{name}: shape {a.shape}, expected "
                       + ("(T, nu = %d)" % physics.nu if name == "actions" else str(shape)))
  if theta is not None:
    theta = jnp.asarray(theta, jnp.float64)
  return _rollout_vjp(physics, *args, theta)
