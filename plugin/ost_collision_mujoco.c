// ost_collision_mujoco.c: MuJoCo 2.2.2's mj_collision for the Newton iterates of a step, with
// its broadphase done once for many iterates (core/README.md section 4, "Collision of the
// iterates").
//
// The `mujoco` provider evaluates MuJoCo's collision at every Newton trial (6-7 per step on a
// falling humanoid); each call sorts the bodies' boxes along the principal axes of the geoms
// (mju_eig3 and two qsorts) and runs the filters of every body pair the world or a plane body
// pairs with, most of which reject. Here the geom pairs that can touch within a slack s are
// listed once, at reference positions; while every geom stays within s of its reference, the
// pairs MuJoCo's narrow phase would accept are all on the list, and they are collided in
// MuJoCo's order. The result is MuJoCo's contact list bit for bit (tests/test_ost_collision.c
// compares every field with mj_collision's), because:
// - a dynamic pair yields contacts only if its bounding spheres, grown by the pair's margin,
//   overlap (or, with a plane, the other geom's sphere reaches the plane's margin); a pair
//   that does overlaps in every frame the broadphase could pick, so the broadphase's list
//   decides only which rejected pairs are tried, never which contacts come out; the world's
//   geoms without a bounding sphere (MuJoCo 2.2.2 gives a height field none) pair with every
//   body whatever the frame, and are listed with every geom;
// - contacts come out ordered by body-pair signature, then by geom within each body, with
//   explicit <pair>s merged by signature; the list keeps that order.
// Models where the broadphase's frame does decide (a margin override, a geom without a
// bounding sphere off the world body, a plane or height field on a static body other than the
// world, a user contact filter) take mj_collision itself.
// With skip_core the pairs that core collides with its own functions (ost_corePair: cylinder-box,
// plane-cylinder, box-box, height fields, plane-mesh) are left out, listed or not: the steps
// replace their MuJoCo contacts by core's, so colliding them (libccd's MPR for a cylinder on a
// box, 9 % of a wheeled robot's step) was wasted. The other contacts keep MuJoCo's order and bits.
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ost_internal.h"

// reference positions are checked against 0.99 s so that the list, built at 2 s, keeps a margin
// far above rounding
#define OST_SLACK_USE 0.99

// 1 if m's contacts do not depend on the broadphase's frame (see the file comment)
static int eligible(const mjModel* m) {
  if (m->opt.collision == mjCOL_PAIR || (m->opt.enableflags & mjENBL_OVERRIDE)
      || m->ngeom >= 65536 || m->nbody >= 65536) {
    return 0;
  }
  for (int g = 0; g < m->ngeom; g++) {
    int b = m->geom_bodyid[g], type = m->geom_type[g];
    if (!(m->geom_rbound[g] > 0) && b != 0) {
      return 0;  // MuJoCo's sweep gives it a box of its margin alone
    }
    // a static body other than the world with a plane or height field pairs with every body
    // in MuJoCo's broadphase and again in its sweep, where its box overlaps
    if (b > 0 && m->body_weldid[b] == 0 && (type == mjGEOM_PLANE || type == mjGEOM_HFIELD)) {
      return 0;
    }
  }
  return 1;
}


// MuJoCo's signature of the body pair (b1 < b2)
static int signature(int b1, int b2) {
  return ((b1 + 1) << 16) + (b2 + 1);
}


// the first index of the ascending array a (n) whose value is at least v (MuJoCo's compiler
// sorts exclude and pair signatures, and mj_collision's merge relies on it)
static int firstAtLeast(const int* a, int n, int v) {
  int lo = 0, hi = n;
  while (lo < hi) {
    int mid = (lo + hi) / 2;
    if (a[mid] < v) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo;
}


// 1 if the dynamic pair (g1, g2) of different bodies passes MuJoCo's position-independent
// filters: a collision function, contype/conaffinity, weld and parent filters, <exclude>, and
// not an explicit <pair> of the same geoms (which is collided as the pair instead)
static int pairAdmissible(const mjModel* m, int g1, int g2) {
  int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
  if (!(t1 <= t2 ? mjCOLLISIONFUNC[t1][t2] : mjCOLLISIONFUNC[t2][t1])) {
    return 0;
  }
  if (!(m->geom_contype[g1] & m->geom_conaffinity[g2])
      && !(m->geom_contype[g2] & m->geom_conaffinity[g1])) {
    return 0;
  }
  int b1 = m->geom_bodyid[g1], b2 = m->geom_bodyid[g2];
  int w1 = m->body_weldid[b1], w2 = m->body_weldid[b2];
  if (w1 == w2) {
    return 0;
  }
  int p1 = m->body_weldid[m->body_parentid[w1]], p2 = m->body_weldid[m->body_parentid[w2]];
  if (!(m->opt.disableflags & mjDSBL_FILTERPARENT) && w1 && w2 && (w1 == p2 || w2 == p1)) {
    return 0;
  }
  int sig = b1 < b2 ? signature(b1, b2) : signature(b2, b1);
  int e = firstAtLeast(m->exclude_signature, m->nexclude, sig);
  if (e < m->nexclude && m->exclude_signature[e] == sig) {
    return 0;
  }
  if (m->opt.collision == mjCOL_ALL) {
    for (int p = firstAtLeast(m->pair_signature, m->npair, sig);
         p < m->npair && m->pair_signature[p] == sig; p++) {
      if ((m->pair_geom1[p] == g1 && m->pair_geom2[p] == g2)
          || (m->pair_geom1[p] == g2 && m->pair_geom2[p] == g1)) {
        return 0;
      }
    }
  }
  return 1;
}


// append the dynamic pair (ga, gb) with its sort key: signature, then the geom of the lower body,
// then the other (MuJoCo's loops)
static int addCandidate(ostCollisionCache* k, const mjModel* m, int ga, int gb) {
  int ba = m->geom_bodyid[ga], bb = m->geom_bodyid[gb];
  if (ba > bb) {
    int t = ga;
    ga = gb;
    gb = t;
    t = ba;
    ba = bb;
    bb = t;
  }
  if (k->ncand == k->cap) {
    int cap = k->cap ? 2 * k->cap : 64;
    uint64_t* g = (uint64_t*)realloc(k->cand, cap * sizeof(uint64_t));
    if (!g) {
      return 1;
    }
    k->cand = g;
    k->cap = cap;
  }
  k->cand[k->ncand++] = ((uint64_t)signature(ba, bb) << 32) | ((uint64_t)ga << 16) | (uint64_t)gb;
  return 0;
}


static int compareKeys(const void* a, const void* b) {
  uint64_t x = *(const uint64_t*)a, y = *(const uint64_t*)b;
  return x < y ? -1 : x > y;
}


// the half-width of geom g's box on the sweep axis: its bounding sphere grown by its margin and
// the slack (a pair's margin, the larger of the two, is at most the sum of both)
static mjtNum reach(const mjModel* m, int g, mjtNum s) {
  return m->geom_rbound[g] + m->geom_margin[g] + s;
}


// 1 if pair (g1, g2) is left out (skip_core)
static int skipped(const ostCollisionCache* k, const mjModel* m, int g1, int g2) {
  return k->skip_core && ost_corePair(m, g1, g2);
}


// list the dynamic pairs that can touch while every geom stays within s of its position in d:
// planes (static, on the world) against every geom whose sphere comes within its margin + 2 s
// of the plane; other geoms by a sweep along x over their spheres grown by margin and slack
static int buildList(ostCollisionCache* k, const mjModel* m, const mjData* d) {
  int ng = m->ngeom;
  mjtNum s = k->slack;
  k->ncand = 0;
  // the sweep order, kept from the last build (nearly sorted: insertion sort)
  int n = 0;
  for (int i = 0; i < ng; i++) {
    int g = k->order[i];
    if (m->geom_rbound[g] > 0) {
      mjtNum lo = d->geom_xpos[3 * g] - reach(m, g, s);
      int j = n++;
      for (; j > 0 && d->geom_xpos[3 * k->order[j - 1]] - reach(m, k->order[j - 1], s) > lo;
           j--) {
        k->order[j] = k->order[j - 1];
      }
      k->order[j] = g;
    }
  }
  for (int g = 0, p = n; g < ng; g++) {
    if (!(m->geom_rbound[g] > 0)) {
      k->order[p++] = g;  // the world's unbounded geoms after the sweep's
    }
  }
  for (int a = 0; a < n; a++) {
    int ga = k->order[a];
    const mjtNum* xa = d->geom_xpos + 3 * ga;
    mjtNum ra = reach(m, ga, s), hi = xa[0] + ra;
    for (int b = a + 1; b < n; b++) {
      int gb = k->order[b];
      const mjtNum* xb = d->geom_xpos + 3 * gb;
      mjtNum rb = reach(m, gb, s);
      if (xb[0] - rb > hi) {
        break;
      }
      mjtNum dy = xa[1] - xb[1], dz = xa[2] - xb[2], r = ra + rb;
      if (dy > r || dy < -r || dz > r || dz < -r || m->geom_bodyid[ga] == m->geom_bodyid[gb]) {
        continue;
      }
      mjtNum dx = xa[0] - xb[0];
      if (dx * dx + dy * dy + dz * dz <= r * r && !skipped(k, m, ga, gb)
          && pairAdmissible(m, ga, gb) && addCandidate(k, m, ga, gb)) {
        return 1;
      }
    }
  }
  for (int p = n; p < ng; p++) {
    // a plane: the geoms whose spheres come within reach of it; another unbounded geom of the
    // world (a height field: no sphere filter in MuJoCo, whose broadphase pairs the world with
    // every body): every geom
    int gp = k->order[p], plane = m->geom_type[gp] == mjGEOM_PLANE;
    const mjtNum* xp = d->geom_xpos + 3 * gp;
    const mjtNum* R = d->geom_xmat + 9 * gp;
    for (int a = 0; a < n; a++) {
      int g = k->order[a];
      const mjtNum* x = d->geom_xpos + 3 * g;
      mjtNum dist = (x[0] - xp[0]) * R[2] + (x[1] - xp[1]) * R[5] + (x[2] - xp[2]) * R[8];
      if ((!plane || dist <= reach(m, g, 2 * s) + m->geom_margin[gp]) && !skipped(k, m, gp, g)
          && pairAdmissible(m, gp, g) && addCandidate(k, m, gp, g)) {
        return 1;
      }
    }
  }
  if (k->ncand > 1) {
    qsort(k->cand, k->ncand, sizeof(uint64_t), compareKeys);
  }
  memcpy(k->ref, d->geom_xpos, 3 * (size_t)ng * sizeof(mjtNum));
  k->builds++;
  return 0;
}


// 1 if every geom is within the slack of its reference position
static int listValid(const ostCollisionCache* k, const mjModel* m, const mjData* d) {
  mjtNum lim = OST_SLACK_USE * k->slack;
  lim *= lim;
  for (int i = 0; i < 3 * m->ngeom; i += 3) {
    mjtNum dx = d->geom_xpos[i] - k->ref[i], dy = d->geom_xpos[i + 1] - k->ref[i + 1];
    mjtNum dz = d->geom_xpos[i + 2] - k->ref[i + 2];
    if (!(dx * dx + dy * dy + dz * dz <= lim)) {
      return 0;
    }
  }
  return 1;
}


// MuJoCo 2.2.2's completion of a contact frame whose normal the collision function set
// (mju_makeFrame): the normal normalized; the first tangent the function's hint if it set one,
// else e_y, or e_z near e_y; made orthogonal to the normal; the second their cross product.
// Returns 1 where MuJoCo would raise its error (the normal undefined).
static int completeFrame(mjtNum frame[9]) {
  if (mju_normalize3(frame) < 0.5) {
    return 1;
  }
  if (mju_norm3(frame + 3) < 0.5) {
    mju_zero3(frame + 3);
    if (frame[1] < 0.5 && frame[1] > -0.5) {
      frame[4] = 1;
    } else {
      frame[5] = 1;
    }
  }
  mjtNum along[3];
  mju_scl3(along, frame, mju_dot3(frame, frame + 3));
  mju_subFrom3(frame + 3, along);
  mju_normalize3(frame + 3);
  mju_cross(frame + 6, frame, frame + 3);
  return 0;
}


// 1 if the geom g2's sphere (radius r2) is farther than margin + r2 from plane g1's surface
static int beyondPlane(const mjData* d, int g1, int g2, mjtNum bound) {
  const mjtNum* R = d->geom_xmat + 9 * g1;
  mjtNum normal[3] = {R[2], R[5], R[8]}, dif[3];
  mju_sub3(dif, d->geom_xpos + 3 * g2, d->geom_xpos + 3 * g1);
  return mju_dot3(dif, normal) > bound;
}


void ost_contactPairParams(const mjModel* m, int g1, int g2, int ipair, mjtNum friction[5],
                           mjtNum solref[mjNREF], mjtNum solimp[mjNIMP]) {
  if (ipair >= 0) {
    mju_copy(friction, m->pair_friction + 5 * ipair, 5);
    mju_copy(solref, m->pair_solref + mjNREF * ipair, mjNREF);
    mju_copy(solimp, m->pair_solimp + mjNIMP * ipair, mjNIMP);
  } else {
    // friction: the higher priority geom's, else the larger, 3 coefficients unpacked to 5
    mjtNum fr[3];
    ost_mixFriction(m, g1, g2, fr);
    mjtNum unpacked[5] = {fr[0], fr[0], fr[1], fr[2], fr[2]};
    mju_copy(friction, unpacked, 5);
    if (m->geom_priority[g1] != m->geom_priority[g2]) {
      int gp = m->geom_priority[g1] > m->geom_priority[g2] ? g1 : g2;
      mju_copy(solref, m->geom_solref + mjNREF * gp, mjNREF);
      mju_copy(solimp, m->geom_solimp + mjNIMP * gp, mjNIMP);
    } else {
      // the solver mix: by solmix where both are set, else 1/2, or all to the one set
      mjtNum s1 = m->geom_solmix[g1], s2 = m->geom_solmix[g2], mix;
      if (s1 >= mjMINVAL && s2 >= mjMINVAL) {
        mix = s1 / (s1 + s2);
      } else if (s1 < mjMINVAL && s2 < mjMINVAL) {
        mix = 0.5;
      } else {
        mix = s1 < mjMINVAL ? 0.0 : 1.0;
      }
      const mjtNum* ref1 = m->geom_solref + mjNREF * g1;
      const mjtNum* ref2 = m->geom_solref + mjNREF * g2;
      for (int i = 0; i < mjNREF; i++) {
        // positive: stiffness and damping mixed; direct (negative): the smaller
        solref[i] = ref1[0] > 0 && ref2[0] > 0 ? mix * ref1[i] + (1 - mix) * ref2[i]
                                               : mju_min(ref1[i], ref2[i]);
      }
      mju_scl(solimp, m->geom_solimp + mjNIMP * g1, mix, mjNIMP);
      mju_addToScl(solimp, m->geom_solimp + mjNIMP * g2, 1 - mix, mjNIMP);
    }
  }
  for (int i = 0; i < 5; i++) {
    friction[i] = mju_max(mjMINMU, friction[i]);
  }
}


// MuJoCo 2.2.2's mj_collideGeoms for a dynamic pair (g1, g2; ipair -1) whose static filters
// passed, or for explicit pair ipair: margin, bounding-sphere and plane filters, the collision
// function, box-box duplicates removed, mixed parameters, then mj_addContact. Returns 1 where
// MuJoCo would raise an error (the caller then lets mj_collision raise it).
static int collidePair(const mjModel* m, mjData* d, int g1, int g2, int ipair) {
  mjContact con[mjMAXCONPAIR];
  if (ipair >= 0) {
    g1 = m->pair_geom1[ipair];
    g2 = m->pair_geom2[ipair];
  }
  if (m->geom_type[g1] > m->geom_type[g2]) {
    int t = g1;
    g1 = g2;
    g2 = t;
  }
  int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
  mjfCollision collide = mjCOLLISIONFUNC[t1][t2];
  if (!collide) {
    return 0;
  }
  mjtNum margin, gap, friction[5], solref[mjNREF], solimp[mjNIMP];
  int condim;
  if (ipair < 0) {
    margin = mju_max(m->geom_margin[g1], m->geom_margin[g2]);
    gap = mju_max(m->geom_gap[g1], m->geom_gap[g2]);
    if (m->geom_priority[g1] != m->geom_priority[g2]) {
      condim = m->geom_condim[m->geom_priority[g1] > m->geom_priority[g2] ? g1 : g2];
    } else {
      condim = m->geom_condim[g1] > m->geom_condim[g2] ? m->geom_condim[g1] : m->geom_condim[g2];
    }
  } else {
    margin = m->pair_margin[ipair];
    gap = m->pair_gap[ipair];
    condim = m->pair_dim[ipair];
  }
  mjtNum r1 = m->geom_rbound[g1], r2 = m->geom_rbound[g2];
  if (r1 > 0 && r2 > 0 && mju_dist3(d->geom_xpos + 3 * g1, d->geom_xpos + 3 * g2) > r1 + r2 + margin) {
    return 0;
  }
  if ((t1 == mjGEOM_PLANE && r2 > 0 && beyondPlane(d, g1, g2, margin + r2))
      || (t2 == mjGEOM_PLANE && r1 > 0 && beyondPlane(d, g2, g1, margin + r1))) {
    return 0;
  }
  int num = collide(m, d, con, g1, g2, margin);
  if (!num) {
    return 0;
  }
  if (num > mjMAXCONPAIR || condim > 6 || condim < 1) {
    return 1;
  }
  if (t1 == mjGEOM_BOX && t2 == mjGEOM_BOX) {
    // box-box can return one point twice: keep the last of equal positions
    int kept = 0;
    for (int i = 0; i < num; i++) {
      int repeated = 0;
      for (int j = i + 1; j < num && !repeated; j++) {
        repeated = con[i].pos[0] == con[j].pos[0] && con[i].pos[1] == con[j].pos[1]
                   && con[i].pos[2] == con[j].pos[2];
      }
      if (!repeated) {
        if (kept < i) {
          con[kept] = con[i];
        }
        kept++;
      }
    }
    num = kept;
  }
  ost_contactPairParams(m, g1, g2, ipair, friction, solref, solimp);
  for (int i = 0; i < num; i++) {
    mjContact* c = con + i;
    c->dim = condim;
    c->geom1 = g1;
    c->geom2 = g2;
    c->includemargin = margin - gap;
    mju_copy(c->friction, friction, 5);
    mju_copy(c->solref, solref, mjNREF);  // no override: MuJoCo's mj_assignRef copies
    mju_copy(c->solimp, solimp, mjNIMP);
    c->exclude = c->dist < c->includemargin ? 0 : 1;  // in the gap: excluded
    if (completeFrame(c->frame)) {
      return 1;
    }
    c->efc_address = -1;
    c->mu = 0;
    mju_zero(c->H, 36);
    if (mj_addContact(m, d, c)) {
      return 0;  // full: MuJoCo warned; the pair's remaining contacts are dropped, as there
    }
  }
  return 0;
}


// 1 if the bounding spheres of the dynamic pair (ga, gb), grown by the pair's margin, are
// apart by more than rounding could blur: then mj_collideGeoms' own test (mju_dist3 against
// r1 + r2 + margin) rejects the pair too, and its call is saved (most listed pairs of a pile of
// particles). Pairs with a plane are left to that test.
static int spheresApart(const mjModel* m, const mjData* d, int ga, int gb) {
  mjtNum ra = m->geom_rbound[ga], rb = m->geom_rbound[gb];
  if (!(ra > 0 && rb > 0)) {
    return 0;
  }
  mjtNum ma = m->geom_margin[ga], mb = m->geom_margin[gb];
  mjtNum r = ra + rb + (ma > mb ? ma : mb);
  const mjtNum *a = d->geom_xpos + 3 * ga, *b = d->geom_xpos + 3 * gb;
  mjtNum dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz > r * r * (1 + 1e-9);
}


// the cached collision; 1 where MuJoCo would raise an error
static int collideListed(const mjModel* m, mjData* d, const ostCollisionCache* k) {
  int merge = m->opt.collision == mjCOL_ALL, pairadr = 0;
  for (int i = 0; i < k->ncand; i++) {
    int sig = (int)(k->cand[i] >> 32);
    while (merge && pairadr < m->npair && m->pair_signature[pairadr] <= sig) {
      if (!skipped(k, m, m->pair_geom1[pairadr], m->pair_geom2[pairadr])
          && collidePair(m, d, pairadr, -1, pairadr)) {
        return 1;
      }
      pairadr++;
    }
    int ga = (int)((k->cand[i] >> 16) & 0xFFFF), gb = (int)(k->cand[i] & 0xFFFF);
    if (!spheresApart(m, d, ga, gb) && collidePair(m, d, ga, gb, -1)) {
      return 1;
    }
  }
  while (merge && pairadr < m->npair) {
    if (!skipped(k, m, m->pair_geom1[pairadr], m->pair_geom2[pairadr])
        && collidePair(m, d, pairadr, -1, pairadr)) {
      return 1;
    }
    pairadr++;
  }
  return 0;
}


void ost_collisionReset(ostCollisionCache* k) {
  k->state = 0;
  k->ncand = 0;
}


void ost_collisionFree(ostCollisionCache* k) {
  free(k->cand);
  free(k->ref);
  free(k->order);
  memset(k, 0, sizeof(*k));
}


// the model's length scale: the mean bounding radius of the geoms that have one
static mjtNum scaleOf(const mjModel* m) {
  mjtNum sum = 0;
  int n = 0;
  for (int g = 0; g < m->ngeom; g++) {
    if (m->geom_rbound[g] > 0) {
      sum += m->geom_rbound[g];
      n++;
    }
  }
  return n ? sum / n : 0;
}


// mj_collision, less the pairs skip_core leaves out
static void collisionAll(const ostCollisionCache* k, const mjModel* m, mjData* d) {
  mj_collision(m, d);
  if (!k->skip_core) {
    return;
  }
  int n = 0;
  for (int i = 0; i < d->ncon; i++) {
    if (!skipped(k, m, d->contact[i].geom1, d->contact[i].geom2)) {
      d->contact[n++] = d->contact[i];
    }
  }
  d->ncon = n;
}


void ost_collision(ostCollisionCache* k, const mjModel* m, mjData* d) {
  if (k->state == 0) {
    // first use since the model changed: decide, and size the arrays
    k->state = -1;
    if (eligible(m)) {
      free(k->ref);
      free(k->order);
      k->ref = (mjtNum*)malloc(3 * (size_t)m->ngeom * sizeof(mjtNum) + 1);
      k->order = (int*)malloc((size_t)m->ngeom * sizeof(int) + 1);
      k->scale = scaleOf(m);
      k->slack = 0.1 * k->scale;  // adapted as lists are built (ost_collision)
      if (k->ref && k->order && k->slack > 0) {
        for (int g = 0; g < m->ngeom; g++) {
          k->order[g] = g;
        }
        k->state = 1;
        k->built = 0;
      }
    }
  }
  d->ncon = 0;
  if (k->state < 0 || mjcb_contactfilter || (m->opt.disableflags & (mjDSBL_CONSTRAINT | mjDSBL_CONTACT))
      || m->nconmax == 0 || m->nbody < 2) {
    collisionAll(k, m, d);
    return;
  }
  if (!k->built || !listValid(k, m, d)) {
    // a list that served few collisions had too little slack for how far the geoms move
    // between them (fast bodies, long steps), one that served many more than it needed: the
    // slack is adapted within [0.05, 2] mean bounding radii. It decides how often the list is
    // built and how many pairs it holds, never which contacts come out.
    if (k->built && k->uses - k->uses_at_build < 8 && k->slack < 2 * k->scale) {
      k->slack *= 1.5;
    } else if (k->built && k->uses - k->uses_at_build > 256 && k->slack > 0.05 * k->scale) {
      k->slack /= 1.5;
    }
    k->built = 0;
    if (buildList(k, m, d)) {
      collisionAll(k, m, d);  // out of memory for the list
      return;
    }
    k->built = 1;
    k->uses_at_build = k->uses;
  }
  k->uses++;
  if (collideListed(m, d, k)) {
    d->ncon = 0;
    collisionAll(k, m, d);  // MuJoCo raises its error there
  }
}
