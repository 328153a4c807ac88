// fixture.c: see fixture.h.
#include "fixture.h"

#include "ostrich.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int allow_warnings = 0;
static int nwarnings = 0;

static void onError(const char* msg) {
  ck_abort_msg("MuJoCo error: %s", msg);
}


static void onWarning(const char* msg) {
  nwarnings++;
  if (!allow_warnings) {
    ck_abort_msg("MuJoCo warning: %s", msg);
  }
}


void ost_fixtureSetup(void) {
  mju_user_error = onError;
  mju_user_warning = onWarning;
  allow_warnings = 0;
  nwarnings = 0;
}


int ost_fixtureAllowWarnings(int allow) {
  allow_warnings = allow;
  return nwarnings;
}


mjModel* ost_fixtureLoadModel(const char* name) {
  char path[1024], err[1000] = "";
  snprintf(path, sizeof(path), "%s/%s", OST_MODEL_DIR, name);
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "cannot load %s: %s", path, err);
  return m;
}


mjModel* ost_fixtureTryLoadString(const char* xml, char* err, int err_sz) {
  char path[] = "/tmp/ostrich_test_XXXXXX.xml";
  int fd = mkstemps(path, 4);
  ck_assert_int_ge(fd, 0);
  FILE* f = fdopen(fd, "w");
  fputs(xml, f);
  fclose(f);
  mjModel* m = mj_loadXML(path, NULL, err, err_sz);
  unlink(path);
  return m;
}


mjModel* ost_fixtureLoadString(const char* xml) {
  char err[1000] = "";
  mjModel* m = ost_fixtureTryLoadString(xml, err, sizeof(err));
  ck_assert_msg(m != NULL, "cannot load XML: %s", err);
  return m;
}


int ost_fixtureRun(Suite* s) {
  SRunner* sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int nfailed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return nfailed == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}


void ost_fixtureSetTimestep(const mjModel* m, mjData* d, double h) {
  ostOptions opt;
  ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
  opt.timestep = h;
  ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
}
