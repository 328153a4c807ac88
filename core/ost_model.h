// ost_model.h: Ostrich's flat, read-only model and one world's kinematic data, the inputs and
// outputs of the native geometry provider (mirrors mjmodel.h / mjdata.h, with MuJoCo's names).
// plugin/ost_pack.c fills an ostModel from an mjModel; core/ never sees MuJoCo.
// Layout contract: every array is listed once in an X-macro (type, name, rows, cols). The tables
// drive the size of the single allocation, the pointer setup and host<->device copies, so a model
// or a world can be copied to the GPU as one block and re-pointed there.
// Invariant: an ostModel is immutable after packing; an ostKin is written only by its world.
#ifndef OSTRICH_CORE_OST_MODEL_H_
#define OSTRICH_CORE_OST_MODEL_H_

#include <stddef.h>

#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum osttJoint_ {         // joint types, numbered as mjtJoint
  OST_JNT_FREE = 0,               // 7 qpos (position, quaternion), 6 dofs
  OST_JNT_BALL,                   // 4 qpos (quaternion), 3 dofs
  OST_JNT_SLIDE,                  // 1 qpos, 1 dof
  OST_JNT_HINGE                   // 1 qpos, 1 dof
} osttJoint;

typedef struct ostSizes_ {        // sizes of an ostModel
  int nq;                         // generalized coordinates
  int nv;                         // degrees of freedom
  int nbody;                      // bodies, world included
  int njnt;                       // joints
  int ngeom;                      // geoms
  int nu;                         // actuators
  int na;                         // activations (actuators with dynamics, the last na)
  int npair;                      // candidate collision pairs (filtered, explicit pairs included)
  int nmesh;                      // meshes
  int nmeshvert;                  // mesh vertices, all meshes (convex hull for convex meshes)
  int nmeshface;                  // mesh faces, all meshes (terrain faces, hull triangles)
  int nhfield;                    // height fields
  int nhfielddata;                // height-field samples, all fields
  int ncell;                      // terrain grid cells, all terrain meshes
  int ncellface;                  // terrain grid cell->face entries, all terrain meshes
  int ncon_max;                   // contact capacity of one world (per iterate)
  int ncol;                       // widest row pattern in columns (ostu_rowWidth)
  int pad;                        // zero: keeps the doubles after an ostSizes unpadded
} ostSizes;
OST_STATIC_ASSERT(sizeof(ostSizes) % 8 == 0, "ostSizes: a multiple of 8 bytes");

// the model's arrays (type, name, rows, cols); sizes come from an ostSizes named s
#define OST_MODEL_ARRAYS(X)                                                                    \
  /* bodies */                                                                                 \
  X(int,    body_parentid,    s.nbody,       1)  /* parent body                          */    \
  X(int,    body_rootid,      s.nbody,       1)  /* top-level ancestor below the world   */    \
  X(int,    body_jntnum,      s.nbody,       1)  /* number of joints                     */    \
  X(int,    body_jntadr,      s.nbody,       1)  /* first joint (-1: none)               */    \
  X(int,    body_dofnum,      s.nbody,       1)  /* number of dofs                       */    \
  X(int,    body_dofadr,      s.nbody,       1)  /* first dof (-1: none)                 */    \
  X(ostNum, body_pos,         s.nbody,       3)  /* position offset in the parent frame  */    \
  X(ostNum, body_quat,        s.nbody,       4)  /* orientation offset in the parent     */    \
  X(ostNum, body_ipos,        s.nbody,       3)  /* center of mass in the body frame     */    \
  X(ostNum, body_iquat,       s.nbody,       4)  /* inertia frame in the body frame      */    \
  X(ostNum, body_mass,        s.nbody,       1)  /* mass (kg)                            */    \
  X(ostNum, body_inertia,     s.nbody,       3)  /* principal inertia (kg m^2)           */    \
  /* joints */                                                                                 \
  X(int,    jnt_type,         s.njnt,        1)  /* osttJoint                            */    \
  X(int,    jnt_qposadr,      s.njnt,        1)  /* first qpos                           */    \
  X(int,    jnt_dofadr,       s.njnt,        1)  /* first dof                            */    \
  X(int,    jnt_bodyid,       s.njnt,        1)  /* body                                 */    \
  X(int,    jnt_limited,      s.njnt,        1)  /* has a range (hinge and slide only)   */    \
  X(ostNum, jnt_pos,          s.njnt,        3)  /* anchor in the body frame             */    \
  X(ostNum, jnt_axis,         s.njnt,        3)  /* axis in the body frame               */    \
  X(ostNum, jnt_stiffness,    s.njnt,        1)  /* spring stiffness                     */    \
  X(ostNum, jnt_range,        s.njnt,        2)  /* limits                               */    \
  X(ostNum, jnt_margin,       s.njnt,        1)  /* limit rows exist within this margin  */    \
  /* dofs */                                                                                   \
  X(int,    dof_bodyid,       s.nv,          1)  /* body                                 */    \
  X(int,    dof_jntid,        s.nv,          1)  /* joint                                */    \
  X(int,    dof_parentid,     s.nv,          1)  /* parent dof (-1: none)                */    \
  X(ostNum, dof_armature,     s.nv,          1)  /* armature inertia                     */    \
  X(ostNum, dof_damping,      s.nv,          1)  /* damping (taken implicitly)           */    \
  X(ostNum, dof_frictionloss, s.nv,          1)  /* dry friction bound (0: none)         */    \
  X(ostNum, qpos_spring,      s.nq,          1)  /* spring reference configuration       */    \
  /* geoms */                                                                                  \
  X(int,    geom_type,        s.ngeom,       1)  /* osttGeom                             */    \
  X(int,    geom_bodyid,      s.ngeom,       1)  /* body                                 */    \
  X(int,    geom_dataid,      s.ngeom,       1)  /* mesh or hfield id (-1: none)         */    \
  X(int,    geom_terrain,     s.ngeom,       1)  /* 1: mesh used as non-convex terrain   */    \
  X(int,    geom_paired,      s.ngeom,       1)  /* 1: in a candidate pair (frame used)  */    \
  X(ostNum, geom_pos,         s.ngeom,       3)  /* position in the body frame           */    \
  X(ostNum, geom_quat,        s.ngeom,       4)  /* orientation in the body frame        */    \
  X(ostNum, geom_size,        s.ngeom,       3)  /* type-specific size                   */    \
  X(ostNum, geom_rbound,      s.ngeom,       1)  /* bounding-sphere radius (0: plane)    */    \
  /* candidate collision pairs, filtered once at packing (contype/conaffinity, exclude,   */   \
  /* parent-child, welded bodies, explicit <pair>); margins include Ostrich's look-ahead  */   \
  X(int,    pair_geom1,       s.npair,       1)  /* first geom (lower type, as MuJoCo)   */    \
  X(int,    pair_geom2,       s.npair,       1)  /* second geom                          */    \
  X(int,    pair_condim,      s.npair,       1)  /* 1, 3, 4 or 6 (MuJoCo's condim)       */    \
  X(ostNum, pair_margin,      s.npair,       1)  /* detection margin (m)                 */    \
  X(ostNum, pair_gap,         s.npair,       1)  /* gap: contact starts at margin - gap  */    \
  X(ostNum, pair_friction,    s.npair,       1)  /* sliding friction coefficient         */    \
  X(ostNum, pair_torsion,     s.npair,       1)  /* torsional coefficient (m; condim 4+) */    \
  X(ostNum, pair_rolling,     s.npair,       1)  /* rolling coefficient (m; condim 6)    */    \
  /* meshes (convex: vertices, hull triangles; terrain: vertices, faces and an xy grid)  */   \
  X(int,    mesh_vertadr,     s.nmesh,       1)  /* first vertex                         */    \
  X(int,    mesh_vertnum,     s.nmesh,       1)  /* number of vertices                   */    \
  X(int,    mesh_faceadr,     s.nmesh,       1)  /* first face                           */    \
  X(int,    mesh_facenum,     s.nmesh,       1)  /* number of faces (0: no hull known)   */    \
  X(int,    mesh_grid,        s.nmesh,       3)  /* terrain grid: nx, ny, first cell     */    \
  X(ostNum, mesh_gridbox,     s.nmesh,       5)  /* terrain grid: x0, y0, dx, dy, base   */    \
  X(ostNum, mesh_vert,        s.nmeshvert,   3)  /* vertices in the mesh frame           */    \
  X(int,    mesh_face,        s.nmeshface,   3)  /* triangles (vertex ids within mesh)   */    \
  X(int,    cell_adr,         s.ncell,       1)  /* first entry of a cell in cell_face   */    \
  X(int,    cell_num,         s.ncell,       1)  /* faces overlapping a cell             */    \
  X(int,    cell_face,        s.ncellface,   1)  /* face ids within the mesh             */    \
  /* height fields */                                                                          \
  X(int,    hfield_nrow,      s.nhfield,     1)  /* samples along y                      */    \
  X(int,    hfield_ncol,      s.nhfield,     1)  /* samples along x                      */    \
  X(int,    hfield_adr,       s.nhfield,     1)  /* first sample                         */    \
  X(ostNum, hfield_size,      s.nhfield,     4)  /* x radius, y radius, height, base     */    \
  X(ostNum, hfield_data,      s.nhfielddata, 1)  /* elevations in [0, 1], row-major      */    \
  /* actuators (joint transmission on hinge and slide joints)                             */   \
  X(int,    actuator_trnid,   s.nu,          1)  /* joint                                */    \
  X(int,    actuator_servo,   s.nu,          1)  /* 1: implicit servo row, 0: explicit   */    \
  X(int,    actuator_ctrllimited,  s.nu,     1)  /* clamp ctrl to ctrlrange              */    \
  X(int,    actuator_forcelimited, s.nu,     1)  /* clamp force to forcerange            */    \
  X(ostNum, actuator_gear,    s.nu,          1)  /* gear[0]                              */    \
  X(ostNum, actuator_gainprm, s.nu,          1)  /* gain: force = g ctrl + b0 + b1 L + b2 V */ \
  X(ostNum, actuator_biasprm, s.nu,          3)  /* b0, b1, b2 (affine bias; else zero)  */    \
  X(ostNum, actuator_ctrlrange,  s.nu,       2)  /* control range                        */    \
  X(ostNum, actuator_forcerange, s.nu,       2)  /* force range                          */    \
  X(int,    actuator_dyntype, s.nu,          1)  /* osttDyn (ost_activation.h)           */    \
  X(int,    actuator_actadr,  s.nu,          1)  /* its activation in act (-1: none)     */    \
  X(int,    actuator_actlimited, s.nu,       1)  /* clamp act to actrange                */    \
  X(ostNum, actuator_dynprm,  s.nu,          2)  /* filter tau; muscle tau_act, tau_deact */   \
  X(ostNum, actuator_actrange, s.nu,         2)  /* activation range                     */    \
  X(int,    actuator_gaintype, s.nu,         1)  /* osttGain (ost_muscle.h)              */    \
  X(int,    actuator_biastype, s.nu,         1)  /* osttBias (ost_muscle.h)              */    \
  X(ostNum, actuator_gainmus, s.nu,          9)  /* muscle gainprm[0..8] (gain muscle)   */    \
  X(ostNum, actuator_biasmus, s.nu,          9)  /* muscle biasprm[0..8] (bias muscle)   */    \
  X(ostNum, actuator_lengthrange, s.nu,      2)  /* muscle length range                  */    \
  X(ostNum, actuator_acc0,    s.nu,          1)  /* |M^-1 moment| at qpos0 (mj_setConst) */

typedef struct ostModel_ {        // Ostrich's model: sizes, options and pointers into one block
  ostSizes s;                     // sizes
  ostNum   gravity[3];            // opt.gravity
  ostNum   mpr_tolerance;         // opt.mpr_tolerance
  int      mpr_iterations;        // opt.mpr_iterations
  int      disableflags;          // opt.disableflags (mjtDisableBit numbering)
#define X(type, name, r, c) type* name;
  OST_MODEL_ARRAYS(X)
#undef X
} ostModel;

// disable bits read by core (mjtDisableBit values)
#define OST_DSBL_FRICTIONLOSS (1 << 2)
#define OST_DSBL_LIMIT     (1 << 3)
#define OST_DSBL_CONTACT   (1 << 4)
#define OST_DSBL_PASSIVE   (1 << 5)
#define OST_DSBL_GRAVITY   (1 << 6)
#define OST_DSBL_CLAMPCTRL (1 << 7)
#define OST_DSBL_ACTUATION (1 << 10)

// one world's kinematic and dynamic quantities at a configuration (mjData's names)
#define OST_KIN_ARRAYS(X)                                                                      \
  X(ostNum,     xpos,            s.nbody,    3)   /* body frame position                  */   \
  X(ostNum,     xquat,           s.nbody,    4)   /* body frame orientation               */   \
  X(ostNum,     xmat,            s.nbody,    9)   /* body frame rotation                  */   \
  X(ostNum,     xipos,           s.nbody,    3)   /* center of mass                       */   \
  X(ostNum,     ximat,           s.nbody,    9)   /* inertia frame rotation               */   \
  X(ostNum,     xanchor,         s.njnt,     3)   /* joint anchor (world)                 */   \
  X(ostNum,     xaxis,           s.njnt,     3)   /* joint axis (world)                   */   \
  X(ostNum,     geom_xpos,       s.ngeom,    3)   /* geom position                        */   \
  X(ostNum,     geom_xmat,       s.ngeom,    9)   /* geom rotation                        */   \
  X(ostNum,     subtree_com,     s.nbody,    3)   /* center of mass of each subtree       */   \
  X(ostNum,     cinert,          s.nbody,    10)  /* com-based body inertia               */   \
  X(ostNum,     crb,             s.nbody,    10)  /* composite rigid-body inertia         */   \
  X(ostNum,     cdof,            s.nv,       6)   /* com-based motion axis of each dof    */   \
  X(ostNum,     cvel,            s.nbody,    6)   /* com-based body velocity              */   \
  X(ostNum,     cdof_dot,        s.nv,       6)   /* time derivative of cdof              */   \
  X(ostNum,     cacc,            s.nbody,    6)   /* com-based acceleration (RNE)         */   \
  X(ostNum,     cfrc,            s.nbody,    6)   /* com-based force (RNE)                */   \
  X(ostNum,     qM,              s.nv,       s.nv) /* joint-space inertia, dense, armature */  \
  X(ostNum,     qfrc_bias,       s.nv,       1)   /* gravity + Coriolis/centrifugal       */   \
  X(ostNum,     qfrc_passive,    s.nv,       1)   /* springs and damping                  */   \
  X(ostNum,     actuator_length, s.nu,       1)   /* transmission length                  */   \
  X(ostNum,     actuator_moment, s.nu,       s.nv) /* transmission moment arms            */   \
  X(ostNum,     jac,             6,          s.nv) /* point Jacobian scratch (jacp, jacr) */   \
  X(ostContact, contact,   s.ncon_max + OST_MAXCONPAIR, 1) /* contacts (+ one pair's slack) */ \
  X(int,        contact_pair, s.ncon_max + OST_MAXCONPAIR, 1) /* candidate pair of each   */

typedef struct ostKin_ {          // one world's kinematics: sizes and pointers into one block
  ostSizes s;                     // sizes (copied from the model)
  int      ncon;                  // contacts in `contact`
  int      overflow;              // 1 if the last collision pass exceeded ncon_max
  const int* pair_only;           // NULL: osti_collision tries every pair; else only these
  int      npair_only;            // (ascending), the adjoint's passes at a fixed contact set
#define X(type, name, r, c) type* name;
  OST_KIN_ARRAYS(X)
#undef X
} ostKin;


// bytes of a block of arrays described by an X-macro table, each array 64-byte aligned
#define OST_ALIGN64(n) ((((size_t)(n)) + 63) / 64 * 64)

// bytes of an ostModel's block
OST_HD size_t ostu_modelSize(ostSizes s) {
  size_t sz = 0;
#define X(type, name, r, c) sz += OST_ALIGN64((size_t)(r) * (c) * sizeof(type));
  OST_MODEL_ARRAYS(X)
#undef X
  return sz;
}


// point m's arrays into buf (ostu_modelSize bytes, 64-byte aligned); m->s must be set
OST_HD void ostu_modelInit(ostModel* m, void* buf) {
  char* p = (char*)buf;
  ostSizes s = m->s;
#define X(type, name, r, c)                                       \
  m->name = (type*)p;                                             \
  p += OST_ALIGN64((size_t)(r) * (c) * sizeof(type));
  OST_MODEL_ARRAYS(X)
#undef X
}


// bytes of one world's ostKin block
OST_HD size_t ostu_kinSize(ostSizes s) {
  size_t sz = 0;
#define X(type, name, r, c) sz += OST_ALIGN64((size_t)(r) * (c) * sizeof(type));
  OST_KIN_ARRAYS(X)
#undef X
  return sz;
}


// point k's arrays into buf (ostu_kinSize(s) bytes, 64-byte aligned)
OST_HD void ostu_kinInit(ostKin* k, void* buf, ostSizes s) {
  char* p = (char*)buf;
  k->s = s;
  k->ncon = 0;
  k->overflow = 0;
  k->pair_only = NULL;
  k->npair_only = 0;
#define X(type, name, r, c)                                       \
  k->name = (type*)p;                                             \
  p += OST_ALIGN64((size_t)(r) * (c) * sizeof(type));
  OST_KIN_ARRAYS(X)
#undef X
}

#ifdef __cplusplus
}
#endif

// C++ with dual numbers (ost_dual.h): the layout twin of the double model and its conversion
#if defined(__cplusplus) && defined(OST_NUM_TYPE) && defined(OSTRICH_CORE_OST_DUAL_H_)
#include "ost_dual.h"
#endif

#endif  // OSTRICH_CORE_OST_MODEL_H_
