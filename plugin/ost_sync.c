// ost_sync.c: the private model follows the user's model without a copy per step (core/README.md
// section 4, "The private model"). A step reads the user's mjModel through a private copy whose
// margins are widened by the look-ahead distance. Users edit mjModel fields between steps
// (masses, friction, gains, height fields), so the copy must follow them; copying the whole
// model every step (textures and meshes included) cost most of a step on small models.
// Instead, the arrays a step reads are compared, per step, with a shadow of their values at the
// last synchronisation; only arrays that differ are copied, and only then is the model checked
// and packed again. Arrays no step reads (names, textures, materials, skins, cameras, lights,
// keyframes, user data) and the mesh arrays (large; read when the model is packed) are not
// compared: after editing a mesh call ost_modelChanged.
#include <stdlib.h>
#include <string.h>

#include <mujoco/mjxmacro.h>

#include "ost_internal.h"

// 1 if mjModel array `name` is compared per step
static int tracked(const char* name) {
  static const char* skip[] = {"name_", "names", "tex_", "mat_", "skin_", "cam_", "light_",
                               "key_", "mesh_", "paths"};
  for (size_t i = 0; i < sizeof(skip) / sizeof(skip[0]); i++) {
    if (!strncmp(name, skip[i], strlen(skip[i]))) {
      return 0;
    }
  }
  size_t n = strlen(name);
  // *_user (user data) and *_rgba (colours) are read by no step
  return !(n > 5 && (!strcmp(name + n - 5, "_user") || !strcmp(name + n - 5, "_rgba")));
}


// the byte ranges of m->buffer that are compared (adjacent tracked arrays merged) into
// c->sync_range, and the shadow they are kept in
static int buildRanges(ostContext* c, const mjModel* m) {
  MJMODEL_POINTERS_PREAMBLE(m)
  int n = 0, cap = 0;
  ostSyncRange* r = NULL;
  const char* base = (const char*)m->buffer;
#define X(type, name, nr, nc)                                                              \
  if (tracked(#name) && m->nr * (nc) > 0) {                                                \
    size_t off = (size_t)((const char*)m->name - base);                                    \
    size_t sz = sizeof(type) * (size_t)m->nr * (size_t)(nc);                               \
    if (n > 0 && r[n - 1].off + r[n - 1].sz == off) {                                      \
      r[n - 1].sz += sz;                                                                   \
    } else {                                                                               \
      if (n == cap) {                                                                      \
        cap = cap ? 2 * cap : 64;                                                          \
        ostSyncRange* g = (ostSyncRange*)realloc(r, cap * sizeof(ostSyncRange));           \
        if (!g) {                                                                          \
          free(r);                                                                         \
          return OST_ERR_MEMORY;                                                           \
        }                                                                                  \
        r = g;                                                                             \
      }                                                                                    \
      r[n].off = off;                                                                      \
      r[n].sz = sz;                                                                        \
      n++;                                                                                 \
    }                                                                                      \
  }
  MJMODEL_POINTERS
#undef X
  size_t total = 0;
  for (int i = 0; i < n; i++) {
    total += r[i].sz;
  }
  free(c->sync_range);
  free(c->sync_shadow);
  c->sync_range = r;
  c->sync_n = n;
  c->sync_shadow = (char*)malloc(total ? total : 1);
  c->sync_sz = total;
  return c->sync_shadow ? OST_OK : OST_ERR_MEMORY;
}


// the private model's own edits after any copy from the user's model: no body or dof is
// "simple" (MuJoCo fills the mass matrix of simple bodies from dof_M0, set once at load time,
// so an edited body_mass would change gravity but not M; the private model's CRB follows edits)
static void privateEdits(mjModel* mo) {
  memset(mo->dof_simplenum, 0, mo->nv * sizeof(int));
  memset(mo->body_simple, 0, mo->nbody * sizeof(mjtByte));
}


int ost_syncModel(ostContext* c, const mjModel* m) {
  const char* src = (const char*)m->buffer;
  if (!c->mo || c->model_dirty || !c->sync_shadow) {
    // first step, or the user said the model changed: a full copy
    c->mo = mj_copyModel(c->mo, m);
    if (!c->mo || buildRanges(c, m)) {
      return ost_fail(c, OST_ERR_MEMORY, "cannot copy the model");
    }
    char* s = c->sync_shadow;
    for (int i = 0; i < c->sync_n; i++) {
      memcpy(s, src + c->sync_range[i].off, c->sync_range[i].sz);
      s += c->sync_range[i].sz;
    }
    c->sync_opt = m->opt;
    privateEdits(c->mo);
    return 1;
  }
  int changed = 0;
  if (memcmp(&c->sync_opt, &m->opt, sizeof(mjOption))) {
    c->sync_opt = m->opt;
    c->mo->opt = m->opt;
    changed = 1;
  }
  char* s = c->sync_shadow;
  char* dst = (char*)c->mo->buffer;
  for (int i = 0; i < c->sync_n; i++) {
    size_t off = c->sync_range[i].off, sz = c->sync_range[i].sz;
    if (memcmp(s, src + off, sz)) {
      memcpy(s, src + off, sz);
      memcpy(dst + off, src + off, sz);
      changed = 1;
    }
    s += sz;
  }
  if (changed) {
    privateEdits(c->mo);
  }
  return changed;
}
