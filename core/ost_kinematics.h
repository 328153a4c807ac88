// ost_kinematics.h: the native smooth dynamics of one world: forward kinematics, com-based frames,
// composite-rigid-body mass matrix, recursive Newton-Euler bias forces, joint springs and dampers,
// joint transmissions, point Jacobians and the placed geoms that collision reads.
// Mirrors MuJoCo 2.2.2's engine_core_smooth.c (mj_kinematics, mj_comPos, mj_comVel, mj_crb,
// mj_rne without acceleration, mj_transmission for joints, mj_jac), engine_passive.c (joint
// springs and dof damping), engine_util_spatial.c (quaternions, com inertias, spatial cross
// products) and engine_support.c (mj_fullM, written dense here).
// Conventions (mjData's): matrices row-major, quaternions (w, x, y, z), spatial vectors
// (rotation; translation) expressed at the subtree com of the body's root, cinert/crb as
// (Ixx, Iyy, Izz, Ixy, Ixz, Iyz, m cx, m cy, m cz, m) with c = xipos - subtree_com[root].
// Invariant: every output array named in a function's comment is written in full (world body
// and unused entries included), from the model and the inputs named in its signature plus the
// outputs of the earlier stages: kinematics -> comPos -> {crb, rne, jac}; passive and
// transmission need only qpos (qvel). Hinge and slide angles are measured from 0, i.e. MuJoCo's
// qpos0 is assumed 0 for them (joint `ref` = 0: the packed model carries no qpos0).
#ifndef OSTRICH_CORE_OST_KINEMATICS_H_
#define OSTRICH_CORE_OST_KINEMATICS_H_

#include <math.h>
#include <stddef.h>

#include "ost_geom.h"
#include "ost_hd.h"
#include "ost_math.h"
#include "ost_model.h"

#ifdef __cplusplus
extern "C" {
#endif

//---------------------------------- quaternion and spatial helpers -------------------------------

// res = a b (Hamilton product; res may alias a or b)
OST_HD void osti_kinQuatMul(ostNum res[4], const ostNum a[4], const ostNum b[4]) {
  ostNum w = a[0]*b[0] - a[1]*b[1] - a[2]*b[2] - a[3]*b[3];
  ostNum x = a[0]*b[1] + a[1]*b[0] + a[2]*b[3] - a[3]*b[2];
  ostNum y = a[0]*b[2] - a[1]*b[3] + a[2]*b[0] + a[3]*b[1];
  ostNum z = a[0]*b[3] + a[1]*b[2] - a[2]*b[1] + a[3]*b[0];
  res[0] = w; res[1] = x; res[2] = y; res[3] = z;
}


// q /= |q| as mju_normalize4: shorter than OST_MINVAL -> (1,0,0,0); within OST_MINVAL of unit
// length -> unchanged (for dual numbers: the derivative is then not projected onto the unit
// sphere, which is exact for tangent seeds q (x) (0, v/2))
OST_HD void osti_kinNormalize4(ostNum q[4]) {
  ostNum n = sqrt(q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3]);
  if (n < OST_MINVAL) {
    q[0] = 1; q[1] = 0; q[2] = 0; q[3] = 0;
  } else if (fabs(n - 1) > OST_MINVAL) {
    ostNum inv = 1 / n;
    q[0] *= inv; q[1] *= inv; q[2] *= inv; q[3] *= inv;
  }
}


// rotation matrix of a unit quaternion: R = (w^2 - |v|^2) I + 2 v v' + 2 w [v]x
OST_HD void osti_kinQuat2Mat(ostNum R[9], const ostNum q[4]) {
  ostNum ww = q[0]*q[0], xx = q[1]*q[1], yy = q[2]*q[2], zz = q[3]*q[3];
  ostNum wx = q[0]*q[1], wy = q[0]*q[2], wz = q[0]*q[3];
  ostNum xy = q[1]*q[2], xz = q[1]*q[3], yz = q[2]*q[3];
  R[0] = ww + xx - yy - zz;  R[1] = 2*(xy - wz);        R[2] = 2*(xz + wy);
  R[3] = 2*(xy + wz);        R[4] = ww - xx + yy - zz;  R[5] = 2*(yz - wx);
  R[6] = 2*(xz - wy);        R[7] = 2*(yz + wx);        R[8] = ww - xx - yy + zz;
}


// res = R v (res must not alias v)
OST_HD void osti_kinMatVec(ostNum res[3], const ostNum R[9], const ostNum v[3]) {
  res[0] = R[0]*v[0] + R[1]*v[1] + R[2]*v[2];
  res[1] = R[3]*v[0] + R[4]*v[1] + R[5]*v[2];
  res[2] = R[6]*v[0] + R[7]*v[1] + R[8]*v[2];
}


// res = a x b (res must not alias)
OST_HD void osti_kinCross(ostNum res[3], const ostNum a[3], const ostNum b[3]) {
  res[0] = a[1]*b[2] - a[2]*b[1];
  res[1] = a[2]*b[0] - a[0]*b[2];
  res[2] = a[0]*b[1] - a[1]*b[0];
}


// spatial force of a com inertia I = (Irot, h = m c, m) times a motion v = (w; u):
//   res = (Irot w + h x u ; m u - h x w)
OST_HD void osti_kinMulInert(ostNum res[6], const ostNum I[10], const ostNum v[6]) {
  const ostNum* w = v;
  const ostNum* u = v + 3;
  res[0] = I[0]*w[0] + I[3]*w[1] + I[4]*w[2] + (I[7]*u[2] - I[8]*u[1]);
  res[1] = I[3]*w[0] + I[1]*w[1] + I[5]*w[2] + (I[8]*u[0] - I[6]*u[2]);
  res[2] = I[4]*w[0] + I[5]*w[1] + I[2]*w[2] + (I[6]*u[1] - I[7]*u[0]);
  res[3] = I[9]*u[0] - (I[7]*w[2] - I[8]*w[1]);
  res[4] = I[9]*u[1] - (I[8]*w[0] - I[6]*w[2]);
  res[5] = I[9]*u[2] - (I[6]*w[1] - I[7]*w[0]);
}


// motion cross product: res = v x m = (w x a ; w x b + u x a) for v = (w; u), m = (a; b)
OST_HD void osti_kinCrossMotion(ostNum res[6], const ostNum v[6], const ostNum mo[6]) {
  ostNum t[3];
  osti_kinCross(res, v, mo);
  osti_kinCross(res + 3, v, mo + 3);
  osti_kinCross(t, v + 3, mo);
  res[3] += t[0]; res[4] += t[1]; res[5] += t[2];
}


// force cross product: res = v x* f = (w x n + u x f ; w x f) for v = (w; u), f = (n; f)
OST_HD void osti_kinCrossForce(ostNum res[6], const ostNum v[6], const ostNum f[6]) {
  ostNum t[3];
  osti_kinCross(res, v, f);
  osti_kinCross(t, v + 3, f + 3);
  res[0] += t[0]; res[1] += t[1]; res[2] += t[2];
  osti_kinCross(res + 3, v, f + 3);
}


// com-based motion of a unit axis a: rotation about an anchor with r = com - anchor gives
// (a ; a x r), translation (r NULL) gives (0 ; a)
OST_HD void osti_kinDofCom(ostNum res[6], const ostNum a[3], const ostNum* r) {
  if (r) {
    res[0] = a[0]; res[1] = a[1]; res[2] = a[2];
    osti_kinCross(res + 3, a, r);
  } else {
    res[0] = 0; res[1] = 0; res[2] = 0;
    res[3] = a[0]; res[4] = a[1]; res[5] = a[2];
  }
}


// q - q_ref of two quaternions as a rotation vector: d = neg(q_ref) q = (cos t/2, n sin t/2),
// res = n t with t wrapped into (-pi, pi] (mju_subQuat; invariant to positive scalings of q)
OST_HD void osti_kinSubQuat(ostNum res[3], const ostNum q[4], const ostNum qref[4]) {
  ostNum neg[4] = {qref[0], -qref[1], -qref[2], -qref[3]}, d[4];
  osti_kinQuatMul(d, neg, q);
  ostNum s = sqrt(d[1]*d[1] + d[2]*d[2] + d[3]*d[3]);
  ostNum n[3] = {1, 0, 0};
  if (s >= OST_MINVAL) {
    n[0] = d[1] / s; n[1] = d[2] / s; n[2] = d[3] / s;
  }
  ostNum t = 2 * ostu_atan2(s, d[0]);
  if (t > (ostNum)3.14159265358979323846) {
    t -= 2 * (ostNum)3.14159265358979323846;
  }
  res[0] = n[0] * t; res[1] = n[1] * t; res[2] = n[2] * t;
}


//---------------------------------- kinematics ---------------------------------------------------

// xpos, xquat, xmat, xipos, ximat of every body, xanchor, xaxis of every joint at configuration
// qpos (mj_kinematics without geoms and sites; osti_kinematics adds the geoms). Bodies are
// visited parent first
// (MuJoCo's body order); within a body, joints act in order, each about its own anchor:
//   free:  x = qpos[0:3], q = normalize(qpos[3:7])      (the body's frame in the world)
//   other: x = x_parent + R_parent body_pos, q = q_parent body_quat, then per joint
//          anchor = x + R(q) jnt_pos, axis = R(q) jnt_axis
//          slide: x += axis qpos
//          hinge: q = q (cos(qpos/2), jnt_axis sin(qpos/2)), x = anchor - R(q) jnt_pos
//          ball:  q = q normalize(qpos[0:4]),            x = anchor - R(q) jnt_pos
// qpos itself is not modified (quaternions are normalized in local copies, as MuJoCo does)
OST_HD void osti_kinematicsBodies(const ostModel* m, ostKin* k, const ostNum* qpos) {
  int nbody = m->s.nbody;

  // world body
  for (int r = 0; r < 3; r++) {
    k->xpos[r] = 0;
    k->xipos[r] = 0;
  }
  k->xquat[0] = 1; k->xquat[1] = 0; k->xquat[2] = 0; k->xquat[3] = 0;
  for (int r = 0; r < 9; r++) {
    k->xmat[r] = (r % 4 == 0);
    k->ximat[r] = (r % 4 == 0);
  }

  // bodies, parent first
  for (int i = 1; i < nbody; i++) {
    ostNum x[3], q[4], v[3];
    int j0 = m->body_jntadr[i], nj = m->body_jntnum[i];

    if (nj > 0 && m->jnt_type[j0] == OST_JNT_FREE) {
      // free joint: the body frame is qpos itself; anchor at the body origin
      const ostNum* qp = qpos + m->jnt_qposadr[j0];
      x[0] = qp[0]; x[1] = qp[1]; x[2] = qp[2];
      q[0] = qp[3]; q[1] = qp[4]; q[2] = qp[5]; q[3] = qp[6];
      osti_kinNormalize4(q);
      for (int r = 0; r < 3; r++) {
        k->xanchor[3*j0 + r] = x[r];
        k->xaxis[3*j0 + r] = m->jnt_axis[3*j0 + r];
      }
    } else {
      // fixed offset from the parent: x = x_p + R_p body_pos, q = q_p body_quat
      int p = m->body_parentid[i];
      osti_kinMatVec(v, k->xmat + 9*p, m->body_pos + 3*i);
      for (int r = 0; r < 3; r++) {
        x[r] = k->xpos[3*p + r] + v[r];
      }
      osti_kinQuatMul(q, k->xquat + 4*p, m->body_quat + 4*i);

      // joints in order, each about its anchor
      for (int j = j0; j < j0 + nj; j++) {
        ostNum R[9], qloc[4];
        const ostNum* qp = qpos + m->jnt_qposadr[j];
        ostNum* anchor = k->xanchor + 3*j;
        ostNum* axis = k->xaxis + 3*j;
        osti_kinQuat2Mat(R, q);
        osti_kinMatVec(axis, R, m->jnt_axis + 3*j);
        osti_kinMatVec(anchor, R, m->jnt_pos + 3*j);
        for (int r = 0; r < 3; r++) {
          anchor[r] += x[r];
        }
        int type = m->jnt_type[j];
        if (type == OST_JNT_SLIDE) {
          for (int r = 0; r < 3; r++) {
            x[r] += axis[r] * qp[0];
          }
          continue;
        }
        if (type == OST_JNT_HINGE) {
          // qloc = (cos(a/2), jnt_axis sin(a/2)); exactly the identity at a = 0, where the
          // first-order term jnt_axis a/2 (+0 turns a -0 into the identity's +0) still carries
          // the derivative of a dual qpos
          if (qp[0] == 0) {
            qloc[0] = 1;
            for (int r = 0; r < 3; r++) {
              qloc[1 + r] = m->jnt_axis[3*j + r] * (0.5 * qp[0]) + 0;
            }
          } else {
            ostNum s = ostu_sin(0.5 * qp[0]);
            qloc[0] = ostu_cos(0.5 * qp[0]);
            for (int r = 0; r < 3; r++) {
              qloc[1 + r] = m->jnt_axis[3*j + r] * s;
            }
          }
        } else {
          // ball (a free joint is only ever a body's first and only joint)
          OST_ASSERT(type == OST_JNT_BALL);
          qloc[0] = qp[0]; qloc[1] = qp[1]; qloc[2] = qp[2]; qloc[3] = qp[3];
          osti_kinNormalize4(qloc);
        }
        osti_kinQuatMul(q, q, qloc);

        // rotation about the anchor: x = anchor - R(q) jnt_pos
        osti_kinQuat2Mat(R, q);
        osti_kinMatVec(v, R, m->jnt_pos + 3*j);
        for (int r = 0; r < 3; r++) {
          x[r] = anchor[r] - v[r];
        }
      }
    }

    // store the frame; inertia frame: xipos = x + R body_ipos, ximat = R(q body_iquat)
    osti_kinNormalize4(q);
    ostNum* R = k->xmat + 9*i;
    osti_kinQuat2Mat(R, q);
    for (int r = 0; r < 4; r++) {
      k->xquat[4*i + r] = q[r];
    }
    osti_kinMatVec(v, R, m->body_ipos + 3*i);
    for (int r = 0; r < 3; r++) {
      k->xpos[3*i + r] = x[r];
      k->xipos[3*i + r] = x[r] + v[r];
    }
    ostNum qi[4];
    osti_kinQuatMul(qi, q, m->body_iquat + 4*i);
    osti_kinQuat2Mat(k->ximat + 9*i, qi);
  }
}


// geom g's frame from its body's: geom_xpos = x_b + R_b geom_pos, geom_xmat = R(q_b geom_quat)
OST_HD void osti_kinGeom(const ostModel* m, ostKin* k, int g) {
  int b = m->geom_bodyid[g];
  ostNum v[3], qg[4];
  osti_kinMatVec(v, k->xmat + 9*b, m->geom_pos + 3*g);
  for (int r = 0; r < 3; r++) {
    k->geom_xpos[3*g + r] = k->xpos[3*b + r] + v[r];
  }
  osti_kinQuatMul(qg, k->xquat + 4*b, m->geom_quat + 4*g);
  osti_kinQuat2Mat(k->geom_xmat + 9*g, qg);
}


// osti_kinematicsBodies, then the frames of the geoms collision reads: those of a candidate pair
// (geom_paired). Dynamics needs the bodies alone, and a geom in no pair (visual meshes,
// contype 0, a model without contact) is never read, so its frame is left as it was.
OST_HD void osti_kinematics(const ostModel* m, ostKin* k, const ostNum* qpos) {
  osti_kinematicsBodies(m, k, qpos);
  for (int g = 0; g < m->s.ngeom; g++) {
    if (m->geom_paired[g]) {
      osti_kinGeom(m, k, g);
    }
  }
}


// geom g placed in the world, as the collision functions see it (kinematics ran)
OST_HD void osti_geom(const ostModel* m, const ostKin* k, int g, ostGeom* out) {
  out->type = m->geom_type[g];
  for (int r = 0; r < 3; r++) {
    out->size[r] = m->geom_size[3*g + r];
    out->pos[r] = k->geom_xpos[3*g + r];
  }
  for (int r = 0; r < 9; r++) {
    out->mat[r] = k->geom_xmat[9*g + r];
  }
  out->rbound = m->geom_rbound[g];

  // meshes: vertices in the geom frame, straight from the model
  int id = m->geom_dataid[g];
  if (out->type == OST_GEOM_MESH && id >= 0) {
    out->nvert = m->mesh_vertnum[id];
    out->vert = m->mesh_vert + 3 * (size_t)m->mesh_vertadr[id];
    out->nface = m->mesh_facenum[id];
    out->face = m->mesh_face + 3 * (size_t)m->mesh_faceadr[id];
  } else {
    out->nvert = out->nface = 0;
    out->vert = NULL;
    out->face = NULL;
  }
}


//---------------------------------- com-based frames ---------------------------------------------

// subtree_com of every body, cinert of every body and cdof of every dof (mj_comPos; kinematics
// ran). The subtree masses are accumulated in cinert[9] before cinert is written.
//   subtree_com[i] = sum_{b in subtree(i)} m_b xipos_b / sum m_b   (xipos_i if the mass < MINVAL)
//   cinert[i]: c = xipos_i - subtree_com[root_i], Irot = R diag(I) R' + m (|c|^2 I - c c')
//   cdof: hinge (axis ; axis x (com_root - anchor)), slide (axis ; 0), ball and the rotation of
//         a free joint: the columns of xmat as hinge axes, free translation (0 ; e_k)
OST_HD void osti_comPos(const ostModel* m, ostKin* k) {
  int nbody = m->s.nbody;

  // mass-weighted positions and masses, accumulated leaf to root (bodies follow their parents)
  for (int i = 0; i < nbody; i++) {
    ostNum mass = m->body_mass[i];
    for (int r = 0; r < 3; r++) {
      k->subtree_com[3*i + r] = k->xipos[3*i + r] * mass;
    }
    k->cinert[10*i + 9] = mass;
  }
  for (int i = nbody - 1; i > 0; i--) {
    int p = m->body_parentid[i];
    for (int r = 0; r < 3; r++) {
      k->subtree_com[3*p + r] += k->subtree_com[3*i + r];
    }
    k->cinert[10*p + 9] += k->cinert[10*i + 9];
  }
  for (int i = 0; i < nbody; i++) {
    ostNum mass = k->cinert[10*i + 9];
    for (int r = 0; r < 3; r++) {
      k->subtree_com[3*i + r] = mass < OST_MINVAL ? k->xipos[3*i + r]
                                                  : k->subtree_com[3*i + r] / mass;
    }
  }

  // com inertias: Irot = R diag(I) R' + m (|c|^2 I - c c'), h = m c
  for (int r = 0; r < 10; r++) {
    k->cinert[r] = 0;
  }
  for (int i = 1; i < nbody; i++) {
    const ostNum* R = k->ximat + 9*i;
    const ostNum* d = m->body_inertia + 3*i;
    const ostNum* com = k->subtree_com + 3*m->body_rootid[i];
    ostNum mass = m->body_mass[i];
    ostNum c[3] = {k->xipos[3*i] - com[0], k->xipos[3*i + 1] - com[1],
                   k->xipos[3*i + 2] - com[2]};
    ostNum* I = k->cinert + 10*i;

    // (R diag(d) R')_ab = sum_t R_at d_t R_bt, entries (00, 11, 22, 01, 02, 12)
    for (int e = 0; e < 6; e++) {
      int a = e < 3 ? e : (e < 5 ? 0 : 1), b = e < 3 ? e : (e == 3 ? 1 : 2);
      const ostNum* Ra = R + 3*a;
      const ostNum* Rb = R + 3*b;
      I[e] = Ra[0]*d[0]*Rb[0] + Ra[1]*d[1]*Rb[1] + Ra[2]*d[2]*Rb[2];
    }
    I[0] += mass * (c[1]*c[1] + c[2]*c[2]);
    I[1] += mass * (c[0]*c[0] + c[2]*c[2]);
    I[2] += mass * (c[0]*c[0] + c[1]*c[1]);
    I[3] -= mass * c[0]*c[1];
    I[4] -= mass * c[0]*c[2];
    I[5] -= mass * c[1]*c[2];
    I[6] = mass * c[0];
    I[7] = mass * c[1];
    I[8] = mass * c[2];
    I[9] = mass;
  }

  // com-based motion axes of the dofs, offset r = subtree_com[root] - anchor
  for (int j = 0; j < m->s.njnt; j++) {
    int b = m->jnt_bodyid[j], da = m->jnt_dofadr[j];
    const ostNum* com = k->subtree_com + 3*m->body_rootid[b];
    const ostNum* anchor = k->xanchor + 3*j;
    ostNum off[3] = {com[0] - anchor[0], com[1] - anchor[1], com[2] - anchor[2]};
    ostNum* cd = k->cdof + 6*da;
    int type = m->jnt_type[j];
    if (type == OST_JNT_FREE) {
      // translation along the world axes
      for (int e = 0; e < 18; e++) {
        cd[e] = 0;
      }
      cd[3] = 1; cd[6 + 4] = 1; cd[12 + 5] = 1;
      cd += 18;
    }
    if (type == OST_JNT_FREE || type == OST_JNT_BALL) {
      // rotation about the body's own axes (columns of xmat)
      const ostNum* R = k->xmat + 9*b;
      for (int c = 0; c < 3; c++) {
        ostNum a[3] = {R[c], R[3 + c], R[6 + c]};
        osti_kinDofCom(cd + 6*c, a, off);
      }
    } else {
      osti_kinDofCom(cd, k->xaxis + 3*j, type == OST_JNT_HINGE ? off : NULL);
    }
  }
}


//---------------------------------- composite rigid body -----------------------------------------

// crb of every body and the dense joint-space inertia qM (nv x nv, both triangles) including
// armature (mj_crb + mj_fullM; comPos ran). crb[i] = sum of cinert over subtree(i) (bodies below
// the world only: a child of the world keeps its own subtree); for dof i of body b and every
// ancestor dof j of i (dof_parentid chain, i itself included):
//   M(i,j) = M(j,i) = cdof_j' crb_b cdof_i,   M(i,i) += armature_i;   0 elsewhere
OST_HD void osti_crb(const ostModel* m, ostKin* k) {
  int nbody = m->s.nbody, nv = m->s.nv;

  // composite inertias, leaf to root
  for (int e = 0; e < 10 * nbody; e++) {
    k->crb[e] = k->cinert[e];
  }
  for (int i = nbody - 1; i > 0; i--) {
    int p = m->body_parentid[i];
    if (p > 0) {
      for (int e = 0; e < 10; e++) {
        k->crb[10*p + e] += k->crb[10*i + e];
      }
    }
  }

  // dense mass matrix over the dof ancestor chains
  for (int e = 0; e < nv * nv; e++) {
    k->qM[e] = 0;
  }
  for (int i = 0; i < nv; i++) {
    ostNum f[6];
    osti_kinMulInert(f, k->crb + 10*m->dof_bodyid[i], k->cdof + 6*i);
    k->qM[(size_t)i*nv + i] = m->dof_armature[i];
    for (int j = i; j >= 0; j = m->dof_parentid[j]) {
      const ostNum* cj = k->cdof + 6*j;
      ostNum Mij = k->qM[(size_t)i*nv + j]
                   + cj[0]*f[0] + cj[1]*f[1] + cj[2]*f[2] + cj[3]*f[3] + cj[4]*f[4] + cj[5]*f[5];
      k->qM[(size_t)i*nv + j] = Mij;
      k->qM[(size_t)j*nv + i] = Mij;
    }
  }
}


//---------------------------------- bias forces --------------------------------------------------

// cvel of every body, cdof_dot of every dof and qfrc_bias = C(q, qvel) qvel + g(q) (mj_comVel +
// mj_rne with zero acceleration; comPos ran). cacc and cfrc hold the RNE pass (world included).
// Velocities, parent first; within a body the dofs act in order:
//   hinge, slide: cdof_dot = cvel x cdof, then cvel += cdof qvel
//   ball (and a free joint's rotation): cdof_dot = cvel x cdof for all three, then cvel += ...
//   free translation: cdof_dot = 0, then cvel += ...
// RNE: cacc_world = (0 ; -gravity) (0 with OST_DSBL_GRAVITY),
//   cacc_i = cacc_parent + sum_d cdof_dot_d qvel_d,  cfrc_i = cinert cacc_i + cvel x* (cinert cvel)
//   cfrc accumulated leaf to root,                     qfrc_bias_d = cdof_d' cfrc_body(d)
OST_HD void osti_rne(const ostModel* m, ostKin* k, const ostNum* qvel) {
  int nbody = m->s.nbody, nv = m->s.nv;

  // world: at rest, accelerating against gravity
  for (int e = 0; e < 6; e++) {
    k->cvel[e] = 0;
    k->cacc[e] = 0;
    k->cfrc[e] = 0;
  }
  if (!(m->disableflags & OST_DSBL_GRAVITY)) {
    for (int r = 0; r < 3; r++) {
      k->cacc[3 + r] = -m->gravity[r];
    }
  }

  // velocities and dof derivatives, parent first
  for (int i = 1; i < nbody; i++) {
    ostNum v[6];
    int p = m->body_parentid[i], da = m->body_dofadr[i], nd = m->body_dofnum[i];
    for (int e = 0; e < 6; e++) {
      v[e] = k->cvel[6*p + e];
    }
    for (int d = da; d < da + nd; d++) {
      int type = m->jnt_type[m->dof_jntid[d]];
      int n = 1;
      if (type == OST_JNT_FREE) {
        // translation: cdof is constant in the world
        for (int e = 0; e < 18; e++) {
          k->cdof_dot[6*d + e] = 0;
        }
        for (int t = d; t < d + 3; t++) {
          for (int e = 0; e < 6; e++) {
            v[e] += k->cdof[6*t + e] * qvel[t];
          }
        }
        d += 3;
        n = 3;
      } else if (type == OST_JNT_BALL) {
        n = 3;
      }

      // n dofs of one joint share the velocity before them
      for (int t = d; t < d + n; t++) {
        osti_kinCrossMotion(k->cdof_dot + 6*t, v, k->cdof + 6*t);
      }
      for (int t = d; t < d + n; t++) {
        for (int e = 0; e < 6; e++) {
          v[e] += k->cdof[6*t + e] * qvel[t];
        }
      }
      d += n - 1;
    }
    for (int e = 0; e < 6; e++) {
      k->cvel[6*i + e] = v[e];
    }
  }

  // accelerations and body forces, parent first
  for (int i = 1; i < nbody; i++) {
    int p = m->body_parentid[i], da = m->body_dofadr[i], nd = m->body_dofnum[i];
    ostNum* a = k->cacc + 6*i;
    for (int e = 0; e < 6; e++) {
      ostNum s = 0;
      for (int d = da; d < da + nd; d++) {
        s += k->cdof_dot[6*d + e] * qvel[d];
      }
      a[e] = k->cacc[6*p + e] + s;
    }
    ostNum Iv[6], vxIv[6];
    const ostNum* I = k->cinert + 10*i;
    osti_kinMulInert(k->cfrc + 6*i, I, a);
    osti_kinMulInert(Iv, I, k->cvel + 6*i);
    osti_kinCrossForce(vxIv, k->cvel + 6*i, Iv);
    for (int e = 0; e < 6; e++) {
      k->cfrc[6*i + e] += vxIv[e];
    }
  }

  // forces leaf to root (the world receives nothing), projected on the dofs
  for (int i = nbody - 1; i > 0; i--) {
    int p = m->body_parentid[i];
    if (p > 0) {
      for (int e = 0; e < 6; e++) {
        k->cfrc[6*p + e] += k->cfrc[6*i + e];
      }
    }
  }
  for (int d = 0; d < nv; d++) {
    const ostNum* c = k->cdof + 6*d;
    const ostNum* f = k->cfrc + 6*m->dof_bodyid[d];
    k->qfrc_bias[d] = c[0]*f[0] + c[1]*f[1] + c[2]*f[2] + c[3]*f[3] + c[4]*f[4] + c[5]*f[5];
  }
}


//---------------------------------- passive forces -----------------------------------------------

// qfrc_passive: joint springs and dof dampers (mj_passive without tendons, viscosity or user
// callbacks); all zero with OST_DSBL_PASSIVE.
//   hinge, slide: -k (q - q_spring);   free: -k (x - x_spring) on the translation, then as ball
//   ball: -k subQuat(q, q_spring) (rotation vector of q_spring^-1 q)
//   every dof: -damping qvel
OST_HD void osti_passive(const ostModel* m, ostKin* k, const ostNum* qpos, const ostNum* qvel) {
  int nv = m->s.nv;
  for (int d = 0; d < nv; d++) {
    k->qfrc_passive[d] = 0;
  }
  if (m->disableflags & OST_DSBL_PASSIVE) {
    return;
  }

  // joint springs
  for (int j = 0; j < m->s.njnt; j++) {
    ostNum stiff = m->jnt_stiffness[j];
    int pa = m->jnt_qposadr[j], da = m->jnt_dofadr[j], type = m->jnt_type[j];
    if (type == OST_JNT_FREE) {
      for (int r = 0; r < 3; r++) {
        k->qfrc_passive[da + r] = -stiff * (qpos[pa + r] - m->qpos_spring[pa + r]);
      }
      pa += 3;
      da += 3;
    }
    if (type == OST_JNT_FREE || type == OST_JNT_BALL) {
      ostNum dif[3];
      osti_kinSubQuat(dif, qpos + pa, m->qpos_spring + pa);
      for (int r = 0; r < 3; r++) {
        k->qfrc_passive[da + r] = -stiff * dif[r];
      }
    } else {
      k->qfrc_passive[da] = -stiff * (qpos[pa] - m->qpos_spring[pa]);
    }
  }

  // dof dampers
  for (int d = 0; d < nv; d++) {
    k->qfrc_passive[d] -= m->dof_damping[d] * qvel[d];
  }
}


//---------------------------------- transmission -------------------------------------------------

// actuator_length and actuator_moment (nu x nv) of joint transmissions on hinge and slide joints
// (mj_transmission): length = gear q_joint, moment row = gear on the joint's dof, 0 elsewhere
OST_HD void osti_transmission(const ostModel* m, ostKin* k, const ostNum* qpos) {
  int nv = m->s.nv;
  for (int i = 0; i < m->s.nu; i++) {
    int j = m->actuator_trnid[i];
    ostNum gear = m->actuator_gear[i];
    ostNum* mom = k->actuator_moment + (size_t)i*nv;
    OST_ASSERT(m->jnt_type[j] == OST_JNT_HINGE || m->jnt_type[j] == OST_JNT_SLIDE);
    k->actuator_length[i] = gear * qpos[m->jnt_qposadr[j]];
    for (int d = 0; d < nv; d++) {
      mom[d] = 0;
    }
    mom[m->jnt_dofadr[j]] = gear;
  }
}


//---------------------------------- Jacobians ----------------------------------------------------

// translational (jacp, 3 x nv) and rotational (jacr, 3 x nv, may be NULL) Jacobians of a point
// (world) moving with body (mj_jac; comPos ran). Over the dofs that move the body (the dof
// ancestor chain of its nearest ancestor with dofs), with r = point - subtree_com[root]:
//   jacr[:,d] = cdof_d[0:3],   jacp[:,d] = cdof_d[3:6] + cdof_d[0:3] x r,   0 elsewhere
OST_HD void osti_jac(const ostModel* m, const ostKin* k, ostNum* jacp, ostNum* jacr,
                     const ostNum point[3], int body) {
  int nv = m->s.nv;
  const ostNum* com = k->subtree_com + 3*m->body_rootid[body];
  ostNum off[3] = {point[0] - com[0], point[1] - com[1], point[2] - com[2]};
  for (int e = 0; e < 3 * nv; e++) {
    if (jacp) jacp[e] = 0;
    if (jacr) jacr[e] = 0;
  }

  // nearest ancestor with dofs (welded bodies move with it)
  while (body > 0 && m->body_dofnum[body] == 0) {
    body = m->body_parentid[body];
  }
  if (body == 0) {
    return;
  }

  // dof ancestor chain from the body's last dof
  for (int d = m->body_dofadr[body] + m->body_dofnum[body] - 1; d >= 0; d = m->dof_parentid[d]) {
    const ostNum* c = k->cdof + 6*d;
    if (jacr) {
      jacr[d] = c[0];
      jacr[nv + d] = c[1];
      jacr[2*nv + d] = c[2];
    }
    if (jacp) {
      ostNum t[3];
      osti_kinCross(t, c, off);
      jacp[d] = c[3] + t[0];
      jacp[nv + d] = c[4] + t[1];
      jacp[2*nv + d] = c[5] + t[2];
    }
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_KINEMATICS_H_
