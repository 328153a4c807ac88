// compare_hard_cases.c: the nine hard cases of `ostrich compare hard` and the
// probes that measure each one's physics: sink and drift of a stack, displacement of a sticking
// box, acceleration of a sliding one, servo tracking error, rebound of a fast ball, sideways
// drift of a robot crossing a box edge, joint-limit violation of a chain and of the humanoid,
// snagging of a grazing cube. The driver (compare_hard.c) adds status, penetration and energy.
//
// Invariant: every number a probe compares with is read from the model or captured from the
// state at t = 0 (incline angle from the gravity vector, mu from the geoms, ball radius from
// its geom), so an edited model cannot silently disagree with its expectation.
#include <math.h>
#include <stdio.h>

#include <mujoco/mujoco.h>

#include "compare_hard.h"
#include "ost_cli_util.h"


//---------------------------------- Probe helpers -------------------------------------------------

// Point slot of p at the free joint of body `name`; return 0, else print why and return 1.
static int hard_watchBody(const mjModel* m, const char* name, int slot, hardProbe* p) {
  int b = mj_name2id(m, mjOBJ_BODY, name);
  if (b < 0 || m->body_jntnum[b] < 1 || m->jnt_type[m->body_jntadr[b]] != mjJNT_FREE) {
    cli_error("compare hard: the model has no free body named '%s'", name);
    return 1;
  }
  p->qpos_adr[slot] = m->jnt_qposadr[m->body_jntadr[b]];
  p->qvel_adr[slot] = m->jnt_dofadr[m->body_jntadr[b]];
  return 0;
}


// Largest violation (rad or m) of a joint limit at d's state, over limited hinges and slides.
static double hard_limitViolation(const mjModel* m, const mjData* d) {
  double worst = 0;
  for (int j = 0; j < m->njnt; j++) {
    int type = m->jnt_type[j];
    if (!m->jnt_limited[j] || (type != mjJNT_HINGE && type != mjJNT_SLIDE)) {
      continue;
    }
    double q = d->qpos[m->jnt_qposadr[j]];
    const mjtNum* range = m->jnt_range + 2 * j;
    worst = fmax(worst, fmax(range[0] - q, q - range[1]));
  }
  return worst;
}


//---------------------------------- 1. Heavy-on-light stack ---------------------------------------

// metric: largest sink of either box below its start height; aux: largest horizontal drift
static int stack_start(const mjModel* m, const mjData* d, hardProbe* p) {
  if (hard_watchBody(m, "light", 0, p) || hard_watchBody(m, "heavy", 1, p)) {
    return 1;
  }
  for (int b = 0; b < 2; b++) {
    mju_copy3(p->ref + 3 * b, d->qpos + p->qpos_adr[b]);
  }
  p->aux = 0;
  return 0;
}


static void stack_observe(const mjModel* m, const mjData* d, hardProbe* p) {
  for (int b = 0; b < 2; b++) {
    const mjtNum* x = d->qpos + p->qpos_adr[b];
    const double* x0 = p->ref + 3 * b;
    p->metric = fmax(p->metric, x0[2] - x[2]);
    p->aux = fmax(p->aux, hypot(x[0] - x0[0], x[1] - x0[1]));
  }
}


//---------------------------------- 2, 3. Box on an incline ---------------------------------------

// Incline angle (rad) of the tilted gravity vector, |g| and the pair's friction (MuJoCo takes the
// larger of the two geoms' sliding friction).
static void incline_read(const mjModel* m, double* theta, double* g, double* mu) {
  const mjtNum* grav = m->opt.gravity;
  *theta = atan2(hypot(grav[0], grav[1]), -grav[2]);
  *g = mju_norm3(grav);
  *mu = 0;
  for (int i = 0; i < m->ngeom; i++) {
    *mu = fmax(*mu, m->geom_friction[3 * i]);
  }
}


// sticking: metric is the largest displacement of the box centre from its start
static int stick_start(const mjModel* m, const mjData* d, hardProbe* p) {
  if (hard_watchBody(m, "box", 0, p)) {
    return 1;
  }
  mju_copy3(p->ref, d->qpos + p->qpos_adr[0]);
  return 0;
}


static void stick_observe(const mjModel* m, const mjData* d, hardProbe* p) {
  mjtNum dx[3];
  mju_sub3(dx, d->qpos + p->qpos_adr[0], p->ref);
  p->metric = fmax(p->metric, mju_norm3(dx));
}


// sliding: aux is the mean acceleration down the slope over the second half of the run,
// a = (v(T) - v(T/2)) / (T/2); metric is its error relative to g (sin theta - mu cos theta)
static int slide_start(const mjModel* m, const mjData* d, hardProbe* p) {
  if (hard_watchBody(m, "box", 0, p)) {
    return 1;
  }
  double theta, g, mu;
  incline_read(m, &theta, &g, &mu);
  p->ref[0] = g * (sin(theta) - mu * cos(theta));
  // unit vector down the slope: the horizontal part of gravity
  double horizontal = hypot(m->opt.gravity[0], m->opt.gravity[1]);
  p->ref[1] = m->opt.gravity[0] / horizontal;
  p->ref[2] = m->opt.gravity[1] / horizontal;
  p->work[0] = NAN;  // velocity at half-time, not yet reached
  p->metric = NAN;   // no measurement until then
  return 0;
}


static void slide_observe(const mjModel* m, const mjData* d, hardProbe* p) {
  const mjtNum* v = d->qvel + p->qvel_adr[0];
  double v_slope = p->ref[1] * v[0] + p->ref[2] * v[1];
  if (isnan(p->work[0])) {
    // half-time within half a step (time is a sum of h's)
    if (d->time >= 0.5 * p->duration - 0.5 * p->h) {
      p->work[0] = v_slope;
      p->work[1] = d->time;
    }
    return;
  }
  if (d->time > p->work[1]) {
    p->aux = (v_slope - p->work[0]) / (d->time - p->work[1]);
    p->metric = fabs(p->aux / p->ref[0] - 1);
  }
}


//---------------------------------- 4. Position servo, kp = 1e9 -----------------------------------

#define SERVO_MOVE_START 0.5      // s: hold the horizontal arm until then,
#define SERVO_MOVE_TIME  1.0      // s: then move to kServoTarget along a cosine ramp, then hold

static const double kServoTarget[3] = {0.5, -0.3, 0.2};  // rad, joints j0..j2

// every actuator tracks its share of the ramp: ctrl = s(t) target, s from 0 to 1
static void servo_control(const mjModel* m, mjData* d, double t_end) {
  double u = fmin(fmax((t_end - SERVO_MOVE_START) / SERVO_MOVE_TIME, 0), 1);
  double s = 0.5 * (1 - cos(M_PI * u));
  for (int i = 0; i < m->nu && i < 3; i++) {
    d->ctrl[i] = s * kServoTarget[i];
  }
}


// metric: largest |q - ctrl| of a joint-driven actuator after the step; aux: largest |qvel|
static void servo_observe(const mjModel* m, const mjData* d, hardProbe* p) {
  for (int i = 0; i < m->nu; i++) {
    if (m->actuator_trntype[i] == mjTRN_JOINT) {
      double q = d->qpos[m->jnt_qposadr[m->actuator_trnid[2 * i]]];
      p->metric = fmax(p->metric, fabs(q - d->ctrl[i]));
    }
  }
  double vmax = 0;
  for (int j = 0; j < m->nv; j++) {
    vmax = fmax(vmax, fabs(d->qvel[j]));
  }
  p->aux = isnan(p->aux) ? vmax : fmax(p->aux, vmax);
}


//---------------------------------- 5. Ball at 20 m/s ---------------------------------------------

#define BALL_TOUCH 1e-3           // m: the ball has landed once its bottom is this close

// metric: rebound, the highest bottom height after the first touchdown; aux: final centre height
static int ball_start(const mjModel* m, const mjData* d, hardProbe* p) {
  if (hard_watchBody(m, "ball", 0, p)) {
    return 1;
  }
  int b = mj_name2id(m, mjOBJ_BODY, "ball");
  p->ref[0] = m->geom_size[3 * m->body_geomadr[b]];  // radius
  p->work[0] = 0;                                    // landed yet
  return 0;
}


static void ball_observe(const mjModel* m, const mjData* d, hardProbe* p) {
  double z = d->qpos[p->qpos_adr[0] + 2], bottom = z - p->ref[0];
  if (!p->work[0] && bottom <= BALL_TOUCH) {
    p->work[0] = 1;
  }
  if (p->work[0]) {
    p->metric = fmax(p->metric, bottom);
  }
  p->aux = z;
}


//---------------------------------- 6. Robot over the pallet edge ---------------------------------

#define ROBOT_WHEEL_SPEED 3.0     // rad/s on every wheel (the README's pallet run)

static void robot_control(const mjModel* m, mjData* d, double t_end) {
  for (int i = 0; i < m->nu; i++) {
    d->ctrl[i] = ROBOT_WHEEL_SPEED;
  }
}


// metric: largest sideways drift |y - y0| of the chassis (the robot and the pallet are
// symmetric about y = 0); aux: final chassis x
static int robot_start(const mjModel* m, const mjData* d, hardProbe* p) {
  if (hard_watchBody(m, "chassis", 0, p)) {
    return 1;
  }
  p->ref[0] = d->qpos[p->qpos_adr[0] + 1];
  return 0;
}


static void robot_observe(const mjModel* m, const mjData* d, hardProbe* p) {
  const mjtNum* x = d->qpos + p->qpos_adr[0];
  p->metric = fmax(p->metric, fabs(x[1] - p->ref[0]));
  p->aux = x[0];
}


//---------------------------------- 7, 9. Chain and humanoid --------------------------------------

// metric: largest joint-limit violation over the run
static void limits_observe(const mjModel* m, const mjData* d, hardProbe* p) {
  p->metric = fmax(p->metric, hard_limitViolation(m, d));
}


//---------------------------------- 8. Grazing contact --------------------------------------------

// metric: largest change of the cube's linear velocity (snagging slows or deflects it);
// aux: largest change of its height (a launch or a sink at the seam)
static int grazing_start(const mjModel* m, const mjData* d, hardProbe* p) {
  if (hard_watchBody(m, "slider", 0, p)) {
    return 1;
  }
  mju_copy3(p->ref, d->qvel + p->qvel_adr[0]);
  p->ref[3] = d->qpos[p->qpos_adr[0] + 2];
  p->aux = 0;
  return 0;
}


static void grazing_observe(const mjModel* m, const mjData* d, hardProbe* p) {
  mjtNum dv[3];
  mju_sub3(dv, d->qvel + p->qvel_adr[0], p->ref);
  p->metric = fmax(p->metric, mju_norm3(dv));
  p->aux = fmax(p->aux, fabs(d->qpos[p->qpos_adr[0] + 2] - p->ref[3]));
}


//---------------------------------- The table -----------------------------------------------------

#define ANY_H INFINITY            // hardBounds.h_max: expected at every step size
#define NONE  INFINITY            // an unchecked upper bound

const hardCase kHardCases[] = {
  {.name = "stack", .model = "stack_heavy_light.xml",
   .summary = "1000 kg box resting on a 1 kg box on the floor", .duration = 5,
   .metric_name = "sink_m", .aux_name = "drift_m",
   .expect = {.h_max = ANY_H, .penetration = 1e-3, .energy_gain = 1.0, .metric = 1e-3,
              .aux_min = -INFINITY, .aux_max = 1e-3},
   .why = "hard contact at rest: penetration and sink only from the 1e-6 regularization; "
          "1 J = a 0.1 mm rise of the heavy box",
   .start = stack_start, .observe = stack_observe},

  {.name = "incline_stick", .model = "hard_incline_stick.xml",
   .summary = "box on a 26 deg incline, mu 0.5 (tan 26 < mu)", .duration = 2,
   .metric_name = "displacement_m",
   .expect = {.h_max = ANY_H, .penetration = 1e-3, .energy_gain = 1e-3, .metric = 1e-4,
              .aux_min = -INFINITY, .aux_max = NONE},
   .why = "Coulomb cone solved exactly at every h: static friction holds, creep only from the "
          "regularization; 1e-3 J = a 0.1 mm rise of the box",
   .start = stick_start, .observe = stick_observe},

  {.name = "incline_slide", .model = "hard_incline_slide.xml",
   .summary = "box on a 27 deg incline, mu 0.5 (tan 27 > mu)", .duration = 2,
   .metric_name = "accel_rel_err", .aux_name = "accel_m_s2",
   .expect = {.h_max = ANY_H, .penetration = 1e-3, .energy_gain = 1e-3, .metric = 0.01,
              .aux_min = -INFINITY, .aux_max = NONE},
   .why = "sliding friction = mu N at every h, so a = g (sin - mu cos) up to 1 %",
   .start = slide_start, .observe = slide_observe},

  {.name = "servo_1e9", .model = "hard_servo_stiff.xml",
   .summary = "3-link arm on kp = 1e9 servos: hold, 1 s move, hold", .duration = 2,
   .actuated = 1, .metric_name = "track_err_rad", .aux_name = "max_qvel",
   .expect = {.h_max = ANY_H, .penetration = NONE, .energy_gain = NONE, .metric = 1e-4,
              .aux_min = -INFINITY, .aux_max = NONE},
   .why = "servo rows are implicit: q+ meets the target up to (inertia + gravity) / kp",
   .control = servo_control, .observe = servo_observe},

  {.name = "ball_20ms", .model = "hard_ball_fast.xml",
   .summary = "ball thrown down at 20 m/s from 1 m onto a plane", .duration = 1,
   .metric_name = "rebound_m", .aux_name = "final_z_m",
   .expect = {.h_max = ANY_H, .penetration = 1e-3, .energy_gain = 1e-3, .metric = 1e-3,
              .aux_min = 0.099, .aux_max = 0.101},
   .why = "the contact is found at q+ whatever the step, and a hard inelastic impact: no "
          "tunnelling, no rebound, energy only lost",
   .start = ball_start, .observe = ball_observe},

  {.name = "robot_edge", .model = "robot_pallet.xml",
   .summary = "wheeled robot at 3 rad/s over the 0.144 m pallet", .duration = 6,
   .actuated = 1, .metric_name = "drift_y_m", .aux_name = "final_x_m",
   .expect = {.h_max = ANY_H, .penetration = 1e-3, .energy_gain = NONE, .metric = 0.05,
              .aux_min = 3.0, .aux_max = NONE},
   .why = "README: climbs and drives off at h = 0.05 and 0.1 s, penetration < 1 mm; the "
          "scene is symmetric in y, so 5 cm of drift is a fault; final x > 3 m: the rear "
          "wheel is past the far edge (x = 2.2 m)",
   .start = robot_start, .control = robot_control, .observe = robot_observe},

  {.name = "chain20", .model = "hard_chain20.xml",
   .summary = "20-link chain, limits +-60 deg, released horizontal", .duration = 3,
   .metric_name = "limit_viol_rad",
   .expect = {.h_max = 0, .penetration = NONE, .energy_gain = 0.2, .metric = 1e-3,
              .aux_min = -INFINITY, .aux_max = NONE},
   .why = "reported, not expected (h_max 0): energy should not grow (0.2 J = 1 % of the "
          "19.6 J the fall releases) and limits are hard rows, but Ostrich's contact-free "
          "step is MuJoCo's semi-implicit Euler (README): gravity and Coriolis forces are "
          "explicit, so the energy error grows with h until the smooth forces are implicit",
   .observe = limits_observe},

  {.name = "grazing", .model = "hard_grazing.xml",
   .summary = "frictionless cube sliding at 2 m/s across a flush seam", .duration = 1,
   .metric_name = "dv_m_s", .aux_name = "dz_m",
   .expect = {.h_max = ANY_H, .penetration = 1e-3, .energy_gain = 1e-3, .metric = 0.02,
              .aux_min = -INFINITY, .aux_max = 1e-3},
   .why = "a contact met tangentially carries no impulse: speed (to 1 % of 2 m/s) and "
          "height (to 1 mm) constant",
   .start = grazing_start, .observe = grazing_observe},

  {.name = "humanoid", .model = NULL,
   .summary = "MuJoCo's humanoid falling from standing onto the floor", .duration = 2,
   .metric_name = "limit_viol_rad",
   .expect = {.h_max = ANY_H, .penetration = 1e-3, .energy_gain = 1.0, .metric = 0.01,
              .aux_min = -INFINITY, .aux_max = NONE},
   .why = "hard contact and hard limits at every h; damping and impacts only remove energy "
          "(1 J = a 2.5 mm rise of the 40.8 kg body)",
   .observe = limits_observe},
};

const int kHardNumCases = (int)(sizeof(kHardCases) / sizeof(kHardCases[0]));
