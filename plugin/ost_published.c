// ost_published.c: reuse of the stages a step published. ost_step2 ends by running MuJoCo's
// position and velocity stages at q+ into the user's mjData (so that sensors, contacts and
// forces describe the new state). The next step's ost_step1 would run the same stages at the
// same state again: on small models that repeat cost a third of a step. ost_step1 skips it when
// d is provably where the publication left it: the state the stages read (time, qpos, qvel,
// act, mocap poses), a fingerprint of their outputs (mass matrix, bias forces, body poses and
// velocities, tendon lengths and velocities; a user who ran mj_forward or mj_kinematics at
// another state in between changes these) and the model (ost_syncModel) are all unchanged.
// Every comparison is bitwise, so a reused step equals a recomputed one bit for bit.
#include <string.h>

#include "ost_internal.h"

// the arrays compared, as (pointer, length): the stages' inputs, then their outputs
#define OST_PUBLISHED_ARRAYS(m, d)                                                          \
  X(&(d)->time, 1) X((d)->qpos, (m)->nq) X((d)->qvel, (m)->nv) X((d)->act, (m)->na)         \
  X((d)->mocap_pos, 3 * (m)->nmocap) X((d)->mocap_quat, 4 * (m)->nmocap)                    \
  X((d)->qM, (m)->nM) X((d)->qfrc_bias, (m)->nv) X((d)->qfrc_passive, (m)->nv)              \
  X((d)->xpos, 3 * (m)->nbody) X((d)->xquat, 4 * (m)->nbody) X((d)->cvel, 6 * (m)->nbody)   \
  X((d)->ten_length, (m)->ntendon) X((d)->ten_velocity, (m)->ntendon)

size_t ost_publishedSize(const mjModel* m) {
  size_t n = 0;
#define X(ptr, len) n += (size_t)(len);
  OST_PUBLISHED_ARRAYS(m, d)
#undef X
  return n;
}


void ost_publishedSave(ostContext* c, const mjModel* m, const mjData* d) {
  mjtNum* s = c->published;
#define X(ptr, len)                                 \
  memcpy(s, ptr, (size_t)(len) * sizeof(mjtNum));   \
  s += (len);
  OST_PUBLISHED_ARRAYS(m, d)
#undef X
  c->published_valid = 1;
}


int ost_publishedCurrent(ostContext* c, const mjModel* m, const mjData* d) {
  if (!c->published_valid || c->model_dirty) {
    return 0;
  }
  const mjtNum* s = c->published;
#define X(ptr, len)                                           \
  if (memcmp(s, ptr, (size_t)(len) * sizeof(mjtNum))) {      \
    return 0;                                                \
  }                                                          \
  s += (len);
  OST_PUBLISHED_ARRAYS(m, d)
#undef X
  // mj_kinematics normalizes qpos's quaternions in place, and normalizing a normalized
  // quaternion can move it by an ulp: then the stages at the moved qpos are not the published
  // ones, bitwise, and are run again
  for (int j = 0; j < m->njnt; j++) {
    int t = m->jnt_type[j];
    if (t == mjJNT_FREE || t == mjJNT_BALL) {
      mjtNum q[4];
      const mjtNum* qp = d->qpos + m->jnt_qposadr[j] + (t == mjJNT_FREE ? 3 : 0);
      mju_copy4(q, qp);
      mju_normalize4(q);
      if (memcmp(q, qp, sizeof(q))) {
        return 0;
      }
    }
  }
  // the model last: a changed model is copied now and packed by ost_step2 (model_dirty)
  int changed = ost_syncModel(c, m);
  if (changed) {
    c->model_dirty = 1;
    return changed < 0 ? -1 : 0;
  }
  return 1;
}
