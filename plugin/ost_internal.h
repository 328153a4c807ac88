// ost_internal.h: Ostrich's per-mjData context, shared by the plugin/ files (not public).
// A context holds what Ostrich keeps beside an mjData: options, statistics, the last error, a
// private model copy with look-ahead margins, and the one allocation of the core world.
// Invariant: a context belongs to exactly one (mjData, d->buffer, mjModel) triple; if any of
// them changes the context is rebuilt.
#ifndef OSTRICH_PLUGIN_OST_INTERNAL_H_
#define OSTRICH_PLUGIN_OST_INTERNAL_H_

#include <stdint.h>

#include <mujoco/mujoco.h>

#include "ost_geom.h"
#include "ost_geometric.h"
#include "ost_model.h"
#include "ost_solver.h"
#include "ostrich.h"

// core's per-world outcome bits (core/ost_solver.h OST_STEP_*) are the public ostStatusBit values:
// the batch hands a world's bits to the user unchanged, and a record keeps them as they are
OST_STATIC_ASSERT(OST_STEP_NOT_CONVERGED == OST_NOT_CONVERGED, "outcome bit: not converged");
OST_STATIC_ASSERT(OST_STEP_OVERFLOW == OST_OVERFLOW, "outcome bit: overflow");
OST_STATIC_ASSERT(OST_STEP_NAN == OST_NAN, "outcome bit: nan");
OST_STATIC_ASSERT(OST_STEP_CHOL_FAIL == OST_CHOL_FAIL, "outcome bit: Cholesky failure");
OST_STATIC_ASSERT(OST_STEP_DEPENETRATED == OST_DEPENETRATED, "outcome bit: depenetrated");
// warnings and errors do not overlap: OST_IS_WARNING tells them apart
OST_STATIC_ASSERT(OST_ERR_NOT_CONVERGED < OST_WARN_FIRST, "error codes below the warnings");

typedef struct ostRecordHead_ {   // header of one recorded substep (ost_adjoint.c)
  double h;                       // its step size (s)
  int    nrow;                    // rows of its solution
  int    step_end;                // 1 if it is the last substep of an ost_step
  int    bits;                    // OST_NOT_CONVERGED / OST_DEPENETRATED of this substep
  int    pad;
  double residual;                // its best merit (m/s)
} ostRecordHead;

typedef struct ostRecord_ {       // pointers into one record block (ost_recordView)
  ostRecordHead* head;
  mjtNum* qpos_prev;              // q-                                            (nq)
  mjtNum* qvel_prev;              // u-                                            (nv)
  mjtNum* qvel;                   // u+                                            (nv)
  mjtNum* ctrl;                   // controls                                      (nu)
  mjtNum* act_prev;               // activations at the start                      (na)
  mjtNum* qfrc_applied;           // applied forces                                (nv)
  mjtNum* xfrc_applied;           // applied wrenches                       (nbody x 6)
  mjtNum* lambda;                 // multipliers of the solution             (nrow_max)
  ostRow* rows;                   // rows of the solution                    (nrow_max)
} ostRecord;

typedef struct ostSyncRange_ {   // a byte range of mjModel.buffer (ost_sync.c)
  size_t off;                     // offset in m->buffer
  size_t sz;                      // bytes
} ostSyncRange;

typedef struct ostCollisionCache_ {  // the iterates' collision (ost_collision_mujoco.c)
  int       state;   // 0: undecided (new or changed model), 1: listed, -1: mj_collision itself
  int       built;   // 1 if cand and ref hold a list
  mjtNum    slack;   // s: the list holds while every geom stays within s of ref
  mjtNum    scale;   // the mean bounding radius of the geoms that are not planes
  uint64_t* cand;    // dynamic geom pairs: signature << 32 | geom << 16 | geom, ascending
  int       ncand;   // their number
  int       cap;     // cand's capacity
  mjtNum*   ref;     // geom_xpos when the list was built                       (3 ngeom)
  int*      order;   // the sweep's order of the geoms, kept between builds        (ngeom)
  long      builds;  // lists built (tests)
  long      uses;    // collisions from a list (tests)
  long      uses_at_build;  // uses when the current list was built
  int       skip_core;  // 1: pairs that core collides (ost_corePair) are left out, as their
                        // MuJoCo contacts would only be replaced (ost_rowsMujoco, publication)
} ostCollisionCache;

typedef struct ostMeshes_ {       // m's meshes as core's collision functions take them
  ostNum* vert;                   // vertices as ostNum (3 nmeshvert); a mesh with a convex hull
                                  // lists the hull's vertices first in its slot
  int*    face;                   // hull triangles, ids into the mesh's slot of vert (3 each)
  int*    faceadr;                // per mesh: its first triangle in face (nmesh)
  int*    facenum;                // per mesh: its triangles, 0 without a hull (nmesh)
} ostMeshes;

typedef struct ostContext_ {
  const mjData*  d;               // the mjData this context serves
  const void*    d_buffer;        // d->buffer when created (detects pointer reuse)
  const mjModel* m;               // the user's model
  mjModel*       mo;              // private copy of m with margins widened by opt.margin
  ostOptions     opt;             // options in use
  int            opt_user;        // 1 if set by ost_setOptions (not re-read from the model)
  ostStats       stats;           // statistics of the last step
  ostTotals      totals;          // counts of all steps (ost_totals)
  char           err[512];        // message of the last failure
  int*           servo;           // 1 if actuator i is an implicit servo row     (nu)
  int            servo_any;       // 1 if any is: the iterates need MuJoCo's transmission
  unsigned char* ten_implicit;    // 1 if tendon t's spring and damper are an implicit row this
                                  // substep (mujocoStart decides, ost_rowsMujoco builds) (ntendon)
  mjtNum*        ten_dt;          // tendon t's J M^-1 J', refreshed at a cold step and where
                                  // time / h is a multiple of 8 (mujocoStart)       (ntendon)
  int            step_cold;       // 1 until the first substep of a step that does not continue
                                  // the last one has started
  mjtNum*        qpos_prev;       // q- of the current step                        (nq)
  mjtNum*        state_start;     // state at ost_step2 entry     (1 + nq + 2 nv + na)
  mjtNum*        state_end;       // state after the last step    (1 + nq + 2 nv + na)
  mjtNum*        act_input;       // the substep's actuator inputs: clamped ctrl, or act+
                                  // for an actuator with dynamics (osti_actuation)  (nu)
  mjtNum*        act_next;        // the substep's act+ (na) after act_input's nu, then
                                  // room for act- while mj_fwdActuation reads act+  (na)
  int            warm_valid;      // 1 if state_end and the world's warm rows are valid
  mjtNum*        published;       // what the last publication left in d (ost_published.c)
  int            published_valid; // 1 if published holds the last step's publication
  int            publish_full;    // 1: the publication runs mj_fwdPosition (tests compare the
                                  // copy of the iterates' stages with it)
  long           publish_copies;  // publications that copied the iterates' stages (tests)
  int            no_row_cache;    // 1: steps without the rows' half-solve cache (tests)
  int            no_envelope;     // 1: steps without the envelope solves of large islands (tests)
  int            step1_synced;    // 1 if the last ost_step1 compared the model (and reused)
  mjtNum*        jac;             // contact Jacobian scratch                     (12 x nv)
  int            ncon_cap;        // contacts the iterates have room for: m->nconmax, doubled
                                  // whenever the look-ahead overflows it (ost_growCapacity)
  int            njmax_cap;       // MuJoCo's constraint rows the iterates have room for
                                  // (equalities, limits, dry friction): m->njmax, doubled
                                  // whenever the look-ahead's limit rows overflow it
  int            overflow_cap;    // the last failure was a contact or row capacity (1) or a
                                  // constraint capacity (2), else 0
  mjData*        dg;              // mujoco provider: private mjData of mo for the iterates,
                                  // sized to ncon_cap (NULL until needed)
  void*          world_buf;       // the core world's single allocation
  void*          geo_buf;         // its geometric Newton arrays' allocation
  ostGeoWork     geo;             // those arrays (core/ost_geometric.h)
  void*          env_buf;         // its envelope solves' arrays' allocation
  void*          dense_buf;       // its large-island dense arrays' allocation
                                  // (ostu_denseLargeInit; the world points into it)
  ostEnvWork     env;             // those arrays (core/ost_envelope.h)
  ostModel       native;          // native provider: packed model (geometry option 1)
  void*          native_block;    // its single allocation
  int            native_dirty;    // 1 if the native packing must be rebuilt
  double         native_margin;   // the look-ahead margin when packed
  int            model_dirty;     // 1 if the private model must be copied, checked and packed
                                  // again (new context, ost_modelChanged, ost_setOptions)
  ostSyncRange*  sync_range;      // byte ranges of m->buffer compared per step (ost_sync.c)
  int            sync_n;          // their number
  char*          sync_shadow;     // their values at the last synchronisation
  size_t         sync_sz;         // its size in bytes
  mjOption       sync_opt;        // m->opt at the last synchronisation
  ostCollisionCache col;           // mujoco provider: the iterates' collision list
  ostModel       corepairs;       // mujoco provider: pairs collided by core (ost_corePair)
  void*          corepairs_block; // their arrays (ost_packCorePairs)
  ostNum*        hfield_data;     // the model's height-field data as ostNum (nhfielddata)
  int            hfield_n;        // its length
  ostMeshes      mesh;            // the model's meshes as core's collision takes them
  void*          kin_buf;         // its kinematics' single allocation
  ostKin         kin;             // native kinematics, pointers into kin_buf
  ostWorld       world;           // core solver state, pointers into world_buf
  void*          rec_buf;         // records of the last step's substeps (ost_adjoint.c), each
                                  // sized to its rows (ost_recordSize), back to back
  int            rec_n;           // records in rec_buf
  size_t         rec_bytes;       // bytes they take
  size_t         rec_last;        // offset of the last one
  size_t         rec_cap;         // capacity of rec_buf in bytes
  void*          adj_work;        // dual-number work block of the adjoint
  void*          adj_rev;         // reverse-mode work of the adjoint (ost_adjoint_rev.h)
  int            adj_reverse_all; // 1: the reverse sweep for every model (tests); 0: where it
                                  // replaces OST_REVERSE_MIN directions or more
  int            adj_oracle;      // 1: the dense dual Jacobian per record (tests' oracle),
                                  // 0: the split passes (ostx_jacColumnsSplit, the default),
                                  // 2: the split passes as 3 threads in turn (tests)
  const void*    adj_model_block; // native_block it was made for
  int*           adj_fric_geom;   // per packed pair: geoms whose friction it takes (2 each)
  mjtNum*        adj_fric_weight; // their weights
  mjtNum*        adj_scratch;     // adjoint scratch: Jacobian, LU factor, vectors
  size_t         adj_scratch_cap; // its capacity in doubles
  struct ostContext_* next;       // registry list
} ostContext;

// the stages the last step published, reused by ost_step1 (ost_published.c): the snapshot's
// length, saving it after a publication, and whether d and the model are still exactly as it
// left them (1), not (0), or the model copy failed (-1)
size_t ost_publishedSize(const mjModel* m);
void ost_publishedSave(ostContext* c, const mjModel* m, const mjData* d);
int ost_publishedCurrent(ostContext* c, const mjModel* m, const mjData* d);

// MuJoCo's position stage at q+ into d for the publication: copied from the iterates' mjData
// where it holds exactly that state (mujoco provider: the last geometry evaluation was the
// committed iterate), then the rest of mj_fwdPosition; else mj_fwdPosition on d. Returns 1 if
// copied.
int ost_publishPosition(ostContext* c, mjData* d);

// find or create the context of (m, d); NULL only if allocation fails
ostContext* ost_context(const mjModel* m, const mjData* d);

// look up the context of d without creating one
ostContext* ost_findContext(const mjData* d);

// record a failure message on the context and return status
int ost_fail(ostContext* c, int status, const char* fmt, ...);

// a contact, constraint or row capacity (what) of cap overflowed by the iterates: an
// OST_ERR_OVERFLOW that ost_step2 answers by growing the capacity (c->overflow_cap = 1)
int ost_capacityFail(ostContext* c, const char* what, int cap);

// the most contacts a context's iterates get room for: OST_GROWTH_MAX times the model's nconmax
#define OST_GROWTH_MAX 64

// fill the world's rows and Jacobians at the configuration in d->qpos using MuJoCo's own
// kinematics and collision on the private model (the `mujoco` geometry provider)
int ost_rowsMujoco(ostContext* c, mjData* d, mjtNum h);

// MuJoCo 2.2.2's mj_collision(m, d), bit for bit, from a list of the geom pairs that can touch
// kept in k while the geoms stay near where it was built (ost_collision_mujoco.c)
void ost_collision(ostCollisionCache* k, const mjModel* m, mjData* d);

// MuJoCo 2.2.2's contact parameters of geoms g1, g2 as mj_collideGeoms sets them: explicit
// pair ipair's own, or (ipair -1) the geoms' mixed: the higher priority geom's, else friction
// the larger, solref mixed by solmix (direct, non-positive: the smaller), solimp mixed; friction
// unpacked to 5 coefficients and clamped to mjMINMU
void ost_contactPairParams(const mjModel* m, int g1, int g2, int ipair, mjtNum friction[5],
                           mjtNum solref[mjNREF], mjtNum solimp[mjNIMP]);

// the list must be decided again (the model changed); ost_collisionFree releases it
void ost_collisionReset(ostCollisionCache* k);
void ost_collisionFree(ostCollisionCache* k);

// the contacts of d from MuJoCo's general convex collision (MPR) with their true distance (GJK
// on separated geoms) instead of MPR's inflated depth; mesh from ost_meshData
void ost_refineConvexContacts(const mjModel* m, mjData* d, const ostMeshes* mesh);

// a contact frame from its unit normal frame[0:3]: the tangents frame[3:9] as
// MuJoCo 2.2.2's mj_collision makes them after a collision function returned the normal
void ost_contactFrame(mjtNum frame[9]);

// m's meshes into *mesh (its old arrays freed): vertices as ostNum, a mesh with a convex hull
// listing the hull's vertices first in its slot (support points search those), and the hull's
// triangles by those ids (ostMeshes); OST_OK or OST_ERR_MEMORY (then *mesh holds nothing)
int ost_meshData(const mjModel* m, ostMeshes* mesh);

// frees ost_meshData's arrays
void ost_meshFree(ostMeshes* mesh);

// tendon t's Jacobian row of d into the dense row J (nv), whether MuJoCo stores it sparse or not
void ost_tendonRow(const mjModel* m, const mjData* d, int t, mjtNum* J);

// the `native` provider's rows at the configuration in d->qpos (core/ost_rows_native.h), with
// the substep's actuator inputs c->act_input
int ost_rowsNative(ostContext* c, mjData* d, mjtNum h);

// the `native` provider's start of a step at d's (q-, u-): Mt and f into the world, with the
// substep's actuator inputs c->act_input
void ost_startNative(ostContext* c, const mjData* d, mjtNum h);

// matching key of a contact: its position in the frame of a moving body of the pair (geom2's
// body unless that is the world), so that contacts keep their keys while the bodies move
void ost_contactKey(const mjModel* m, const mjData* d, const mjContact* con, mjtNum key[3]);

// 1 if geoms g1, g2 are a pair that both providers collide with core's own functions, not
// MuJoCo's: cylinder-box, height field-primitive, plane-mesh, plane-cylinder and box-box
// (plugin/ost_pack.c coreTypes)
int ost_corePair(const mjModel* m, int g1, int g2);

// MuJoCo's friction (sliding, torsional, rolling) of geoms g1, g2: priority, else the larger
void ost_mixFriction(const mjModel* m, int g1, int g2, mjtNum fr[3]);

// contacts of core pair (g1, g2) of m at d's kinematics with the given margin into con (room
// for OST_MAXCONPAIR); hfield_data, mesh: m's height-field data as ostNum and meshes
// (ost_hfieldData, ost_meshData)
int ost_collideCorePair(const mjModel* m, const mjData* d, const ostNum* hfield_data,
                        const ostMeshes* mesh, int g1, int g2, ostNum margin, ostContact* con);

// deepest penetration at d's kinematics (ost_maxPenetration) with the core pairs of m, m's
// height-field data and mesh vertices already packed (a context's corepairs, hfield_data and
// mesh_vert)
double ost_penetrationWith(const mjModel* m, const mjData* d, const ostModel* pairs,
                           const ostNum* hfield_data, const ostMeshes* mesh);

// m's height-field data as ostNum into *buf (reallocated to m->nhfielddata, *n its length)
int ost_hfieldData(const mjModel* m, ostNum** buf, int* n);

// pack m into om (arrays in *block, 64-byte aligned, caller frees) with a contact capacity
int ost_packModel(const mjModel* m, int ncon_max, ostModel* om, void** block, char* err,
                  int err_sz);

// the candidate core pairs of m (ost_corePair) with their contact parameters, into the pair_*
// arrays and s.npair of pairs (arrays in *block, freed and replaced; nothing else of pairs is
// set): the mujoco provider collides these pairs with core's functions
int ost_packCorePairs(const mjModel* m, ostModel* pairs, void** block);

// classify actuator i: 1 implicit servo, 0 explicit force, -1 unsupported (message in err)
int ost_actuatorKind(const mjModel* m, int i, char* err, int err_sz);

// pack the native model for the context if it is not current (needed by the native provider
// and by every gradient); OST_ERR_MODEL names what native geometry cannot represent
int ost_nativeReady(ostContext* c, const mjModel* m);

// options, model check and private model of a context before a step (ost_step.c)
int ost_prepareContext(ostContext* c, const mjModel* m);

// every geom, pair and joint margin of mo = m's plus the look-ahead distance (gaps unchanged,
// so contacts and limits within it get rows); the private model of ost_step and of a batch.
// mo may be m.
void ost_setMargins(mjModel* mo, const mjModel* m, mjtNum lookahead);

// bring the private model c->mo up to date with m, copying only the arrays that changed since
// the last call (a full copy on the first call or when c->model_dirty): 1 if anything changed,
// 0 if not, < 0 if out of memory (message recorded)
int ost_syncModel(ostContext* c, const mjModel* m);

// rows a step can need: equality (<= 6 per constraint), joint limits (<= 2 per joint),
// contacts (<= 3 per contact, capacity nconmax) and one servo row per actuator (ost_context.c)
int ost_rowCapacity(const mjModel* m);

// rows of m with room for ncon contacts (ost_rowCapacity is ncon = m->nconmax)
int ost_rowCapacityFor(const mjModel* m, int ncon);

// give the context's iterates room for ncon contacts (and the rows that go with them) and njmax
// of MuJoCo's constraint rows: the world is reallocated (the warm start is dropped), the private
// mjData and the native packing are rebuilt at the next use. Returns OST_OK or OST_ERR_MEMORY.
int ost_growCapacity(ostContext* c, int ncon, int njmax);

// the mujoco provider's private mjData for the iterates, made on first use with room for
// c->ncon_cap contacts; NULL if allocation fails
mjData* ost_geometryData(ostContext* c);

// the widest constraint row of m in dofs: two dof chains of the kinematic tree (ostu_rowWidth),
// or the chains a tendon's bodies span, at most nv (ost_context.c)
int ost_rowWidth(const mjModel* m);

// the Newton and PCR settings of a step from the options (ost_step.c)
ostSolverOptions ost_solverOptions(const ostOptions* o);

// a context's warm-start state (validity, last rows and forces, end state): its size in
// bytes, and copies out of and into a context, so that a recomputed step starts as the
// recorded one did
size_t ost_warmSize(const ostContext* c);
void ost_warmSave(const ostContext* c, void* buf);
int ost_warmLoad(ostContext* c, const void* buf);

// bytes of one substep record with nrow rows
size_t ost_recordSize(const mjModel* m, int nrow);

// pointers into the record at rec (its head's nrow sizes its rows); returns its size in bytes
size_t ost_recordView(const mjModel* m, void* rec, ostRecord* r);

// append the substep advance() just committed to the context's records, with its best merit
// and its OST_NOT_CONVERGED / OST_DEPENETRATED bits
int ost_recordSubstep(ostContext* c, const mjModel* m, const mjData* d, mjtNum h,
                      mjtNum residual, int bits);

// backward pass over the records in the nbytes at recs: g = (gq, gu, ga) (2 nv + na) at their
// end in, at their start out; gctrl (nu) and gtheta accumulate (either may be NULL)
int ost_recordsBackward(ostContext* c, const mjModel* m, void* recs, size_t nbytes,
                        const ostGradOptions* go, mjtNum* g, mjtNum* gctrl, mjtNum* gtheta);

// the friction map of the parameter group OST_PARAM_FRICTION on the packed model's candidate
// pairs (ostdStep.pair_fric_geom, pair_fric_weight; 2 entries per pair): the geoms whose
// coefficient a pair takes (-1: an explicit <pair>, which no geom parameter moves) and their
// weights (MuJoCo's mixing: the higher priority's, else the larger; 1/2 each at a tie)
void ost_paramFrictionMap(const mjModel* m, const ostModel* native, int* geom, mjtNum* weight);

// whether theta entry i has a derivative: 1 yes; 0 none (the bias parameters of an actuator
// whose bias is neither affine nor a muscle's, which MuJoCo does not read); -1 unknown (a
// muscle's gainprm[0] and biasprm[1], [2]: they shape its curves, not differentiated)
int ost_paramDifferentiable(const mjModel* m, int i);

// the adjoint's resources of a context (called when the context is freed)
void ost_adjointFree(ostContext* c);

// tests: the largest per-column relative difference between the split passes' step Jacobian
// and the dense oracle's (ostContext.adj_oracle) over the records of d's last step
int ost_adjointOracleDiff(const mjModel* m, mjData* d, int truncate, int params, double* diff);

#endif  // OSTRICH_PLUGIN_OST_INTERNAL_H_
