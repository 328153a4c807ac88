#!/usr/bin/env python3
"""MJX baseline of `ostrich synth`: time per gradient iteration of the control-synthesis
task on the wheeled robot, batched over W worlds, with reverse-mode jax.grad through MJX.

The task, spline and loss are those of plugin/cli/ost_cli_synth.c (see its header comment):
  scene    mjcf_models/robot_box.xml at its opt.timestep h = 2 ms, 3000 steps over T = 6 s
  task     start x, y ~ U(-0.2, 0.2), yaw ~ U(-0.2, 0.2); target x = 3, y ~ U(-0.3, 0.3),
           heading ~ U(-0.3, 0.3); one random task per world (numpy RNG, --seed)
  controls K = 10 knots per actuator at t_j = j T / (K - 1); step k's control is the
           piecewise-linear spline at its midpoint (k + 1/2) h
  loss     10 |p_S - p*|^2 + 2 wrap(psi_S - psi*)^2 + 5 |v_S|^2 + 1 w_S^2
           + 2 * 0.1 * sum_{s=1..S} dist(p_s, start-target segment)^2   (every 0.1 s = 50 steps)
           + 1e-3 sum kappa^2 + 1e-2 sum (kappa_{j+1} - kappa_j)^2
  gradient jax.grad of the whole rollout: lax.scan over segments, each segment a
           jax.checkpoint'ed lax.scan of --segment steps; vmap over worlds
  update   one Adam step per iteration (lr 0.3, betas 0.9, 0.999), knots clipped to ctrlrange
Scene change (MJX has no cylinder-box collider): see build_model() and README.md.
One JSON line per world count on stdout; progress on stderr.
"""
import argparse
import contextlib
import csv
import json
import math
import os
import statistics
import sys
import time

import numpy as np

# Task constants, as in plugin/cli/ost_cli_synth.c
NKNOT, HORIZON, DT = 10, 6.0, 0.1
TARGET_X, START_XY, START_YAW, TARGET_Y, TARGET_HEAD = 3.0, 0.2, 0.2, 0.3, 0.3
INIT_KNOT = 1.5
W_POS, W_HEAD, W_VEL, W_YAW, W_TRACK, W_MAG, W_SMOOTH = 10.0, 2.0, 5.0, 1.0, 2.0, 1e-3, 1e-2
LR, B1, B2, ADAM_EPS = 0.3, 0.9, 0.999, 1e-8
# Sides of the wheel's prism proxy for the box contacts. Measured against MuJoCo's C collider on
# 1200 random wheel-box poses: 20 sides (MJX's hull-face vertex cap) gave 151 bogus contacts up to
# 15 cm deep (MJX's SAT; robots blew up to NaN); 12-19 sides gave 0-4, at most 1.7 cm; 18 gave 0
# (and 4 of 4500 on a second sample, <= 1.7 cm). Faceting: +-2.7 mm at 18 sides.
PRISM_SIDES = 18
_COS = math.cos(math.pi / PRISM_SIDES)
SCENE_CHANGE = (
    "MJX (JAX impl) has no cylinder-box collider, so the wheel-box contacts use a proxy: each "
    f"wheel body gets a massless convex {PRISM_SIDES}-gon prism mesh (the wheel's size and pose, "
    "vertex radius 2r/(1+cos(pi/%d)), so its faces are within +-%.1f mm of the 0.35 m rim) that "
    "collides with the box only, while the wheel cylinder keeps colliding with the floor (MJX "
    "plane-cylinder). Contact bits: box contype/conaffinity 1 -> 2, chassis conaffinity 1 -> 3, "
    "proxy 0/2; floor, cylinders and every other pair as in robot_box.xml. Masses and inertias "
    "unchanged (wheel inertials copied from the original compile)."
    % (PRISM_SIDES, 350 * (1 - _COS) / (1 + _COS)))


def parse_args():
  p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  p.add_argument("--worlds", default="1,8,64", help="comma-separated world counts (sweep)")
  p.add_argument("--iters", type=int, default=3, help="timed Adam iterations per world count")
  p.add_argument("--warmup", type=int, default=1,
                 help="untimed runs of the compiled iteration before the timed ones (default 1)")
  p.add_argument("--steps", type=int, default=None,
                 help="steps per rollout, a multiple of 50 (default: the 6 s horizon, 3000)")
  p.add_argument("--segment", type=int, default=50, help="steps per checkpointed segment")
  p.add_argument("--seed", type=int, default=1)
  p.add_argument("--csv", help="also write the per-world-count records to this CSV file")
  p.add_argument("--platform", choices=["cpu", "gpu"], help="JAX platform (default: JAX's)")
  p.add_argument("--iterations", type=int, default=10, help="Newton iterations (opt.iterations)")
  p.add_argument("--ls-iterations", type=int, default=6, help="line-search iterations")
  p.add_argument("--x64", action="store_true", help="float64 (default float32, as MJX users)")
  p.add_argument("--model", default=None, help="MJCF (default mjcf_models/robot_box.xml)")
  p.add_argument("--check-grad", action="store_true",
                 help="compare jax.grad with central differences on a short horizon, in float64 "
                      "(float32 differences of a 100-step contact rollout are noise); exit")
  p.add_argument("--check-steps", type=int, default=100, help="horizon of --check-grad")
  p.add_argument("--check-eps", type=float, default=1e-3, help="difference step (rad/s)")
  a = p.parse_args()
  a.worlds = [int(w) for w in a.worlds.split(",")]
  a.x64 = a.x64 or a.check_grad
  return a


ARGS = parse_args()
# Platform and precision must be chosen before JAX creates any array.
if ARGS.platform:
  os.environ["JAX_PLATFORMS"] = {"cpu": "cpu", "gpu": "cuda"}[ARGS.platform]
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
jax.config.update("jax_enable_x64", ARGS.x64)
import mujoco  # noqa: E402
with contextlib.redirect_stdout(sys.stderr):  # mjx prints "Failed to import warp" on stdout
  from mujoco import mjx  # noqa: E402
  from mujoco.mjx._src import solver as mjx_solver  # noqa: E402


def log(*a):
  print(*a, file=sys.stderr, flush=True)


# MJX (through at least 3.17) runs its outer Newton loop in lax.while_loop, which jax.grad cannot
# reverse (google-deepmind/mujoco#2259). Run exactly that loop as a fixed-length lax.scan of
# opt.iterations (MJX's own _while_loop_scan, already used for its line search; converged
# iterations become no-ops), as upstream PR #3264 does. Only the solver's own loop is redirected.
_orig_solve, _while_loop = mjx_solver.solve, jax.lax.while_loop


def _solve_scan(m, d):
  def loop(cond, body, init):
    if getattr(body, "__qualname__", "") == "solve.<locals>.body":
      return mjx_solver._while_loop_scan(cond, body, init, m.opt.iterations)
    return _while_loop(cond, body, init)
  jax.lax.while_loop = loop
  try:
    return _orig_solve(m, d)
  finally:
    jax.lax.while_loop = _while_loop


mjx_solver.solve = _solve_scan


def build_model(path):
  """robot_box.xml with the wheel-box contacts on a prism proxy (SCENE_CHANGE)."""
  m0 = mujoco.MjModel.from_xml_path(path)
  spec = mujoco.MjSpec.from_file(path)
  n, c = PRISM_SIDES, math.cos(math.pi / PRISM_SIDES)
  box = floor = None
  meshes = set()
  for g in list(spec.geoms):
    if g.type == mujoco.mjtGeom.mjGEOM_BOX and g.parent.name == "world":
      box = g                                 # the obstacle
    elif g.type == mujoco.mjtGeom.mjGEOM_PLANE:
      floor = g
    elif g.type == mujoco.mjtGeom.mjGEOM_BOX:
      g.conaffinity = 3                       # the chassis: floor (bit 1) and box (bit 2)
    elif g.type == mujoco.mjtGeom.mjGEOM_CYLINDER:
      r, hl = g.size[0], g.size[1]
      rv = 2 * r / (1 + c)                    # faces within +-r(1-c)/(1+c) of the rim
      mesh = f"wheel_prism_{r:g}_{hl:g}"      # one mesh per wheel size: one MJX collision group
      if mesh not in meshes:
        vert = [(rv * math.cos(2 * math.pi * i / n), rv * math.sin(2 * math.pi * i / n), z)
                for z in (-hl, hl) for i in range(n)]
        spec.add_mesh(name=mesh, uservert=np.ravel(vert).tolist())
        meshes.add(mesh)
      gi = m0.geom(g.name).id
      body = g.parent
      body.add_geom(name=g.name + "_prism", type=mujoco.mjtGeom.mjGEOM_MESH,
                    meshname=mesh, pos=m0.geom_pos[gi], quat=m0.geom_quat[gi],
                    contype=0, conaffinity=2, mass=0, rgba=[0, 0, 0, 0])
      bi = m0.body(body.name).id              # keep the cylinder's compiled inertia exactly
      body.explicitinertial = True
      body.mass, body.ipos = m0.body_mass[bi], m0.body_ipos[bi]
      body.iquat, body.inertia = m0.body_iquat[bi], m0.body_inertia[bi]
  assert box is not None and floor is not None and floor.contype == 1
  box.contype, box.conaffinity = 2, 2         # the box: chassis and prisms only
  m = spec.compile()
  for f in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "actuator_gainprm",
            "actuator_biasprm", "actuator_ctrlrange", "qpos0", "geom_friction", "geom_solref",
            "geom_solimp", "body_invweight0", "dof_invweight0"):
    a, b = getattr(m0, f), getattr(m, f)
    b = b[: a.shape[0]]
    assert np.allclose(a, b, rtol=1e-12, atol=1e-12), f  # dynamics unchanged but for contacts
  return m


def make_tasks(seed, w):
  """(w, 6): start x, y, yaw; target x, y, heading (per world, drawn in the C program's order)."""
  rng = np.random.default_rng(seed)
  t = np.zeros((w, 6))
  for i in range(w):
    sx, sy = rng.uniform(-START_XY, START_XY), rng.uniform(-START_XY, START_XY)
    syaw = rng.uniform(-START_YAW, START_YAW)
    ty, thead = rng.uniform(-TARGET_Y, TARGET_Y), rng.uniform(-TARGET_HEAD, TARGET_HEAD)
    t[i] = (sx, sy, syaw, TARGET_X, ty, thead)
  return t


def spline_matrix(steps, h):
  """(steps, K): row k holds the weights (1 - a, a) of knots j, j+1 at the step's midpoint."""
  spacing = steps * h / (NKNOT - 1)
  w = np.zeros((steps, NKNOT))
  for k in range(steps):
    t = (k + 0.5) * h / spacing
    j = min(max(int(math.floor(t)), 0), NKNOT - 2)
    w[k, j], w[k, j + 1] = 1 - (t - j), t - j
  return w


def wrap(a):
  """Angle wrapped to (-pi, pi] (derivative 1)."""
  return a - 2 * jnp.pi * jnp.ceil((a - jnp.pi) / (2 * jnp.pi))


def make_loss(mx, steps, segment, h):
  """world_loss(knots (nu, K), task (6,)) -> loss of one world's rollout and knots."""
  nsub = int(round(DT / h))
  if abs(nsub * h - DT) > 1e-9 or steps % nsub or steps % segment:
    sys.exit(f"--steps {steps} must be a multiple of {nsub} (0.1 s) and of --segment {segment}")
  wmat = jnp.asarray(spline_matrix(steps, h))
  d0 = mjx.make_data(mx)
  nu = mx.nu

  def step(d, u):
    d = mjx.step(mx, d.replace(ctrl=u))
    return d, d.qpos[:2]                      # chassis xy after every step (tracking samples)

  @jax.checkpoint                             # the backward pass recomputes a segment's steps
  def run_segment(d, us):
    return jax.lax.scan(step, d, us)

  def world_loss(knots, task):
    # start: the chassis at (x, y, qpos0 z) with the task's yaw, everything else at rest
    half = 0.5 * task[2]
    qpos = d0.qpos.at[0].set(task[0]).at[1].set(task[1])
    zero = jnp.zeros_like(half)
    qpos = qpos.at[3:7].set(jnp.stack([jnp.cos(half), zero, zero, jnp.sin(half)]))
    ctrl = (wmat @ knots.T).reshape(steps // segment, segment, nu)
    d, xy = jax.lax.scan(run_segment, d0.replace(qpos=qpos), ctrl)
    ps = xy.reshape(steps, 2)[nsub - 1::nsub]  # p_s, s = 1..S (every 0.1 s)

    # tracking: squared distance from the start-target segment
    a, b = task[0:2], task[3:5]
    ab = b - a
    t = jnp.clip(((ps - a) @ ab) / jnp.maximum(ab @ ab, 1e-30), 0.0, 1.0)
    loss = W_TRACK * DT * jnp.sum((ps - a - t[:, None] * ab) ** 2)
    # final position, heading psi = atan2(R10, R00), velocity and yaw rate (qvel 0..2, 5)
    q, v = d.qpos, d.qvel
    w_, x_, y_, z_ = q[3], q[4], q[5], q[6]
    psi = jnp.arctan2(2 * (x_ * y_ + w_ * z_), 1 - 2 * (y_ * y_ + z_ * z_))
    loss += W_POS * jnp.sum((q[0:2] - b) ** 2) + W_HEAD * wrap(psi - task[5]) ** 2
    loss += W_VEL * jnp.sum(v[0:3] ** 2) + W_YAW * v[5] ** 2
    # regularizers, per actuator
    loss += W_MAG * jnp.sum(knots ** 2) + W_SMOOTH * jnp.sum(jnp.diff(knots, axis=1) ** 2)
    return loss

  return world_loss


def peak_bytes():
  try:
    s = jax.devices()[0].memory_stats()
    return int(s["peak_bytes_in_use"]) if s and "peak_bytes_in_use" in s else None
  except Exception:  # noqa: BLE001 (backends without memory stats)
    return None


def is_oom(e):
  s = str(e)
  return "RESOURCE_EXHAUSTED" in s or "out of memory" in s.lower()


def null_nan(v):
  """JSON has no NaN: a non-finite float becomes null."""
  return None if isinstance(v, float) and not math.isfinite(v) else v


def check_grad(m, args):
  """jax.grad against central differences of the loss for two knots, one world."""
  h = m.opt.timestep
  mx = mjx.put_model(m, impl="jax")
  seg = 20 if args.check_steps % 20 == 0 else args.check_steps
  world_loss = make_loss(mx, args.check_steps, seg, h)
  task = jnp.asarray(make_tasks(args.seed, 1)[0])
  knots = np.full((m.nu, NKNOT), INIT_KNOT)
  knots[:, -1] = 0.0
  knots[:, 3] += np.array([0.3, -0.2, 0.1])[: m.nu]   # away from the symmetric start
  eps = args.check_eps
  picks = [(0, 3), (m.nu - 1, 6)]
  batch = [knots]                             # world 0: the gradient; then knot -+ eps
  for (i, j) in picks:
    for s in (1, -1):
      k = knots.copy()
      k[i, j] += s * eps
      batch.append(k)
  t0 = time.perf_counter()                    # one compiled function for all (mostly compile)
  loss, g = jax.jit(jax.vmap(jax.value_and_grad(world_loss), in_axes=(0, None)))(
      jnp.asarray(np.stack(batch)), task)
  loss, g = np.asarray(loss), np.asarray(g[0])
  out = []
  for n, (i, j) in enumerate(picks):
    fd = (loss[1 + 2 * n] - loss[2 + 2 * n]) / (2 * eps)
    out.append({"actuator": i, "knot": j, "ad": float(g[i, j]), "fd": float(fd),
                "rel_err": float(abs(g[i, j] - fd) / max(abs(fd), 1e-12))})
  rec = {"check": "grad", "steps": args.check_steps, "segment": seg, "eps": eps,
         "dtype": "float64" if args.x64 else "float32", "loss": float(loss[0]),
         "grad_finite": bool(np.all(np.isfinite(g))), "knots": out,
         "max_rel_err": max(o["rel_err"] for o in out), "ok": max(o["rel_err"] for o in out) < 0.05,
         "seconds": time.perf_counter() - t0}
  print(json.dumps(rec), flush=True)


def main():
  args = ARGS
  here = os.path.dirname(os.path.abspath(__file__))
  path = args.model or os.path.join(here, "..", "..", "mjcf_models", "robot_box.xml")
  m = build_model(path)
  m.opt.iterations, m.opt.ls_iterations = args.iterations, args.ls_iterations
  h = m.opt.timestep
  args.steps = args.steps or int(round(HORIZON / h))
  lo, hi = -np.inf, np.inf                    # knot bounds: ctrlrange, per actuator
  if m.actuator_ctrllimited[0]:
    lo, hi = m.actuator_ctrlrange[:, 0:1], m.actuator_ctrlrange[:, 1:2]
  dev = jax.devices()[0]
  log(f"scene change: {SCENE_CHANGE}")
  log(f"mujoco {mujoco.__version__}, jax {jax.__version__}, device {dev.device_kind} "
      f"({dev.platform}); h = {h} s, steps {args.steps}, segment {args.segment}, "
      f"Newton iterations {m.opt.iterations}, ls_iterations {m.opt.ls_iterations}")
  if args.check_grad:
    check_grad(m, args)
    return

  mx = mjx.put_model(m, impl="jax")
  world_loss = make_loss(mx, args.steps, args.segment, h)
  value_and_grad = jax.vmap(jax.value_and_grad(world_loss))
  lo_j, hi_j = jnp.asarray(lo, dtype=float), jnp.asarray(hi, dtype=float)

  @jax.jit
  def iteration(knots, mom, var, t, tasks):
    """One Adam step of every world: (knots, moments, t) -> next, with the loss and finiteness."""
    loss, g = value_and_grad(knots, tasks)
    t = t + 1
    mom = B1 * mom + (1 - B1) * g
    var = B2 * var + (1 - B2) * g * g
    step = LR * (mom / (1 - B1 ** t)) / (jnp.sqrt(var / (1 - B2 ** t)) + ADAM_EPS)
    knots = jnp.clip(knots - step, lo_j, hi_j)
    finite = jnp.isfinite(loss) & jnp.all(jnp.isfinite(g), axis=(1, 2))   # per world
    return knots, mom, var, t, loss, finite

  common = {"mujoco": mujoco.__version__, "jax": jax.__version__, "device": dev.device_kind,
            "platform": dev.platform, "steps": args.steps, "h": h, "segment": args.segment,
            "iterations": m.opt.iterations, "ls_iterations": m.opt.ls_iterations,
            "dtype": "float64" if args.x64 else "float32", "seed": args.seed}
  records = []
  for w in args.worlds:
    rec = {"worlds": w, "status": "ok"}
    try:
      knots0 = np.full((w, m.nu, NKNOT), INIT_KNOT)
      knots0[:, :, -1] = 0.0                  # the last knot: a stop
      knots0 = np.clip(knots0, lo, hi)
      state = (jnp.asarray(knots0), jnp.zeros(knots0.shape), jnp.zeros(knots0.shape),
               jnp.asarray(0.0))
      tasks = jnp.asarray(make_tasks(args.seed, w))
      log(f"[{w} worlds] compiling ...")
      t0 = time.perf_counter()
      compiled = iteration.lower(*state, tasks).compile()
      rec["compile_s"] = time.perf_counter() - t0
      try:
        ma = compiled.memory_analysis()
        rec["xla_temp_bytes"] = int(ma.temp_size_in_bytes)
      except Exception:  # noqa: BLE001 (not every backend reports it)
        rec["xla_temp_bytes"] = None
      t0 = time.perf_counter()                # warm-up runs, their updates discarded
      for _ in range(args.warmup):
        jax.block_until_ready(compiled(*state, tasks))
      rec["warmup_s"] = time.perf_counter() - t0
      times, losses, finite = [], [], np.ones(w, bool)
      for i in range(args.iters):
        t0 = time.perf_counter()
        out = jax.block_until_ready(compiled(*state, tasks))
        times.append(time.perf_counter() - t0)
        state = out[:4]
        loss = np.asarray(out[4])
        ok = np.isfinite(loss)                # mean over the worlds whose loss is finite
        losses.append(float(loss[ok].mean()) if ok.any() else math.nan)
        finite &= np.asarray(out[5])
        log(f"[{w} worlds] iter {i + 1}/{args.iters}: {times[-1]:.3f} s, "
            f"mean finite loss {losses[-1]:.4f}, worlds with a finite loss and gradient "
            f"{int(np.sum(np.asarray(out[5])))}/{w}")
      med = statistics.median(times)
      rec.update({"median_iter_s": med, "min_iter_s": min(times),
                  "world_iters_per_s": w / med, "world_steps_per_s": w * args.steps / med,
                  "peak_bytes": peak_bytes(), "loss_first": losses[0], "loss_last": losses[-1],
                  "grad_finite": bool(finite.all()), "nonfinite_worlds": int(np.sum(~finite))})
    except Exception as e:  # noqa: BLE001
      if not is_oom(e):
        raise
      rec.update({"status": "OOM", "peak_bytes": peak_bytes(),
                  "error": str(e).split("\n")[0][:300]})
      log(f"[{w} worlds] out of memory; the sweep stops here")
    rec.update(common)
    records.append(rec)
    print(json.dumps({k: null_nan(v) for k, v in rec.items()}), flush=True)
    if rec["status"] != "ok":
      break

  log("\nworlds  status  compile_s  median_iter_s  world_iters/s  peak_MiB  loss_first -> last")
  for r in records:
    pk = r.get("peak_bytes")
    nan = float("nan")
    log(f"{r['worlds']:6d}  {r['status']:6s}  {r.get('compile_s', nan):9.1f}  "
        f"{r.get('median_iter_s', nan):13.3f}  {r.get('world_iters_per_s', nan):13.2f}  "
        f"{'-' if pk is None else f'{pk / 2**20:8.0f}':>8s}  "
        f"{r.get('loss_first', nan):.4f} -> {r.get('loss_last', nan):.4f}")
  if args.csv:
    fields = []
    for r in records:
      fields += [k for k in r if k not in fields]
    with open(args.csv, "w", newline="") as f:
      wr = csv.DictWriter(f, fieldnames=fields)
      wr.writeheader()
      for r in records:
        wr.writerow(r)


if __name__ == "__main__":
  main()
