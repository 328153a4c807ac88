// test_ost_kinematics.c: core/ost_kinematics.h against MuJoCo 2.2.2's mj_forward (the installed
// binary is the oracle): body, joint and geom frames, com frames, the dense mass matrix, bias and
// passive forces, transmissions and point Jacobians at random configurations of every model in
// mjcf_models/, of MuJoCo's humanoid and of an inline dm-control-style model (several joints on
// one body, ball, slide and free joints with springs, armature, damping and actuators).
// Outputs are poisoned with NaN (all bytes 0xFF) before every call; the error of a quantity is
// max |a - b| / max(1, |b|) over its entries and must stay <= 1e-10.
#include "ost_kinematics.h"  // first: the header compiles alone

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ost_internal.h"

#define TOL 1e-10
#define NCONF 24      // random configurations per model
#define NJAC 4        // random (body, point) Jacobians per configuration

// the compared quantities
enum {
  Q_XPOS = 0, Q_XQUAT, Q_XMAT, Q_XIPOS, Q_XIMAT, Q_XANCHOR, Q_XAXIS, Q_GEOM_XPOS, Q_GEOM_XMAT,
  Q_GEOM, Q_SUBTREE_COM, Q_CINERT, Q_CDOF, Q_CRB, Q_QM, Q_CVEL, Q_CDOF_DOT, Q_QFRC_BIAS,
  Q_QFRC_PASSIVE, Q_ACT_LENGTH, Q_ACT_MOMENT, Q_JACP, Q_JACR, NQUANT
};
static const char* qname[NQUANT] = {
  "xpos", "xquat", "xmat", "xipos", "ximat", "xanchor", "xaxis", "geom_xpos", "geom_xmat",
  "osti_geom", "subtree_com", "cinert", "cdof", "crb", "qM (mj_fullM)", "cvel", "cdof_dot",
  "qfrc_bias", "qfrc_passive", "actuator_length", "actuator_moment", "jacp (mj_jac)",
  "jacr (mj_jac)"
};

typedef struct {
  double err[NQUANT];  // max error of each quantity
  int nconf;           // configurations compared
} Errors;

static const char* dm_style =
  "<mujoco model='dm_style'>"
  "  <option gravity='0.3 -0.2 -9.81'/>"
  "  <default><joint armature='0.05' damping='0.3'/></default>"
  "  <worldbody>"
  "    <geom type='plane' size='5 5 0.1'/>"
  "    <body name='torso' pos='0 0 1' euler='10 -20 30'>"
  "      <joint name='rootx' type='slide' axis='1 0 0' stiffness='4' springref='0.2'/>"
  "      <joint name='rootz' type='slide' axis='0 0 1' armature='0'/>"
  "      <joint name='rooty' type='hinge' axis='0 1 0' pos='0.1 0 0.05' damping='0'/>"
  "      <geom type='capsule' fromto='-0.3 0 0 0.3 0 0' size='0.05'/>"
  "      <body name='thigh' pos='0.3 0 -0.1' quat='0.9 0.1 -0.2 0.3'>"
  "        <joint name='hip_x' type='hinge' axis='1 0 0' pos='0 0 0.05' stiffness='5'"
  "               springref='10'/>"
  "        <joint name='hip_y' type='hinge' axis='0 1 1' pos='0.01 0.02 0.03'/>"
  "        <joint name='hip_z' type='hinge' axis='0 0 1' stiffness='2'/>"
  "        <geom type='box' size='0.05 0.04 0.2' pos='0 0 -0.2' euler='10 20 30'/>"
  "        <body name='shin' pos='0 0 -0.4'>"
  "          <joint name='knee' type='ball' pos='0 0.02 0.03' stiffness='3' damping='0.5'/>"
  "          <geom type='ellipsoid' size='0.05 0.06 0.2' pos='0 0.01 -0.1'/>"
  "          <body name='foot' pos='0 0 -0.3'>"
  "            <joint name='ext' type='slide' axis='0.3 0.4 1' stiffness='20' springref='0.1'/>"
  "            <geom type='sphere' size='0.05' pos='0.02 0 0'/>"
  "            <geom type='cylinder' size='0.03 0.05' pos='0 0.05 0' euler='90 0 0'/>"
  "          </body>"
  "        </body>"
  "      </body>"
  "    </body>"
  "    <body name='floater' pos='1 1 1' quat='0.7 0.1 0.7 0.1'>"
  "      <joint name='free' type='free' stiffness='2' damping='0.1'/>"
  "      <inertial pos='0.1 0.2 0.3' quat='0.5 0.5 -0.5 0.5' mass='2' diaginertia='0.1 0.2 0.3'/>"
  "      <geom type='box' size='0.1 0.2 0.3' mass='0'/>"
  "      <body name='welded' pos='0.3 0 0' euler='0 45 0'>"
  "        <geom type='capsule' size='0.05 0.1'/>"
  "        <body name='arm' pos='0 0 0.2'>"
  "          <joint name='elbow' type='hinge' axis='0 1 0' pos='0 0 -0.05' stiffness='1'/>"
  "          <geom type='capsule' fromto='0 0 0 0.2 0 0.1' size='0.03'/>"
  "        </body>"
  "      </body>"
  "    </body>"
  "    <body name='pendant' pos='-1 0 1'>"
  "      <joint name='shoulder' type='ball' pos='0 0 0.1'/>"
  "      <geom type='capsule' fromto='0 0 0.1 0 0.1 -0.3' size='0.04'/>"
  "    </body>"
  "  </worldbody>"
  "  <actuator>"
  "    <motor joint='hip_x' gear='2.5'/>"
  "    <position joint='rootx' kp='10' gear='-1.5'/>"
  "    <motor joint='ext' gear='3'/>"
  "    <velocity joint='elbow' kv='2'/>"
  "  </actuator>"
  "</mujoco>";


//---------------------------------- helpers ------------------------------------------------------

// xorshift64* uniform in [lo, hi)
static double uniform(unsigned long long* s, double lo, double hi) {
  *s ^= *s >> 12;
  *s ^= *s << 25;
  *s ^= *s >> 27;
  unsigned long long r = *s * 2685821657736338717ULL;
  return lo + (hi - lo) * (double)(r >> 11) / 9007199254740992.0;
}


// a random unit quaternion (rejection from the unit ball), times scale
static void randomQuat(unsigned long long* s, mjtNum q[4], double scale) {
  double n2;
  do {
    for (int r = 0; r < 4; r++) q[r] = uniform(s, -1, 1);
    n2 = q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3];
  } while (n2 > 1 || n2 < 1e-4);
  for (int r = 0; r < 4; r++) q[r] *= scale / sqrt(n2);
}


// record max |a - b| / max(1, |b|) over n entries into *err (NaN counts as infinite)
static void compare(double* err, const ostNum* a, const mjtNum* b, int n) {
  for (int i = 0; i < n; i++) {
    double e = fabs((double)a[i] - b[i]) / fmax(1.0, fabs(b[i]));
    if (!(e <= *err)) {
      *err = isnan(e) ? INFINITY : e;
    }
  }
}


// random qpos (quaternions unit or, with odd conf, scaled by [0.5, 2)) and qvel
static void randomState(const mjModel* m, mjData* d, unsigned long long* s, int conf) {
  for (int j = 0; j < m->njnt; j++) {
    mjtNum* q = d->qpos + m->jnt_qposadr[j];
    double scale = conf % 2 ? uniform(s, 0.5, 2) : 1;
    switch (m->jnt_type[j]) {
    case mjJNT_FREE:
      for (int r = 0; r < 3; r++) q[r] = uniform(s, -1.5, 1.5);
      randomQuat(s, q + 3, scale);
      break;
    case mjJNT_BALL:
      randomQuat(s, q, scale);
      break;
    case mjJNT_SLIDE:
      q[0] = uniform(s, -0.5, 0.5);
      break;
    default:
      q[0] = uniform(s, -3.14, 3.14);
    }
  }
  for (int i = 0; i < m->nv; i++) d->qvel[i] = uniform(s, -2, 2);
}


// compare core's smooth dynamics with mj_forward at NCONF random states of m; 0 if m cannot be
// packed (message in err)
static int checkModel(mjModel* m, const char* label, Errors* out, char* err, int err_sz) {
  ostModel om;
  void* block = NULL;
  memset(out, 0, sizeof(*out));
  if (ost_packModel(m, 8, &om, &block, err, err_sz) != OST_OK) {
    return 0;
  }

  // hinge and slide angles are measured from 0 (core has no qpos0)
  for (int j = 0; j < m->njnt; j++) {
    if (m->jnt_type[j] == mjJNT_HINGE || m->jnt_type[j] == mjJNT_SLIDE) {
      ck_assert_msg(m->qpos0[m->jnt_qposadr[j]] == 0, "%s: joint %d has ref != 0", label, j);
    }
  }

  // one world
  ostSizes s = om.s;
  ostKin k;
  size_t sz = ostu_kinSize(s);
  void* buf = aligned_alloc(64, OST_ALIGN64(sz > 0 ? sz : 64));
  ck_assert_ptr_nonnull(buf);
  ostu_kinInit(&k, buf, s);

  // MuJoCo without collision and constraints (the smooth quantities do not depend on them)
  m->opt.disableflags |= mjDSBL_CONTACT | mjDSBL_CONSTRAINT;
  mjData* d = mj_makeData(m);
  int nv = m->nv, nq = m->nq;
  mjtNum* qpos = malloc(sizeof(mjtNum) * (nq + 1));
  mjtNum* qM = malloc(sizeof(mjtNum) * (nv * nv + 1));
  mjtNum* jacp = malloc(sizeof(mjtNum) * (3 * nv + 1));
  mjtNum* jacr = malloc(sizeof(mjtNum) * (3 * nv + 1));
  unsigned long long seed = 0x9E3779B97F4A7C15ULL ^ (unsigned long long)(nq * 131 + nv);
  double* e = out->err;

  for (int conf = 0; conf < NCONF; conf++) {
    // oracle at a random state (qpos copied first: core must not rely on MuJoCo touching it)
    randomState(m, d, &seed, conf);
    memcpy(qpos, d->qpos, sizeof(mjtNum) * nq);
    mj_forward(m, d);
    mj_fullM(m, qM, d->qM);

    // core, every output poisoned with NaN first
#define X(type, name, r, c) memset(k.name, 0xFF, (size_t)(r) * (c) * sizeof(type));
    OST_KIN_ARRAYS(X)
#undef X
    osti_kinematics(&om, &k, qpos);
    // a geom in no candidate pair keeps its frame (still the NaN poison): nothing reads it;
    // its frame is then computed alone (osti_kinGeom) and checked as every other
    for (int g = 0; g < m->ngeom; g++) {
      if (!om.geom_paired[g]) {
        ck_assert_msg(isnan(k.geom_xpos[3 * g]) && isnan(k.geom_xmat[9 * g + 8]),
                      "%s: geom %d is in no pair but its frame was computed", label, g);
        osti_kinGeom(&om, &k, g);
      }
    }
    osti_comPos(&om, &k);
    osti_crb(&om, &k);
    osti_rne(&om, &k, d->qvel);
    osti_passive(&om, &k, qpos, d->qvel);
    osti_transmission(&om, &k, qpos);

    int nb = m->nbody, nj = m->njnt, ng = m->ngeom, nu = m->nu;
    compare(e + Q_XPOS, k.xpos, d->xpos, 3 * nb);
    compare(e + Q_XQUAT, k.xquat, d->xquat, 4 * nb);
    compare(e + Q_XMAT, k.xmat, d->xmat, 9 * nb);
    compare(e + Q_XIPOS, k.xipos, d->xipos, 3 * nb);
    compare(e + Q_XIMAT, k.ximat, d->ximat, 9 * nb);
    compare(e + Q_XANCHOR, k.xanchor, d->xanchor, 3 * nj);
    compare(e + Q_XAXIS, k.xaxis, d->xaxis, 3 * nj);
    compare(e + Q_GEOM_XPOS, k.geom_xpos, d->geom_xpos, 3 * ng);
    compare(e + Q_GEOM_XMAT, k.geom_xmat, d->geom_xmat, 9 * ng);
    compare(e + Q_SUBTREE_COM, k.subtree_com, d->subtree_com, 3 * nb);
    compare(e + Q_CINERT, k.cinert, d->cinert, 10 * nb);
    compare(e + Q_CDOF, k.cdof, d->cdof, 6 * nv);
    compare(e + Q_CRB, k.crb, d->crb, 10 * nb);
    compare(e + Q_QM, k.qM, qM, nv * nv);
    compare(e + Q_CVEL, k.cvel, d->cvel, 6 * nb);
    compare(e + Q_CDOF_DOT, k.cdof_dot, d->cdof_dot, 6 * nv);
    compare(e + Q_QFRC_BIAS, k.qfrc_bias, d->qfrc_bias, nv);
    compare(e + Q_QFRC_PASSIVE, k.qfrc_passive, d->qfrc_passive, nv);
    compare(e + Q_ACT_LENGTH, k.actuator_length, d->actuator_length, nu);
    compare(e + Q_ACT_MOMENT, k.actuator_moment, d->actuator_moment, nu * nv);

    // placed geoms: frames from kinematics, shape and mesh vertices straight from the model
    for (int g = 0; g < ng; g++) {
      ostGeom og;
      memset(&og, 0xFF, sizeof(og));
      osti_geom(&om, &k, g, &og);
      ck_assert_int_eq(og.type, m->geom_type[g]);
      compare(e + Q_GEOM, og.size, m->geom_size + 3 * g, 3);
      compare(e + Q_GEOM, og.pos, d->geom_xpos + 3 * g, 3);
      compare(e + Q_GEOM, og.mat, d->geom_xmat + 9 * g, 9);
      compare(e + Q_GEOM, &og.rbound, m->geom_rbound + g, 1);
      if (og.type == mjGEOM_MESH) {
        int id = m->geom_dataid[g];
        ck_assert_int_eq(og.nvert, m->mesh_vertnum[id]);
        if (om.geom_terrain[g]) {
          continue;  // a terrain mesh is packed in the world frame (ost_pack.c)
        }
        const float* mv = m->mesh_vert + 3 * m->mesh_vertadr[id];
        for (int i = 0; i < 3 * og.nvert; i++) {
          mjtNum vi = mv[i];
          compare(e + Q_GEOM, og.vert + i, &vi, 1);
        }
      } else {
        ck_assert_int_eq(og.nvert, 0);
        ck_assert_ptr_null(og.vert);
      }
    }

    // Jacobians of random points on random bodies (world included), jacr also omitted
    for (int t = 0; t < NJAC; t++) {
      int b = (int)uniform(&seed, 0, nb);
      mjtNum point[3];
      for (int r = 0; r < 3; r++) point[r] = d->xpos[3 * b + r] + uniform(&seed, -0.5, 0.5);
      mj_jac(m, d, jacp, jacr, point, b);
      memset(k.jac, 0xFF, sizeof(ostNum) * 6 * nv);
      osti_jac(&om, &k, k.jac, k.jac + 3 * nv, point, b);
      compare(e + Q_JACP, k.jac, jacp, 3 * nv);
      compare(e + Q_JACR, k.jac + 3 * nv, jacr, 3 * nv);
      memset(k.jac, 0xFF, sizeof(ostNum) * 6 * nv);
      osti_jac(&om, &k, k.jac, NULL, point, b);
      compare(e + Q_JACP, k.jac, jacp, 3 * nv);
      for (int i = 3 * nv; i < 6 * nv; i++) {
        ck_assert_msg(isnan(k.jac[i]), "osti_jac wrote jacr although it was NULL");
      }
    }
    out->nconf++;
  }

  free(qpos);
  free(qM);
  free(jacp);
  free(jacr);
  mj_deleteData(d);
  free(buf);
  free(block);
  return 1;
}


// print the errors of a model and fail the test if any exceeds TOL
static void report(const char* label, const mjModel* m, const Errors* er) {
  double worst = 0;
  int iw = 0;
  for (int q = 0; q < NQUANT; q++) {
    if (er->err[q] > worst || isinf(er->err[q])) {
      worst = er->err[q];
      iw = q;
    }
  }
  printf("%-24s nbody %3d nv %3d nu %3d: %d configurations, max error %.2e (%s)\n", label,
         m->nbody, m->nv, m->nu, er->nconf, worst, qname[iw]);
  for (int q = 0; q < NQUANT; q++) {
    ck_assert_msg(er->err[q] <= TOL, "%s: %s error %.3e > %.0e", label, qname[q], er->err[q],
                  TOL);
  }
}


// print every quantity's error (one table per test)
static void table(const char* title, const Errors* er) {
  printf("%s: max relative error per quantity\n", title);
  for (int q = 0; q < NQUANT; q++) {
    printf("  %-18s %.2e\n", qname[q], er->err[q]);
  }
}


// running maxima over models
static void accumulate(Errors* all, const Errors* er) {
  for (int q = 0; q < NQUANT; q++) {
    all->err[q] = fmax(all->err[q], er->err[q]);
  }
  all->nconf += er->nconf;
}


//---------------------------------- tests --------------------------------------------------------

// every model in mjcf_models/; the listed ones must load and pack
START_TEST(test_mjcfModels) {
  ost_fixtureSetup();
  static const char* required[] = {"wheeled_robot.xml", "robot_pallet.xml", "pendulum_chain.xml",
                                   "arm_position_servo.xml", "box_plane.xml",
                                   "stack_heavy_light.xml"};
  int nreq = sizeof(required) / sizeof(required[0]), found[16] = {0}, nchecked = 0;
  Errors all;
  memset(&all, 0, sizeof(all));
  DIR* dir = opendir(OST_MODEL_DIR);
  ck_assert_ptr_nonnull(dir);
  struct dirent* ent;
  while ((ent = readdir(dir))) {
    const char* fn = ent->d_name;
    size_t len = strlen(fn);
    if (len < 5 || strcmp(fn + len - 4, ".xml")) {
      continue;
    }
    int req = -1;
    for (int i = 0; i < nreq; i++) {
      if (!strcmp(fn, required[i])) req = i;
    }
    char path[1024], err[1000] = "";
    snprintf(path, sizeof(path), "%s/%s", OST_MODEL_DIR, fn);
    mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
    if (!m) {
      ck_assert_msg(req < 0, "required model %s does not load: %s", fn, err);
      printf("%-24s skipped: does not load on its own (%s)\n", fn, err);
      continue;
    }
    Errors er;
    if (!checkModel(m, fn, &er, err, sizeof(err))) {
      ck_assert_msg(req < 0, "required model %s does not pack: %s", fn, err);
      printf("%-24s skipped: does not pack (%s)\n", fn, err);
      mj_deleteModel(m);
      continue;
    }
    report(fn, m, &er);
    accumulate(&all, &er);
    nchecked++;
    if (req >= 0) found[req] = 1;
    mj_deleteModel(m);
  }
  closedir(dir);
  for (int i = 0; i < nreq; i++) {
    ck_assert_msg(found[i], "required model %s not found", required[i]);
  }
  printf("%d models checked\n", nchecked);
  table("mjcf_models/*.xml", &all);
}
END_TEST


// MuJoCo's humanoid: free root, several hinges per body, springs, armature, damping, motors
START_TEST(test_humanoid) {
  ost_fixtureSetup();
  char err[1000] = "";
  const char* path = "/usr/share/mujoco/model/humanoid/humanoid.xml";
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "cannot load %s: %s", path, err);
  Errors er;
  ck_assert_msg(checkModel(m, "humanoid", &er, err, sizeof(err)), "humanoid: %s", err);
  report("humanoid.xml", m, &er);
  table("humanoid.xml", &er);
  mj_deleteModel(m);
}
END_TEST


// the inline dm-control-style model, as given and with gravity and passive forces disabled
START_TEST(test_inlineModel) {
  ost_fixtureSetup();
  static const int flags[3] = {0, mjDSBL_GRAVITY, mjDSBL_PASSIVE | mjDSBL_GRAVITY};
  static const char* label[3] = {"dm_style", "dm_style, no gravity",
                                 "dm_style, no passive+gravity"};
  Errors all;
  memset(&all, 0, sizeof(all));
  for (int f = 0; f < 3; f++) {
    char err[1000] = "";
    mjModel* m = ost_fixtureLoadString(dm_style);
    m->opt.disableflags |= flags[f];

    // the model exercises what it claims: springs, armature, damping, all joint types
    int types = 0;
    double stiff = 0, arm = 0, damp = 0;
    for (int j = 0; j < m->njnt; j++) {
      types |= 1 << m->jnt_type[j];
      stiff += m->jnt_stiffness[j];
    }
    for (int i = 0; i < m->nv; i++) {
      arm += m->dof_armature[i];
      damp += m->dof_damping[i];
    }
    ck_assert_int_eq(types, 15);
    ck_assert(stiff > 0 && arm > 0 && damp > 0 && m->nu == 4);

    Errors er;
    ck_assert_msg(checkModel(m, label[f], &er, err, sizeof(err)), "%s: %s", label[f], err);
    report(label[f], m, &er);
    accumulate(&all, &er);
    mj_deleteModel(m);
  }
  table("dm_style (all flags)", &all);
}
END_TEST


// disabled gravity and passive forces give exactly zero in a model at rest (no springs loaded)
START_TEST(test_disabledZero) {
  ost_fixtureSetup();
  char err[1000] = "";
  mjModel* m = ost_fixtureLoadString(dm_style);
  m->opt.disableflags |= mjDSBL_GRAVITY | mjDSBL_PASSIVE;
  ostModel om;
  void* block = NULL;
  ck_assert_msg(ost_packModel(m, 8, &om, &block, err, sizeof(err)) == OST_OK, "%s", err);
  ostKin k;
  void* buf = aligned_alloc(64, OST_ALIGN64(ostu_kinSize(om.s)));
  ostu_kinInit(&k, buf, om.s);
  mjtNum qvel[64] = {0};
  ck_assert_int_le(m->nv, 64);  // capacity of the local qvel[64]
  for (int i = 0; i < m->nv; i++) qvel[i] = 1;
  osti_kinematics(&om, &k, m->qpos0);
  osti_comPos(&om, &k);
  osti_passive(&om, &k, m->qpos0, qvel);
  for (int i = 0; i < m->nv; i++) qvel[i] = 0;
  osti_rne(&om, &k, qvel);
  for (int i = 0; i < m->nv; i++) {
    ck_assert(k.qfrc_passive[i] == 0);
    ck_assert(k.qfrc_bias[i] == 0);
  }
  free(buf);
  free(block);
  mj_deleteModel(m);
}
END_TEST


// ost_pack copies opt.disableflags verbatim, so the bits core tests must be MuJoCo's
START_TEST(test_disableBits) {
  ck_assert_msg(OST_DSBL_GRAVITY == mjDSBL_GRAVITY, "OST_DSBL_GRAVITY %d != mjDSBL_GRAVITY %d",
                OST_DSBL_GRAVITY, mjDSBL_GRAVITY);
  ck_assert_msg(OST_DSBL_PASSIVE == mjDSBL_PASSIVE, "OST_DSBL_PASSIVE %d != mjDSBL_PASSIVE %d",
                OST_DSBL_PASSIVE, mjDSBL_PASSIVE);
  ck_assert_msg(OST_DSBL_CONTACT == mjDSBL_CONTACT, "OST_DSBL_CONTACT %d != mjDSBL_CONTACT %d",
                OST_DSBL_CONTACT, mjDSBL_CONTACT);
  ck_assert_msg(OST_DSBL_LIMIT == mjDSBL_LIMIT, "OST_DSBL_LIMIT %d != mjDSBL_LIMIT %d",
                OST_DSBL_LIMIT, mjDSBL_LIMIT);
  ck_assert_msg(OST_DSBL_CLAMPCTRL == mjDSBL_CLAMPCTRL,
                "OST_DSBL_CLAMPCTRL %d != mjDSBL_CLAMPCTRL %d", OST_DSBL_CLAMPCTRL,
                mjDSBL_CLAMPCTRL);
  ck_assert_msg(OST_DSBL_ACTUATION == mjDSBL_ACTUATION,
                "OST_DSBL_ACTUATION %d != mjDSBL_ACTUATION %d", OST_DSBL_ACTUATION,
                mjDSBL_ACTUATION);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_kinematics");
  TCase* tc = tcase_create("kinematics");
  tcase_set_timeout(tc, 600);
  tcase_add_test(tc, test_disableBits);
  tcase_add_test(tc, test_mjcfModels);
  tcase_add_test(tc, test_humanoid);
  tcase_add_test(tc, test_inlineModel);
  tcase_add_test(tc, test_disabledZero);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
