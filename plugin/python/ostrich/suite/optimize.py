"""Open-loop trajectory optimization on the suite's tasks: Ostrich's adjoint gradients against the
same optimizer fed by finite differences of stock MuJoCo, and against a sampling planner.

  python3 -m ostrich.suite.optimize --task cartpole-swingup [--horizon N] [--budget SECONDS]
      [--methods adjoint,fd,fdjac,cem] [--seed S] [--csv FILE] [--plot FILE.png]

The decision variable is the action sequence A (H x nu) of the episode's first H control steps
from the task's random start state (seed S), inside the action spec's bounds. Every method
maximises the same objective J(A) = sum_k f(qpos_k+1, qvel_k+1, a_k), summed over the states at
the end of each control step:

  adjoint  Adam ascent on J, gradients from ostrich.rollout(...).backward(...) (the adjoint of
           Ostrich's implicit steps) and the partial derivatives of f; actions clipped to the
           spec after each update.
  fd       the same Adam, with dJ/dA by forward differences of stock MuJoCo rollouts (mj_step):
           one rollout per action component, each restarted from the saved state of its step
           (the steps before it are unchanged), so H (H + 1) / 2 * nu control steps a gradient.
  fdjac    the same Adam, with dJ/dA through stock MuJoCo's step Jacobians by forward
           differences (mjd_transitionFD; ostrich.mujoco_linearized_rollout) chained backward
           along the nominal rollout: 1 + 2 nv + na + nu steps per step, the way iLQR-style
           planners on MuJoCo differentiate. Exact up to the differences on smooth dynamics; the
           chain of soft-contact Jacobians can blow up (the walker's: 700 times fd's gradient).
  cem      the cross-entropy method on Ostrich rollouts of a Batch (one thread): samples around
           a mean sequence, the best ones refit the mean and spread.

f is the task's reward_fn where that is smooth (cartpole, walker, hopper stand); a smooth
surrogate where the reward is sparse or flat (SURROGATES below). Each method
gets the same wall-clock budget, measured over its own work only: every so often (at most
every 10 % of the elapsed time, and at the end) the current action sequence is played in the
task's dm_env Environment on the Ostrich engine, from the same start state, and the sum of the
task's own rewards over the H steps is its return; that evaluation's time is not counted.

A step that does not converge (Ostrich) or a rollout that is not finite (MuJoCo) is never used
silently: it is reported on stderr, counted in the table's `bad` column, and the iteration is
rejected (the optimizer goes back to its best actions with half the step; CEM drops the sample).
"""

import argparse
import collections
import csv
import io
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

from ..linearized import mujoco_linearized_rollout
from ..rollout import mujoco_rollout
from ..rollout import rollout as ost_rollout
from ..batch import Batch
from ..errors import MujocoWarning, NotConvergedError, NotConvergedWarning, OstrichError
from . import find_suite_dir, load, planar, TASKS
from .rewards import tolerance

METHODS = ("adjoint", "fd", "fdjac", "cem")
FD_METHODS = ("fd", "fdjac")  # the baselines on stock MuJoCo
# control steps optimized per task by default: long enough for the task's motion (a swing-up
# takes 2 to 3 s, the reacher about 1 s, a cheetah's stride about 0.3 s)
DEFAULT_HORIZON = {("cartpole", "swingup"): 300, ("cartpole", "balance"): 200,
                   ("pendulum", "swingup"): 150, ("reacher", "easy"): 100,
                   ("cheetah", "run"): 100, ("walker", "walk"): 60, ("walker", "stand"): 60}
DERIV_STEP = 1e-6    # central differences of the closed-form f: error ~1e-10 relative
FD_STEP = 1e-6       # forward differences of MuJoCo rollouts (actions are O(1): error ~1e-6)
ADAM_LR = 0.05       # Adam's step in action units (the suite's actions lie in [-1, 1])


class SetupError(Exception):
  """A refusal before any work (exit status 2)."""


# ---- objectives: f(qpos, qvel, ctrl) with leading batch dimensions

def _pendulum_surrogate(env):
  # the sparse reward is 1 within 8 degrees of upright; the surrogate keeps that plateau and
  # falls linearly in cos(angle) outside it, down to 0 at hanging straight down
  bound = math.cos(math.radians(8))

  def f(qpos, qvel, ctrl):
    return tolerance(np.cos(qpos[..., 0]), (bound, 1), margin=1 + bound, sigmoid="linear",
                     value_at_margin=0)
  return f


def _reacher_surrogate(env):
  # the sparse reward is 1 while the finger touches the target; the surrogate keeps that and
  # falls linearly in the distance outside it, to 0 at 0.5 m (no target is farther from the
  # finger: the arm reaches 0.22 m, targets lie within 0.2 m), so its slope never vanishes
  model = env.physics.named.model
  base = np.array(model.body_pos["arm"][:2], dtype=float)
  l1, l2 = float(model.body_pos["hand"][0]), float(model.body_pos["finger"][0])
  target = np.array(model.geom_pos["target"][:2], dtype=float)
  radii = float(model.geom_size[["target", "finger"], 0].sum())

  def f(qpos, qvel, ctrl):
    a, b = qpos[..., 0], qpos[..., 0] + qpos[..., 1]
    dx = target[0] - (base[0] + l1 * np.cos(a) + l2 * np.cos(b))
    dy = target[1] - (base[1] + l1 * np.sin(a) + l2 * np.sin(b))
    return tolerance(np.sqrt(dx ** 2 + dy ** 2), (0, radii), margin=0.5, sigmoid="linear",
                     value_at_margin=0)
  return f


def _cheetah_surrogate(env):
  # the reward is the torso subtree's forward speed / 10 m/s, clipped to [0, 1]; the surrogate
  # is that speed / 10 m/s unclipped, so that it has a slope at every speed
  velocity = planar.subtree_com_velocity(env.physics, "torso")

  def f(qpos, qvel, ctrl):
    return velocity(qpos, qvel)[0] / 10.0
  return f


# what each task's optimizers maximise: the exact reward_fn, or a surrogate and why
SURROGATES = {
    ("pendulum", "swingup"): (_pendulum_surrogate, "reward within 8 deg of upright, linear in "
                              "cos(angle) outside (the reward is sparse)"),
    ("reacher", "easy"): (_reacher_surrogate, "reward at contact, linear in the finger's "
                          "distance outside (the reward is sparse)"),
    ("cheetah", "run"): (_cheetah_surrogate, "the torso subtree's forward speed / 10 m/s, "
                         "unclipped (the reward is flat below 0 and above 10 m/s)"),
}
EXACT = (("cartpole", "balance"), ("cartpole", "swingup"), ("walker", "stand"),
         ("walker", "walk"), ("hopper", "stand"))
SUPPORTED = tuple(k for k in TASKS if k in EXACT or k in SURROGATES)


def objective_of(env):
  """(f, description) for env's task: f(qpos, qvel, ctrl) -> reward-like values."""
  key = (env.task.domain, env.task.name)
  if key in EXACT:
    return env.reward_fn(np), "the task's reward_fn (exact)"
  if key in SURROGATES:
    make, why = SURROGATES[key]
    return make(env), "surrogate: " + why
  raise SetupError(f"{key[0]}-{key[1]}: no differentiable reward or surrogate; tasks: "
                   + ", ".join(f"{d}-{t}" for d, t in SUPPORTED))


def partials(f, qpos, qvel, ctrl, step=DERIV_STEP):
  """df/dqpos, df/dqvel, df/dctrl of a closed-form f at rows (T x n): central differences, all
  2 (nq + nv + nu) perturbed copies in one evaluation of the formula along a new leading axis
  (f takes leading batch dimensions), so the Python cost does not grow with the sizes."""
  args = [np.array(qpos, dtype=float), np.array(qvel, dtype=float), np.array(ctrl, dtype=float)]
  sizes = [a.shape[-1] for a in args]
  n = sum(sizes)
  stacked = [np.repeat(a[None], 2 * n, axis=0) for a in args]  # copy k: +step, n + k: -step
  k = 0
  for i, size in enumerate(sizes):
    for j in range(size):
      stacked[i][k, ..., j] += step
      stacked[i][n + k, ..., j] -= step
      k += 1
  values = f(*stacked)
  diff = (values[:n] - values[n:]) / (2 * step)  # n x T
  out, k = [], 0
  for a, size in zip(args, sizes):
    out.append(np.moveaxis(diff[k:k + size], 0, -1).reshape(a.shape))
    k += size
  return out


class Unconverged(Exception):
  """A rollout with unconverged (Ostrich) or non-finite (MuJoCo) steps: no objective, no
  gradient."""


class Problem:
  """One task's trajectory optimization problem: the start state (seed), the horizon H, the
  bounds, the objective, and its gradients by the adjoint and by MuJoCo finite differences."""

  def __init__(self, domain, task, horizon=None, seed=0, xml_dir=None, physics_timestep=None):
    # physics_timestep: Ostrich's step (default the suite's); fd's MuJoCo keeps the suite's own
    self.domain, self.task, self.seed, self.xml_dir = domain, task, seed, xml_dir
    self.physics_timestep = physics_timestep
    self.env = load(domain, task, xml_dir=xml_dir, seed=seed,  # Ostrich: adjoint and CEM
                    physics_timestep=physics_timestep)
    self.env.reset()
    p = self.env.physics
    self.qpos0, self.qvel0 = p.data.qpos.copy(), p.data.qvel.copy()
    self.n_sub = self.env.n_sub_steps
    self.horizon = int(horizon or DEFAULT_HORIZON.get((domain, task), 100))
    episode = int(round(self.env.step_limit))
    if not 1 <= self.horizon <= episode:
      raise SetupError(f"--horizon {self.horizon}: the episode has {episode} control steps")
    spec = self.env.action_spec()
    self.lo, self.hi = np.array(spec.minimum, float), np.array(spec.maximum, float)
    self.nu = p.nu
    self.f, self.objective_text = objective_of(self.env)
    self.eval_env = load(domain, task, xml_dir=xml_dir, seed=seed,
                         physics_timestep=physics_timestep)
    self._mj = None  # the MuJoCo environment, made when fd needs it
    self.device = "cpu:1"  # the sampling planners' batches: one thread, as the other planners
    self.rows = np.arange(1, self.horizon + 1) * self.n_sub  # rollout rows ending control steps

  def clip(self, actions):
    return np.clip(actions, self.lo, self.hi)

  def initial_actions(self):
    return self.clip(np.zeros((self.horizon, self.nu)))

  # -- evaluation: the task's own reward in its dm_env Environment (Ostrich)

  def evaluate(self, actions):
    """(return, unconverged steps) of actions played in the task's Environment on Ostrich from
    the start state: the sum of the task's rewards over the H control steps."""
    env = self.eval_env
    env.task.random = np.random.RandomState(self.seed)  # the same draws: the same start
    env.reset()
    if not (np.array_equal(env.physics.data.qpos, self.qpos0)
            and np.array_equal(env.physics.data.qvel, self.qvel0)):
      raise RuntimeError("the evaluation environment did not reproduce the start state")
    total, bad = 0.0, 0
    with warnings.catch_warnings(record=True) as caught:
      warnings.simplefilter("always", NotConvergedWarning)
      for a in actions:
        total += env.step(a).reward
    bad = sum(issubclass(w.category, NotConvergedWarning) for w in caught)
    for w in caught:
      if not issubclass(w.category, NotConvergedWarning):
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return total, bad

  # -- the adjoint (Ostrich)

  def objective_and_gradient(self, actions):
    """(J, dJ/dA) by one Ostrich rollout and its adjoint. Raises Unconverged."""
    p = self.env.physics
    ctrl = np.repeat(actions, self.n_sub, axis=0)
    with warnings.catch_warnings():
      warnings.simplefilter("ignore", NotConvergedWarning)  # counted from traj.status below
      traj = ost_rollout(p, ctrl, self.qpos0, self.qvel0)
    if not traj.converged:
      raise Unconverged(f"{int(np.sum(traj.status != 0))} of {len(ctrl)} Ostrich steps did not "
                        "converge")
    qp, qv = traj.qpos[self.rows], traj.qvel[self.rows]
    J = float(np.sum(self.f(qp, qv, actions)))
    dq, dv, du = partials(self.f, qp, qv, actions)
    cq, cv = np.zeros_like(traj.qpos), np.zeros_like(traj.qvel)
    cq[self.rows], cv[self.rows] = dq, dv
    try:
      grads = traj.backward(cq, cv, params=False)
    except NotConvergedError as e:  # not expected after the check above; never a gradient
      raise Unconverged(str(e)) from e
    g = grads.ctrl.reshape(self.horizon, self.n_sub, self.nu).sum(axis=1) + du
    if not (np.isfinite(J) and np.isfinite(g).all()):
      raise Unconverged("the adjoint gave a non-finite gradient")
    return J, g

  def objective(self, actions):
    """J on Ostrich (one rollout, no tape used). Raises Unconverged."""
    return self.objective_batch(actions[None])[0][0]

  # -- finite differences of stock MuJoCo

  @property
  def mujoco(self):
    if self._mj is None:
      env = load(self.domain, self.task, xml_dir=self.xml_dir, seed=self.seed, engine="mujoco")
      env.reset()  # the same draws (targets, ...); the start state is then Ostrich's own
      self._mj = env
    return self._mj

  def _mj_start(self):
    """The start state as a snapshot (mujoco_rollout's layout: qpos, qvel, qacc_warmstart,
    act): Ostrich's start, warm start and act zero, as after reset."""
    p = self.mujoco.physics
    s = np.zeros(p.nq + 2 * p.nv + p.data.act.size)
    s[:p.nq], s[p.nq:p.nq + p.nv] = self.qpos0, self.qvel0
    return s

  def _mj_restore(self, s):
    """Put snapshot s into the MuJoCo physics' data."""
    d = self.mujoco.physics.data
    nq, nv = d.qpos.size, d.qvel.size
    d.qpos[:], d.qvel[:], d.qacc_warmstart[:] = s[:nq], s[nq:nq + nv], s[nq + nv:nq + 2 * nv]
    if d.act.size:  # (no suite task here has activations; an empty view is read-only)
      d.act[:] = s[nq + 2 * nv:]

  @staticmethod
  def _mj_usable(caught, J, g):
    """Raise Unconverged if MuJoCo warned (caught) or J or g is not finite."""
    if caught or not (np.isfinite(J) and np.isfinite(g).all()):
      why = "; ".join(str(w.message) for w in caught[:2]) or "non-finite states"
      raise Unconverged(f"MuJoCo rollout not usable: {why}")

  def _mj_run(self, actions, k0, snap, qp_out, qv_out):
    """Play actions[k0:] on MuJoCo from snapshot k0 (self._snap), writing the end-of-step states
    into qp_out[k0:], qv_out[k0:] and the snapshots of steps k0.. into snap (if given). The steps
    run in C (mujoco_rollout): no Python call per step."""
    p = self.mujoco.physics
    self._mj_restore(self._snap[k0])
    mujoco_rollout(p, actions[k0:], self.mujoco.n_sub_steps, qp_out[k0:], qv_out[k0:],
                   None if snap is None else snap[k0:])

  def fd_objective_and_gradient(self, actions, step=FD_STEP):
    """(J, dJ/dA) on stock MuJoCo: J of the nominal rollout and forward differences of one
    rollout per action component, restarted at its step. Raises Unconverged (not finite)."""
    p = self.mujoco.physics
    H, nu = self.horizon, self.nu
    snap = np.zeros((H, p.nq + 2 * p.nv + p.data.act.size))
    snap[0] = self._mj_start()
    self._snap = snap
    qp, qv = np.zeros((H, p.nq)), np.zeros((H, p.nv))
    with warnings.catch_warnings(record=True) as caught:
      warnings.simplefilter("always", MujocoWarning)
      self._mj_run(actions, 0, snap, qp, qv)
      r = self.f(qp, qv, actions)
      J = float(np.sum(r))
      prefix = np.concatenate(([0.0], np.cumsum(r)))  # rewards of the unchanged steps
      g = np.zeros((H, nu))
      qp2, qv2 = qp.copy(), qv.copy()
      a2 = actions.copy()
      for k in range(H):
        for j in range(nu):
          h = step if actions[k, j] + step <= self.hi[j] else -step  # stay inside the bounds
          a2[k, j] = actions[k, j] + h
          self._mj_run(a2, k, None, qp2, qv2)
          Jk = prefix[k] + float(np.sum(self.f(qp2[k:], qv2[k:], a2[k:])))
          g[k, j] = (Jk - J) / h
          a2[k, j] = actions[k, j]
    self._mj_usable(caught, J, g)
    return J, g

  def fdjac_objective_and_gradient(self, actions, eps=FD_STEP):
    """(J, dJ/dA) on stock MuJoCo by the Jacobian chain: the nominal rollout with every step's
    Jacobians by forward differences (mjd_transitionFD, ostrich.mujoco_linearized_rollout),
    chained backward from the partial derivatives of f. Raises Unconverged (not finite)."""
    p = self.mujoco.physics
    self._mj_restore(self._mj_start())  # fd's start too
    with warnings.catch_warnings(record=True) as caught:
      warnings.simplefilter("always", MujocoWarning)
      lin = mujoco_linearized_rollout(p, actions, self.mujoco.n_sub_steps, eps=eps)
      J = float(np.sum(self.f(lin.qpos, lin.qvel, actions)))
      dq, dv, du = partials(self.f, lin.qpos, lin.qvel, actions)
      g = lin.backward(dq, dv)[0] + du
    self._mj_usable(caught, J, g)
    return J, g

  # -- batches for the sampling planner

  def batch(self, nworld):
    return Batch(self.env.physics, nworld, device=self.device)

  def objective_batch(self, actions, batch=None):
    """J of each sequence (N x H x nu) on Ostrich, and each one's unconverged step count."""
    n = len(actions)
    batch = batch or self.batch(n)
    ctrl = np.repeat(np.transpose(actions, (1, 0, 2)), self.n_sub, axis=0)  # T x N x nu
    with warnings.catch_warnings():
      warnings.simplefilter("ignore", NotConvergedWarning)  # counted from traj.unconverged
      traj = batch.rollout(ctrl, self.qpos0, self.qvel0)
    qp, qv = traj.qpos[self.rows], traj.qvel[self.rows]  # H x N x n
    J = np.sum(self.f(qp, qv, np.transpose(actions, (1, 0, 2))), axis=0)
    return J, np.asarray(traj.unconverged)


# ---- the optimizers: generators of (iteration, objective, actions, bad) per iteration

class Adam:
  def __init__(self, shape, lr, b1=0.9, b2=0.999, eps=1e-8):
    self.lr, self.b1, self.b2, self.eps = lr, b1, b2, eps
    self.m, self.v, self.t = np.zeros(shape), np.zeros(shape), 0

  def ascend(self, x, g):
    self.t += 1
    self.m = self.b1 * self.m + (1 - self.b1) * g
    self.v = self.b2 * self.v + (1 - self.b2) * g * g
    mhat = self.m / (1 - self.b1 ** self.t)
    vhat = self.v / (1 - self.b2 ** self.t)
    return x + self.lr * mhat / (np.sqrt(vhat) + self.eps)


def gradient_ascent(problem, grad, lr=ADAM_LR, log=None):
  """Adam on J with gradients grad(actions) -> (J, dJ/dA), actions clipped to the spec. Yields
  (objective, actions, bad) per iteration; an unusable iterate is reported, counted, and
  replaced by the best one so far with half the step (doubled again, up to lr, after 10
  accepted iterations in a row)."""
  x = problem.initial_actions()
  adam = Adam(x.shape, lr)
  best_x, best_J = x.copy(), -np.inf
  accepted = 0
  while True:
    try:
      J, g = grad(x)
    except Unconverged as e:
      if log:
        log(f"rejected: {e}; back to the best actions, step {adam.lr:.3g} -> {adam.lr / 2:.3g}")
      adam = Adam(x.shape, adam.lr / 2)
      x, accepted = best_x.copy(), 0
      yield best_J, best_x, 1
      continue
    accepted += 1
    if accepted % 10 == 0 and adam.lr < lr:
      adam.lr = min(lr, 2 * adam.lr)
    if J > best_J:
      best_x, best_J = x.copy(), J
    yield J, x, 0
    x = problem.clip(adam.ascend(x, g))


def cem(problem, rng, population=64, elites=8, init_std=0.5, min_std=0.02, log=None):
  """The cross-entropy method: population sequences ~ N(mean, std^2) clipped to the spec, the
  best `elites` refit mean and std. Yields (best objective so far, its actions, bad)."""
  H, nu = problem.horizon, problem.nu
  mean = problem.initial_actions()
  std = np.full((H, nu), init_std) * (problem.hi - problem.lo) / 2
  batch = problem.batch(population)
  best_x, best_J = mean.copy(), -np.inf
  while True:
    samples = problem.clip(mean + std * rng.standard_normal((population, H, nu)))
    samples[0] = mean  # the mean itself is always a candidate
    J, unconverged = problem.objective_batch(samples, batch)
    bad = int(np.count_nonzero(unconverged))
    if bad and log:
      log(f"{bad} of {population} samples had unconverged Ostrich steps; dropped")
    J = np.where((unconverged == 0) & np.isfinite(J), J, -np.inf)
    order = np.argsort(J)[::-1][:elites]
    order = order[np.isfinite(J[order])]
    if len(order):
      if J[order[0]] > best_J:
        best_J, best_x = float(J[order[0]]), samples[order[0]].copy()
      mean = samples[order].mean(axis=0)
      std = np.maximum(samples[order].std(axis=0), min_std)
    yield best_J, best_x, bad


# ---- running a method under a budget

Point = collections.namedtuple("Point", "iteration wall objective ret")


class Result:
  def __init__(self, task, method, engine):
    self.task, self.method, self.engine = task, method, engine
    self.points, self.iterations, self.bad, self.eval_unconverged = [], 0, 0, 0
    self.note = ""

  def best(self):
    """(best return, wall time of its first evaluation)."""
    if not self.points:
      return float("nan"), float("nan")
    p = max(self.points, key=lambda p: (p.ret, -p.wall))
    return p.ret, p.wall

  def time_to(self, target):
    """Wall time of the first evaluation whose return reached target (None: never)."""
    for p in self.points:
      if p.ret >= target:
        return p.wall
    return None


def run_method(problem, method, budget, seed=0, max_iterations=None, err=None):
  """Run one method for `budget` seconds of its own work (evaluations not counted) or
  max_iterations; return its Result. Progress lines go to err (default sys.stderr)."""
  err = err or sys.stderr
  name = f"{problem.domain}-{problem.task}"
  result = Result(name, method, "mujoco" if method in FD_METHODS else "ostrich")

  def log(msg):
    print(f"[{name} {method}] {msg}", file=err, flush=True)

  if method == "adjoint":
    it = gradient_ascent(problem, problem.objective_and_gradient, log=log)
  elif method == "fd":
    it = gradient_ascent(problem, problem.fd_objective_and_gradient, log=log)
  elif method == "fdjac":
    it = gradient_ascent(problem, problem.fdjac_objective_and_gradient, log=log)
  elif method == "cem":
    it = cem(problem, np.random.RandomState(seed), log=log)
  else:
    raise ValueError(method)
  work, last_eval, i = 0.0, -1.0, 0
  while True:
    t0 = time.perf_counter()
    J, x, bad = next(it)
    work += time.perf_counter() - t0
    result.bad += bad
    i += 1
    done = work >= budget or (max_iterations is not None and i >= max_iterations)
    ret = None
    if i == 1 or done or work >= 1.1 * last_eval + budget / 1000:  # ~100 evaluations a run
      ret, unconverged = problem.evaluate(x)
      result.eval_unconverged += unconverged
      if unconverged:
        log(f"evaluation: {unconverged} unconverged Ostrich steps in the Environment")
      result.points.append(Point(i, work, J, ret))
      last_eval = work
    print(f"[{name} {method}] iter {i:5d}  wall {work:8.3f} s  objective {J:10.4f}  return "
          + (f"{ret:9.3f}" if ret is not None else "        -"), file=err, flush=True)
    if done:
      result.iterations = i
      return result


# ---- output

def check_writable(path, what):
  """Refuse (SetupError) an output path that cannot be written, before any work."""
  path = os.path.abspath(path)
  folder = os.path.dirname(path)
  if os.path.isdir(path):
    raise SetupError(f"{what} {path}: is a directory")
  if not os.path.isdir(folder):
    raise SetupError(f"{what} {path}: no directory {folder}")
  try:
    fd, probe = tempfile.mkstemp(dir=folder, prefix=".probe-")
  except OSError as e:
    raise SetupError(f"{what} {path}: cannot write in {folder}: {e.strerror}") from e
  os.close(fd)
  os.unlink(probe)
  if os.path.exists(path) and not os.access(path, os.W_OK):
    raise SetupError(f"{what} {path}: not writable")


def _temporary_beside(path):
  fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)),
                             prefix="." + os.path.basename(path) + ".", suffix=".tmp")
  os.close(fd)
  umask = os.umask(0)
  os.umask(umask)
  os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would outlive the rename
  return tmp


def write_atomic(path, text):
  """Write text to a temporary file beside path, then rename it onto path."""
  tmp = _temporary_beside(path)
  try:
    with open(tmp, "w") as out:
      out.write(text)
    os.replace(tmp, path)
  except BaseException:
    if os.path.exists(tmp):
      os.unlink(tmp)
    raise


CSV_FIELDS = ("task", "method", "engine", "iteration", "wall_s", "objective", "return")


def csv_text(results):
  out = io.StringIO()
  w = csv.writer(out, lineterminator="\n")
  w.writerow(CSV_FIELDS)
  for r in results:
    for p in r.points:
      w.writerow((r.task, r.method, r.engine, p.iteration, f"{p.wall:.6f}", f"{p.objective:.9g}",
                  f"{p.ret:.9g}"))
  return out.getvalue()


def draw_png(path, data_text, script, width):
  """Draw a PNG with gnuplot: data_text goes to a temporary CSV, script(data_name) gives the
  commands after the terminal and output lines; the PNG is drawn into a temporary file beside
  path (pngcairo, else png, width x 480) and renamed onto path. OSError if gnuplot fails."""
  data = tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False)
  tmp = _temporary_beside(path)
  try:
    with data:
      data.write(data_text)
    proc = None
    for terminal in (f"pngcairo size {width},480 noenhanced", f"png size {width},480 noenhanced"):
      lines = [f"set terminal {terminal}", f"set output '{tmp}'"] + script(data.name)
      proc = subprocess.run(["gnuplot"], input="\n".join(lines) + "\n", text=True,
                            capture_output=True)
      if proc.returncode == 0 and os.path.getsize(tmp) > 0:
        os.replace(tmp, path)
        return
    raise OSError(f"gnuplot could not draw {path}: {proc.stderr.strip()[-300:]}")
  finally:
    os.unlink(data.name)
    if os.path.exists(tmp):
      os.unlink(tmp)


def plot(path, results, title=""):
  """Draw return against wall time, one line per method, one panel per task (draw_png)."""
  tasks = list(dict.fromkeys(r.task for r in results))

  def script(data):
    out = ["set datafile separator ','", "set key bottom right", "set grid",
           "set xlabel 'wall time, s (each method its own budget)'",
           "set ylabel 'return (Ostrich Environment)'",
           f"set multiplot layout 1,{len(tasks)} title '{title}'"]
    for task in tasks:
      lines = []
      for r in results:
        if r.task == task and r.points:
          label = {"adjoint": "adjoint (Ostrich)", "fd": "finite differences (MuJoCo)",
                   "fdjac": "FD step Jacobians (MuJoCo)",
                   "cem": "CEM (Ostrich)"}.get(r.method, r.method)
          lines.append(f"'{data}' using (strcol(1) eq '{task}' && strcol(2) eq "
                       f"'{r.method}' ? $5 : NaN):7 with steps lw 2 title '{label}'")
      out.append(f"set title '{task}'")
      out.append("plot " + ", ".join(lines) if lines else "plot NaN notitle")
    return out + ["unset multiplot"]
  draw_png(path, csv_text(results), script, max(640, 560 * len(tasks)))


def table(results):
  """The summary table (Markdown) and the adjoint-vs-fd (and -fdjac) comparison lines."""
  rows = ["| task | method | optimizes on | best return | wall s to best | iterations | "
          "initial return | bad |", "|---|---|---|---:|---:|---:|---:|---:|"]
  for r in results:
    best, t = r.best()
    init = r.points[0].ret if r.points else float("nan")
    rows.append(f"| {r.task} | {r.method} | {r.engine} | {best:.2f} | {t:.2f} | {r.iterations} "
                f"| {init:.2f} | {r.bad + r.eval_unconverged} |")
  lines = []
  for task in dict.fromkeys(r.task for r in results):
    by = {r.method: r for r in results if r.task == task}
    for fd in FD_METHODS:
      if not ("adjoint" in by and fd in by and by[fd].points):
        continue
      target, t_fd = by[fd].best()
      t_adj = by["adjoint"].time_to(target)
      if t_adj is None:
        lines.append(f"{task}: adjoint never reached {fd}'s best return {target:.2f} ({fd}: "
                     f"{t_fd:.2f} s)")
      else:
        speed = t_fd / max(t_adj, 1e-9)
        lines.append(f"{task}: adjoint reached {fd}'s best return {target:.2f} at {t_adj:.2f} "
                     f"s, {fd} at {t_fd:.2f} s: {speed:.1f}x")
  return "\n".join(rows), "\n".join(lines)


# ---- command line

def parse(argv):
  ap = argparse.ArgumentParser(
      prog="python3 -m ostrich.suite.optimize",
      description="Open-loop trajectory optimization on dm_control suite tasks: Adam on "
      "Ostrich's adjoint gradients (adjoint), the same Adam on finite differences of stock "
      "MuJoCo rollouts (fd) and through its finite-difference step Jacobians (fdjac), and the "
      "cross-entropy method on Ostrich rollouts (cem), each for the same wall-clock budget; returns are the task's own, played on Ostrich.")
  ap.add_argument("--task", required=True,
                  help="DOMAIN-TASK, or several separated by commas; one of: "
                  + ", ".join(f"{d}-{t}" for d, t in SUPPORTED))
  ap.add_argument("--horizon", type=int, help="control steps optimized (default per task)")
  ap.add_argument("--budget", type=float, default=60.0,
                  help="seconds of work per method and task (default 60)")
  ap.add_argument("--methods", default="adjoint,fd,fdjac,cem",
                  help="comma-separated: adjoint,fd,fdjac,cem")
  ap.add_argument("--seed", type=int, default=0, help="the task's start state and CEM's samples")
  ap.add_argument("--iterations", type=int, help="stop a method after this many iterations")
  ap.add_argument("--xml-dir", help="dm_control's suite MJCF folder (default: as ostrich.suite)")
  ap.add_argument("--csv", help="write every evaluation (task, method, iteration, wall, "
                  "objective, return) to this CSV")
  ap.add_argument("--plot", help="draw return against wall time into this PNG (gnuplot)")
  return ap.parse_args(argv)


def parse_tasks(text, supported):
  """[(domain, task)] of a comma-separated DOMAIN-TASK list, each one of `supported`."""
  tasks = []
  for name in text.split(","):
    domain, _, task = name.strip().partition("-")
    if (domain, task) not in supported:
      raise SetupError(f"--task {name}: one of " + ", ".join(f"{d}-{t}" for d, t in supported))
    tasks.append((domain, task))
  return tasks


def parse_methods(text, known):
  """The comma-separated methods of text, each one of `known`."""
  methods = [m.strip() for m in text.split(",") if m.strip()]
  for m in methods:
    if m not in known:
      raise SetupError(f"--methods: unknown method {m!r}; one of {', '.join(known)}")
  if not methods:
    raise SetupError("--methods: none given")
  return methods


def check_outputs_and_data(args):
  """Refuse, before any work, outputs that cannot be written (--csv, --plot and its gnuplot,
  where the parser has them) and a missing suite folder (--xml-dir)."""
  if getattr(args, "csv", None):
    check_writable(args.csv, "--csv")
  if getattr(args, "plot", None):
    check_writable(args.plot, "--plot")
    if shutil.which("gnuplot") is None:
      raise SetupError("--plot needs gnuplot (Debian: gnuplot-nox)")
  try:
    find_suite_dir(args.xml_dir)
  except FileNotFoundError as e:
    raise SetupError(str(e)) from e


def setup(args):
  """Check everything that can be checked before work; return [(domain, task)], [methods]."""
  tasks = parse_tasks(args.task, SUPPORTED)
  methods = parse_methods(args.methods, METHODS)
  if not args.budget > 0:
    raise SetupError("--budget must be positive")
  if args.horizon is not None and args.horizon < 1:
    raise SetupError("--horizon must be at least 1")
  check_outputs_and_data(args)
  return tasks, methods


def main(argv=None, out=None, err=None):
  out, err = out or sys.stdout, err or sys.stderr
  args = parse(argv)
  try:
    tasks, methods = setup(args)
  except SetupError as e:
    print(f"ostrich.suite.optimize: {e}", file=err)
    return 2
  results = []
  for domain, task in tasks:
    try:
      problem = Problem(domain, task, args.horizon, args.seed, args.xml_dir)
    except SetupError as e:
      print(f"ostrich.suite.optimize: {e}", file=err)
      return 2
    print(f"[{domain}-{task}] horizon {problem.horizon} control steps of "
          f"{problem.env.control_timestep():g} s ({problem.n_sub} engine steps each), seed "
          f"{args.seed}; objective: {problem.objective_text}; returns played on Ostrich",
          file=err, flush=True)
    for method in methods:
      results.append(run_method(problem, method, args.budget, args.seed, args.iterations, err))
  rows, speed = table(results)
  print(rows, file=out)
  if speed:
    print(speed, file=out)
  if args.csv:
    write_atomic(args.csv, csv_text(results))
    print(f"ostrich.suite.optimize: wrote {args.csv}", file=err)
  if args.plot:
    plot(args.plot, results, f"open-loop trajectory optimization, {args.budget:g} s per method")
    print(f"ostrich.suite.optimize: wrote {args.plot}", file=err)
  return 0


if __name__ == "__main__":
  sys.exit(main())
