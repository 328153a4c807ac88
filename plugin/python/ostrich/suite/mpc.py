"""Model-predictive control on the suite's tasks: whole episodes, re-planned at every control step,
with Ostrich's adjoint gradients, with the same optimizer fed by finite differences of stock
MuJoCo, and with a sampling planner (MPPI) on Ostrich batches.

  python3 -m ostrich.suite.mpc --task cartpole-swingup[,pendulum-swingup,...]
      [--methods adjoint,fd,fdjac,mppi] [--iters 1,2,5] [--samples 16,64] [--horizon N]
      [--steps N] [--control-cost C] [--seed S] [--csv FILE] [--plot FILE.png]

The plant is the task's dm_env Environment on Ostrich (dm_control's XML, start state, reward,
control timestep and episode length). At every control step the planner starts from the plant's
state, optimizes the next H actions (default: 1 s of control steps) warm-started by its previous
plan shifted one step, and the plant plays the first action. The episode's return is the sum of
the task's own rewards. Planners maximize

  J(A) = sum_k f(qpos_k+1, qvel_k+1, a_k) - C |a_k|^2

with f the objective of ostrich.suite.optimize (the task's reward_fn, or its documented smooth
surrogate where the reward is sparse) and C = --control-cost (default 1e-2). C keeps actions
off saturation: at a hard joint limit (the reacher's wrist) a torque pushing into the limit
moves nothing, so its gradient is exactly 0 and a gradient planner cannot pull it back without
C (measured: the reacher held its wrist at the limit 3 cm from the target, return 0).

  adjoint  K Adam steps per control step on dJ/dA from ostrich.rollout(...).backward(...).
  fd       the same K Adam steps on dJ/dA by forward differences of stock MuJoCo rollouts from
           the plant's state (ostrich.suite.optimize.Problem.fd_objective_and_gradient).
  fdjac    the same K Adam steps on dJ/dA through stock MuJoCo's finite-difference step
           Jacobians chained backward (Problem.fdjac_objective_and_gradient): the iLQR-style
           baseline, cheaper than fd for horizons of more than a few steps.
  mppi     model-predictive path integral control: N sampled action sequences around the plan
           (one Ostrich Batch rollout on one thread) averaged with weights exp((J_i - max J) /
           (0.1 (max J - mean J))).

Each (method, K or N) is one episode: one point of return against the planners' own wall time
(the plant's steps are not counted), drawn by --plot. An iteration whose rollout does not
converge (Ostrich) or is not finite (MuJoCo) is not used: the plan stays, and the `bad` column
counts it; the plant's own unconverged steps are counted there too.
"""

import argparse
import collections
import csv
import io
import math
import sys
import time
import warnings

import numpy as np

from ..errors import NotConvergedWarning, OstrichError
from . import load
from .optimize import (Adam, Problem, SetupError, SUPPORTED, Unconverged,
                       check_outputs_and_data, draw_png, parse_methods, parse_tasks,
                       write_atomic)

METHODS = ("adjoint", "fd", "fdjac", "mppi")
ADAM_LR = 0.1          # Adam's step in action units (the suite's actions lie in [-1, 1])
CONTROL_COST = 1e-2    # C: per step, against rewards in [0, 1]
MPPI_STD = 0.3         # MPPI's sampling spread, in half-ranges of the action spec

Episode = collections.namedtuple(
    "Episode", "task method setting ret plan_s steps iterations bad plant_unconverged")


class Planner:
  """One task's receding-horizon problem: a Problem (optimize.py) whose start state is moved to
  the plant's state before each plan, and whose objective carries the control cost."""

  def __init__(self, domain, task, horizon=None, seed=0, xml_dir=None,
               control_cost=CONTROL_COST, physics_timestep=None, device="cpu:1"):
    env = load(domain, task, xml_dir=xml_dir, seed=seed, physics_timestep=physics_timestep)
    if horizon is None:  # 1 s of control steps: a swing, a reach, a stride
      horizon = max(1, int(round(1.0 / env.control_timestep())))
    self.problem = Problem(domain, task, horizon, seed, xml_dir, physics_timestep)
    self.problem.device = self.device = device  # MPPI's batches
    f, c = self.problem.f, float(control_cost)
    self.problem.f = lambda qpos, qvel, ctrl: f(qpos, qvel, ctrl) - c * np.sum(ctrl ** 2, -1)
    self.horizon, self.nu = self.problem.horizon, self.problem.nu
    self.domain, self.task, self.seed, self.xml_dir = domain, task, seed, xml_dir
    self.physics_timestep = physics_timestep

  def set_start(self, qpos, qvel):
    self.problem.qpos0, self.problem.qvel0 = qpos.copy(), qvel.copy()


def _shift(x):
  """A plan (or optimizer moment) one control step later: drop the first row, repeat the last."""
  return np.concatenate([x[1:], x[-1:]])


class GradientMPC:
  """K Adam steps per control step on grad(actions) -> (J, dJ/dA); the plan and Adam's moments
  carry over, shifted, from one control step to the next."""

  def __init__(self, planner, grad, iterations, lr=ADAM_LR):
    self.p, self.grad, self.iterations = planner, grad, iterations
    self.plan = planner.problem.initial_actions()
    self.adam = Adam(self.plan.shape, lr)

  def act(self):
    """(action, bad iterations) for the current start state."""
    bad = 0
    for _ in range(self.iterations):
      try:
        _, g = self.grad(self.plan)
      except Unconverged:
        bad += 1
        continue
      self.plan = self.p.problem.clip(self.adam.ascend(self.plan, g))
    action = self.plan[0].copy()
    self.plan = _shift(self.plan)
    self.adam.m, self.adam.v = _shift(self.adam.m), _shift(self.adam.v)
    return action, bad


class MPPI:
  """N samples around the plan per control step; the weighted mean is the new plan."""

  def __init__(self, planner, samples, rng, std=MPPI_STD):
    self.p, self.n, self.rng = planner, samples, rng
    prob = planner.problem
    self.plan = prob.initial_actions()
    self.std = std * (prob.hi - prob.lo) / 2
    self.batch = prob.batch(samples)

  def act(self):
    prob = self.p.problem
    noise = self.std * self.rng.standard_normal((self.n, prob.horizon, prob.nu))
    noise[0] = 0  # the plan itself is always a candidate
    samples = prob.clip(self.plan + noise)
    J, unconverged = prob.objective_batch(samples, self.batch)
    ok = (np.asarray(unconverged) == 0) & np.isfinite(J)
    bad = int(np.count_nonzero(~ok))
    if ok.any():
      Jok = J[ok]
      # temperature: a tenth of the spread between the best and the mean sample, so the
      # weights do not depend on the objective's scale
      lam = 0.1 * max(Jok.max() - Jok.mean(), 1e-12)
      w = np.exp((Jok - Jok.max()) / lam)
      self.plan = np.tensordot(w / w.sum(), samples[ok], axes=1)
    action = self.plan[0].copy()
    self.plan = _shift(self.plan)
    return action, bad


def run_episode(planner, method, setting, steps=None, err=None):
  """Play one closed-loop episode of `steps` control steps (default: the task's episode) on
  the plant; return its Episode. Progress every 10 % on err."""
  err = err or sys.stderr
  prob = planner.problem
  if method == "adjoint":
    agent = GradientMPC(planner, prob.objective_and_gradient, setting)
  elif method == "fd":
    agent = GradientMPC(planner, prob.fd_objective_and_gradient, setting)
  elif method == "fdjac":
    agent = GradientMPC(planner, prob.fdjac_objective_and_gradient, setting)
  elif method == "mppi":
    agent = MPPI(planner, setting, np.random.RandomState(planner.seed))
  else:
    raise ValueError(method)
  plant = load(planner.domain, planner.task, xml_dir=planner.xml_dir, seed=planner.seed,
               physics_timestep=planner.physics_timestep)
  plant.reset()
  steps = int(steps or round(plant.step_limit))
  name = f"{planner.domain}-{planner.task}"
  total, plan_s, bad, plant_bad = 0.0, 0.0, 0, 0
  with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always", NotConvergedWarning)
    for k in range(steps):
      planner.set_start(plant.physics.data.qpos, plant.physics.data.qvel)
      t0 = time.perf_counter()
      with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotConvergedWarning)  # planners count their own
        action, b = agent.act()
      plan_s += time.perf_counter() - t0
      bad += b
      timestep = plant.step(action)
      total += timestep.reward
      if (k + 1) % max(1, steps // 10) == 0 or k + 1 == steps:
        print(f"[{name} {method} {setting}] step {k + 1:5d}/{steps}  return {total:9.2f}  "
              f"planning {plan_s:8.2f} s  bad {bad}", file=err, flush=True)
      if timestep.last():
        steps = k + 1
        break
    plant_bad = sum(issubclass(w.category, NotConvergedWarning) for w in caught)
  label = method if method != "mppi" or planner.device == "cpu:1" else f"mppi@{planner.device}"
  return Episode(name, label, setting, total, plan_s, steps,
                 setting * steps if method != "mppi" else steps, bad, plant_bad)


# ---- output

CSV_FIELDS = Episode._fields


def csv_text(episodes):
  out = io.StringIO()
  w = csv.writer(out, lineterminator="\n")
  w.writerow(CSV_FIELDS)
  for e in episodes:
    w.writerow((e.task, e.method, e.setting, f"{e.ret:.9g}", f"{e.plan_s:.6f}", e.steps,
                e.iterations, e.bad, e.plant_unconverged))
  return out.getvalue()


REACH = 0.98  # "reached fd's return": within 2 %, the spread of one planner's returns over K


def table(episodes):
  """The Markdown table and, per task, how much less planning time the adjoint needed to come
  within 2 % of fd's best return (REACH: the spread of returns of one planner over K measured
  1 %, from when the swing-up or reach happens to complete)."""
  rows = ["| task | method | K or N | return | planning s | ms per control step | bad |",
          "|---|---|---:|---:|---:|---:|---:|"]
  for e in episodes:
    rows.append(f"| {e.task} | {e.method} | {e.setting} | {e.ret:.1f} | {e.plan_s:.2f} | "
                f"{1e3 * e.plan_s / max(e.steps, 1):.2f} | {e.bad + e.plant_unconverged} |")
  lines = []
  for task in dict.fromkeys(e.task for e in episodes):
    adj = [e for e in episodes if e.task == task and e.method == "adjoint"]
    for name in ("fd", "fdjac"):
      fd = [e for e in episodes if e.task == task and e.method == name]
      if not (adj and fd):
        continue
      best = max(fd, key=lambda e: (e.ret, -e.plan_s))
      target = REACH * best.ret
      reach = [e for e in adj if e.ret >= target]
      if not reach:
        lines.append(f"{task}: no adjoint episode came within 2 % of {name}'s best return "
                     f"{best.ret:.1f}")
        continue
      fast = min(reach, key=lambda e: e.plan_s)
      fd_fast = min((e for e in fd if e.ret >= target), key=lambda e: e.plan_s)
      lines.append(f"{task}: {name}'s best return {best.ret:.1f}; within 2 % of it: {name} K = "
                   f"{fd_fast.setting} in {fd_fast.plan_s:.2f} s of planning, adjoint K = "
                   f"{fast.setting} ({fast.ret:.1f}) in {fast.plan_s:.2f} s: "
                   f"{fd_fast.plan_s / max(fast.plan_s, 1e-9):.1f}x less planning time")
  return "\n".join(rows), "\n".join(lines)


def read_csv(path):
  """The Episodes of a CSV that --csv wrote."""
  with open(path) as f:
    rows = list(csv.DictReader(f))
  return [Episode(r["task"], r["method"], int(r["setting"]), float(r["ret"]),
                  float(r["plan_s"]), int(r["steps"]), int(r["iterations"]), int(r["bad"]),
                  int(r["plant_unconverged"])) for r in rows]


def plot(path, episodes, title=""):
  """Return against planning time, one line per method (its K or N in order), one panel per
  task (optimize.draw_png)."""
  tasks = list(dict.fromkeys(e.task for e in episodes))
  labels = {"adjoint": "Adam, adjoint (Ostrich)", "fd": "Adam, finite differences (MuJoCo)",
            "mppi": "MPPI (Ostrich batch)"}

  def script(data):
    out = ["set datafile separator ','", "set key bottom right", "set grid", "set logscale x",
           "set xlabel 'planning wall time per episode, s'", "set ylabel 'episode return'",
           f"set multiplot layout 1,{len(tasks)} title '{title}'"]
    for task in tasks:
      lines = [f"'{data}' using (strcol(1) eq '{task}' && strcol(2) eq '{m}' ? $5 : "
               f"NaN):4 with linespoints lw 2 pt 7 title '{labels[m]}'"
               for m in METHODS if any(e.task == task and e.method == m for e in episodes)]
      out += [f"set title '{task}'", "plot " + ", ".join(lines)]
    return out + ["unset multiplot"]
  draw_png(path, csv_text(sorted(episodes, key=lambda e: (e.task, e.method, e.plan_s))), script,
           max(640, 560 * len(tasks)))


# ---- command line

def _ints(text, flag):
  try:
    values = [int(v) for v in text.split(",") if v.strip()]
  except ValueError:
    raise SetupError(f"{flag} {text!r}: not a comma-separated list of integers") from None
  if not values or min(values) < 1:
    raise SetupError(f"{flag} {text!r}: need positive integers")
  return values


def parse(argv):
  ap = argparse.ArgumentParser(
      prog="python3 -m ostrich.suite.mpc",
      description="Model-predictive control of dm_control suite tasks on Ostrich: Adam on "
      "Ostrich's adjoint gradients (adjoint), the same Adam on finite differences of stock "
      "MuJoCo rollouts (fd) and through its finite-difference step Jacobians (fdjac), and MPPI "
      "on Ostrich batches (mppi); one whole episode per method and "
      "setting, returns and planning time.")
  ap.add_argument("--task", required=True,
                  help="DOMAIN-TASK, or several separated by commas; one of: "
                  + ", ".join(f"{d}-{t}" for d, t in SUPPORTED))
  ap.add_argument("--methods", default="adjoint,fd,fdjac,mppi", help="comma-separated: "
                  + ",".join(METHODS))
  ap.add_argument("--iters", default="1,2,5",
                  help="Adam steps per control step for adjoint, fd and fdjac, one episode each")
  ap.add_argument("--samples", default="16,64", help="MPPI's samples per control step, one "
                  "episode each")
  ap.add_argument("--horizon", type=int, help="planned control steps (default: 1 s of them)")
  ap.add_argument("--steps", type=int, help="control steps per episode (default: the task's)")
  ap.add_argument("--physics-timestep", type=float,
                  help="Ostrich's step for the plant and the Ostrich planners (default: the "
                  "suite's; the control timestep must be a multiple of it); fd's MuJoCo keeps "
                  "the suite's own")
  ap.add_argument("--control-cost", type=float, default=CONTROL_COST,
                  help=f"C in J = sum f - C |a|^2 (default {CONTROL_COST:g})")
  ap.add_argument("--seed", type=int, default=0, help="the task's start state and MPPI's draws")
  ap.add_argument("--device", default="cpu:1",
                  help="MPPI's batches: cpu:1 (one thread, as the gradient planners; the "
                  "default), cpu:N, cpu (all cores) or cuda; other than cpu:1 its rows are "
                  "labelled mppi@DEVICE")
  ap.add_argument("--xml-dir", help="dm_control's suite MJCF folder (default: as ostrich.suite)")
  ap.add_argument("--csv", help="write one row per episode to this CSV")
  ap.add_argument("--plot", help="draw return against planning time into this PNG (gnuplot)")
  return ap.parse_args(argv)


def setup(args):
  """Check everything that can be checked before work; return tasks, [(method, setting)]."""
  tasks = parse_tasks(args.task, SUPPORTED)
  methods = parse_methods(args.methods, METHODS)
  iters, samples = _ints(args.iters, "--iters"), _ints(args.samples, "--samples")
  runs = [(m, s) for m in methods for s in (samples if m == "mppi" else iters)]
  if args.horizon is not None and args.horizon < 1:
    raise SetupError("--horizon must be at least 1")
  if args.steps is not None and args.steps < 1:
    raise SetupError("--steps must be at least 1")
  if args.physics_timestep is not None and not (math.isfinite(args.physics_timestep)
                                                and args.physics_timestep > 0):
    raise SetupError("--physics-timestep must be positive")
  if not (math.isfinite(args.control_cost) and args.control_cost >= 0):
    raise SetupError("--control-cost must be finite and at least 0")
  check_outputs_and_data(args)
  return tasks, runs


def main(argv=None, out=None, err=None):
  out, err = out or sys.stdout, err or sys.stderr
  args = parse(argv)
  try:
    tasks, runs = setup(args)
    planners = [Planner(d, t, args.horizon, args.seed, args.xml_dir, args.control_cost,
                        args.physics_timestep, args.device) for d, t in tasks]
    if any(m == "mppi" for m, _ in runs):
      try:
        for planner in planners:
          planner.problem.batch(1)  # the device exists and takes each task's model
      except OstrichError as e:
        raise SetupError(f"--device {args.device}: {e}") from None
  except (SetupError, ValueError) as e:
    print(f"ostrich.suite.mpc: {e}", file=err)
    return 2
  episodes = []
  for planner in planners:
    print(f"[{planner.domain}-{planner.task}] horizon {planner.horizon} control steps of "
          f"{planner.problem.n_sub} Ostrich steps, seed "
          f"{args.seed}; objective: {planner.problem.objective_text} - {args.control_cost:g} "
          "|a|^2; plant: Ostrich", file=err, flush=True)
    for method, setting in runs:
      episodes.append(run_episode(planner, method, setting, args.steps, err))
  rows, speed = table(episodes)
  print(rows, file=out)
  if speed:
    print(speed, file=out)
  if args.csv:
    write_atomic(args.csv, csv_text(episodes))
    print(f"ostrich.suite.mpc: wrote {args.csv}", file=err)
  if args.plot:
    plot(args.plot, episodes, "model-predictive control: return against planning time")
    print(f"ostrich.suite.mpc: wrote {args.plot}", file=err)
  return 0


if __name__ == "__main__":
  sys.exit(main())
