"""The dm_control suite's tasks on ostrich.Physics: each task's episode initialisation,
observation and reward as dm_control's suite defines them (cartpole.py, pendulum.py, reacher.py,
finger.py, cheetah.py, walker.py, hopper.py), on the suite's own MJCF files.

A task is a class with the suite's numbers (xml file, time limit, control timestep) and
  initialize_episode(physics, settle): the episode's start state, drawn from self.random
      (np.random.RandomState, drawn in dm_control's order); settle(seconds) steps the physics
      with the environment's engine (cheetah lets its random pose settle)
  get_observation(physics): OrderedDict of float64 arrays, named and shaped as dm_control's
  get_reward(physics): a float in [0, 1]
  reward_fn(physics, xp): the reward as a function (qpos, qvel, ctrl) -> reward written with the
      array module xp (numpy, torch), leading batch dimensions allowed; None where the reward
      needs more than the generalized state (subtree velocities, contacts)
"""

import collections
import math

import numpy as np

from . import planar
from .rewards import tolerance

_XMAT = {"xx": 0, "xy": 1, "xz": 2, "yx": 3, "yy": 4, "yz": 5, "zx": 6, "zy": 7, "zz": 8}
_FREE, _BALL, _SLIDE, _HINGE = 0, 1, 2, 3  # mjtJoint


def xmat(physics, body, components):
  """Components ('zz', 'xz', ...) of a body's (or list of bodies') world rotation matrix."""
  rows = physics.named.data.xmat[body]
  cols = [_XMAT[c] for c in components] if isinstance(components, (list, tuple)) \
      else _XMAT[components]
  return np.array(rows[..., cols], dtype=np.float64)


def sensor(physics, name):
  """A copy of a sensor's values by name, always 1-D (dim entries)."""
  return np.atleast_1d(np.array(physics.named.data.sensordata[name], dtype=np.float64))


def randomize_limited_and_rotational_joints(physics, random):
  """dm_control's suite.utils.randomizers function of that name, in its order of draws: limited
  hinges and slides uniform in their range, unlimited hinges uniform in [-pi, pi], unlimited ball
  joints and free joints' orientations uniform quaternions; unlimited slides and free joints'
  positions are left."""
  model, qpos = physics.model, physics.data.qpos
  for j in range(physics.size("njnt")):
    kind, limited = int(model.jnt_type[j]), bool(model.jnt_limited[j])
    adr = int(model.jnt_qposadr[j])
    lo, hi = model.jnt_range[j]
    if limited:
      if kind in (_HINGE, _SLIDE):
        qpos[adr] = random.uniform(lo, hi)
      elif kind == _BALL:
        raise NotImplementedError("limited ball joints are not randomised (no suite task here "
                                  "has one)")
    elif kind == _HINGE:
      qpos[adr] = random.uniform(-np.pi, np.pi)
    elif kind == _BALL:
      quat = random.randn(4)
      qpos[adr:adr + 4] = quat / np.linalg.norm(quat)
    elif kind == _FREE:
      quat = random.rand(4)  # dm_control's own choice (rand, not randn), kept for its seeds
      qpos[adr + 3:adr + 7] = quat / np.linalg.norm(quat)


class Task:
  """A suite task: subclasses set domain, name, xml, time_limit and control_timestep (None: one
  step of the suite's model timestep)."""

  domain = name = xml = None
  time_limit = 10.0
  control_timestep = None
  suite_timestep = None  # the model's own opt.timestep, set by load()

  def __init__(self, random=None):
    self.random = random if isinstance(random, np.random.RandomState) \
        else np.random.RandomState(random)

  def initialize_episode(self, physics, settle):
    raise NotImplementedError

  def get_observation(self, physics):
    raise NotImplementedError

  def get_reward(self, physics):
    raise NotImplementedError

  def reward_fn(self, physics, xp=np):
    return None


# ---- cartpole: balance and swingup (dm_control's smooth reward, one pole)

class CartpoleBalance(Task):
  domain, name, xml, time_limit = "cartpole", "balance", "cartpole.xml", 10.0
  swing_up = False

  def initialize_episode(self, physics, settle):
    nv = physics.nv
    qpos, qvel = physics.data.qpos, physics.data.qvel
    if self.swing_up:
      qpos[0] = .01 * self.random.randn()
      qpos[1] = np.pi + .01 * self.random.randn()
      qpos[2:] = .1 * self.random.randn(nv - 2)
    else:
      qpos[0] = self.random.uniform(-.1, .1)
      qpos[1:] = self.random.uniform(-.034, .034, nv - 1)
    qvel[:] = .01 * self.random.randn(nv)

  def get_observation(self, physics):
    obs = collections.OrderedDict()
    poles = physics.names("body")[2:]
    obs["position"] = np.hstack((physics.named.data.qpos["slider"],
                                 xmat(physics, poles, ["zz", "xz"]).ravel()))
    obs["velocity"] = physics.data.qvel.copy()
    return obs

  def get_reward(self, physics):
    poles = physics.names("body")[2:]
    upright = (xmat(physics, poles, "zz") + 1) / 2
    centered = (1 + tolerance(float(physics.named.data.qpos["slider"]), margin=2)) / 2
    small_control = tolerance(physics.data.ctrl.copy(), margin=1, value_at_margin=0,
                              sigmoid="quadratic")[0]
    small_control = (4 + small_control) / 5
    small_velocity = (1 + tolerance(physics.data.qvel[1:].copy(), margin=5).min()) / 2
    return float(upright.mean() * small_control * small_velocity * centered)

  def reward_fn(self, physics, xp=np):
    def reward(qpos, qvel, ctrl):
      # one pole hinged about y: the pole's zz is cos(hinge)
      upright = (xp.cos(qpos[..., 1]) + 1) / 2
      centered = (1 + tolerance(qpos[..., 0], margin=2, xp=xp)) / 2
      small_control = (4 + tolerance(ctrl[..., 0], margin=1, value_at_margin=0,
                                     sigmoid="quadratic", xp=xp)) / 5
      small_velocity = (1 + tolerance(qvel[..., 1], margin=5, xp=xp)) / 2
      return upright * small_control * small_velocity * centered
    return reward


class CartpoleSwingup(CartpoleBalance):
  name, swing_up = "swingup", True


# ---- pendulum: swingup (sparse: upright within 8 degrees)

_PENDULUM_COSINE_BOUND = math.cos(math.radians(8))


class PendulumSwingup(Task):
  domain, name, xml, time_limit = "pendulum", "swingup", "pendulum.xml", 20.0

  def initialize_episode(self, physics, settle):
    physics.named.data.qpos["hinge"] = self.random.uniform(-np.pi, np.pi)

  def get_observation(self, physics):
    obs = collections.OrderedDict()
    obs["orientation"] = xmat(physics, "pole", ["zz", "xz"])
    obs["velocity"] = np.atleast_1d(np.array(physics.named.data.qvel["hinge"], dtype=float))
    return obs

  def get_reward(self, physics):
    return tolerance(float(xmat(physics, "pole", "zz")), (_PENDULUM_COSINE_BOUND, 1))

  def reward_fn(self, physics, xp=np):
    def reward(qpos, qvel, ctrl):
      return tolerance(xp.cos(qpos[..., 0]), (_PENDULUM_COSINE_BOUND, 1), xp=xp)
    return reward


# ---- reacher: easy (sparse: the finger touches a target of radius 0.05)

class ReacherEasy(Task):
  domain, name, xml, time_limit = "reacher", "easy", "reacher.xml", 20.0
  target_size = .05

  def initialize_episode(self, physics, settle):
    physics.named.model.geom_size["target", 0] = self.target_size
    randomize_limited_and_rotational_joints(physics, self.random)
    angle = self.random.uniform(0, 2 * np.pi)
    radius = self.random.uniform(.05, .20)
    physics.named.model.geom_pos["target", 0] = radius * np.sin(angle)
    physics.named.model.geom_pos["target", 1] = radius * np.cos(angle)

  @staticmethod
  def _finger_to_target(physics):
    xpos = physics.named.data.geom_xpos
    return np.array(xpos["target"][:2] - xpos["finger"][:2], dtype=np.float64)

  def get_observation(self, physics):
    obs = collections.OrderedDict()
    obs["position"] = physics.data.qpos.copy()
    obs["to_target"] = self._finger_to_target(physics)
    obs["velocity"] = physics.data.qvel.copy()
    return obs

  def _radii(self, physics):
    return float(physics.named.model.geom_size[["target", "finger"], 0].sum())

  def get_reward(self, physics):
    return tolerance(float(np.linalg.norm(self._finger_to_target(physics))),
                     (0, self._radii(physics)))

  def reward_fn(self, physics, xp=np):
    # planar two-link arm: shoulder at the arm body's origin, the wrist `hand` body's x offset
    # along the arm, the finger body's x offset along the hand (the finger geom at its origin)
    model = physics.named.model
    base = np.array(model.body_pos["arm"][:2], dtype=float)
    l1, l2 = float(model.body_pos["hand"][0]), float(model.body_pos["finger"][0])
    target = np.array(model.geom_pos["target"][:2], dtype=float)
    radii = self._radii(physics)

    def reward(qpos, qvel, ctrl):
      a, b = qpos[..., 0], qpos[..., 0] + qpos[..., 1]
      dx = target[0] - (base[0] + l1 * xp.cos(a) + l2 * xp.cos(b))
      dy = target[1] - (base[1] + l1 * xp.sin(a) + l2 * xp.sin(b))
      return tolerance(xp.sqrt(dx ** 2 + dy ** 2), (0, radii), xp=xp)
    return reward


# ---- finger: spin (sparse: the hinge turns faster than 15 rad/s clockwise)

class FingerSpin(Task):
  domain, name, xml, time_limit, control_timestep = "finger", "spin", "finger.xml", 20.0, .02

  def initialize_episode(self, physics, settle):
    physics.named.model.site_rgba["target", 3] = 0
    physics.named.model.site_rgba["tip", 3] = 0
    physics.named.model.dof_damping["hinge"] = .03
    for _ in range(1000):  # a random pose without contacts, as dm_control's _set_random_...
      randomize_limited_and_rotational_joints(physics, self.random)
      physics.forward()
      if physics.data.ncon == 0:
        return
    raise RuntimeError("finger: no collision-free random pose in 1000 attempts")

  def get_observation(self, physics):
    obs = collections.OrderedDict()
    tip = sensor(physics, "tip")[[0, 2]] - sensor(physics, "spinner")[[0, 2]]
    obs["position"] = np.hstack((sensor(physics, "proximal"), sensor(physics, "distal"), tip))
    obs["velocity"] = np.hstack([sensor(physics, n) for n in
                                 ("proximal_velocity", "distal_velocity", "hinge_velocity")])
    obs["touch"] = np.log1p(np.hstack((sensor(physics, "touchtop"),
                                       sensor(physics, "touchbottom"))))
    return obs

  def get_reward(self, physics):
    return float(sensor(physics, "hinge_velocity")[0] <= -15.0)

  def reward_fn(self, physics, xp=np):
    # the hinge_velocity sensor is the spinner hinge's qvel (sparse: its gradient is 0)
    i = int(physics.model.jnt_dofadr[physics.id("joint", "hinge")])

    def reward(qpos, qvel, ctrl):
      return (qvel[..., i] <= -15.0) * 1.0
    return reward


# ---- cheetah: run (linear in the torso subtree's forward speed up to 10 m/s)

class CheetahRun(Task):
  domain, name, xml, time_limit = "cheetah", "run", "cheetah.xml", 10.0
  settle_steps = 200  # dm_control steps its random pose 200 model steps before the episode

  def initialize_episode(self, physics, settle):
    limited = physics.model.jnt_limited == 1
    lower, upper = physics.model.jnt_range[limited].T
    physics.data.qpos[limited] = self.random.uniform(lower, upper)
    settle(self.settle_steps * self.suite_timestep)
    physics.data.time = 0

  def get_observation(self, physics):
    obs = collections.OrderedDict()
    obs["position"] = physics.data.qpos[1:].copy()
    obs["velocity"] = physics.data.qvel.copy()
    return obs

  def get_reward(self, physics):
    return self._reward(float(sensor(physics, "torso_subtreelinvel")[0]))

  def _reward(self, speed, xp=np):
    return tolerance(speed, bounds=(10, float("inf")), margin=10, value_at_margin=0,
                     sigmoid="linear", xp=xp)

  def reward_fn(self, physics, xp=np):
    # the torso_subtreelinvel sensor, by planar kinematics
    velocity = planar.subtree_com_velocity(physics, "torso", xp)

    def reward(qpos, qvel, ctrl):
      return self._reward(velocity(qpos, qvel)[0], xp=xp)
    return reward


# ---- walker: stand and walk

class WalkerStand(Task):
  domain, name, xml, time_limit, control_timestep = "walker", "stand", "walker.xml", 25.0, .025
  move_speed = 0.0
  stand_height = 1.2

  def initialize_episode(self, physics, settle):
    randomize_limited_and_rotational_joints(physics, self.random)

  def get_observation(self, physics):
    obs = collections.OrderedDict()
    obs["orientations"] = xmat(physics, physics.names("body")[1:], ["xx", "xz"]).ravel()
    obs["height"] = np.float64(physics.named.data.xpos["torso", 2])
    obs["velocity"] = physics.data.qvel.copy()
    return obs

  def _stand(self, height, upright_zz, xp=np):
    standing = tolerance(height, bounds=(self.stand_height, float("inf")),
                         margin=self.stand_height / 2, xp=xp)
    upright = (1 + upright_zz) / 2
    return (3 * standing + upright) / 4

  def get_reward(self, physics):
    return self._reward(float(physics.named.data.xpos["torso", 2]),
                        float(xmat(physics, "torso", "zz")),
                        float(sensor(physics, "torso_subtreelinvel")[0]))

  def _reward(self, height, upright_zz, speed, xp=np):
    stand = self._stand(height, upright_zz, xp=xp)
    if self.move_speed == 0:
      return stand
    move = tolerance(speed, bounds=(self.move_speed, float("inf")), margin=self.move_speed / 2,
                     value_at_margin=0.5, sigmoid="linear", xp=xp)
    return stand * (5 * move + 1) / 6

  def reward_fn(self, physics, xp=np):
    # the torso slides along z (rootz) and turns about y (rooty) at its origin; the walk's
    # speed is the torso_subtreelinvel sensor, by planar kinematics
    z0 = float(physics.named.model.body_pos["torso"][2])
    iz = int(physics.model.jnt_qposadr[physics.id("joint", "rootz")])
    iy = int(physics.model.jnt_qposadr[physics.id("joint", "rooty")])
    velocity = planar.subtree_com_velocity(physics, "torso", xp) if self.move_speed else None

    def reward(qpos, qvel, ctrl):
      speed = velocity(qpos, qvel)[0] if velocity else 0.0
      return self._reward(z0 + qpos[..., iz], xp.cos(qpos[..., iy]), speed, xp=xp)
    return reward


class WalkerWalk(WalkerStand):
  name, move_speed = "walk", 1.0


# ---- hopper: stand

class HopperStand(Task):
  domain, name, xml, time_limit, control_timestep = "hopper", "stand", "hopper.xml", 20.0, .02

  def initialize_episode(self, physics, settle):
    randomize_limited_and_rotational_joints(physics, self.random)

  def get_observation(self, physics):
    obs = collections.OrderedDict()
    obs["position"] = physics.data.qpos[1:].copy()
    obs["velocity"] = physics.data.qvel.copy()
    obs["touch"] = np.log1p(np.hstack((sensor(physics, "touch_toe"),
                                       sensor(physics, "touch_heel"))))
    return obs

  def get_reward(self, physics):
    xipos = physics.named.data.xipos
    height = float(xipos["torso", 2] - xipos["foot", 2])
    return float(self._reward(height, physics.data.ctrl.copy()))

  def _reward(self, height, ctrl, xp=np):
    standing = tolerance(height, (0.6, 2), xp=xp)
    small_control = tolerance(ctrl, margin=1, value_at_margin=0, sigmoid="quadratic",
                              xp=xp).mean(-1)
    return standing * (small_control + 4) / 5

  def reward_fn(self, physics, xp=np):
    # the height of the torso's centre of mass above the foot's, by planar kinematics
    height = planar.com_height(physics, "torso", "foot", xp)

    def reward(qpos, qvel, ctrl):
      return self._reward(height(qpos), ctrl, xp=xp)
    return reward


TASKS = collections.OrderedDict(
    ((cls.domain, cls.name), cls) for cls in (
        CartpoleBalance, CartpoleSwingup, PendulumSwingup, ReacherEasy, FingerSpin, CheetahRun,
        WalkerStand, WalkerWalk, HopperStand))
