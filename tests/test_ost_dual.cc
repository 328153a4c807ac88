// test_ost_dual.cc: core/ compiled as C++ with ostNum = ostDual<8> (core/ost_dual.h). The dual
// arithmetic and math functions against analytic derivatives; the dual model against the
// double one; then the derivatives of core's native kinematics, dynamics and collision with
// respect to qpos (and qvel) against central finite differences of the same functions' values:
// kinematics on wheeled_robot.xml and MuJoCo's humanoid, contacts on wheeled_robot.xml (plane :
// cylinder) and robot_pallet.xml with wheels on the pallet's edge and on its top (cylinder : box
// by MPR; MPR is checked on the face only, see test_palletEdge).
// Directions are the tangent directions of qpos, one per dof: the differences step by
// mj_integratePos (a ball or free rotation q becomes q (x) exp(h e_k / 2)), the duals are seeded
// with the same first-order motion (slide, hinge, translation: d qpos = e_k; rotation:
// d q = q (x) (0, e_k / 2)). The error of a quantity is its Jacobian's error in the max norm,
// relative where the Jacobian exceeds 1 (SI units: N, kg m^2, m or 1 per m or rad):
// max |dual - fd| / max(1, max(|dual|, |fd|)) over its entries, directions and configurations.
#include "ost_dual.h"

#define ND 8                      // directions per dual pass
#define OST_NUM_TYPE ostDual<ND>  // before any core header

#include "ost_collision.h"
#include "ost_kinematics.h"
#include "ost_model.h"

#include <check.h>
#include <mujoco/mujoco.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <type_traits>
#include <vector>

extern "C" {
#include "fixture.h"

// plugin/ost_internal.h's packer (libostrich, ostNum = double): its ostModel is this TU's
// ostModelDouble. Declared here: ost_internal.h would bring core's headers with the double type.
int ost_packModel(const mjModel* m, int ncon_max, struct ostModelDouble* om, void** block,
                  char* err, int err_sz);
}

typedef ostDual<ND> Dual;
static_assert(std::is_same<ostNum, Dual>::value, "core is compiled with the dual type");

#define H 1e-6          // finite-difference step (m, rad)
// TOL_KIN, TOL_CON: regression baselines (measured: at most 2.7e-8 and 1.9e-10 at the time of
// writing) kept above central differences' round-off at H, 1e-16 / H = 1e-10 relative
#define TOL_KIN 1e-6    // kinematics and dynamics
#define TOL_CON 1e-5    // contacts (analytic pairs; MPR on a face, see test_palletEdge)
#define NCONF 6         // configurations per model: the reference pose, then random ones
#define NQMAX 8         // quantities compared at most


//---------------------------------- helpers ------------------------------------------------------

// |a - b| within tol relative to max(1, |b|)
static int near(double a, double b, double tol) {
  return fabs(a - b) <= tol * fmax(1.0, fabs(b));
}


// running max |dual - fd| and max(|dual|, |fd|) of each compared quantity; its error is
// max |dual - fd| / max(1, max(|dual|, |fd|))
struct Agreement {
  double diff[NQMAX] = {0};
  double scale[NQMAX] = {0};

  void add(int q, double dual, double fd) {
    diff[q] = fmax(diff[q], fabs(dual - fd));
    scale[q] = fmax(scale[q], fmax(fabs(dual), fabs(fd)));
    if (isnan(dual) || isnan(fd)) diff[q] = INFINITY;
  }
  double err(int q) const { return diff[q] / fmax(1.0, scale[q]); }
};


// print the errors of quantities q0 .. q1-1 and fail if one exceeds tol
static void report(const char* label, const Agreement& a, const char* const* name, int q0,
                   int q1, double tol) {
  for (int q = q0; q < q1; q++) {
    printf("%-30s %-10s max relative error %.2e (max |d| %.2e)\n", label, name[q], a.err(q),
           a.scale[q]);
    ck_assert_msg(a.err(q) <= tol, "%s: %s error %.3e > %.0e", label, name[q], a.err(q), tol);
  }
}


// xorshift64* uniform in [lo, hi)
static double uniform(unsigned long long* s, double lo, double hi) {
  *s ^= *s >> 12;
  *s ^= *s << 25;
  *s ^= *s >> 27;
  unsigned long long r = *s * 2685821657736338717ULL;
  return lo + (hi - lo) * (double)(r >> 11) / 9007199254740992.0;
}


// a model packed by libostrich (double), its dual copy and one world's dual kinematics
struct Packed {
  mjModel* m = nullptr;
  ostModelDouble md;
  void* md_block = nullptr;
  ostModel om;
  void* om_block = nullptr;
  ostKin k;
  void* k_block = nullptr;

  explicit Packed(mjModel* model) : m(model) {
    char err[1000] = "";
    ck_assert_msg(ost_packModel(m, 64, &md, &md_block, err, sizeof(err)) == 0, "%s", err);
    om_block = aligned_alloc(64, OST_ALIGN64(ostx_dualModelSize(md.s)));
    k_block = aligned_alloc(64, OST_ALIGN64(ostu_kinSize(md.s)));
    ck_assert(om_block && k_block);
    ostx_dualModel(&om, om_block, &md);
    ostu_kinInit(&k, k_block, om.s);
  }
  ~Packed() {
    free(md_block);
    free(om_block);
    free(k_block);
    mj_deleteModel(m);
  }
};


// dual qpos with values qpos and derivative k along the tangent direction of dof d0 + k
static void seedQpos(const mjModel* m, const mjtNum* qpos, int d0, Dual* q) {
  for (int i = 0; i < m->nq; i++) {
    q[i] = qpos[i];
  }
  for (int j = 0; j < m->njnt; j++) {
    int a = m->jnt_qposadr[j], v = m->jnt_dofadr[j] - d0, type = m->jnt_type[j];
    if (type == mjJNT_FREE) {
      for (int i = 0; i < 3; i++) {
        if (v + i >= 0 && v + i < ND) q[a + i].d[v + i] = 1;
      }
      a += 3;
      v += 3;
    }
    if (type == mjJNT_FREE || type == mjJNT_BALL) {
      // rotation about the body's axis i: d q = q (x) (0, e_i / 2)
      for (int i = 0; i < 3; i++) {
        if (v + i < 0 || v + i >= ND) continue;
        mjtNum e[4] = {0, 0, 0, 0}, dq[4];
        e[1 + i] = 0.5;
        mju_mulQuat(dq, qpos + a, e);
        for (int r = 0; r < 4; r++) q[a + r].d[v + i] = dq[r];
      }
    } else if (v >= 0 && v < ND) {
      q[a].d[v] = 1;
    }
  }
}


// qpos (+) step e_dof as values (mj_integratePos: a finite-difference step along a tangent)
static void stepQpos(const mjModel* m, const mjtNum* qpos, int dof, double step, Dual* q) {
  std::vector<mjtNum> qp(qpos, qpos + m->nq), dir(m->nv, 0.0);
  dir[dof] = step;
  mj_integratePos(m, qp.data(), dir.data(), 1);
  for (int i = 0; i < m->nq; i++) {
    q[i] = qp[i];
  }
}


// a configuration: conf 0 the model's reference (hinges exactly at 0), else random angles and
// unit quaternions, every free body kept near its reference position (contacts need a pose)
static void configuration(const mjModel* m, int conf, unsigned long long* seed, mjtNum* qpos,
                          mjtNum* qvel) {
  for (int i = 0; i < m->nq; i++) qpos[i] = m->qpos0[i];
  for (int i = 0; i < m->nv; i++) qvel[i] = uniform(seed, -2, 2);
  if (conf == 0) {
    return;
  }
  for (int j = 0; j < m->njnt; j++) {
    mjtNum* q = qpos + m->jnt_qposadr[j];
    switch (m->jnt_type[j]) {
    case mjJNT_FREE:
      for (int r = 0; r < 3; r++) q[r] += uniform(seed, -0.5, 0.5);
      q += 3;
      [[fallthrough]];  // the rotation
    case mjJNT_BALL:
      for (int r = 0; r < 4; r++) q[r] = uniform(seed, -1, 1);
      mju_normalize4(q);
      break;
    case mjJNT_SLIDE:
      q[0] = uniform(seed, -0.5, 0.5);
      break;
    default:
      q[0] = uniform(seed, -3.14, 3.14);
    }
  }
}


//---------------------------------- kinematics and dynamics --------------------------------------

enum { K_XPOS = 0, K_XMAT, K_XIPOS, K_QM, K_BIAS, K_JACP, K_JACR, NK };
static const char* kname[NK] = {"xpos", "xmat", "xipos", "qM", "qfrc_bias", "jacp", "jacr"};


// offsets of the quantities in evalKin's output (off[NK]: its length)
static void kinLayout(const mjModel* m, int off[NK + 1]) {
  int nb = m->nbody, nv = m->nv;
  int len[NK] = {3 * nb, 9 * nb, 3 * nb, nv * nv, nv, 3 * nv * nb, 3 * nv * nb};
  off[0] = 0;
  for (int q = 0; q < NK; q++) off[q + 1] = off[q] + len[q];
}


// core at (qpos, qvel): xpos, xmat, xipos, qM (osti_crb), qfrc_bias (osti_rne) and the
// Jacobians (osti_jac) of every body's center of mass, into out (kinLayout)
static void evalKin(Packed* p, const Dual* qpos, const Dual* qvel, Dual* out) {
  const ostModel* om = &p->om;
  ostKin* k = &p->k;
  int nb = om->s.nbody, nv = om->s.nv, off[NK + 1];
  kinLayout(p->m, off);
  osti_kinematics(om, k, qpos);
  osti_comPos(om, k);
  osti_crb(om, k);
  osti_rne(om, k, qvel);
  for (int i = 0; i < 3 * nb; i++) out[off[K_XPOS] + i] = k->xpos[i];
  for (int i = 0; i < 9 * nb; i++) out[off[K_XMAT] + i] = k->xmat[i];
  for (int i = 0; i < 3 * nb; i++) out[off[K_XIPOS] + i] = k->xipos[i];
  for (int i = 0; i < nv * nv; i++) out[off[K_QM] + i] = k->qM[i];
  for (int i = 0; i < nv; i++) out[off[K_BIAS] + i] = k->qfrc_bias[i];
  for (int b = 0; b < nb; b++) {
    osti_jac(om, k, k->jac, k->jac + 3 * nv, k->xipos + 3 * b, b);
    for (int i = 0; i < 3 * nv; i++) {
      out[off[K_JACP] + 3 * nv * b + i] = k->jac[i];
      out[off[K_JACR] + 3 * nv * b + i] = k->jac[3 * nv + i];
    }
  }
}


// derivatives of evalKin's outputs along every dof of qpos (wrt = 0) or qvel (wrt = 1) at
// NCONF configurations, against central differences; the values against mj_kinematics
static void checkKinematics(Packed* p, const char* label) {
  const mjModel* m = p->m;
  int nq = m->nq, nv = m->nv, off[NK + 1];
  kinLayout(m, off);
  int n = off[NK];
  std::vector<Dual> q(nq), v(nv), out(n), plus(n), minus(n);
  std::vector<mjtNum> qpos(nq), qvel(nv);
  mjData* d = mj_makeData(m);
  unsigned long long seed = 0x9E3779B97F4A7C15ULL;
  Agreement a[2];
  for (int conf = 0; conf < NCONF; conf++) {
    configuration(m, conf, &seed, qpos.data(), qvel.data());

    // values: the dual build computes core's (hence MuJoCo's) kinematics
    mju_copy(d->qpos, qpos.data(), nq);
    mj_kinematics(m, d);
    seedQpos(m, qpos.data(), nv, q.data());  // no direction seeded
    for (int i = 0; i < nv; i++) v[i] = qvel[i];
    evalKin(p, q.data(), v.data(), out.data());
    for (int i = 0; i < 3 * m->nbody; i++) {
      ck_assert_msg(near(out[off[K_XPOS] + i].v, d->xpos[i], 1e-12), "%s: xpos value", label);
    }

    for (int wrt = 0; wrt < 2; wrt++) {
      for (int d0 = 0; d0 < nv; d0 += ND) {
        // seed ND directions at once
        seedQpos(m, qpos.data(), wrt == 0 ? d0 : nv, q.data());
        for (int i = 0; i < nv; i++) {
          v[i] = qvel[i];
          if (wrt == 1 && i >= d0 && i < d0 + ND) v[i].d[i - d0] = 1;
        }
        evalKin(p, q.data(), v.data(), out.data());

        // one central difference per direction
        for (int k = 0; k < ND && d0 + k < nv; k++) {
          for (int s = -1; s <= 1; s += 2) {
            for (int i = 0; i < nv; i++) v[i] = qvel[i];
            if (wrt == 0) {
              stepQpos(m, qpos.data(), d0 + k, s * H, q.data());
            } else {
              seedQpos(m, qpos.data(), nv, q.data());
              v[d0 + k] += s * H;
            }
            evalKin(p, q.data(), v.data(), s > 0 ? plus.data() : minus.data());
          }
          for (int qq = 0; qq < NK; qq++) {
            if (wrt == 1 && qq != K_BIAS) continue;  // only qfrc_bias depends on qvel
            for (int i = off[qq]; i < off[qq + 1]; i++) {
              a[wrt].add(qq, out[i].d[k], (plus[i].v - minus[i].v) / (2 * H));
            }
          }
        }
      }
    }
  }
  mj_deleteData(d);
  char lab[64];
  snprintf(lab, sizeof(lab), "%s d/dqpos", label);
  report(lab, a[0], kname, 0, NK, TOL_KIN);
  snprintf(lab, sizeof(lab), "%s d/dqvel", label);
  report(lab, a[1], kname, K_BIAS, K_BIAS + 1, TOL_KIN);
}


//---------------------------------- collision ----------------------------------------------------

enum { C_DIST = 0, C_FRAME, C_POS, NC };
static const char* cname[NC] = {"dist", "frame", "pos"};


// core's contacts at qpos (osti_kinematics, osti_collision): their number, with each contact's
// dist, frame and pos in out[13 i ...] and its candidate pair in pair[i]
static int evalContacts(Packed* p, const Dual* qpos, Dual* out, int* pair) {
  osti_kinematics(&p->om, &p->k, qpos);
  osti_collision(&p->om, &p->k);
  ck_assert(!p->k.overflow);
  for (int i = 0; i < p->k.ncon; i++) {
    const ostContact* c = p->k.contact + i;
    out[13 * i] = c->dist;
    for (int r = 0; r < 9; r++) out[13 * i + 1 + r] = c->frame[r];
    for (int r = 0; r < 3; r++) out[13 * i + 10 + r] = c->pos[r];
    pair[i] = p->k.contact_pair[i];
  }
  return p->k.ncon;
}


// derivatives of every contact's dist, frame and pos along every dof at qpos against central
// differences, into a[0] for plane pairs (analytic) and a[1] for the others (MPR); the contact
// set must not change within the step. Returns the number of contacts.
static int checkContacts(Packed* p, const mjtNum* qpos, Agreement a[2]) {
  const mjModel* m = p->m;
  int nv = m->nv, cap = 13 * (p->om.s.ncon_max + OST_MAXCONPAIR), ncon = 0;
  std::vector<Dual> q(m->nq), out(cap), plus(cap), minus(cap);
  std::vector<int> pair(cap), pair2(cap);
  for (int d0 = 0; d0 < nv; d0 += ND) {
    seedQpos(m, qpos, d0, q.data());
    ncon = evalContacts(p, q.data(), out.data(), pair.data());
    for (int k = 0; k < ND && d0 + k < nv; k++) {
      for (int s = -1; s <= 1; s += 2) {
        stepQpos(m, qpos, d0 + k, s * H, q.data());
        int n2 = evalContacts(p, q.data(), s > 0 ? plus.data() : minus.data(), pair2.data());
        ck_assert_msg(n2 == ncon && !memcmp(pair.data(), pair2.data(), sizeof(int) * ncon),
                      "the contact set changes along dof %d", d0 + k);
      }
      for (int i = 0; i < ncon; i++) {
        int mpr = m->geom_type[p->md.pair_geom1[pair[i]]] != mjGEOM_PLANE;
        for (int e = 13 * i; e < 13 * (i + 1); e++) {
          int qq = e % 13 == 0 ? C_DIST : (e % 13 < 10 ? C_FRAME : C_POS);
          a[mpr].add(qq, out[e].d[k], (plus[e].v - minus[e].v) / (2 * H));
        }
      }
    }
  }
  return ncon;
}


// the robot's pose: free joint (x, y, z, roll, pitch, yaw) and the three wheel angles
static void robotPose(const mjModel* m, const double pose[6], const double wheel[3],
                      mjtNum* qpos) {
  mjtNum* q = qpos + m->jnt_qposadr[0];
  ck_assert_int_eq(m->jnt_type[0], mjJNT_FREE);
  q[0] = pose[0]; q[1] = pose[1]; q[2] = pose[2];
  mjtNum qx[4] = {cos(pose[3] / 2), sin(pose[3] / 2), 0, 0};
  mjtNum qy[4] = {cos(pose[4] / 2), 0, sin(pose[4] / 2), 0};
  mjtNum qz[4] = {cos(pose[5] / 2), 0, 0, sin(pose[5] / 2)};
  mjtNum t[4];
  mju_mulQuat(t, qz, qy);
  mju_mulQuat(q + 3, t, qx);
  for (int j = 1; j <= 3; j++) {
    ck_assert_int_eq(m->jnt_type[j], mjJNT_HINGE);
    qpos[m->jnt_qposadr[j]] = wheel[j - 1];
  }
}


//---------------------------------- tests --------------------------------------------------------

// an entry of the dual model equals the double model's (ints; values with zero derivatives)
static bool sameEntry(int a, int b) {
  return a == b;
}
static bool sameEntry(const Dual& a, double b) {
  bool same = a.v == b;
  for (int k = 0; k < ND; k++) same = same && a.d[k] == 0;
  return same;
}


// every operator and math function against its analytic derivative; values equal double's
START_TEST(test_dualArithmetic) {
  typedef ostDual<2> D;
  const double xv = 1.3, yv = -0.7;
  D x = ostx_seed<2>(xv, 0), y = ostx_seed<2>(yv, 1);

  // r has value val and gradient (dx, dy)
#define EXPECT(r, val, dx, dy)                                                                   \
  do {                                                                                           \
    D r_ = (r);                                                                                  \
    ck_assert_msg(r_.v == (val), "%s: value %.17g != %.17g", #r, r_.v, (double)(val));          \
    ck_assert_msg(near(ostx_der(r_, 0), (dx), 1e-14) && near(ostx_der(r_, 1), (dy), 1e-14),     \
                  "%s: derivatives (%.17g, %.17g) != (%.17g, %.17g)", #r, r_.d[0], r_.d[1],     \
                  (double)(dx), (double)(dy));                                                   \
  } while (0)

  // arithmetic, dual-dual and mixed
  EXPECT(x + y, xv + yv, 1, 1);
  EXPECT(x - y, xv - yv, 1, -1);
  EXPECT(x * y, xv * yv, yv, xv);
  EXPECT(x / y, xv / yv, 1 / yv, -xv / (yv * yv));
  EXPECT(-x, -xv, -1, 0);
  EXPECT(x + 2.0, xv + 2.0, 1, 0);
  EXPECT(2 + x, 2 + xv, 1, 0);
  EXPECT(x - 2, xv - 2, 1, 0);
  EXPECT(2.0 - y, 2.0 - yv, 0, -1);
  EXPECT(3 * x, 3 * xv, 3, 0);
  EXPECT(y * 3.0, yv * 3.0, 0, 3);
  EXPECT(x / 4, xv / 4, 0.25, 0);
  EXPECT(4 / x, 4 / xv, -4 / (xv * xv), 0);
  D z = x;
  z += y;
  z -= 0.5;
  z *= y;
  z /= x;  // z = (x + y - 0.5) y / x
  EXPECT(z, (xv + yv - 0.5) * yv / xv, yv / xv - (xv + yv - 0.5) * yv / (xv * xv),
         (xv + 2 * yv - 0.5) / xv);
  D w = x;
  w *= w;  // aliasing
  EXPECT(w, xv * xv, 2 * xv, 0);

  // comparisons see values only, mixed or not
  ck_assert(y < x && y <= x && x > y && x >= y && x != y && !(x == y));
  ck_assert(x == xv && x != yv && x > 1 && 2 > x && x <= 1.3 && 1.3 >= x && y < 0 && 0 > y);
  ck_assert((double)x == xv && ostx_val(y) == yv);

  // math functions
  double r2 = xv * xv + yv * yv, u = xv - 1;  // u in (-1, 1) for acos and asin
  EXPECT(sqrt(x), sqrt(xv), 0.5 / sqrt(xv), 0);
  EXPECT(fabs(y), fabs(yv), 0, -1);
  EXPECT(fabs(x), fabs(xv), 1, 0);
  EXPECT(sin(x * y), sin(xv * yv), cos(xv * yv) * yv, cos(xv * yv) * xv);
  EXPECT(cos(x), cos(xv), -sin(xv), 0);
  EXPECT(atan2(y, x), atan2(yv, xv), -yv / r2, xv / r2);
  EXPECT(atan2(y, 2.0), atan2(yv, 2.0), 0, 2 / (4 + yv * yv));
  EXPECT(acos(x - 1), acos(u), -1 / sqrt(1 - u * u), 0);
  EXPECT(asin(x - 1), asin(u), 1 / sqrt(1 - u * u), 0);
  EXPECT(exp(y), exp(yv), 0, exp(yv));
  EXPECT(log(x), log(xv), 1 / xv, 0);
  EXPECT(pow(x, 2.5), pow(xv, 2.5), 2.5 * pow(xv, 1.5), 0);
  EXPECT(pow(x, 0.0), 1, 0, 0);
  EXPECT(fmin(x, y), yv, 0, 1);
  EXPECT(fmin(x, 5.0), xv, 1, 0);
  EXPECT(fmax(x, y), xv, 1, 0);
  EXPECT(fmax(0.0, y), 0, 0, 0);
  EXPECT(floor(x), 1, 0, 0);
  EXPECT(ceil(y), -0.0, 0, 0);
  ck_assert(isfinite(x) && !isfinite(x / 0.0) && !isnan(x) && isnan(sqrt(y)));

  // conventions at the nondifferentiable points: sqrt and fabs at 0, ties of fmin and fmax
  D zero = ostx_seed<2>(0, 0);
  EXPECT(sqrt(zero), 0, 0, 0);
  EXPECT(fabs(zero), 0, 0, 0);
  EXPECT(fmin(x, xv), xv, 1, 0);
  EXPECT(fmax(D(yv), y), yv, 0, 0);

  // a plain double in memory: zero bytes are 0, arrays initialize as doubles
  D m[3] = {0};
  memset(m + 1, 0, sizeof(D));
  ck_assert(m[0] == 0 && m[0].d[0] == 0 && m[2].d[1] == 0 && m[1].v == 0 && m[1].d[1] == 0);
#undef EXPECT
}
END_TEST


// the dual model equals the double model: every value copied, every derivative zero
START_TEST(test_dualModel) {
  ost_fixtureSetup();
  Packed p(ost_fixtureLoadModel("robot_pallet.xml"));
  ostSizes s = p.md.s;
  ck_assert(!memcmp(&p.om.s, &s, sizeof(s)));
  ck_assert(p.om.mpr_iterations == p.md.mpr_iterations &&
            p.om.disableflags == p.md.disableflags && p.om.mpr_tolerance == p.md.mpr_tolerance);
  for (int i = 0; i < 3; i++) ck_assert(p.om.gravity[i] == p.md.gravity[i]);
  int bad = 0;
#define X(type, name, r, c)                                                                      \
  for (size_t i = 0; i < (size_t)(r) * (c); i++) {                                               \
    bad += !sameEntry(p.om.name[i], p.md.name[i]);                                               \
  }
  OST_MODEL_ARRAYS(X)
#undef X
  ck_assert_int_eq(bad, 0);
}
END_TEST


// kinematics and dynamics of the wheeled robot (free base, three hinges)
START_TEST(test_kinWheeledRobot) {
  ost_fixtureSetup();
  Packed p(ost_fixtureLoadModel("wheeled_robot.xml"));
  checkKinematics(&p, "wheeled_robot");
}
END_TEST


// kinematics and dynamics of MuJoCo's humanoid (free root, 21 hinges, nv = 27)
START_TEST(test_kinHumanoid) {
  ost_fixtureSetup();
  char err[1000] = "";
  const char* path = "/usr/share/mujoco/model/humanoid/humanoid.xml";
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "cannot load %s: %s", path, err);
  Packed p(m);
  checkKinematics(&p, "humanoid");
}
END_TEST


// plane : cylinder contacts of the wheeled robot, every wheel sunk 7-16 mm and tilted by the
// base's roll (so that each wheel's near disk is well defined); two contacts per wheel
START_TEST(test_contactsWheeledRobot) {
  ost_fixtureSetup();
  Packed p(ost_fixtureLoadModel("wheeled_robot.xml"));
  std::vector<mjtNum> qpos(p.m->nq);
  const double pose[6] = {0.1, -0.2, 0.340, 0.01, 0.005, 0.3}, wheel[3] = {0.3, -1.2, 2.0};
  robotPose(p.m, pose, wheel, qpos.data());
  Agreement a[2];
  ck_assert_int_eq(checkContacts(&p, qpos.data(), a), 6);
  ck_assert(a[1].scale[C_DIST] == 0);  // plane pairs only
  report("wheeled_robot plane:cylinder", a[0], cname, 0, NC, TOL_CON);
}
END_TEST


// robot_pallet: the left front wheel 7 mm into the pallet's near edge (x = 1, z = 0.144), yawed by
// 0.05 rad so that the edge crosses the wheel's rims at different depths, the robot at
// y = -0.15 so that the right wheel clears the pallet's side by 3 cm, every wheel also on the
// floor and the base rolled as in test_contactsWheeledRobot: 6 plane : cylinder contacts and
// two cylinder : box contacts (Ostrich's generator, core/ost_collision_cylbox.h: the edge's points
// at the two rims' ends, the ends of its line of contact, against the wheel's curved surface; the
// shallower one is within the look-ahead margin). Unlike MuJoCo's MPR there, whose result jumped
// between final portals under one-ulp perturbations, this contact is a smooth function of the pose: checked to the same tolerance.
START_TEST(test_palletEdge) {
  ost_fixtureSetup();
  Packed p(ost_fixtureLoadModel("robot_pallet.xml"));
  std::vector<mjtNum> qpos(p.m->nq);
  const double pose[6] = {0.370, -0.15, 0.345, 0.01, 0.0, 0.05}, wheel[3] = {0.4, 0.1, -0.7};
  robotPose(p.m, pose, wheel, qpos.data());
  Agreement a[2];
  ck_assert_int_eq(checkContacts(&p, qpos.data(), a), 8);
  ck_assert(a[1].scale[C_DIST] > 0);
  report("robot_pallet edge plane:cyl", a[0], cname, 0, NC, TOL_CON);
  report("robot_pallet edge cyl:box", a[1], cname, 0, NC, TOL_CON);
}
END_TEST


// robot_pallet with the left front and rear wheels on the pallet's top face (the right wheel
// beyond its side): the cylinder : box contacts are the rims' lowest points over the face
// (three within the margin: the base is rolled, so one rim of a wheel is higher)
START_TEST(test_palletTop) {
  ost_fixtureSetup();
  Packed p(ost_fixtureLoadModel("robot_pallet.xml"));
  std::vector<mjtNum> qpos(p.m->nq);
  const double pose[6] = {1.6, -0.15, 0.490, 0.01, 0.0, 0.05}, wheel[3] = {0.4, 0.1, -0.7};
  robotPose(p.m, pose, wheel, qpos.data());
  Agreement a[2];
  ck_assert_int_eq(checkContacts(&p, qpos.data(), a), 3);
  ck_assert(a[0].scale[C_DIST] == 0);  // cylinder : box pairs only
  report("robot_pallet top cyl:box", a[1], cname, 0, NC, TOL_CON);
}
END_TEST


// an ellipsoid (a free body) about a box (core/ost_collision_ellipsoid.h) with its nearest box
// feature a face, an edge and a corner, turned about two axes, overlapping or within the 1 cm
// margin: one contact each, whose dist, frame and pos come from a closed form (face) or the root
// of the secular equation (edge, corner), differentiated through its last Newton steps
START_TEST(test_ellipsoidBox) {
  ost_fixtureSetup();
  const char* xml =
    "<mujoco><worldbody><geom type='box' size='0.05 0.05 0.01' margin='0.01'/>"
    "<body><freejoint/><geom type='ellipsoid' size='0.03 0.04 0.02' margin='0.01'/></body>"
    "</worldbody></mujoco>";
  Packed p(ost_fixtureLoadString(xml));
  const double place[3][3] = {{0.01, 0.005, 0.031}, {0.068, 0.0, 0.028}, {0.066, 0.068, 0.024}};
  const char* where[3] = {"face", "edge", "corner"};
  for (int c = 0; c < 3; c++) {
    std::vector<mjtNum> qpos(p.m->nq);
    mjtNum qx[4] = {cos(0.15), sin(0.15), 0, 0}, qz[4] = {cos(0.4), 0, 0, sin(0.4)};
    for (int k = 0; k < 3; k++) qpos[k] = place[c][k];
    mju_mulQuat(qpos.data() + 3, qz, qx);
    Agreement a[2];
    ck_assert_int_eq(checkContacts(&p, qpos.data(), a), 1);
    char lab[64];
    snprintf(lab, sizeof(lab), "ellipsoid:box %s", where[c]);
    report(lab, a[1], cname, 0, NC, TOL_CON);
  }
}
END_TEST


// a capsule (a free body) about a fixed ellipsoid, then about a fixed cylinder and a fixed cube
// mesh (core/ost_collision_ellipsoid.h, _ball.h), turned, overlapping or within the 1 cm
// margin: one contact each, through the secular root and the bisection's last Newton step
// (ellipsoid) or GJK's last simplex (cylinder, mesh)
START_TEST(test_capsulePairs) {
  ost_fixtureSetup();
  const char* others[3] = {
      "<geom type='ellipsoid' size='0.03 0.04 0.02' margin='0.01'/>",
      "<geom type='cylinder' size='0.03 0.02' margin='0.01'/>",
      "<geom type='mesh' mesh='cube' margin='0.01'/>"};
  const char* label[3] = {"capsule:ellipsoid", "capsule:cylinder", "capsule:mesh"};
  const double place[3][3] = {{0.01, 0.004, 0.034}, {0.012, 0.005, 0.026}, {0.01, 0.004, 0.036}};
  for (int o = 0; o < 3; o++) {
    char xml[1024];
    snprintf(xml, sizeof(xml),
             "<mujoco><asset><mesh name='cube' vertex='-.025 -.025 -.025 .025 -.025 -.025 "
             "-.025 .025 -.025 .025 .025 -.025 -.025 -.025 .025 .025 -.025 .025 -.025 .025 .025 "
             ".025 .025 .025'/></asset><worldbody>%s<body><freejoint/>"
             "<geom type='capsule' size='0.01 0.02' margin='0.01'/></body></worldbody></mujoco>",
             others[o]);
    Packed p(ost_fixtureLoadString(xml));
    std::vector<mjtNum> qpos(p.m->nq);
    mjtNum qx[4] = {cos(0.5), sin(0.5), 0, 0}, qz[4] = {cos(0.3), 0, 0, sin(0.3)};
    for (int k = 0; k < 3; k++) qpos[k] = place[o][k];
    mju_mulQuat(qpos.data() + 3, qz, qx);
    Agreement a[2];
    ck_assert_int_eq(checkContacts(&p, qpos.data(), a), 1);
    report(label[o], a[1], cname, 0, NC, TOL_CON);
  }
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_dual");
  TCase* tc = tcase_create("dual");
  tcase_set_timeout(tc, 600);
  tcase_add_test(tc, test_dualArithmetic);
  tcase_add_test(tc, test_dualModel);
  tcase_add_test(tc, test_kinWheeledRobot);
  tcase_add_test(tc, test_kinHumanoid);
  tcase_add_test(tc, test_contactsWheeledRobot);
  tcase_add_test(tc, test_palletEdge);
  tcase_add_test(tc, test_palletTop);
  tcase_add_test(tc, test_ellipsoidBox);
  tcase_add_test(tc, test_capsulePairs);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
