"""dm_control's suite tasks as dm_env environments on Ostrich.

  from ostrich import suite
  env = suite.load("cartpole", "balance", seed=0)     # engine="mujoco" for mj_step
  timestep = env.reset()
  while not timestep.last():
    timestep = env.step(np.zeros(env.action_spec().shape))

The models are dm_control's own MJCF files, read unchanged from where they are: `xml_dir`, else
$OSTRICH_DM_SUITE_DIR, else the installed dm_control package's suite/ folder (its wheel installed
with `pip install --no-deps dm_control` is enough: only its files are read, nothing of it is
imported). Each task has dm_control's observation, reward, discount, control timestep and episode
length; the physics timestep may be chosen (physics_timestep) as long as the control timestep is
a multiple of it.
"""

import importlib.util
import os

from .environment import (Array, BoundedArray, Environment, StepType, TimeStep,
                          compute_n_steps)
from .rewards import tolerance
from .tasks import TASKS
from ..physics import Physics

ENGINES = ("ostrich", "mujoco")
# tasks whose reward is also a function of (qpos, qvel, ctrl): Environment.reward_fn(xp), all
REWARD_FNS = tuple(TASKS)

__all__ = ["load", "find_suite_dir", "TASKS", "REWARD_FNS", "Environment", "TimeStep",
           "StepType", "Array", "BoundedArray", "tolerance"]


def find_suite_dir(xml_dir=None):
  """The folder of dm_control's suite MJCF files (cartpole.xml, ..., common/): xml_dir, else
  $OSTRICH_DM_SUITE_DIR, else the installed dm_control package's suite/. FileNotFoundError
  saying where it looked when there is none."""
  tried = []
  candidates = []
  if xml_dir is not None:
    candidates.append(("xml_dir", str(xml_dir)))
  else:
    if os.environ.get("OSTRICH_DM_SUITE_DIR"):
      candidates.append(("OSTRICH_DM_SUITE_DIR", os.environ["OSTRICH_DM_SUITE_DIR"]))
    try:
      spec = importlib.util.find_spec("dm_control")  # locates the package; runs none of it
    except (ImportError, ValueError):
      spec = None
    for location in (spec.submodule_search_locations or []) if spec else []:
      candidates.append(("the dm_control package", os.path.join(location, "suite")))
  for what, path in candidates:
    if os.path.isfile(os.path.join(path, "cartpole.xml")):
      return path
    tried.append(f"{what}: {path}")
  raise FileNotFoundError(
      "dm_control's suite MJCF files were not found (" + ("; ".join(tried) or "no xml_dir, no "
      "$OSTRICH_DM_SUITE_DIR, no dm_control package") + "). Install them with `python3 -m pip "
      "install --no-deps dm_control`, or pass xml_dir= the folder holding cartpole.xml and "
      "common/")


def load(domain, task, xml_dir=None, physics_timestep=None, engine="ostrich", seed=None,
         time_limit=None):
  """The suite task (domain, task) as an Environment.

  xml_dir: the suite's MJCF folder (see find_suite_dir). physics_timestep: the step the engine
  takes (default the model's; Ostrich's option `timestep` or MuJoCo's opt.timestep); the suite's
  control timestep must be a multiple of it. engine: 'ostrich' or 'mujoco'. seed: an int or a
  np.random.RandomState for the task's random initial states. time_limit: seconds per episode
  (default the suite's).
  """
  if (domain, task) not in TASKS:
    known = ", ".join(f"{d} {t}" for d, t in TASKS)
    raise KeyError(f"no suite task {domain!r} {task!r}; tasks: {known}")
  if engine not in ENGINES:
    raise ValueError(f"engine {engine!r}: use 'ostrich' or 'mujoco'")
  task_ = TASKS[domain, task](random=seed)
  path = os.path.join(find_suite_dir(xml_dir), task_.xml)
  physics = Physics.from_xml_path(path)  # includes (common/*.xml) resolve beside the file
  suite_timestep = task_.suite_timestep = physics.model.timestep
  control_timestep = task_.control_timestep or suite_timestep
  if physics_timestep is not None:
    if engine == "ostrich":
      physics.set_options(timestep=float(physics_timestep))
    else:
      physics.model.timestep = float(physics_timestep)
  h = physics.timestep if engine == "ostrich" else physics.model.timestep
  n_sub_steps = compute_n_steps(control_timestep, h)
  return Environment(physics, task_, engine, n_sub_steps, control_timestep,
                     task_.time_limit if time_limit is None else float(time_limit))
