"""A dm_env-style Environment over ostrich.Physics, as dm_control's rl.control.Environment: the
action is written to ctrl, the physics takes the control timestep's steps with the chosen engine,
the task gives observation and reward; an episode ends after time_limit / control_timestep steps
with discount 1 (the suite's tasks never terminate early).

dm_env's own TimeStep, StepType and specs are used when dm_env is installed; otherwise the small
equivalents below (same fields, same methods that the suite uses).
"""

import collections
import enum

import numpy as np

try:  # dm_env is optional: its classes when it is there
  import dm_env as _dm_env
  from dm_env import specs as _specs
except ImportError:  # pragma: no cover - exercised where dm_env is absent
  _dm_env = None
  _specs = None

MJMAXVAL = 1e10  # MuJoCo's mjMAXVAL: the action bound of an actuator without ctrlrange


if _dm_env is not None:
  StepType, TimeStep, EnvironmentBase = _dm_env.StepType, _dm_env.TimeStep, _dm_env.Environment
  Array, BoundedArray = _specs.Array, _specs.BoundedArray
else:
  class StepType(enum.IntEnum):
    """dm_env.StepType: FIRST, MID, LAST."""
    FIRST = 0
    MID = 1
    LAST = 2

    def first(self):
      return self is StepType.FIRST

    def mid(self):
      return self is StepType.MID

    def last(self):
      return self is StepType.LAST

  class TimeStep(collections.namedtuple("TimeStep",
                                        ["step_type", "reward", "discount", "observation"])):
    """dm_env.TimeStep: step_type, reward, discount, observation."""
    __slots__ = ()

    def first(self):
      return self.step_type == StepType.FIRST

    def mid(self):
      return self.step_type == StepType.MID

    def last(self):
      return self.step_type == StepType.LAST

  class Array:
    """dm_env.specs.Array: shape, dtype, name; validate(value) raises ValueError."""

    def __init__(self, shape, dtype, name=None):
      self.shape, self.dtype, self.name = tuple(int(n) for n in shape), np.dtype(dtype), name

    def validate(self, value):
      value = np.asarray(value)
      if value.shape != self.shape:
        raise ValueError(f"{self.name}: expected shape {self.shape}, got {value.shape}")
      if value.dtype != self.dtype:
        raise ValueError(f"{self.name}: expected dtype {self.dtype}, got {value.dtype}")
      return value

    def generate_value(self):
      return np.zeros(self.shape, self.dtype)

    def __repr__(self):
      return f"Array(shape={self.shape}, dtype={self.dtype}, name={self.name!r})"

  class BoundedArray(Array):
    """dm_env.specs.BoundedArray: an Array with elementwise minimum and maximum."""

    def __init__(self, shape, dtype, minimum, maximum, name=None):
      super().__init__(shape, dtype, name)
      self.minimum = np.broadcast_to(np.asarray(minimum, self.dtype), self.shape)
      self.maximum = np.broadcast_to(np.asarray(maximum, self.dtype), self.shape)

    def validate(self, value):
      value = super().validate(value)
      if (value < self.minimum).any() or (value > self.maximum).any():
        raise ValueError(f"{self.name}: values out of [{self.minimum}, {self.maximum}]")
      return value

    def generate_value(self):
      return np.array(self.minimum, dtype=self.dtype)

    def __repr__(self):
      return (f"BoundedArray(shape={self.shape}, dtype={self.dtype}, name={self.name!r}, "
              f"minimum={self.minimum}, maximum={self.maximum})")

  EnvironmentBase = object


def compute_n_steps(control_timestep, physics_timestep, tolerance=1e-8):
  """Physics steps in one control step (dm_control's rule): the control timestep must be an
  integer multiple of the physics timestep."""
  if control_timestep < physics_timestep * (1 - tolerance):
    raise ValueError(f"control timestep ({control_timestep}) cannot be smaller than the physics "
                     f"timestep ({physics_timestep})")
  ratio = control_timestep / physics_timestep
  if abs(ratio - round(ratio)) > tolerance:
    raise ValueError(f"control timestep ({control_timestep}) must be an integer multiple of the "
                     f"physics timestep ({physics_timestep})")
  return int(round(ratio))


class Environment(EnvironmentBase):
  """A suite task on ostrich.Physics with dm_env's interface.

  reset() -> TimeStep(FIRST, None, None, observation); step(action) -> TimeStep(MID or LAST,
  reward, discount 1.0, observation) (step after LAST resets); observation_spec(),
  action_spec() (BoundedArray from ctrlrange), reward_spec(), discount_spec().
  physics, task, engine, n_sub_steps, control_timestep(), step_limit; reward_fn(xp) gives the
  task's reward as a function of (qpos, qvel, ctrl) (None where the task has none).
  """

  def __init__(self, physics, task, engine, n_sub_steps, control_timestep, time_limit):
    self._physics = physics
    self._task = task
    self.engine = engine
    self.n_sub_steps = n_sub_steps
    self._control_timestep = control_timestep
    self.step_limit = time_limit / control_timestep  # dm_control's float step limit
    self._step_count = 0
    self._reset_next_step = True

  @property
  def physics(self):
    return self._physics

  @property
  def task(self):
    return self._task

  def control_timestep(self):
    """Seconds between actions: the suite's control timestep."""
    return self._control_timestep

  def _advance(self, nstep):
    self._physics.step(nstep, engine=self.engine)
    if self.engine == "mujoco":
      # mj_step leaves positions and sensors of the step's start; dm_control's Physics refreshes
      # them at the new state (its legacy step), so that observations see the new state
      self._physics.forward()

  def _settle(self, seconds):
    self._advance(int(round(seconds / self._physics_timestep())))

  def _physics_timestep(self):
    return self._physics.timestep if self.engine == "ostrich" else self._physics.model.timestep

  def reset(self):
    """Start an episode: the task's random initial state; a FIRST TimeStep."""
    self._reset_next_step = False
    self._step_count = 0
    self._physics.reset()
    self._task.initialize_episode(self._physics, self._settle)
    self._physics.forward()
    return TimeStep(StepType.FIRST, None, None, self._task.get_observation(self._physics))

  def step(self, action):
    """Apply `action` for one control timestep; a MID TimeStep, or LAST at the time limit."""
    if self._reset_next_step:
      return self.reset()
    np.copyto(self._physics.data.ctrl, np.asarray(action, dtype=np.float64))
    self._advance(self.n_sub_steps)
    reward = float(self._task.get_reward(self._physics))
    observation = self._task.get_observation(self._physics)
    self._step_count += 1
    if self._step_count >= self.step_limit:
      self._reset_next_step = True
      return TimeStep(StepType.LAST, reward, 1.0, observation)
    return TimeStep(StepType.MID, reward, 1.0, observation)

  def observation_spec(self):
    """OrderedDict of Array specs, inferred from an observation as dm_control does."""
    observation = self._task.get_observation(self._physics)
    return collections.OrderedDict(
        (k, Array(np.shape(v), np.asarray(v).dtype, name=k)) for k, v in observation.items())

  def action_spec(self):
    """BoundedArray (nu,) float64 from the actuators' ctrlrange (+-1e10 where unlimited)."""
    model, nu = self._physics.model, self._physics.nu
    limited = np.asarray(model.actuator_ctrllimited).ravel().astype(bool)
    minimum, maximum = np.full(nu, -MJMAXVAL), np.full(nu, MJMAXVAL)
    ctrlrange = np.asarray(model.actuator_ctrlrange).reshape(nu, 2)
    minimum[limited], maximum[limited] = ctrlrange[limited].T
    return BoundedArray((nu,), np.float64, minimum, maximum, name="action")

  def reward_spec(self):
    return Array((), np.float64, name="reward")

  def discount_spec(self):
    return BoundedArray((), np.float64, 0.0, 1.0, name="discount")

  def reward_fn(self, xp=np):
    """The task's reward as f(qpos, qvel, ctrl) over the array module xp (numpy, torch), with
    the episode's parameters (targets, link lengths) read from the model now; None for tasks
    whose reward needs more than the generalized state (see ostrich.suite.REWARD_FNS)."""
    return self._task.reward_fn(self._physics, xp)

  def close(self):
    pass
