// ost_preload.c: LD_PRELOAD shim that makes an unmodified MuJoCo 2.2.2 program step with Ostrich.
// It interposes mj_step, mj_stepSkip and mj_step2 (engine_forward.c, engine_derivative.c) and
// routes them to ost_step / ost_step / ost_step2; mj_loadXML and mj_loadModel mark load-time steps,
// mj_deleteData releases Ostrich's per-mjData state, mj_deleteModel forgets a model's verdict.
// The real functions come from dlsym(RTLD_NEXT, ...). See mujoco-integration.md section 3(c).
//
// Invariant: a step goes to Ostrich only if the library is MuJoCo 2.2.2, no model is being
// compiled on this thread (nor on any thread, for a model not yet checked), the call does not come
// from inside Ostrich, and ost_checkModel has accepted the model; in every other case the stock
// function runs with the caller's arguments unchanged. Nothing here exits, aborts or calls
// mju_error: failures are printed and the state is left as Ostrich left it.
//
// Messages (stderr, each one line, prefixed "ostrich: "):
//   banner   "stepping <model> with Ostrich"           first Ostrich step of the process
//   refusal  "refusing model '<name>': <err>; ..."      once per model, printed even when quiet
//   failure  "step <t> failed: <ost_lastError>; this step was taken by stock MuJoCo"
//            on the first failure of each status code; every failure is counted
//   warning  "step <t> did not converge (residual r m/s); ..."   on the first such step
//   summary  "<N> steps, mean Newton iterations <x>, mean residual <y>, <u> not converged
//            (worst residual r), <k> failed and stepped by stock MuJoCo[ (last: ...)]"   at exit
//            (means over the steps that Ostrich took)
// A failed Ostrich step (capacity overflow, numerical failure) leaves the state as it was; the
// shim then takes that step with stock MuJoCo, so that a program never keeps stepping a frozen
// state, and says so. Like MuJoCo's warnings, failures and unconverged steps are counted on
// every occurrence and printed on the first.
// OSTRICH_QUIET=1 silences the banner and the summary.
//
// LD_PRELOAD is removed from the environment of a program that links libmujoco, so its children
// do not inherit it; wrappers (sh, timeout, xvfb-run, valgrind) keep it and pass it on.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <link.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "ostrich.h"

// exported by libmujoco 2.2.2 but not declared in mujoco.h (engine_derivative.h)
void mj_stepSkip(const mjModel* m, mjData* d, int skipstage, int skipsensor);


//---------------------------------- State ---------------------------------------------------------

typedef void (*ostfStep)(const mjModel* m, mjData* d);
typedef void (*ostfStepSkip)(const mjModel* m, mjData* d, int skipstage, int skipsensor);
typedef mjModel* (*ostfLoadXML)(const char* filename, const mjVFS* vfs, char* error, int error_sz);
typedef mjModel* (*ostfLoadModel)(const char* filename, const mjVFS* vfs);
typedef void (*ostfDeleteModel)(mjModel* m);
typedef void (*ostfDeleteData)(mjData* d);

// the stock functions, resolved once by resolveReal
typedef struct ostReal_ {
  ostfStep        step;           // mj_step
  ostfStepSkip    stepSkip;       // mj_stepSkip (may be NULL on other builds)
  ostfStep        step2;          // mj_step2
  ostfLoadXML     loadXML;        // mj_loadXML
  ostfLoadModel   loadModel;      // mj_loadModel
  ostfDeleteModel deleteModel;    // mj_deleteModel
  ostfDeleteData  deleteData;     // mj_deleteData
} ostReal;

// verdict of ost_checkModel for one model
typedef struct ostVerdict_ {
  const mjModel* m;               // model pointer (NULL: free slot)
  int            ok;              // 1: Ostrich steps it, 0: refused, stock steps it
} ostVerdict;

#define OST_NVERDICT 64           // verdict cache capacity; the oldest entry is replaced when full

static pthread_once_t g_once = PTHREAD_ONCE_INIT;
static ostReal g_real;            // stock functions
static int g_active = 0;          // 1 if the library is MuJoCo 2.2.2 and all stock steps resolved
static int g_quiet = 0;           // OSTRICH_QUIET set (banner and summary off)

static pthread_mutex_t g_model_lock = PTHREAD_MUTEX_INITIALIZER;
static ostVerdict g_verdict[OST_NVERDICT];  // guarded by g_model_lock
static int g_verdict_next = 0;              // slot to replace when full, guarded by g_model_lock
static atomic_uint g_model_gen = 0;         // bumped when a verdict is forgotten
static atomic_int g_loading = 0;            // model loads in progress, all threads

static _Thread_local int tl_loading = 0;    // model loads in progress on this thread
static _Thread_local int tl_inside = 0;     // calls into Ostrich in progress on this thread
static _Thread_local const mjModel* tl_model = NULL;  // last verdict seen on this thread
static _Thread_local int tl_ok = 0;
static _Thread_local unsigned tl_gen = 0;

static atomic_int g_banner = 0;             // banner printed
static atomic_uint g_failed_seen = 0;       // bit s: failure with status s printed (31: other)

// step statistics, guarded by g_stats_lock
static pthread_mutex_t g_stats_lock = PTHREAD_MUTEX_INITIALIZER;
static long g_nstep = 0;                    // steps routed to Ostrich
static long g_nfail = 0;                    // of which returned an error status (then stock)
static long g_nwarn = 0;                    // of which were taken but not to tolerance
static double g_worst_residual = 0;         // largest residual of those (m/s)
static char g_last_fail[200] = "";          // message of the last failure
static long g_nstat = 0;                    // successful steps with statistics
static double g_sum_iter = 0;               // sum of Newton iterations over those
static double g_sum_residual = 0;           // sum of merit residuals over those


//---------------------------------- Initialization ------------------------------------------------

// resolve the stock functions and check the library version (once per process)
static void resolveReal(void) {
  g_real.step = (ostfStep)dlsym(RTLD_NEXT, "mj_step");
  g_real.stepSkip = (ostfStepSkip)dlsym(RTLD_NEXT, "mj_stepSkip");
  g_real.step2 = (ostfStep)dlsym(RTLD_NEXT, "mj_step2");
  g_real.loadXML = (ostfLoadXML)dlsym(RTLD_NEXT, "mj_loadXML");
  g_real.loadModel = (ostfLoadModel)dlsym(RTLD_NEXT, "mj_loadModel");
  g_real.deleteModel = (ostfDeleteModel)dlsym(RTLD_NEXT, "mj_deleteModel");
  g_real.deleteData = (ostfDeleteData)dlsym(RTLD_NEXT, "mj_deleteData");

  const char* quiet = getenv("OSTRICH_QUIET");
  g_quiet = (quiet && quiet[0] && strcmp(quiet, "0") != 0);

  // version guard: the mjData layout Ostrich writes is that of 2.2.2
  int version = mj_version();
  if (version != 222) {
    fprintf(stderr, "ostrich: MuJoCo version %d is not 2.2.2; passing through to stock MuJoCo\n",
            version);
    return;
  }
  if (!g_real.step || !g_real.step2 || !g_real.deleteData || !g_real.deleteModel) {
    fprintf(stderr, "ostrich: cannot find the stock mj_step family (%s); "
            "passing through to stock MuJoCo\n", dlerror());
    return;
  }
  g_active = 1;
}


static inline void init(void) {
  pthread_once(&g_once, resolveReal);
}


// remove every entry naming this library from LD_PRELOAD (separated by spaces or colons)
static void dropFromPreload(void) {
  const char* list = getenv("LD_PRELOAD");
  Dl_info info;
  if (!list || !dladdr((void*)dropFromPreload, &info) || !info.dli_fname) {
    return;
  }
  const char* self = strrchr(info.dli_fname, '/');
  self = self ? self + 1 : info.dli_fname;

  size_t len = strlen(list);
  char* kept = (char*)malloc(len + 1);
  char* copy = strdup(list);
  if (!kept || !copy) {
    free(kept);
    free(copy);
    unsetenv("LD_PRELOAD");
    return;
  }

  // keep the entries whose file name differs from ours
  kept[0] = '\0';
  char* save = NULL;
  for (char* tok = strtok_r(copy, " :", &save); tok; tok = strtok_r(NULL, " :", &save)) {
    const char* base = strrchr(tok, '/');
    base = base ? base + 1 : tok;
    if (strcmp(base, self) != 0) {
      if (kept[0]) {
        strcat(kept, " ");
      }
      strcat(kept, tok);
    }
  }
  if (kept[0]) {
    setenv("LD_PRELOAD", kept, 1);
  } else {
    unsetenv("LD_PRELOAD");
  }
  free(kept);
  free(copy);
}


// dl_iterate_phdr callback for the first object, the main program: set *data to 1 if one of its
// DT_NEEDED entries is libmujoco
static int findMujocoNeeded(struct dl_phdr_info* info, size_t size, void* data) {
  const ElfW(Dyn)* dyn = NULL;
  for (int i = 0; i < info->dlpi_phnum; i++) {
    if (info->dlpi_phdr[i].p_type == PT_DYNAMIC) {
      dyn = (const ElfW(Dyn)*)(info->dlpi_addr + info->dlpi_phdr[i].p_vaddr);
    }
  }
  if (!dyn) {
    return 1;
  }

  // string table; the loader may or may not have relocated the address in place
  const char* strtab = NULL;
  for (const ElfW(Dyn)* e = dyn; e->d_tag != DT_NULL; e++) {
    if (e->d_tag == DT_STRTAB) {
      ElfW(Addr) adr = e->d_un.d_ptr;
      strtab = (const char*)(adr < info->dlpi_addr ? adr + info->dlpi_addr : adr);
    }
  }
  if (!strtab) {
    return 1;
  }

  // needed libraries
  for (const ElfW(Dyn)* e = dyn; e->d_tag != DT_NULL; e++) {
    if (e->d_tag == DT_NEEDED && strstr(strtab + e->d_un.d_val, "libmujoco")) {
      *(int*)data = 1;
    }
  }
  return 1;
}


// constructor: resolve, and keep the children of a MuJoCo program from inheriting the preload
__attribute__((constructor)) static void ostPreloadInit(void) {
  init();
  int mujoco_program = 0;
  dl_iterate_phdr(findMujocoNeeded, &mujoco_program);
  if (mujoco_program) {
    dropFromPreload();
  }
}


// destructor: one summary line of the Ostrich steps of this process
__attribute__((destructor)) static void ostPreloadFini(void) {
  pthread_mutex_lock(&g_stats_lock);
  long nstep = g_nstep, nfail = g_nfail, nstat = g_nstat, nwarn = g_nwarn;
  double sum_iter = g_sum_iter, sum_residual = g_sum_residual, worst = g_worst_residual;
  char last[200];
  snprintf(last, sizeof(last), "%s", g_last_fail);
  pthread_mutex_unlock(&g_stats_lock);
  // failures and unconverged steps are reported even when quiet
  if ((g_quiet && nfail == 0 && nwarn == 0) || nstep == 0) {
    return;
  }

  char tail[400];
  snprintf(tail, sizeof(tail), ", %ld not converged (worst residual %.3g m/s), %ld failed and "
           "stepped by stock MuJoCo%s%s%s", nwarn, worst, nfail, nfail ? " (last: " : "",
           nfail ? last : "", nfail ? ")" : "");
  if (nstat > 0) {
    fprintf(stderr, "ostrich: %ld steps, mean Newton iterations %.2f, mean residual %.3g%s\n",
            nstep, sum_iter / nstat, sum_residual / nstat, tail);
  } else {
    fprintf(stderr, "ostrich: %ld steps, mean Newton iterations n/a, mean residual n/a%s\n",
            nstep, tail);
  }
}


//---------------------------------- Routing -------------------------------------------------------

// name of a model: the first entry of m->names in 2.2.2
static const char* modelName(const mjModel* m) {
  return (m->nnames > 0 && m->names && m->names[0]) ? m->names : "model";
}


// forget the verdict of m (deleted, or reloaded at the same address)
static void forgetModel(const mjModel* m) {
  pthread_mutex_lock(&g_model_lock);
  for (int i = 0; i < OST_NVERDICT; i++) {
    if (g_verdict[i].m == m) {
      g_verdict[i].m = NULL;
    }
  }
  atomic_fetch_add(&g_model_gen, 1);
  pthread_mutex_unlock(&g_model_lock);
}


// verdict for m: 1 Ostrich, 0 stock, -1 stock for now (first seen while a model is compiling);
// ost_checkModel runs without the lock held, so Ostrich may take its own locks
static int modelVerdict(const mjModel* m) {
  // cached
  pthread_mutex_lock(&g_model_lock);
  for (int i = 0; i < OST_NVERDICT; i++) {
    if (g_verdict[i].m == m) {
      int ok = g_verdict[i].ok;
      pthread_mutex_unlock(&g_model_lock);
      return ok;
    }
  }
  pthread_mutex_unlock(&g_model_lock);

  // new while some thread compiles: may be a half-built model (lengthrange threads)
  if (atomic_load(&g_loading) > 0) {
    return -1;
  }

  // check
  char err[512] = "";
  tl_inside++;
  int ok = (ost_checkModel(m, err, sizeof(err)) == OST_OK);
  tl_inside--;

  // insert, unless another thread did meanwhile
  pthread_mutex_lock(&g_model_lock);
  for (int i = 0; i < OST_NVERDICT; i++) {
    if (g_verdict[i].m == m) {
      ok = g_verdict[i].ok;
      pthread_mutex_unlock(&g_model_lock);
      return ok;
    }
  }
  int slot = -1;
  for (int i = 0; i < OST_NVERDICT && slot < 0; i++) {
    if (!g_verdict[i].m) {
      slot = i;
    }
  }
  if (slot < 0) {
    slot = g_verdict_next;
    g_verdict_next = (g_verdict_next + 1) % OST_NVERDICT;
  }
  g_verdict[slot].m = m;
  g_verdict[slot].ok = ok;
  pthread_mutex_unlock(&g_model_lock);

  // refusals are printed even when quiet
  if (!ok) {
    fprintf(stderr, "ostrich: refusing model '%s': %s; stepping it with stock MuJoCo\n",
            modelName(m), err[0] ? err : "unsupported model");
  }
  return ok;
}


// 1 if this step of (m, d) goes to Ostrich
static int useOstrich(const mjModel* m, const mjData* d) {
  init();
  if (!g_active || tl_loading || tl_inside || !m || !d) {
    return 0;
  }

  // per-thread cache of the last verdict, valid until a verdict is forgotten
  unsigned gen = atomic_load(&g_model_gen);
  if (tl_model == m && tl_gen == gen) {
    return tl_ok;
  }
  int ok = modelVerdict(m);
  if (ok < 0) {
    return 0;
  }
  tl_model = m;
  tl_ok = ok;
  tl_gen = gen;
  return ok;
}


// print a failure or warning of a step at time t, once per process per status code
static void reportFailure(const mjData* d, int status, double t) {
  int bit = OST_IS_WARNING(status) ? 30 : (status > 0 && status < 30) ? status : 31;
  unsigned mask = 1u << bit;
  if (atomic_fetch_or(&g_failed_seen, mask) & mask) {
    return;
  }
  const ostStats* st = ost_stats(d);
  if (OST_IS_WARNING(status)) {
    fprintf(stderr, "ostrich: step at t = %g s did not converge (residual %.3g m/s above tol); "
            "the step was taken; such steps are counted (raise ostrich/newton_iter or lower "
            "h)\n", t, st ? st->residual : 0.0);
    return;
  }
  const char* msg = ost_lastError(d);
  fprintf(stderr, "ostrich: step at t = %g s failed: %s; this step and later failed ones are "
          "taken by stock MuJoCo and counted\n", t, msg && msg[0] ? msg : "(no message)");
}


// one Ostrich step (half = 0: ost_step, 1: ost_step2), then bookkeeping
static void ostrichStep(const mjModel* m, mjData* d, int half) {
  // banner on the first Ostrich step of the process
  if (!atomic_exchange(&g_banner, 1) && !g_quiet) {
    fprintf(stderr, "ostrich: stepping %s with Ostrich\n", modelName(m));
  }

  // step; calls back into mj_* from inside Ostrich go to stock
  tl_inside++;
  double t = d->time;
  int status = half ? ost_step2(m, d) : ost_step(m, d);
  const ostStats* stats = ost_stats(d);
  int newton_iter = stats ? stats->newton_iter : 0;
  double residual = stats ? stats->residual : 0;
  int failed = status != OST_OK && !OST_IS_WARNING(status);
  if (status != OST_OK) {
    reportFailure(d, status, t);
  }
  char msg[200];
  snprintf(msg, sizeof(msg), "%s", failed ? ost_lastError(d) : "");
  tl_inside--;

  // a failed step left the state unchanged: take it with stock MuJoCo instead of freezing
  if (failed) {
    if (half && g_real.step2) {
      g_real.step2(m, d);
    } else if (!half && g_real.step) {
      g_real.step(m, d);
    }
  }

  // accumulate
  pthread_mutex_lock(&g_stats_lock);
  g_nstep++;
  if (failed) {
    g_nfail++;
    snprintf(g_last_fail, sizeof(g_last_fail), "%s", msg);
  } else if (stats) {
    g_nstat++;
    g_sum_iter += newton_iter;
    g_sum_residual += residual;
    if (OST_IS_WARNING(status)) {
      g_nwarn++;
      g_worst_residual = residual > g_worst_residual ? residual : g_worst_residual;
    }
  }
  pthread_mutex_unlock(&g_stats_lock);
}


//---------------------------------- Interposed functions ------------------------------------------

// advance simulation: Ostrich, or stock while loading / refused / not 2.2.2
void mj_step(const mjModel* m, mjData* d) {
  if (useOstrich(m, d)) {
    ostrichStep(m, d, 0);
  } else if (g_real.step) {
    g_real.step(m, d);
  }
}


// step with skipped stages (mjd_transitionFD): Ostrich ignores the skip flags and recomputes
// everything, since the skip logic assumes d holds pre-step position and velocity data
void mj_stepSkip(const mjModel* m, mjData* d, int skipstage, int skipsensor) {
  if (useOstrich(m, d)) {
    ostrichStep(m, d, 0);
  } else if (g_real.stepSkip) {
    g_real.stepSkip(m, d, skipstage, skipsensor);
  } else if (g_real.step) {
    g_real.step(m, d);
  }
}


// second half of a step (after stock mj_step1): Ostrich solve and commit
void mj_step2(const mjModel* m, mjData* d) {
  if (useOstrich(m, d)) {
    ostrichStep(m, d, 1);
  } else if (g_real.step2) {
    g_real.step2(m, d);
  }
}


// compile a model; steps on this thread meanwhile (the compiler's test step) are stock
mjModel* mj_loadXML(const char* filename, const mjVFS* vfs, char* error, int error_sz) {
  init();
  if (!g_real.loadXML) {
    if (error && error_sz > 0) {
      snprintf(error, error_sz, "ostrich: stock mj_loadXML not found");
    }
    return NULL;
  }
  tl_loading++;
  atomic_fetch_add(&g_loading, 1);
  mjModel* m = g_real.loadXML(filename, vfs, error, error_sz);
  atomic_fetch_sub(&g_loading, 1);
  tl_loading--;

  // a new model may reuse the address of one whose verdict is cached
  if (m && g_active) {
    forgetModel(m);
  }
  return m;
}


// load a binary model; same load-time rule as mj_loadXML
mjModel* mj_loadModel(const char* filename, const mjVFS* vfs) {
  init();
  if (!g_real.loadModel) {
    return NULL;
  }
  tl_loading++;
  atomic_fetch_add(&g_loading, 1);
  mjModel* m = g_real.loadModel(filename, vfs);
  atomic_fetch_sub(&g_loading, 1);
  tl_loading--;
  if (m && g_active) {
    forgetModel(m);
  }
  return m;
}


// delete a model: forget its verdict first, so a new model at the same address is re-checked
void mj_deleteModel(mjModel* m) {
  init();
  if (g_active && m && !tl_inside) {
    forgetModel(m);
  }
  if (g_real.deleteModel) {
    g_real.deleteModel(m);
  }
}


// delete data: release Ostrich's per-mjData state first
void mj_deleteData(mjData* d) {
  init();
  if (g_active && d && !tl_inside) {
    tl_inside++;
    ost_detach(d);
    tl_inside--;
  }
  if (g_real.deleteData) {
    g_real.deleteData(d);
  }
}
