// ost_native_check.c: native geometry against MuJoCo at random configurations (the oracle of
// `ostrich check`). For each configuration it runs MuJoCo's mj_forward and core's kinematics,
// dynamics and collision on the same state and records the largest disagreement per quantity.
// Invariant: only the user's model is read; the comparison never changes the caller's mjData.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ost_collision.h"
#include "ost_internal.h"
#include "ost_kinematics.h"

// relative error |a - b| / max(1, |b|)
static double relErr(double a, double b) {
  double s = fabs(b) > 1 ? fabs(b) : 1;
  return fabs(a - b) / s;
}


// max relative error over n entries
static double maxRelErr(const mjtNum* a, const mjtNum* b, int n) {
  double e = 0;
  for (int i = 0; i < n; i++) {
    double x = relErr(a[i], b[i]);
    e = x > e || isnan(x) ? x : e;
  }
  return e;
}


// uniform in [lo, hi]
static double uniform(unsigned* seed, double lo, double hi) {
  *seed = *seed * 1103515245u + 12345u;
  return lo + (hi - lo) * ((*seed >> 8) & 0xffffff) / (double)0xffffff;
}


// a random configuration: hinge/slide in range (or +-1 around qpos0), unit quaternions, free
// positions within 0.3 m of qpos0; qvel in [-1, 1]
static void randomState(const mjModel* m, mjData* d, unsigned* seed) {
  for (int j = 0; j < m->njnt; j++) {
    mjtNum* q = d->qpos + m->jnt_qposadr[j];
    const mjtNum* q0 = m->qpos0 + m->jnt_qposadr[j];
    int t = m->jnt_type[j];
    if (t == mjJNT_FREE) {
      for (int k = 0; k < 3; k++) q[k] = q0[k] + uniform(seed, -0.3, 0.3);
      q += 3;  // then the quaternion
    }
    if (t == mjJNT_FREE || t == mjJNT_BALL) {
      for (int k = 0; k < 4; k++) q[k] = uniform(seed, -1, 1);
      mju_normalize4(q);
    } else {
      if (m->jnt_limited[j]) {
        q[0] = uniform(seed, m->jnt_range[2 * j], m->jnt_range[2 * j + 1]);
      } else {
        q[0] = q0[0] + uniform(seed, -1, 1);
      }
    }
  }
  for (int i = 0; i < m->nv; i++) {
    d->qvel[i] = uniform(seed, -1, 1);
  }
}


// 1 if MuJoCo 2.2.2 finds this pair of geom types analytically (else MPR: tolerance 1e-6)
static int analyticPair(int t1, int t2) {
  int lo = t1 < t2 ? t1 : t2, hi = t1 < t2 ? t2 : t1;
  if (lo == mjGEOM_PLANE) {
    return hi != mjGEOM_ELLIPSOID && hi != mjGEOM_MESH;
  }
  if (lo == mjGEOM_HFIELD || hi == mjGEOM_ELLIPSOID || hi == mjGEOM_CYLINDER
      || hi == mjGEOM_MESH) {
    return 0;
  }
  return 1;  // sphere, capsule, box among themselves
}


// 1 if contact pair (g1, g2) is (a, b) in either order; *sign -1 when swapped
static int samePair(int g1, int g2, int a, int b, double* sign) {
  *sign = g1 == a ? 1 : -1;
  return (g1 == a && g2 == b) || (g1 == b && g2 == a);
}


// compare contacts of d (MuJoCo) with k (native), pair by pair: the j-th contact of a pair in
// MuJoCo's list against the j-th of the same pair in native's (both keep the pair function's
// order); pairs with different counts count as unmatched. Contacts of an ostrich/terrain mesh
// are skipped (MuJoCo collides that mesh as its convex hull), and so are cylinder-box and
// height field-cylinder pairs: both providers collide them with Ostrich's own functions, not
// MuJoCo's MPR (checked against closed-form geometry in test_ost_collision_primitive and
// test_ost_collision_terrain, and by dual numbers in test_ost_dual).
static void compareContacts(const mjModel* m, const mjData* d, const ostModel* om,
                            const ostKin* k, ostNativeReport* r) {
  int terrain = ost_terrainGeom(m), unmatched = 0;
  for (int i = 0; i < d->ncon; i++) {
    const mjContact* c = d->contact + i;
    if (c->geom1 == terrain || c->geom2 == terrain || ost_corePair(m, c->geom1, c->geom2)) {
      continue;
    }
    r->ncontact++;
    int rank = 0, nmj = 0, nnat = 0, match = -1;
    double sign = 1, s;
    for (int j = 0; j < d->ncon; j++) {
      if (samePair(d->contact[j].geom1, d->contact[j].geom2, c->geom1, c->geom2, &s)) {
        rank += j < i;
        nmj++;
      }
    }
    for (int j = 0; j < k->ncon; j++) {
      int p = k->contact_pair[j];
      if (samePair(om->pair_geom1[p], om->pair_geom2[p], c->geom1, c->geom2, &s)) {
        if (nnat == rank) {
          match = j;
          sign = s;
        }
        nnat++;
      }
    }
    if (nnat != nmj || match < 0) {
      unmatched++;
      continue;
    }
    const ostContact* o = k->contact + match;
    int analytic = analyticPair(m->geom_type[c->geom1], m->geom_type[c->geom2]);
    double* e = analytic ? r->contact_analytic : r->contact_mpr;
    double ep = 0, en = 0;
    for (int a = 0; a < 3; a++) {
      ep = fmax(ep, fabs(o->pos[a] - c->pos[a]));
      en = fmax(en, fabs(sign * o->frame[a] - c->frame[a]));
    }
    e[0] = fmax(e[0], fabs(o->dist - c->dist));
    e[1] = fmax(e[1], en);
    e[2] = fmax(e[2], ep);
  }
  // native contacts of pairs MuJoCo did not report at all
  for (int j = 0; j < k->ncon; j++) {
    int p = k->contact_pair[j], found = 0;
    double s;
    if (om->pair_geom1[p] == terrain || om->pair_geom2[p] == terrain
        || ost_corePair(m, om->pair_geom1[p], om->pair_geom2[p])) {
      continue;
    }
    for (int i = 0; i < d->ncon && !found; i++) {
      found = samePair(d->contact[i].geom1, d->contact[i].geom2, om->pair_geom1[p],
                       om->pair_geom2[p], &s);
    }
    unmatched += !found;
  }
  r->contact_count = unmatched > r->contact_count ? unmatched : r->contact_count;
}


int ost_compareNative(const mjModel* m, int nstate, unsigned seed, ostNativeReport* r,
                      char* err, int err_sz) {
  if (!m) return -1;
  if (nstate < 0) return -2;
  if (!r) return -4;
  memset(r, 0, sizeof(*r));
  ostModel om;
  void* block = NULL;
  int status = ost_packModel(m, m->nconmax > 0 ? m->nconmax : 1000, &om, &block, err, err_sz);
  if (status) {
    return status;
  }
  mjData* d = mj_makeData(m);
  void* kbuf = aligned_alloc(64, OST_ALIGN64(ostu_kinSize(om.s)));
  int nv = m->nv;
  mjtNum* M = (mjtNum*)malloc(sizeof(mjtNum) * (nv * nv + 6 * nv + 1));
  if (!d || !kbuf || !M) {
    if (err) snprintf(err, err_sz, "out of memory");
    mj_deleteData(d);
    free(kbuf);
    free(M);
    free(block);
    return OST_ERR_MEMORY;
  }
  ostKin k;
  ostu_kinInit(&k, kbuf, om.s);
  mjtNum* jp = M + nv * nv;
  mjtNum* jr = jp + 3 * nv;

  // the keyframes, then random states
  for (int s = 0; s < m->nkey + nstate; s++) {
    if (s < m->nkey) {
      mj_resetDataKeyframe(m, d, s);
    } else {
      randomState(m, d, &seed);
    }
    mj_forward(m, d);
    osti_kinematics(&om, &k, d->qpos);
    for (int g = 0; g < m->ngeom; g++) {
      if (!om.geom_paired[g]) {
        osti_kinGeom(&om, &k, g);  // checked too, though steps never read them
      }
    }
    osti_comPos(&om, &k);
    osti_crb(&om, &k);
    osti_rne(&om, &k, d->qvel);
    osti_passive(&om, &k, d->qpos, d->qvel);
    osti_transmission(&om, &k, d->qpos);
    r->nstate++;

    // kinematics: positions and orientations (rotation matrices: quaternion sign is free)
    r->body_pos = fmax(r->body_pos, maxRelErr(k.xpos, d->xpos, 3 * m->nbody));
    r->body_pos = fmax(r->body_pos, maxRelErr(k.geom_xpos, d->geom_xpos, 3 * m->ngeom));
    r->body_rot = fmax(r->body_rot, maxRelErr(k.xmat, d->xmat, 9 * m->nbody));
    r->body_rot = fmax(r->body_rot, maxRelErr(k.geom_xmat, d->geom_xmat, 9 * m->ngeom));

    // dynamics: mass matrix, bias and passive forces, transmission
    mj_fullM(m, M, d->qM);
    r->mass_matrix = fmax(r->mass_matrix, maxRelErr(k.qM, M, nv * nv));
    r->bias = fmax(r->bias, maxRelErr(k.qfrc_bias, d->qfrc_bias, nv));
    r->passive = fmax(r->passive, maxRelErr(k.qfrc_passive, d->qfrc_passive, nv));
    r->actuator = fmax(r->actuator, maxRelErr(k.actuator_length, d->actuator_length, m->nu));
    r->actuator = fmax(r->actuator, maxRelErr(k.actuator_moment, d->actuator_moment, m->nu * nv));

    // Jacobians at every body's center of mass
    for (int b = 1; b < m->nbody; b++) {
      mj_jac(m, d, jp, jr, d->xipos + 3 * b, b);
      osti_jac(&om, &k, k.jac, k.jac + 3 * nv, d->xipos + 3 * b, b);
      r->jacobian = fmax(r->jacobian, maxRelErr(k.jac, jp, 3 * nv));
      r->jacobian = fmax(r->jacobian, maxRelErr(k.jac + 3 * nv, jr, 3 * nv));
    }
    // contacts from MuJoCo's geom poses: kinematics agree to round-off (checked above), and
    // MPR's result at deep penetration jumps with round-off in its input, so collision is
    // checked on identical inputs
    memcpy(k.geom_xpos, d->geom_xpos, 3 * m->ngeom * sizeof(mjtNum));
    memcpy(k.geom_xmat, d->geom_xmat, 9 * m->ngeom * sizeof(mjtNum));
    osti_collision(&om, &k);
    compareContacts(m, d, &om, &k, r);
  }

  // verdict: kinematics/dynamics 1e-10 relative, analytic contacts 1e-9, MPR contacts 1e-6
  double kin = fmax(fmax(fmax(r->body_pos, r->body_rot), fmax(r->mass_matrix, r->bias)),
                    fmax(fmax(r->passive, r->actuator), r->jacobian));
  r->ok = kin <= 1e-10 && r->contact_count == 0 && r->contact_analytic[0] <= 1e-9
          && r->contact_analytic[1] <= 1e-9 && r->contact_analytic[2] <= 1e-9
          && r->contact_mpr[0] <= 1e-6 && r->contact_mpr[1] <= 1e-6 && r->contact_mpr[2] <= 1e-6;
  mj_deleteData(d);
  free(kbuf);
  free(M);
  free(block);
  return OST_OK;
}
