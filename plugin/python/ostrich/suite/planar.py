"""Planar kinematics of dm_control's walkers (cheetah, walker, hopper) as functions of (qpos,
qvel) written with an array module `xp` (numpy, or torch for autograd), with leading batch
dimensions: MuJoCo's mj_kinematics and the velocity of mj_comVel restricted to the x-z plane, so
that rewards read from xipos or from subtree velocity sensors become functions the suite's
reward_fn can return.

Valid for bodies that are unrotated in their parents (body_quat = 1) and move by slides and by
hinges about the y axis only; planar_chain refuses other models (ValueError). A hinge about +y
by a turns (x, z) into (x cos a + z sin a, z cos a - x sin a), so a vector u of a body turning at
rate w changes at w (u_z, -u_x). Joint angles and offsets count from qpos0, as in mj_kinematics.
"""

import numpy as np


def _rotate(v, c, s):
  """(x, z) of v turned by the angle whose cosine and sine are c and s."""
  return (v[0] * c + v[1] * s, v[1] * c - v[0] * s)


def planar_chain(physics, bodies, xp=np):
  """f(qpos, qvel=None) -> {body id: (x, z, angle, vx, vz, w)} of the frames of `bodies` (names)
  and their ancestors; velocities are None without qvel."""
  m = physics.model
  order = []
  for name in bodies:
    chain, b = [], physics.id("body", name)
    while b > 0:
      chain.append(b)
      b = int(m.body_parentid[b])
    order += chain[::-1]
  steps = []  # (body, parent, offset, [(kind, qposadr, dofadr, axis or sign, anchor)])
  for body in dict.fromkeys(order):
    if not np.allclose(m.body_quat[body], [1, 0, 0, 0]):
      raise ValueError(f"body {body}: rotated in its parent; not a planar chain")
    joints = []
    for j in range(int(m.body_jntadr[body]), int(m.body_jntadr[body] + m.body_jntnum[body])):
      axis, kind = np.asarray(m.jnt_axis[j], float), int(m.jnt_type[j])
      adr, dof = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
      if kind == 2:  # slide: along its axis in the body's (x, z)
        joints.append(("slide", adr, dof, axis[[0, 2]], None))
      elif kind == 3 and abs(abs(axis[1]) - 1) < 1e-12:  # hinge about +y or -y
        joints.append(("hinge", adr, dof, float(np.sign(axis[1])),
                       np.asarray(m.jnt_pos[j], float)[[0, 2]]))
      else:
        raise ValueError(f"joint {j}: neither a slide nor a hinge about y; not planar")
    steps.append((body, int(m.body_parentid[body]), np.asarray(m.body_pos[body], float)[[0, 2]],
                  joints))
  qpos0 = np.asarray(m.qpos0, float).copy()

  def frames(qpos, qvel=None):
    vel = qvel is not None
    out = {0: (0.0, 0.0, 0.0, 0.0, 0.0, 0.0) if vel else (0.0, 0.0, 0.0, None, None, None)}
    for body, parent, offset, joints in steps:
      x, z, a, vx, vz, w = out[parent]
      dx, dz = _rotate(offset, xp.cos(a), xp.sin(a))
      x, z = x + dx, z + dz
      if vel:  # the offset turns with the parent
        vx, vz = vx + w * dz, vz - w * dx
      for kind, adr, dof, arg, anchor in joints:
        q = qpos[..., adr] - qpos0[adr]
        c, s = xp.cos(a), xp.sin(a)
        if kind == "slide":
          ux, uz = _rotate(arg, c, s)
          x, z = x + q * ux, z + q * uz
          if vel:
            qd = qvel[..., dof]
            vx, vz = vx + qd * ux + q * w * uz, vz + qd * uz - q * w * ux
        else:  # the anchor stays put while the body turns about it
          ax, az = _rotate(anchor, c, s)
          if vel:  # the anchor's velocity, then the body's turning about it
            vx, vz = vx + w * az, vz - w * ax
            w = w + arg * qvel[..., dof]
          a = a + arg * q
          bx, bz = _rotate(anchor, xp.cos(a), xp.sin(a))
          x, z = x + ax - bx, z + az - bz
          if vel:
            vx, vz = vx - w * bz, vz + w * bx
      out[body] = (x, z, a, vx, vz, w)
    return out
  return frames


def com_height(physics, upper, lower, xp=np):
  """f(qpos) -> z of body `upper`'s centre of mass (xipos) minus body `lower`'s."""
  frames = planar_chain(physics, [upper, lower], xp)
  ipos = {b: np.asarray(physics.model.body_ipos[physics.id("body", b)], float)[[0, 2]]
          for b in (upper, lower)}

  def height(qpos):
    f = frames(qpos)

    def com_z(name):
      x, z, a = f[physics.id("body", name)][:3]
      return z + _rotate(ipos[name], xp.cos(a), xp.sin(a))[1]
    return com_z(upper) - com_z(lower)
  return height


def subtree_com_velocity(physics, root, xp=np):
  """f(qpos, qvel) -> (vx, vz), the linear velocity of the centre of mass of body `root`'s
  subtree (MuJoCo's subtreelinvel sensor)."""
  m = physics.model
  rid = physics.id("body", root)
  members = []
  for b in range(1, physics.size("nbody")):
    a = b
    while a > 0 and a != rid:
      a = int(m.body_parentid[a])
    if a == rid:
      members.append(b)
  names = [physics.names("body")[b] for b in members]
  frames = planar_chain(physics, names, xp)
  mass = {b: float(m.body_mass[b]) for b in members}
  total = sum(mass.values())
  ipos = {b: np.asarray(m.body_ipos[b], float)[[0, 2]] for b in members}

  def velocity(qpos, qvel):
    f = frames(qpos, qvel)
    vx, vz = 0.0, 0.0
    for b in members:
      x, z, a, bvx, bvz, w = f[b]
      rx, rz = _rotate(ipos[b], xp.cos(a), xp.sin(a))
      vx, vz = vx + mass[b] * (bvx + w * rz), vz + mass[b] * (bvz - w * rx)
    return vx / total, vz / total
  return velocity
