"""CUDA batches from Python equal CPU batches bit for bit: states, unconverged flags and
gradients (parameters' included), on the cart-pole, the robot over the box (contacts) and
an arm pushing a box through actuators with activation dynamics (activations included). A
script, not a pytest module (the GPU machine has no pytest): ctest runs it as test_python_gpu (label gpu) in CUDA builds;
by hand: PYTHONPATH=BUILD/python OSTRICH_MODEL_DIR=mjcf_models python3 THIS [NWORLD]. Exit
status 0 when every array is equal, 1 otherwise (each difference printed)."""

import os
import sys

import numpy as np

import ostrich

MODEL_DIR = os.environ.get("OSTRICH_MODEL_DIR") or os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "mjcf_models")


def check(name, nworld, steps, scale, seed=0):
  """Differences (name, max |cpu - cuda|) of one model's rollout and backward pass."""
  physics = ostrich.Physics.from_xml_path(os.path.join(MODEL_DIR, name))
  rng = np.random.default_rng(seed)
  actions = rng.uniform(-scale, scale, (steps, nworld, physics.nu))
  qvel0 = rng.uniform(-0.1, 0.1, (nworld, physics.nv))
  act0 = rng.uniform(0, 0.5, (nworld, physics.na))
  out = {}
  for device in ("cpu:1", "cuda"):
    batch = ostrich.Batch(physics, nworld, device)
    traj = batch.rollout(actions, None, qvel0, act0=act0)
    crng = np.random.default_rng(seed + 1)
    cot_qpos = crng.uniform(-1, 1, traj.qpos.shape)
    cot_qvel = crng.uniform(-1, 1, traj.qvel.shape)
    grads = traj.backward(cot_qpos, cot_qvel, strict=False, params=True)
    out[device] = (traj.qpos, traj.qvel, traj.act, traj.unconverged, grads.qpos, grads.qvel,
                   grads.ctrl, grads.theta)
  labels = ("qpos", "qvel", "act", "unconverged", "grad qpos0", "grad qvel0", "grad ctrl",
            "grad theta")
  diffs = []
  for label, a, b in zip(labels, out["cpu:1"], out["cuda"]):
    a, b = np.asarray(a, float), np.asarray(b, float)
    same = np.array_equal(a, b, equal_nan=True)
    diffs.append((label, same, float(np.nanmax(np.abs(a - b))) if a.size else 0.0))
  return diffs


def main(argv):
  nworld = int(argv[1]) if len(argv) > 1 else 512
  bad = 0
  # controls: the cart-pole's force in [-0.5, 0.5], the robot's wheel speeds in [-3, 3] rad/s,
  # the pusher's in [-1, 1] (clamped to each actuator's range)
  for name, steps, scale in (("cartpole.xml", 40, 0.5), ("robot_box.xml", 20, 3.0),
                             ("../tests/models/activation_pusher.xml", 20, 1.0)):
    for label, same, diff in check(name, nworld, steps, scale):
      print(f"{os.path.basename(name):21s} {nworld} worlds  {label:12s} {'equal' if same else 'DIFFERENT'}"
            f"  max diff {diff:.3g}")
      bad += not same
  print("cuda = cpu bit for bit" if not bad else f"{bad} arrays differ")
  return 1 if bad else 0


if __name__ == "__main__":
  sys.exit(main(sys.argv))
