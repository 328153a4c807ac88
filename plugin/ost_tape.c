// ost_tape.c: recording a rollout and its backward pass (core/README.md section 2, "Memory").
// Without checkpoints the tape keeps every substep's record (ost_adjoint.c: state, controls and
// converged forces, sized to the rows the substep used). With checkpoint S it keeps, per step, only the
// inputs (controls and applied forces), and every S steps the state and the warm start; the
// backward pass re-runs one segment of S steps at a time on a private mjData, bitwise as the
// recorded run (same options, same warm start), and differentiates its records.
// Invariant: the user's mjData is only stepped (ost_step); recomputation never touches it.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ost_internal.h"

struct ostTape_ {
  const mjModel* m;               // the model recorded
  int     checkpoint;             // S: steps per segment (0: keep every record)
  int     nstep;                  // steps recorded
  int     step_cap;               // capacity of the per-step arrays
  size_t* step_rec;               // byte offset in recs of each step's first record (no
                                  // checkpoints: of the rollout; else: of the segment) (nstep + 1)
  void*   recs;                   // records (no checkpoints) or one segment's records
  size_t  rec_bytes;              // bytes of records held
  size_t  rec_cap;                // capacity of recs in bytes
  mjtNum* inputs;                 // per step: ctrl, qfrc_applied, xfrc_applied (checkpoints)
  int     ninput;                 // numbers per step in inputs
  int     input_cap;              // capacity of inputs in steps
  void*   ckpt;                   // per segment: state (time, qpos, qvel, qacc_warmstart, act)
                                  // and warm start (checkpoints)
  size_t  ckpt_sz;                // bytes per checkpoint
  int     ncon_cap;               // largest contact capacity of the recorded steps' context
  int     ckpt_cap;               // capacity of ckpt
  mjData* scratch;                // private mjData: recomputation and the backward pass
  int     bad_step;               // first step not solved to tol (warning status), or -1
  char    bad_err[256];           // why (ost_lastError of that step)
  char    err[512];               // message of the last failure
};


ostTape* ost_tapeCreate(const mjModel* m, int checkpoint) {
  if (!m || checkpoint < 0) {
    return NULL;
  }
  ostTape* t = (ostTape*)calloc(1, sizeof(ostTape));
  if (!t) {
    return NULL;
  }
  t->m = m;
  t->checkpoint = checkpoint;
  t->bad_step = -1;
  t->ninput = m->nu + m->nv + 6 * m->nbody;
  t->scratch = mj_makeData(m);
  ostContext* c = t->scratch ? ost_context(m, t->scratch) : NULL;
  if (!c) {
    ost_tapeDelete(t);
    return NULL;
  }
  t->ckpt_sz = (1 + m->nq + 2 * (size_t)m->nv + m->na) * sizeof(mjtNum) + ost_warmSize(c);
  return t;
}


void ost_tapeDelete(ostTape* t) {
  if (!t) {
    return;
  }
  if (t->scratch) {
    ost_deleteData(t->scratch);
  }
  free(t->step_rec);
  free(t->recs);
  free(t->inputs);
  free(t->ckpt);
  free(t);
}


void ost_tapeClear(ostTape* t) {
  if (t) {
    t->nstep = 0;
    t->rec_bytes = 0;
    t->bad_step = -1;
    t->err[0] = 0;
  }
}


int ost_tapeSteps(const ostTape* t) {
  return t ? t->nstep : 0;
}


size_t ost_tapeBytes(const ostTape* t) {
  if (!t) {
    return 0;
  }
  size_t nckpt = t->ckpt_cap;
  return sizeof(ostTape) + t->rec_cap + nckpt * t->ckpt_sz
         + (size_t)t->step_cap * sizeof(size_t) + (size_t)t->input_cap * t->ninput * sizeof(mjtNum);
}


const char* ost_tapeError(const ostTape* t) {
  return t ? t->err : "";
}


static int tapeFail(ostTape* t, int status, const char* msg) {
  snprintf(t->err, sizeof(t->err), "%s", msg);
  return status;
}


// grow a buffer of *cap items of sz bytes to hold n items (doubling)
static int grow(void** buf, int* cap, int n, size_t sz) {
  if (n <= *cap) {
    return 0;
  }
  int c = *cap ? *cap : 16;
  while (c < n) {
    c *= 2;
  }
  void* p = realloc(*buf, (size_t)c * sz);
  if (!p) {
    return 1;
  }
  *buf = p;
  *cap = c;
  return 0;
}


// append the records of a context's last step into recs (capacity doubling, in bytes)
static int appendRecords(ostTape* t, const ostContext* c) {
  size_t need = t->rec_bytes + c->rec_bytes;
  if (need > t->rec_cap) {
    size_t cap = t->rec_cap ? t->rec_cap : 4096;
    while (cap < need) {
      cap *= 2;
    }
    void* p = realloc(t->recs, cap);
    if (!p) {
      return 1;
    }
    t->recs = p;
    t->rec_cap = cap;
  }
  memcpy((char*)t->recs + t->rec_bytes, c->rec_buf, c->rec_bytes);
  t->rec_bytes = need;
  return 0;
}


// make every checkpoint slot hold sz bytes: a context whose contact capacity grew has a larger
// warm start (ost_warmSize), so the slots are widened, the saved ones moved (last first)
static int widenCheckpoints(ostTape* t, size_t sz) {
  if (sz <= t->ckpt_sz) {
    return 0;
  }
  sz = (sz + 15) / 16 * 16;
  if (t->ckpt_cap) {
    void* p = realloc(t->ckpt, (size_t)t->ckpt_cap * sz);
    if (!p) {
      return 1;
    }
    t->ckpt = p;
    for (int k = t->ckpt_cap - 1; k > 0; k--) {
      memmove((char*)t->ckpt + k * sz, (char*)t->ckpt + k * t->ckpt_sz, t->ckpt_sz);
    }
  }
  t->ckpt_sz = sz;
  return 0;
}


// the state and warm start of d (context c) into checkpoint k
static void saveCheckpoint(ostTape* t, const mjData* d, const ostContext* c, int k) {
  const mjModel* m = t->m;
  mjtNum* s = (mjtNum*)((char*)t->ckpt + k * t->ckpt_sz);
  s[0] = d->time;
  memcpy(s + 1, d->qpos, m->nq * sizeof(mjtNum));
  memcpy(s + 1 + m->nq, d->qvel, m->nv * sizeof(mjtNum));
  memcpy(s + 1 + m->nq + m->nv, d->qacc_warmstart, m->nv * sizeof(mjtNum));
  memcpy(s + 1 + m->nq + 2 * m->nv, d->act, m->na * sizeof(mjtNum));
  ost_warmSave(c, s + 1 + m->nq + 2 * m->nv + m->na);
}


int ost_tapeStep(ostTape* t, const mjModel* m, mjData* d) {
  if (!t) return -1;
  if (!m || m != t->m) return -2;
  if (!d) return -3;
  ostContext* c = ost_context(m, d);
  if (!c) {
    return tapeFail(t, OST_ERR_MEMORY, "cannot allocate");
  }
  int k = t->nstep, S = t->checkpoint;
  if (t->nstep == 0) {
    // the recomputation and the backward pass use the recorded run's options
    if (ost_prepareContext(c, m) || ost_setOptions(m, t->scratch, &c->opt)) {
      return tapeFail(t, OST_ERR_MODEL, ost_lastError(d));
    }
  }
  if (grow((void**)&t->step_rec, &t->step_cap, k + 2, sizeof(size_t))
      || (S && grow((void**)&t->inputs, &t->input_cap, k + 2, t->ninput * sizeof(mjtNum)))) {
    return tapeFail(t, OST_ERR_MEMORY, "cannot grow the tape");
  }
  if (S && k % S == 0) {
    size_t need = (1 + m->nq + 2 * (size_t)m->nv + m->na) * sizeof(mjtNum) + ost_warmSize(c);
    if (widenCheckpoints(t, need) || grow(&t->ckpt, &t->ckpt_cap, k / S + 1, t->ckpt_sz)) {
      return tapeFail(t, OST_ERR_MEMORY, "cannot grow the tape");
    }
    saveCheckpoint(t, d, c, k / S);
  }
  int status = ost_step(m, d);
  if (status && !OST_IS_WARNING(status)) {
    return tapeFail(t, status, ost_lastError(d));
  }
  t->ncon_cap = c->ncon_cap > t->ncon_cap ? c->ncon_cap : t->ncon_cap;
  if (status && t->bad_step < 0) {
    // recorded, but the backward pass will refuse it (its gradient is not exact)
    t->bad_step = k;
    snprintf(t->bad_err, sizeof(t->bad_err), "residual %.3g m/s above tol",
             ost_stats(d)->residual);
  }
  if (S) {
    // the inputs the step used (after mjcb_control), from its first record
    ostRecord r;
    ost_recordView(m, c->rec_buf, &r);
    mjtNum* in = t->inputs + (size_t)k * t->ninput;
    memcpy(in, r.ctrl, m->nu * sizeof(mjtNum));
    memcpy(in + m->nu, r.qfrc_applied, m->nv * sizeof(mjtNum));
    memcpy(in + m->nu + m->nv, r.xfrc_applied, 6 * m->nbody * sizeof(mjtNum));
  } else {
    t->step_rec[k] = t->rec_bytes;
    if (appendRecords(t, c)) {
      return tapeFail(t, OST_ERR_MEMORY, "cannot grow the tape");
    }
    t->step_rec[k + 1] = t->rec_bytes;
  }
  t->nstep++;
  return status;
}


// re-run steps [k0, k1) from checkpoint k0 / S on the private mjData; their records replace
// recs, step_rec[k - k0] indexes them
static int recomputeSegment(ostTape* t, int k0, int k1) {
  const mjModel* m = t->m;
  mjData* d = t->scratch;
  ostContext* c = ost_context(m, d);
  const mjtNum* s = (const mjtNum*)((char*)t->ckpt + (k0 / t->checkpoint) * t->ckpt_sz);
  d->time = s[0];
  memcpy(d->qpos, s + 1, m->nq * sizeof(mjtNum));
  memcpy(d->qvel, s + 1 + m->nq, m->nv * sizeof(mjtNum));
  memcpy(d->qacc_warmstart, s + 1 + m->nq + m->nv, m->nv * sizeof(mjtNum));
  memcpy(d->act, s + 1 + m->nq + 2 * m->nv, m->na * sizeof(mjtNum));
  if (ost_warmLoad(c, s + 1 + m->nq + 2 * m->nv + m->na)) {
    return tapeFail(t, OST_ERR_MEMORY, ost_lastError(d));
  }
  t->rec_bytes = 0;
  for (int k = k0; k < k1; k++) {
    const mjtNum* in = t->inputs + (size_t)k * t->ninput;
    memcpy(d->ctrl, in, m->nu * sizeof(mjtNum));
    memcpy(d->qfrc_applied, in + m->nu, m->nv * sizeof(mjtNum));
    memcpy(d->xfrc_applied, in + m->nu + m->nv, 6 * m->nbody * sizeof(mjtNum));
    int status = ost_step(m, d);
    if (status && !OST_IS_WARNING(status)) {
      return tapeFail(t, status, ost_lastError(d));
    }
    t->step_rec[k - k0] = t->rec_bytes;
    if (appendRecords(t, c)) {
      return tapeFail(t, OST_ERR_MEMORY, "cannot grow the tape");
    }
  }
  t->step_rec[k1 - k0] = t->rec_bytes;
  return OST_OK;
}


int ost_tapeBackward(ostTape* t, const mjModel* m, const ostGradOptions* go, const mjtNum* gq,
                     const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0, mjtNum* gu0, mjtNum* gtheta) {
  if (!t) return -1;
  if (!m || m != t->m) return -2;
  ostGradOptions def;
  if (!go) {
    ost_defaultGradOptions(&def);
    go = &def;
  }
  int nv = m->nv, nu = m->nu, n = t->nstep, S = t->checkpoint;
  ostContext* c = ost_context(m, t->scratch);
  int status;
  if ((status = ost_prepareContext(c, m))) {
    return tapeFail(t, status, c->err);
  }
  // the records' rows need the contact capacity the recorded steps grew to
  if (t->ncon_cap > c->ncon_cap && ost_growCapacity(c, t->ncon_cap, c->njmax_cap)) {
    return tapeFail(t, OST_ERR_MEMORY, "cannot grow the contact capacity");
  }
  if (t->bad_step >= 0) {
    char msg[400];
    snprintf(msg, sizeof(msg), "step %d of the rollout did not converge (%s): no exact "
             "gradient; raise ostrich/newton_iter or lower h", t->bad_step, t->bad_err);
    return tapeFail(t, OST_ERR_NOT_CONVERGED, msg);
  }
  // running cotangent of (q, u, act): the activations carry the controls' effect to later steps
  mjtNum* g = (mjtNum*)calloc(2 * nv + m->na + 1, sizeof(mjtNum));
  if (!g) {
    return tapeFail(t, OST_ERR_MEMORY, "cannot allocate");
  }
  if (gctrl) {
    memset(gctrl, 0, (size_t)n * nu * sizeof(mjtNum));
  }

  // steps n-1 .. 0: add the loss's cotangent at the step's end, then pull back through it
  int seg_k0 = 0;
  for (int k = n - 1; k >= 0 && !status; k--) {
    if (S && (k == n - 1 || k < seg_k0)) {
      seg_k0 = k / S * S;
      status = recomputeSegment(t, seg_k0, k + 1);
      if (status) {
        break;
      }
    }
    int base = S ? seg_k0 : 0;
    for (int i = 0; i < nv; i++) {
      g[i] += gq ? gq[(size_t)(k + 1) * nv + i] : 0;
      g[nv + i] += gu ? gu[(size_t)(k + 1) * nv + i] : 0;
    }
    size_t r0 = t->step_rec[k - base], r1 = t->step_rec[k - base + 1];
    status = ost_recordsBackward(c, m, (char*)t->recs + r0, r1 - r0, go, g,
                                 gctrl ? gctrl + (size_t)k * nu : NULL, gtheta);
    if (status) {
      char msg[512];
      snprintf(msg, sizeof(msg), "step %d: %.480s", k, c->err);
      tapeFail(t, status, msg);
    }
  }
  for (int i = 0; i < nv && !status; i++) {
    if (gq0) gq0[i] = g[i] + (gq ? gq[i] : 0);
    if (gu0) gu0[i] = g[nv + i] + (gu ? gu[i] : 0);
  }
  free(g);
  return status;
}
