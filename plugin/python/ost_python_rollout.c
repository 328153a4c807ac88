// ost_python_rollout.c: the flat C library's recorded rollouts (ost_tape) with their backward
// pass, the conversions between qpos coordinates and tangent vectors that let Python take and
// give gradients of qpos as the arrays it sees, and the batch's backward pass. Part of
// libostrich_python.so (ost_python.c has the rest).
//
// Invariant: a tape's qpos rows are the states its rollout recorded, start first, so that a
// coordinate cotangent of state k is pulled back at the qpos it was taken at.
#include <stdio.h>
#include <stdlib.h>

#include "ost_python.h"

typedef struct ostpyTape_ {       // a recorded rollout (ost_tape) and its states' qpos
  ostTape* tape;
  int      nstep;                 // steps recorded
  int      cap;                   // capacity of qpos in states
  mjtNum*  qpos;                  // qpos of every state, the start included ((nstep + 1) x nq)
  char     err[OSTPY_MSG_SZ];     // message of the last failure ("" if none)
} ostpyTape;


//---------------------------------- Recorded rollouts ---------------------------------------------

// New tape for p's model (checkpoint as ost_tapeCreate); NULL if out of memory.
OSTPY_API ostpyTape* ostpy_tapeCreate(ostpyPhysics* p, int checkpoint) {
  ostpyTape* t = (ostpyTape*)calloc(1, sizeof(ostpyTape));
  if (!t) {
    return NULL;
  }
  t->tape = ost_tapeCreate(p->m, checkpoint);
  if (!t->tape) {
    free(t);
    return NULL;
  }
  return t;
}


// Release a tape (NULL is ignored).
OSTPY_API void ostpy_tapeFree(ostpyTape* t) {
  if (t) {
    ost_tapeDelete(t->tape);
    free(t->qpos);
    free(t);
  }
}


// Message of the tape's last failure ("" if none).
OSTPY_API const char* ostpy_tapeError(const ostpyTape* t) {
  return t ? t->err : "no tape";
}


// Record nstep Ostrich steps from p's state with controls ctrl (nstep x nu; NULL: keep d's),
// after forgetting the tape's last rollout. qpos ((nstep + 1) x nq), qvel ((nstep + 1) x nv)
// and act ((nstep + 1) x na) receive every state, the start first; status (nstep) each step's
// ost_step status; any may be NULL. Returns OST_OK, OST_WARN_NOT_CONVERGED if a step warned (the rollout went on; the
// backward pass will refuse it), or the error of the step that failed (message in
// ostpy_tapeError; the rollout stops there and t->nstep counts the steps taken).
OSTPY_API int ostpy_rollout(ostpyPhysics* p, ostpyTape* t, int nstep, const mjtNum* ctrl,
                            mjtNum* qpos, mjtNum* qvel, mjtNum* act, int* status) {
  const mjModel* m = p->m;
  mjData* d = p->d;
  int nq = m->nq, nv = m->nv, nu = m->nu, na = m->na, result = OST_OK;
  t->err[0] = 0;
  t->nstep = 0;
  ost_tapeClear(t->tape);
  if (nstep < 0) {
    return ostpy_fail(t->err, -3, "the number of steps is negative");
  }
  if (t->cap < nstep + 1) {
    mjtNum* grown = (mjtNum*)realloc(t->qpos, sizeof(mjtNum) * (size_t)(nstep + 1) * nq);
    if (!grown) {
      return ostpy_fail(t->err, OST_ERR_MEMORY, "out of memory for the rollout's states");
    }
    t->qpos = grown;
    t->cap = nstep + 1;
  }
  ostpy_mujocoError()[0] = 0;
  mju_copy(t->qpos, d->qpos, nq);
  if (qpos) {
    mju_copy(qpos, d->qpos, nq);
  }
  if (qvel) {
    mju_copy(qvel, d->qvel, nv);
  }
  if (act) {
    mju_copy(act, d->act, na);
  }
  for (int k = 0; k < nstep; k++) {
    if (ctrl) {
      mju_copy(d->ctrl, ctrl + (size_t)k * nu, nu);
    }
    int s = ost_tapeStep(t->tape, m, d);
    if (status) {
      status[k] = s;
    }
    if (s != OST_OK && !OST_IS_WARNING(s)) {
      char msg[OSTPY_MSG_SZ];
      snprintf(msg, sizeof(msg), "step %d of the rollout failed: %.900s", k + 1,
               ost_lastError(d));
      return ostpy_fail(t->err, s, msg);
    }
    if (ostpy_mujocoError()[0]) {
      char msg[OSTPY_MSG_SZ];
      snprintf(msg, sizeof(msg), "step %d of the rollout: MuJoCo error: %.900s", k + 1,
               ostpy_mujocoError());
      return ostpy_fail(t->err, OST_ERR_NUMERIC, msg);
    }
    if (OST_IS_WARNING(s)) {
      result = s;
    }
    t->nstep = k + 1;
    mju_copy(t->qpos + (size_t)(k + 1) * nq, d->qpos, nq);
    if (qpos) {
      mju_copy(qpos + (size_t)(k + 1) * nq, d->qpos, nq);
    }
    if (qvel) {
      mju_copy(qvel + (size_t)(k + 1) * nv, d->qvel, nv);
    }
    if (act) {
      mju_copy(act + (size_t)(k + 1) * na, d->act, na);
    }
  }
  return result;
}


// Tangent cotangent gt (nv) of a coordinate cotangent gc (nq) at qpos: gt = G(qpos)^T gc, where
// G is the derivative of qpos along mj_integratePos's tangent (identity for slides, hinges and
// free positions; d(q * exp(delta / 2))/d delta_i = 1/2 q * (0, e_i) for ball and free
// rotations, delta in the local frame).
static void coordToTangent(const mjModel* m, const mjtNum* qpos, const mjtNum* gc, mjtNum* gt) {
  for (int j = 0; j < m->njnt; j++) {
    int padr = m->jnt_qposadr[j], vadr = m->jnt_dofadr[j], type = m->jnt_type[j];
    if (type == mjJNT_FREE) {
      mju_copy3(gt + vadr, gc + padr);
      padr += 3;
      vadr += 3;
    }
    if (type == mjJNT_FREE || type == mjJNT_BALL) {
      for (int i = 0; i < 3; i++) {
        mjtNum e[4] = {0, 0, 0, 0}, dq[4];
        e[i + 1] = 0.5;
        mju_mulQuat(dq, qpos + padr, e);
        gt[vadr + i] = mju_dot(gc + padr, dq, 4);
      }
    } else {
      gt[vadr] = gc[padr];
    }
  }
}


// Coordinate gradient gc (nq) of a tangent gradient gt (nv) at qpos: the one tangent to the
// unit sphere of each quaternion, gc = G (G^T G)^-1 gt = 4 G gt (the columns of G are
// orthogonal with norm 1/2), so that gc . (G delta) = gt . delta for every tangent delta.
static void tangentToCoord(const mjModel* m, const mjtNum* qpos, const mjtNum* gt, mjtNum* gc) {
  for (int j = 0; j < m->njnt; j++) {
    int padr = m->jnt_qposadr[j], vadr = m->jnt_dofadr[j], type = m->jnt_type[j];
    if (type == mjJNT_FREE) {
      mju_copy3(gc + padr, gt + vadr);
      padr += 3;
      vadr += 3;
    }
    if (type == mjJNT_FREE || type == mjJNT_BALL) {
      mju_zero4(gc + padr);
      for (int i = 0; i < 3; i++) {
        mjtNum e[4] = {0, 0, 0, 0}, dq[4];
        e[i + 1] = 2;  // 4 * 1/2
        mju_mulQuat(dq, qpos + padr, e);
        mju_addToScl(gc + padr, dq, gt[vadr + i], 4);
      }
    } else {
      gc[padr] = gt[vadr];
    }
  }
}


// Backward pass of the recorded rollout (ost_tapeBackward). gqpos: dL/dqpos of every state
// ((nstep + 1) x nq coordinates, or (nstep + 1) x nv tangent vectors if tangent), gqvel
// ((nstep + 1) x nv); NULL = zero. Outputs, any may be NULL: gctrl (nstep x nu), gqpos0 (nq
// coordinates, or nv if tangent), gqvel0 (nv) and, with params, gtheta (ost_nparam, set, not
// accumulated). truncate: ostGradOptions.truncate. Returns ost_tapeBackward's status (message
// in ostpy_tapeError: a rollout with an unconverged step is refused, OST_ERR_NOT_CONVERGED).
OSTPY_API int ostpy_backward(ostpyPhysics* p, ostpyTape* t, int tangent, int params,
                             int truncate, const mjtNum* gqpos, const mjtNum* gqvel,
                             mjtNum* gctrl, mjtNum* gqpos0, mjtNum* gqvel0, mjtNum* gtheta) {
  const mjModel* m = p->m;
  int nq = m->nq, nv = m->nv, n = t->nstep, status = OST_OK;
  size_t rows = (size_t)n + 1;
  t->err[0] = 0;
  if (ost_tapeSteps(t->tape) != n) {
    return ostpy_fail(t->err, OST_ERR_INPUT, "the tape holds no complete rollout");
  }
  mjtNum* gq = (mjtNum*)calloc(rows * nv + nv, sizeof(mjtNum));
  if (!gq) {
    return ostpy_fail(t->err, OST_ERR_MEMORY, "out of memory");
  }
  mjtNum* gq0 = gq + rows * nv;
  for (size_t k = 0; k < rows && gqpos; k++) {
    if (tangent) {
      mju_copy(gq + k * nv, gqpos + k * nv, nv);
    } else {
      coordToTangent(m, t->qpos + k * nq, gqpos + k * nq, gq + k * nv);
    }
  }
  if (params && gtheta) {
    mju_zero(gtheta, ost_nparam(m));
  }
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.truncate = truncate;
  go.params = params && gtheta;
  ostpy_mujocoError()[0] = 0;
  status = ost_tapeBackward(t->tape, m, &go, gq, gqvel, gctrl, gq0, gqvel0,
                            go.params ? gtheta : NULL);
  if (status != OST_OK) {
    ostpy_fail(t->err, status, ost_tapeError(t->tape));
  } else if (ostpy_mujocoError()[0]) {
    status = ostpy_fail(t->err, OST_ERR_NUMERIC, ostpy_mujocoError());
  } else if (gqpos0) {
    if (tangent) {
      mju_copy(gqpos0, gq0, nv);
    } else {
      tangentToCoord(m, t->qpos, gq0, gqpos0);
    }
  }
  free(gq);
  return status;
}


// Tangent cotangents gt (n x nv) of coordinate cotangents gc (n x nq) at the states qpos
// (n x nq): coordToTangent row by row (batches' backward passes take tangent vectors).
OSTPY_API void ostpy_coordToTangent(const ostpyPhysics* p, int n, const mjtNum* qpos,
                                    const mjtNum* gc, mjtNum* gt) {
  int nq = p->m->nq, nv = p->m->nv;
  for (size_t k = 0; k < (size_t)n; k++) {
    coordToTangent(p->m, qpos + k * nq, gc + k * nq, gt + k * nv);
  }
}


// Coordinate gradients gc (n x nq) of tangent gradients gt (n x nv) at the states qpos
// (n x nq): tangentToCoord row by row.
OSTPY_API void ostpy_tangentToCoord(const ostpyPhysics* p, int n, const mjtNum* qpos,
                                    const mjtNum* gt, mjtNum* gc) {
  int nq = p->m->nq, nv = p->m->nv;
  for (size_t k = 0; k < (size_t)n; k++) {
    tangentToCoord(p->m, qpos + k * nq, gt + k * nv, gc + k * nq);
  }
}


// ost_batchBackwardParams with ostGradOptions built here (truncate; parameters when gtheta is
// given: nworld x ost_nparam, overwritten).
OSTPY_API int ostpy_batchBackward(ostBatch* b, int truncate, int checkpoint, const mjtNum* gq,
                                  const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0, mjtNum* gu0,
                                  mjtNum* gtheta) {
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.truncate = truncate;
  go.params = gtheta != NULL;
  return ost_batchBackwardParams(b, &go, checkpoint, gq, gu, gctrl, gq0, gu0, gtheta);
}
