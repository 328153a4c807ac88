// test_compare_metric.c: the A/B harness's shared part (compare/compare_run.c) against hand-made
// answers: the trajectory error metric (pure offset, pure yaw offset, yaw across +-pi, combined,
// time-varying with interpolation, fixed base, common span), angle helpers, the zero-order hold,
// the CSV reader's rejections, and the default pallet-traversal commands.
#define _POSIX_C_SOURCE 200809L

#include "compare_run.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "fixture.h"

static const double kPi = 3.14159265358979323846;

typedef void (*poseFunction)(double t, double* pose);  // a pose (x, y, z, yaw) at time t


// A pose trajectory of f sampled every dt over [t0, t1] (yaw given wrapped, as a log has it).
static void makePose(cmpTrajectory* tr, double t0, double t1, double dt, poseFunction f) {
  cmp_initTrajectory(tr, CMP_POSE, 4);
  long n = lround((t1 - t0) / dt);
  for (long k = 0; k <= n; k++) {
    double t = t0 + (double)k * dt, pose[4];
    f(t, pose);
    pose[3] = cmp_wrapAngle(pose[3]);
    ck_assert_int_eq(cmp_appendSample(tr, t, pose), 0);
  }
}


// Reference poses: a straight drive along x at 1 m/s heading yaw 0.3, and variants of it.
static void poseRef(double t, double* p) {
  p[0] = t;
  p[1] = 0.5;
  p[2] = 0.35;
  p[3] = 0.3;
}
static void poseOffset(double t, double* p) {  // (0.03, -0.04, 0.12) away: |dp| = 0.13
  poseRef(t, p);
  p[0] += 0.03;
  p[1] -= 0.04;
  p[2] += 0.12;
}
static void poseYaw(double t, double* p) {     // yaw 0.2 rad off
  poseRef(t, p);
  p[3] += 0.2;
}
static void poseBoth(double t, double* p) {    // (0.03, 0.04, 0) and 0.1 rad
  poseRef(t, p);
  p[0] += 0.03;
  p[1] += 0.04;
  p[3] -= 0.1;
}
static void poseDrift(double t, double* p) {   // error growing linearly: dx = t
  poseRef(t, p);
  p[0] += t;
}
static void poseSpin(double t, double* p) {    // spinning at 2 rad/s: yaw crosses +-pi
  poseRef(t, p);
  p[3] = 2 * t + 3;
}
static void poseSpinLag(double t, double* p) { // the same, 0.1 rad behind
  poseSpin(t, p);
  p[3] -= 0.1;
}


START_TEST(test_poseErrors) {
  cmpTrajectory ref, a;
  makePose(&ref, 0, 2, 0.01, poseRef);

  // identical: 0; pure offset: |dp|; pure yaw offset: L * dyaw; combined: both in quadrature
  makePose(&a, 0, 2, 0.01, poseRef);
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &ref, 0.01), 0, 1e-15);
  cmp_freeTrajectory(&a);
  makePose(&a, 0, 2, 0.01, poseOffset);
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &ref, 0.01), 0.13, 1e-12);
  cmp_freeTrajectory(&a);
  makePose(&a, 0, 2, 0.01, poseYaw);
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &ref, 0.01), CMP_YAW_LENGTH * 0.2, 1e-12);
  cmp_freeTrajectory(&a);
  makePose(&a, 0, 2, 0.01, poseBoth);
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &ref, 0.01), sqrt(0.05 * 0.05 + 0.05 * 0.05),
                          1e-12);
  cmp_freeTrajectory(&a);

  // dx = t on [0, 1] every 0.01 s: sqrt(mean of (k/100)^2, k = 0..100) = sqrt(0.335)
  cmpTrajectory ref1;
  makePose(&ref1, 0, 1, 0.01, poseRef);
  makePose(&a, 0, 1, 0.01, poseDrift);
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &ref1, 0.01), sqrt(0.335), 1e-12);
  cmp_freeTrajectory(&a);

  // the same drift sampled at 0.1 s (and at 0.001 s): linear, so interpolation is exact
  makePose(&a, 0, 1, 0.1, poseDrift);
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &ref1, 0.01), sqrt(0.335), 1e-12);
  cmp_freeTrajectory(&a);
  makePose(&a, 0, 1, 0.001, poseDrift);
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &ref1, 0.01), sqrt(0.335), 1e-12);
  cmp_freeTrajectory(&a);
  cmp_freeTrajectory(&ref1);
  cmp_freeTrajectory(&ref);
}
END_TEST


START_TEST(test_yawWrap) {
  // constant yaws on either side of the cut: pi - 0.01 against -pi + 0.01 differ by 0.02
  cmpTrajectory a, b;
  cmp_initTrajectory(&a, CMP_POSE, 4);
  cmp_initTrajectory(&b, CMP_POSE, 4);
  for (int k = 0; k <= 10; k++) {
    double pa[4] = {0, 0, 0, kPi - 0.01}, pb[4] = {0, 0, 0, -kPi + 0.01};
    cmp_appendSample(&a, 0.01 * k, pa);
    cmp_appendSample(&b, 0.01 * k, pb);
  }
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &b, 0.01), CMP_YAW_LENGTH * 0.02, 1e-12);
  cmp_freeTrajectory(&a);
  cmp_freeTrajectory(&b);

  // spinning through +-pi several times, sampled coarsely (0.1 s = 0.2 rad): the stored yaw is
  // unwrapped, so interpolation never jumps, and a constant 0.1 rad lag gives L * 0.1
  makePose(&a, 0, 5, 0.1, poseSpin);
  makePose(&b, 0, 5, 0.01, poseSpinLag);
  for (int i = 1; i < a.n; i++) {
    ck_assert_double_eq_tol(a.coord[4 * i + 3] - a.coord[4 * (i - 1) + 3], 0.2, 1e-12);
  }
  ck_assert_double_eq_tol(cmp_trajectoryError(&b, &a, 0.01), CMP_YAW_LENGTH * 0.1, 1e-9);
  cmp_freeTrajectory(&a);
  cmp_freeTrajectory(&b);
}
END_TEST


START_TEST(test_fixedBaseAndSpan) {
  // qpos trajectories: an offset (0.3, -0.4) at the same times gives 0.5
  cmpTrajectory a, b, c;
  cmp_initTrajectory(&a, CMP_QPOS, 2);
  cmp_initTrajectory(&b, CMP_QPOS, 2);
  cmp_initTrajectory(&c, CMP_QPOS, 2);
  for (int k = 0; k <= 100; k++) {
    double t = 0.01 * k, qa[2] = {sin(t), t}, qc[2] = {sin(t) + 0.3, t - 0.4};
    cmp_appendSample(&a, t, qa);
    cmp_appendSample(&c, t, qc);
    cmp_appendSample(&b, t + 0.5, qc);  // the same samples, 0.5 s later: span [0.5, 1.5]
  }
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &c, 0.01), 0.5, 1e-12);

  // only the common span [0.5, 1] counts, each at the same time: b(t) = (sin(t - 0.5) + 0.3,
  // t - 0.9); sin is linear to 1e-5 between samples
  double sum = 0;
  for (int k = 0; k <= 50; k++) {
    double t = 0.5 + 0.01 * k;
    double dq0 = sin(t) - (sin(t - 0.5) + 0.3), dq1 = 0.9;
    sum += dq0 * dq0 + dq1 * dq1;
  }
  ck_assert_double_eq_tol(cmp_trajectoryError(&a, &b, 0.01), sqrt(sum / 51), 1e-4);
  cmp_freeTrajectory(&c);

  // a different kind or disjoint spans give NaN
  cmpTrajectory p;
  makePose(&p, 0, 1, 0.01, poseRef);
  ck_assert(isnan(cmp_trajectoryError(&a, &p, 0.01)));
  cmpTrajectory late;
  makePose(&late, 2, 3, 0.01, poseRef);
  ck_assert(isnan(cmp_trajectoryError(&p, &late, 0.01)));
  cmp_freeTrajectory(&a);
  cmp_freeTrajectory(&b);
  cmp_freeTrajectory(&p);
  cmp_freeTrajectory(&late);
}
END_TEST


START_TEST(test_angles) {
  ck_assert_double_eq_tol(cmp_wrapAngle(kPi), kPi, 1e-15);
  ck_assert_double_eq_tol(cmp_wrapAngle(-kPi), kPi, 1e-15);
  ck_assert_double_eq_tol(cmp_wrapAngle(3 * kPi + 0.5), -kPi + 0.5, 1e-12);
  ck_assert_double_eq_tol(cmp_wrapAngle(-0.25), -0.25, 1e-15);

  // yaw of rotations about z, and of a yaw-then-pitch rotation (ZYX): the yaw survives
  for (double yaw = -3; yaw <= 3; yaw += 0.5) {
    mjtNum q[4] = {cos(0.5 * yaw), 0, 0, sin(0.5 * yaw)}, pitch[4] = {cos(0.2), 0, sin(0.2), 0};
    mjtNum qp[4];
    ck_assert_double_eq_tol(cmp_yaw(q), yaw, 1e-12);
    mju_mulQuat(qp, q, pitch);
    ck_assert_double_eq_tol(cmp_yaw(qp), yaw, 1e-12);
  }
}
END_TEST


START_TEST(test_zeroOrderHold) {
  cmpCommands c;
  ck_assert_int_eq(cmp_allocCommands(&c, 3, 2), 0);
  for (int i = 0; i < 3; i++) {
    c.time[i] = i;
    c.ctrl[2 * i] = 10 * i;
    c.ctrl[2 * i + 1] = -i;
  }
  double probe[5] = {-1, 0.5, 1.0, 1.999, 7}, want[5] = {0, 0, 10, 10, 20};
  for (int k = 0; k < 5; k++) {
    mjtNum u[2];
    cmp_commandAt(&c, probe[k], u);
    ck_assert_double_eq(u[0], want[k]);
    ck_assert_double_eq(u[1], -want[k] / 10);
  }
  cmp_freeCommands(&c);

  // the default traversal: rest, then 1 m/s on all wheels (1 / 0.35 rad/s), then a left turn at
  // 0.8 rad/s from 4.1 s (front wheels (1 -+ 0.8 * 0.35) / 0.35)
  ck_assert_int_eq(cmp_traversalCommands(&kCmpDefaultTraversal, 100, &c), 0);
  mjtNum u[3];
  cmp_commandAt(&c, 0.1, u);
  ck_assert_double_eq(u[0], 0);
  cmp_commandAt(&c, 2.0, u);
  ck_assert_double_eq_tol(u[0], 1 / 0.35, 1e-12);
  ck_assert_double_eq_tol(u[2], 1 / 0.35, 1e-12);
  cmp_commandAt(&c, 5.0, u);
  ck_assert_double_eq_tol(u[0], (1 - 0.8 * 0.35) / 0.35, 1e-12);
  ck_assert_double_eq_tol(u[1], (1 + 0.8 * 0.35) / 0.35, 1e-12);
  ck_assert_double_eq_tol(c.time[c.nrow - 1], 7.67, 1e-12);
  cmp_freeCommands(&c);
}
END_TEST


// Write text to a temporary file and return its path (static buffer).
static const char* writeTemp(const char* text) {
  static char path[64];
  snprintf(path, sizeof(path), "/tmp/ostrich_metric_XXXXXX");
  int fd = mkstemp(path);
  ck_assert_int_ge(fd, 0);
  FILE* f = fdopen(fd, "w");
  fputs(text, f);
  fclose(f);
  return path;
}


START_TEST(test_csvReader) {
  // a good file: comments, spaces, CRLF
  cmpTable t;
  const char* path = writeTemp("# comment\ntime, a ,b\r\n0,1,2\n# more\n0.5, 3 ,4\r\n\n");
  ck_assert_int_eq(cmp_readTable(path, &t), 0);
  ck_assert_int_eq(t.nrow, 2);
  ck_assert_int_eq(t.ncol, 3);
  ck_assert_int_eq(cmp_tableColumn(&t, "a"), 1);
  ck_assert_double_eq(t.data[4], 3);
  cmp_freeTable(&t);
  unlink(path);

  // rejections: wrong column count, NaN, text, time not increasing, no 'time', no rows
  const char* bad[] = {"time,a\n0,1\n1,2,3\n", "time,a\n0,nan\n", "time,a\n0,x\n",
                       "time,a\n0,1\n0,2\n", "t,a\n0,1\n", "time,a\n"};
  for (int i = 0; i < (int)(sizeof(bad) / sizeof(bad[0])); i++) {
    path = writeTemp(bad[i]);
    ck_assert_msg(cmp_readTable(path, &t) != 0, "accepted bad CSV %d", i);
    ck_assert_ptr_null(t.data);
    unlink(path);
  }
  ck_assert_int_ne(cmp_readTable("/nonexistent/ostrich.csv", &t), 0);

  // a command file must have 1 + nu columns
  cmpCommands c;
  path = writeTemp("time,u\n0,1\n");
  ck_assert_int_ne(cmp_readCommands(path, 3, &c), 0);
  ck_assert_int_eq(cmp_readCommands(path, 1, &c), 0);
  cmp_freeCommands(&c);
  unlink(path);
}
END_TEST


int main(void) {
  Suite* s = suite_create("compare_metric");
  TCase* tc = tcase_create("metric");
  tcase_add_test(tc, test_poseErrors);
  tcase_add_test(tc, test_yawWrap);
  tcase_add_test(tc, test_fixedBaseAndSpan);
  tcase_add_test(tc, test_angles);
  tcase_add_test(tc, test_zeroOrderHold);
  tcase_add_test(tc, test_csvReader);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
