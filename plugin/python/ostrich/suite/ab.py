"""A/B of the suite's tasks: the mean episode return of a seeded random policy on stock MuJoCo and
on Ostrich at the suite's physics step, and on Ostrich at larger physics steps.

  python3 -m ostrich.suite.ab [--task cartpole-balance,...] [--seeds 3] [--steps N]
      [--factors 1,2,4,5,10] [--csv FILE]

The policy draws every action uniformly inside the action spec from RandomState(1000 + seed);
the task's start state comes from its own seed (the same on both engines). A factor k runs
Ostrich at k times the suite's physics step where the control step is a whole multiple of it
(walker: 10 steps of 2.5 ms per action, so k = 2, 5, 10; hopper: 4 of 5 ms, k = 2, 4; finger:
2 of 10 ms, k = 2); elsewhere the physics step is the control step, and a larger step would
change the task (the table says so). Each cell: mean return over the seeds, its spread (the
standard deviation over seeds), simulated seconds per wall second (×), and "bad": unconverged
Ostrich steps or MuJoCo warnings.
The table goes to stdout; --csv writes one row per (task, engine, factor, seed), atomically.
"""

import argparse
import csv
import io
import sys
import time
import warnings

import numpy as np

from ..errors import MujocoWarning, NotConvergedWarning
from . import load, TASKS
from .optimize import SetupError, check_outputs_and_data, parse_tasks, write_atomic

CSV_FIELDS = ("task", "engine", "factor", "physics_timestep", "seed", "return", "wall_s",
              "engine_steps", "unconverged", "mujoco_warnings")


def episode(domain, task, engine, seed, factor=1, steps=None, xml_dir=None):
  """One random-policy episode: dict of CSV_FIELDS."""
  base = load(domain, task, xml_dir=xml_dir, seed=seed)
  dt = base.physics.timestep * factor
  env = load(domain, task, xml_dir=xml_dir, seed=seed, engine=engine,
             physics_timestep=dt if factor != 1 else None)
  spec, rng = env.action_spec(), np.random.RandomState(1000 + seed)
  steps = int(steps or round(env.step_limit))
  total = 0.0
  with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always", NotConvergedWarning)
    warnings.simplefilter("always", MujocoWarning)
    timestep = env.reset()
    t0 = time.perf_counter()
    for _ in range(steps):
      timestep = env.step(rng.uniform(spec.minimum, spec.maximum))
      total += timestep.reward
    wall = time.perf_counter() - t0
  return {"task": f"{domain}-{task}", "engine": engine, "factor": factor,
          "physics_timestep": env.physics.timestep, "seed": seed, "return": total,
          "wall_s": wall, "engine_steps": steps * env.n_sub_steps,
          "unconverged": sum(issubclass(w.category, NotConvergedWarning) for w in caught),
          "mujoco_warnings": sum(issubclass(w.category, MujocoWarning) for w in caught)}


def factors_of(domain, task, factors, xml_dir=None):
  """The factors that keep the control step a whole multiple of the physics step."""
  env = load(domain, task, xml_dir=xml_dir, seed=0)
  n = env.n_sub_steps
  return [k for k in factors if k == 1 or (k <= n and n % k == 0)]


def table(rows, factors):
  """Markdown: one line per task, columns MuJoCo, Ostrich at each factor."""
  head = ["task", "MuJoCo (h)"] + [f"Ostrich ({k} h)" for k in factors]
  out = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
  for name in dict.fromkeys(r["task"] for r in rows):
    cells = [name]
    for engine, k in [("mujoco", 1)] + [("ostrich", k) for k in factors]:
      sel = [r for r in rows if r["task"] == name and r["engine"] == engine and r["factor"] == k]
      if not sel:
        cells.append("—")
        continue
      ret = np.array([r["return"] for r in sel])
      sim = sum(r["engine_steps"] * r["physics_timestep"] for r in sel)
      rate = sim / max(sum(r["wall_s"] for r in sel), 1e-12)
      bad = sum(r["unconverged"] + r["mujoco_warnings"] for r in sel)
      cells.append(f"{ret.mean():.1f} ± {ret.std():.1f} ({rate:,.1f}×"
                   + (f", {bad} bad" if bad else "") + ")")
    out.append("| " + " | ".join(cells) + " |")
  return "\n".join(out)


def parse(argv):
  ap = argparse.ArgumentParser(prog="python3 -m ostrich.suite.ab", description=__doc__.split(
      "\n\n")[0])
  ap.add_argument("--task", default=",".join(f"{d}-{t}" for d, t in TASKS),
                  help="DOMAIN-TASK, comma-separated (default: every task)")
  ap.add_argument("--seeds", type=int, default=3, help="episodes per cell (default 3)")
  ap.add_argument("--steps", type=int, help="control steps per episode (default: the task's)")
  ap.add_argument("--factors", default="1,2,4,5,10",
                  help="Ostrich's physics step in suite steps, where the control step allows")
  ap.add_argument("--xml-dir", help="dm_control's suite MJCF folder (default: as ostrich.suite)")
  ap.add_argument("--csv", help="one row per episode")
  return ap.parse_args(argv)


def main(argv=None, out=None, err=None):
  out, err = out or sys.stdout, err or sys.stderr
  args = parse(argv)
  try:
    tasks = parse_tasks(args.task, tuple(TASKS))
    try:
      factors = sorted({int(k) for k in args.factors.split(",") if k.strip()})
    except ValueError:
      raise SetupError(f"--factors {args.factors!r}: not integers") from None
    if not factors or factors[0] < 1 or args.seeds < 1 or (args.steps is not None
                                                            and args.steps < 1):
      raise SetupError("--factors, --seeds and --steps must be positive")
    check_outputs_and_data(args)
  except SetupError as e:
    print(f"ostrich.suite.ab: {e}", file=err)
    return 2
  rows = []
  for domain, task in tasks:
    runs = [("mujoco", 1)] + [("ostrich", k) for k in factors_of(domain, task, factors,
                                                                   args.xml_dir)]
    for engine, k in runs:
      for seed in range(args.seeds):
        rows.append(episode(domain, task, engine, seed, k, args.steps, args.xml_dir))
        r = rows[-1]
        print(f"[{r['task']} {engine} {k} h seed {seed}] return {r['return']:.2f}  wall "
              f"{r['wall_s']:.2f} s  unconverged {r['unconverged']}", file=err, flush=True)
  print(table(rows, factors), file=out)
  if args.csv:
    text = io.StringIO()
    w = csv.DictWriter(text, CSV_FIELDS, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    write_atomic(args.csv, text.getvalue())
    print(f"ostrich.suite.ab: wrote {args.csv}", file=err)
  return 0


if __name__ == "__main__":
  sys.exit(main())
