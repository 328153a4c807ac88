// ost_context.c: the registry that attaches Ostrich's state to an mjData (MuJoCo 2.2.2 has no
// plugin_data slot), plus the small accessors of ostrich.h. Mirrors engine_io.c's allocation.
// Invariant: the registry is guarded by one mutex; a context is rebuilt whenever its mjData's
// buffer or its model pointer changes, so a reused mjData address never sees stale state.
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ost_internal.h"

int ost_validateOptions(const ostOptions* opt, char* err, int err_sz);
int ost_optionsEqual(const ostOptions* a, const ostOptions* b);

static pthread_mutex_t registry_lock = PTHREAD_MUTEX_INITIALIZER;
static ostContext* registry = NULL;


static void freeContext(ostContext* c) {
  if (c->dg) {
    mj_deleteData(c->dg);
  }
  if (c->mo) {
    mj_deleteModel(c->mo);
  }
  free(c->servo);
  free(c->ten_implicit);
  free(c->ten_dt);
  free(c->qpos_prev);
  free(c->state_end);
  free(c->state_start);
  free(c->published);
  free(c->act_input);
  free(c->jac);
  free(c->world_buf);
  free(c->geo_buf);
  free(c->env_buf);
  free(c->dense_buf);
  free(c->native_block);
  free(c->corepairs_block);
  ost_collisionFree(&c->col);
  free(c->hfield_data);
  ost_meshFree(&c->mesh);
  free(c->sync_range);
  free(c->sync_shadow);
  free(c->kin_buf);
  ost_adjointFree(c);
  free(c);
}


int ost_rowCapacity(const mjModel* m) {
  return ost_rowCapacityFor(m, m->nconmax);
}


int ost_rowCapacityFor(const mjModel* m, int ncon) {
  // equality rows (weld: 6), two limit sides per joint and tendon, dry friction per dof and
  // tendon, a spring row per tendon, a contact's normal and friction rows, a servo per actuator
  int condim = 3;  // rows per contact: 1 + the friction rows of the largest condim
  for (int i = 0; i < m->ngeom; i++) {
    condim = m->geom_condim[i] > condim ? m->geom_condim[i] : condim;
  }
  for (int i = 0; i < m->npair; i++) {
    condim = m->pair_dim[i] > condim ? m->pair_dim[i] : condim;
  }
  return 6 * m->neq + 2 * m->njnt + 4 * m->ntendon + m->nv + condim * ncon + m->nu;
}


// dofs of the chains from the bodies in mark (nbody) to the root, marks cleared
static int chainDofs(const mjModel* m, unsigned char* mark) {
  int n = 0;
  for (int b = m->nbody - 1; b > 0; b--) {
    if (mark[b]) {
      n += m->body_dofnum[b];
      mark[m->body_parentid[b]] = 1;
      mark[b] = 0;
    }
  }
  mark[0] = 0;
  return n;
}


// the bodies whose motion moves tendon t (its joints' and sites' and geoms' bodies) into mark
static void tendonBodies(const mjModel* m, int t, unsigned char* mark) {
  for (int k = m->tendon_adr[t]; k < m->tendon_adr[t] + m->tendon_num[t]; k++) {
    int id = m->wrap_objid[k];
    switch (m->wrap_type[k]) {
    case mjWRAP_JOINT: mark[m->jnt_bodyid[id]] = 1; break;
    case mjWRAP_SITE:  mark[m->site_bodyid[id]] = 1; break;
    case mjWRAP_SPHERE:
    case mjWRAP_CYLINDER: mark[m->geom_bodyid[id]] = 1; break;
    default: break;
    }
  }
}


int ost_rowWidth(const mjModel* m) {
  int width = ostu_rowWidth(m->dof_parentid, m->nv);
  unsigned char* mark = (unsigned char*)calloc(m->nbody > 0 ? m->nbody : 1, 1);
  if (!mark) {
    return m->nv;
  }
  // a tendon row (equality between two tendons, an actuator on a tendon) spans its bodies'
  // chains; count both tendons of a tendon equality together
  for (int t = 0; t < m->ntendon; t++) {
    tendonBodies(m, t, mark);
    int n = chainDofs(m, mark);
    width = n > width ? n : width;
  }
  for (int e = 0; e < m->neq; e++) {
    if (m->eq_type[e] == mjEQ_TENDON) {
      tendonBodies(m, m->eq_obj1id[e], mark);
      if (m->eq_obj2id[e] >= 0) tendonBodies(m, m->eq_obj2id[e], mark);
      int n = chainDofs(m, mark);
      width = n > width ? n : width;
    }
  }
  free(mark);
  return width < m->nv ? width : m->nv;
}


int ost_growCapacity(ostContext* c, int ncon, int njmax) {
  const mjModel* m = c->m;
  int nrow_max = ost_rowCapacityFor(m, ncon);
  int ncol = ost_rowWidth(m);
  size_t sz = ostu_worldSize(m->nv, ncol, nrow_max);
  void* buf = aligned_alloc(64, (sz + 63) / 64 * 64);
  if (!buf) {
    return OST_ERR_MEMORY;
  }
  memset(buf, 0, sz);
  size_t gsz = ostu_geoSize(m->nv, ncol, nrow_max);
  size_t esz = ostu_envSize(m->nv, ncol, nrow_max);
  size_t dsz = ostu_denseLargeSize(m->nv, nrow_max);
  void* gbuf = aligned_alloc(64, (gsz + 63) / 64 * 64);
  void* ebuf = aligned_alloc(64, (esz + 63) / 64 * 64 + 64);
  void* dbuf = aligned_alloc(64, dsz + 64);
  if (!gbuf || !ebuf || !dbuf) {
    free(buf);
    free(gbuf);
    free(ebuf);
    free(dbuf);
    return OST_ERR_MEMORY;
  }
  free(c->world_buf);
  free(c->geo_buf);
  free(c->env_buf);
  free(c->dense_buf);
  c->world_buf = buf;
  c->geo_buf = gbuf;
  c->env_buf = ebuf;
  c->dense_buf = dbuf;
  ostu_worldInit(&c->world, c->world_buf, m->nv, ncol, nrow_max, 0);
  ostu_denseLargeInit(&c->world, c->dense_buf, nrow_max);
  ostu_geoInit(&c->geo, c->geo_buf, m->nv, ncol, nrow_max, 0);
  ostu_envInit(&c->env, c->env_buf, m->nv, ncol, nrow_max);
  c->ncon_cap = ncon;
  c->njmax_cap = njmax;
  c->warm_valid = 0;
  if (c->dg) {
    mj_deleteData(c->dg);
    c->dg = NULL;
  }
  c->native_dirty = 1;       // packed again with room for ncon contacts
  c->adj_model_block = NULL; // the adjoint's work is sized to the rows: made again
  return OST_OK;
}


mjData* ost_geometryData(ostContext* c) {
  if (!c->dg && c->mo) {
    // MuJoCo 2.2.2 sizes an mjData's contacts and constraint rows by the model's nconmax and
    // njmax: make it with the context's capacity, then give mo back the user's sizes
    int nconmax = c->mo->nconmax, njmax = c->mo->njmax;
    c->mo->nconmax = c->ncon_cap;
    c->mo->njmax = c->njmax_cap;
    c->dg = mj_makeData(c->mo);
    c->mo->nconmax = nconmax;
    c->mo->njmax = njmax;
    if (c->dg) {
      // MuJoCo prints a warning the first time it is counted: these overflows are Ostrich's to
      // answer (ost_rowsMujoco compares the counts), not the user's to read
      c->dg->warning[mjWARN_CONTACTFULL].number = 1;
      c->dg->warning[mjWARN_CNSTRFULL].number = 1;
    }
  }
  return c->dg;
}


// allocate a context for (m, d); options from the model, check deferred to the step
static ostContext* newContext(const mjModel* m, const mjData* d) {
  ostContext* c = (ostContext*)calloc(1, sizeof(ostContext));
  if (!c) {
    return NULL;
  }
  c->d = d;
  c->d_buffer = d->buffer;
  c->m = m;
  c->servo = (int*)calloc(m->nu > 0 ? m->nu : 1, sizeof(int));
  c->ten_implicit = (unsigned char*)calloc(m->ntendon > 0 ? m->ntendon : 1, 1);
  c->ten_dt = (mjtNum*)calloc(m->ntendon > 0 ? m->ntendon : 1, sizeof(mjtNum));
  c->qpos_prev = (mjtNum*)calloc(m->nq > 0 ? m->nq : 1, sizeof(mjtNum));
  c->jac = (mjtNum*)calloc(12 * (m->nv > 0 ? m->nv : 1), sizeof(mjtNum));
  c->state_end = (mjtNum*)calloc(1 + m->nq + 2 * m->nv + m->na, sizeof(mjtNum));
  c->state_start = (mjtNum*)calloc(1 + m->nq + 2 * m->nv + m->na, sizeof(mjtNum));
  c->act_input = (mjtNum*)calloc(m->nu + 2 * m->na + 1, sizeof(mjtNum));
  c->published = (mjtNum*)calloc(ost_publishedSize(m), sizeof(mjtNum));
  c->act_next = c->act_input + m->nu;
  if (!c->servo || !c->ten_implicit || !c->ten_dt || !c->qpos_prev || !c->state_end || !c->state_start || !c->jac
      || !c->act_input || !c->published || ost_growCapacity(c, m->nconmax, m->njmax)) {
    freeContext(c);
    return NULL;
  }
  ost_defaultOptions(&c->opt);
  c->model_dirty = 1;
  return c;
}


ostContext* ost_findContext(const mjData* d) {
  pthread_mutex_lock(&registry_lock);
  ostContext* c = registry;
  while (c && c->d != d) {
    c = c->next;
  }
  pthread_mutex_unlock(&registry_lock);
  return c;
}


// unlink and return the context of d (caller frees)
static ostContext* unlinkContext(const mjData* d) {
  ostContext** p = &registry;
  while (*p && (*p)->d != d) {
    p = &(*p)->next;
  }
  ostContext* c = *p;
  if (c) {
    *p = c->next;
  }
  return c;
}


ostContext* ost_context(const mjModel* m, const mjData* d) {
  pthread_mutex_lock(&registry_lock);
  ostContext* c = registry;
  while (c && c->d != d) {
    c = c->next;
  }
  // stale: same address, different buffer or model
  if (c && (c->d_buffer != d->buffer || c->m != m)) {
    c = unlinkContext(d);
    freeContext(c);
    c = NULL;
  }
  if (!c) {
    c = newContext(m, d);
    if (c) {
      c->next = registry;
      registry = c;
    }
  }
  pthread_mutex_unlock(&registry_lock);
  return c;
}


int ost_fail(ostContext* c, int status, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(c->err, sizeof(c->err), fmt, ap);
  va_end(ap);
  return status;
}


int ost_setOptions(const mjModel* m, mjData* d, const ostOptions* opt) {
  if (!m) return -1;
  if (!d) return -2;
  if (!opt) return -3;
  ostContext* c = ost_context(m, d);
  if (!c) {
    return OST_ERR_MEMORY;
  }
  int status = ost_validateOptions(opt, c->err, sizeof(c->err));
  if (status) {
    return status;
  }
  // margins, checks and packing depend on the options: the model is packed again when they
  // changed, not when the same options are set again (a tape sets its recorded run's options
  // on its private mjData at every rollout; each repack copied the whole model, textures
  // included, and cost more than a dm_control pendulum's 150-step backward pass)
  if (!c->opt_user || !ost_optionsEqual(&c->opt, opt)) {
    c->model_dirty = 1;
  }
  c->opt = *opt;
  c->opt_user = 1;
  return OST_OK;
}


void ost_modelChanged(const mjModel* m) {
  pthread_mutex_lock(&registry_lock);
  for (ostContext* c = registry; c; c = c->next) {
    if (c->m == m) {
      c->model_dirty = 1;
    }
  }
  pthread_mutex_unlock(&registry_lock);
}


const ostStats* ost_stats(const mjData* d) {
  ostContext* c = ost_findContext(d);
  return c ? &c->stats : NULL;
}


const ostTotals* ost_totals(const mjData* d) {
  ostContext* c = ost_findContext(d);
  return c ? &c->totals : NULL;
}


void ost_resetTotals(const mjData* d) {
  ostContext* c = ost_findContext(d);
  if (c) {
    memset(&c->totals, 0, sizeof(c->totals));
  }
}


const char* ost_lastError(const mjData* d) {
  ostContext* c = ost_findContext(d);
  return c ? c->err : "";
}


void ost_detach(const mjData* d) {
  pthread_mutex_lock(&registry_lock);
  ostContext* c = unlinkContext(d);
  pthread_mutex_unlock(&registry_lock);
  if (c) {
    freeContext(c);
  }
}


void ost_deleteData(mjData* d) {
  ost_detach(d);
  mj_deleteData(d);
}


double ost_penetrationWith(const mjModel* m, const mjData* d, const ostModel* pairs,
                           const ostNum* hfield_data, const ostMeshes* mesh) {
  double pen = 0;
  for (int i = 0; i < d->ncon; i++) {
    const mjContact* con = d->contact + i;
    if (con->exclude == 0 && !ost_corePair(m, con->geom1, con->geom2) && -con->dist > pen) {
      pen = -con->dist;
    }
  }
  // core pairs (cylinder-box, ellipsoid and ball pairs, height fields) by Ostrich's own functions
  // for every engine, so that runs compare on one measure (MuJoCo's MPR depth is inexact there)
  for (int p = 0; p < pairs->s.npair; p++) {
    ostContact con[OST_MAXCONPAIR];
    int n = ost_collideCorePair(m, d, hfield_data, mesh, pairs->pair_geom1[p],
                                pairs->pair_geom2[p], 0, con);
    for (int i = 0; i < n; i++) {
      pen = -con[i].dist > pen ? -con[i].dist : pen;
    }
  }
  return pen;
}


double ost_maxPenetration(const mjModel* m, const mjData* d) {
  ostModel pairs;
  void* block = NULL;
  ostNum* hdata = NULL;
  ostMeshes mesh;
  memset(&mesh, 0, sizeof(mesh));
  int hn = 0;
  if (ost_packCorePairs(m, &pairs, &block) != OST_OK || ost_hfieldData(m, &hdata, &hn) != OST_OK
      || ost_meshData(m, &mesh) != OST_OK) {
    pairs.s.npair = 0;  // out of memory: MuJoCo's contacts only
  }
  double pen = ost_penetrationWith(m, d, &pairs, hdata, &mesh);
  free(block);
  free(hdata);
  ost_meshFree(&mesh);
  return pen;
}


int ost_capacityFail(ostContext* c, const char* what, int cap) {
  c->overflow_cap = strcmp(what, "constraint") ? 1 : 2;
  return ost_fail(c, OST_ERR_OVERFLOW, "%s capacity exceeded: more than %d with the look-ahead",
                  what, cap);
}
