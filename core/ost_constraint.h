// ost_constraint.h: constraint rows of one Ostrich step (core/README.md section 1; paper eq. 3-7).
// Mirrors engine_core_constraint.c: the row description, the Fischer-Burmeister (FB) function,
// the projection of multipliers onto their admissible
// sets, and the matching of multipliers across Newton iterates whose contact sets differ.
//
// Row layout contract: a contact contributes one OST_ROW_CONTACT (normal) row, immediately
// followed by its OST_ROW_FRICTION rows when it has friction: two tangents (condim 3), then the
// torsional row (condim 4) and the two rolling rows (condim 6), each only where its coefficient
// is positive (OST_MAXFRIC rows at most). A friction row stores the index of its normal row in
// `normal`. Friction rows are normalized so that one circular cone |lambda_f| <= mu lambda_n
// holds MuJoCo's elliptic cone sum_k (force_k / mu_k)^2 <= lambda_n^2: row k's Jacobian is
// scaled by s_k = mu_k / mu (1 for the tangents; metres for torsion and rolling, which makes
// every row a velocity) and its force is s_k lambda_k. Units: every row's residual is a
// velocity.
// Dry-friction rows (frictionloss) are box-constrained: |lambda| <= mu, one row per dof or
// tendon, obj = (dof or tendon id, 0 dof / 1 tendon). Limit rows: obj = (joint id, side) for
// joints, (tendon id, 2 + side) for tendons.
#ifndef OSTRICH_CORE_OST_CONSTRAINT_H_
#define OSTRICH_CORE_OST_CONSTRAINT_H_

#include <math.h>
#include <stddef.h>

#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum osttRow_ {           // kind of constraint row
  OST_ROW_EQUALITY = 0,           // bilateral c(q) + E*lambda = 0 (connect, weld, joint)
  OST_ROW_LIMIT,                  // unilateral joint limit, FB(gap, lambda) = 0
  OST_ROW_CONTACT,                // unilateral contact normal, FB(gap, lambda) = 0
  OST_ROW_FRICTION,               // tangential: J_f u + W lambda_f = 0
  OST_ROW_SERVO,                  // implicit actuator: alpha*(lambda - force(q, u)) = 0
  OST_ROW_DRY                     // dry friction (frictionloss): J u + c lambda = 0, |lambda| <= mu
} osttRow;

typedef struct ostRow_ {          // one constraint row                        (nrow x 1)
  int    type;                    // osttRow
  int    obj[2];                  // matching key: geom ids (contact), else (object id, sub-row)
  int    normal;                  // friction rows: index of the normal row; else -1
  ostNum key[3];                  // contact position (matching key); zero otherwise
  ostNum pos;                     // unilateral: gap (m); equality: violation; servo: force at u=0
  ostNum mu;                      // contact: friction coefficient; servo: velocity gain b2 <= 0;
                                  // dry: the frictionloss (force bound, N or N m)
  ostNum alpha;                   // servo: compliance 1/(kd + h kp); equality: compliance E;
                                  // friction: the row's scale s_k = mu_k / mu
  ostNum lo;                      // servo: lower force limit (-HUGE_VAL if none); friction:
                                  // the slot in MuJoCo's contact frame (1, 2 sliding, 3
                                  // torsional, 4, 5 rolling)
  ostNum hi;                      // servo: upper force limit (+HUGE_VAL if none)
} ostRow;

#ifndef OST_NUM_TYPE  // a substituted scalar type never crosses the boundary
OST_STATIC_ASSERT(sizeof(ostRow) == 4 * sizeof(int) + 8 * sizeof(ostNum),
                  "ostRow crosses the gcc/nvcc boundary: keep it unpadded");
#endif


#define OST_MAXFRIC 5              // friction rows of one contact at most (condim 6)


// number of friction rows that follow contact row i (0 if none or row i is not a contact)
OST_HD int osti_frictionCount(const ostRow* rows, int nrow, int i) {
  int n = 0;
  while (i + n + 1 < nrow && rows[i + n + 1].type == OST_ROW_FRICTION
         && rows[i + n + 1].normal == i) {
    n++;
  }
  return rows[i].type == OST_ROW_CONTACT ? n : 0;
}


// smoothed Fischer-Burmeister function phi(a,b) = a + b - sqrt(a^2 + b^2 + eps^2) and its
// partial derivatives; phi = 0 iff a >= 0, b >= 0, a*b = eps^2/2 (paper eq. 4)
OST_HD ostNum osti_fb(ostNum a, ostNum b, ostNum eps, ostNum* fa, ostNum* fb) {
  ostNum s = sqrt(a * a + b * b + eps * eps);
  *fa = 1 - a / s;
  *fb = 1 - b / s;
  return a + b - s;
}


// 1 if a frictionless contact's normal row moves its degrees of freedom beyond rounding: jn2 =
// |J_n|^2 above OST_IMMOBILE times rel2 = |J_p2 - J_p1|^2, the contact points' relative motion in
// all three directions, both summed over the same dofs. Two spheres centred on the pivots of two
// hinged links (the finger bases of a hand joined by an explicit condim-1 pair) keep their gap
// whatever the joints do, and under a shared parent (the wrist) J_n is rounding, 1e-16 of J_p:
// its FB row, of scale k = h^2 J_n Mt^-1 J_n' ~ 1e-36 m/N, left the force free and Newton drove
// it to 1e19 N within an iterate. Such a contact can carry no force and gets no row (a contact
// with friction compares with its tangent rows instead: osti_contactImmobile). The bound stays
// far below any physical ratio (see osti_contactImmobile).
#define OST_IMMOBILE 1e-14
OST_HD int osti_normalMoves(ostNum jn2, ostNum rel2) {
  return jn2 > OST_IMMOBILE * rel2;
}


// rows n, t1, t2 of a contact from the translational Jacobians j1, j2 (3 x nv each) of its two
// bodies at the contact point: frame rows times (j2 - j1), so J_n u > 0 separates. t1, t2 may be
// NULL (frictionless). Returns 0 if the contact moves no degree of freedom. Shared by both
// geometry providers.
OST_HD int osti_contactRows(const ostNum frame[9], const ostNum* j1, const ostNum* j2, int nv,
                            ostNum* Jn, ostNum* Jt1, ostNum* Jt2) {
  int any = 0;
  for (int j = 0; j < nv; j++) {
    ostNum dx = j2[j] - j1[j], dy = j2[nv + j] - j1[nv + j], dz = j2[2 * nv + j] - j1[2 * nv + j];
    Jn[j] = frame[0] * dx + frame[1] * dy + frame[2] * dz;
    if (Jt1) {
      Jt1[j] = frame[3] * dx + frame[4] * dy + frame[5] * dz;
      Jt2[j] = frame[6] * dx + frame[7] * dy + frame[8] * dz;
    }
    any |= Jn[j] != 0;
  }
  return any;
}


// matching key of a contact: its position pos in the frame (xpos, xmat) of a moving body of the
// pair, key = xmat' (pos - xpos), so that contacts keep their keys while the bodies move
OST_HD void osti_contactKeyOf(ostNum key[3], const ostNum pos[3], const ostNum xpos[3],
                              const ostNum xmat[9]) {
  ostNum dx[3] = {pos[0] - xpos[0], pos[1] - xpos[1], pos[2] - xpos[2]};
  for (int r = 0; r < 3; r++) {
    key[r] = xmat[r] * dx[0] + xmat[3 + r] * dx[1] + xmat[6 + r] * dx[2];
  }
}


// the row of MuJoCo's contact frame (0 normal, 1 and 2 tangents) that friction slot k (1, 2
// sliding, 3 torsional, 4, 5 rolling) projects on: torsion turns about the normal, the sliding
// and rolling pairs run along and about the tangents
OST_HD int osti_slotAxis(int slot) {
  return slot == 3 ? 0 : (slot == 1 || slot == 4 ? 1 : 2);
}


// the friction rows of a contact from the translational Jacobians j1, j2 and rotational
// Jacobians r1, r2 (3 x nv each, r1, r2 may be NULL when only the tangents are asked for) of
// its two bodies: the rows of the slots (1 t1, 2 t2, 3 torsion, 4, 5 rolling; MuJoCo's contact
// frame times J(body2) - J(body1)) given in slot[0..nf-1], each times its scale s_k, into J
// (nf rows apart by nv)
OST_HD void osti_frictionJacobian(const ostNum frame[9], const ostNum* j1, const ostNum* j2,
                                  const ostNum* r1, const ostNum* r2, int nv, int nf,
                                  const int* slot, const ostNum* scale, ostNum* J) {
  for (int f = 0; f < nf; f++) {
    // slot 1, 2: tangent rows of the translational difference; 3: normal row, 4, 5: tangent
    // rows of the rotational difference
    int ang = slot[f] >= 3;
    const ostNum* a = ang ? r1 : j1;
    const ostNum* b = ang ? r2 : j2;
    const ostNum* e = frame + 3 * osti_slotAxis(slot[f]);
    ostNum* Jf = J + (size_t)f * nv;
    for (int j = 0; j < nv; j++) {
      ostNum dx = b[j] - a[j], dy = b[nv + j] - a[nv + j], dz = b[2 * nv + j] - a[2 * nv + j];
      Jf[j] = scale[f] * (e[0] * dx + e[1] * dy + e[2] * dz);
    }
  }
}


// the friction rows of a contact with condim, sliding, torsional and rolling coefficients mu,
// mu_tor, mu_roll: their slots and scales (see the row layout contract); returns their number
// (0: frictionless)
OST_HD int osti_frictionSlots(int condim, ostNum mu, ostNum mu_tor, ostNum mu_roll, int* slot,
                              ostNum* scale) {
  if (condim < 3 || !(mu > 0)) {
    return 0;
  }
  int nf = 0;
  for (int k = 1; k <= OST_MAXFRIC; k++) {
    ostNum c = k <= 2 ? mu : (k == 3 ? mu_tor : mu_roll);
    if ((k == 3 && condim < 4) || (k > 3 && condim < 6) || !(c > 0)) {
      continue;
    }
    slot[nf] = k;
    scale[nf] = k <= 2 ? 1 : c / mu;
    nf++;
  }
  return nf;
}


// the implicit servo row of actuator act (eq. 8): force = g ctrl + b0 + b1 L(q) + b2 V with
// V = moment u, compliance 1 / (kd + h kp) where kp = -b1, kd = -b2; ctrl already clamped;
// the force is limited to range when forcelimited. The caller fills the row's Jacobian (moment).
OST_HD void osti_servoRow(ostRow* r, int act, ostNum gain, const ostNum bias[3], ostNum ctrl,
                          ostNum length, ostNum h, int forcelimited, const ostNum range[2]) {
  r->type = OST_ROW_SERVO;
  r->normal = -1;
  r->obj[0] = act;
  r->obj[1] = 0;
  r->key[0] = r->key[1] = r->key[2] = 0;
  r->pos = gain * ctrl + bias[0] + bias[1] * length;
  r->mu = bias[2];
  r->alpha = 1 / (-bias[2] - h * bias[1]);
  r->lo = forcelimited ? range[0] : -HUGE_VAL;
  r->hi = forcelimited ? range[1] : HUGE_VAL;
}


// project the multipliers onto their admissible sets (paper section III-B safeguards):
// lambda_n >= 0, |lambda_f| <= mu lambda_n (cone clamp), servo forces within forcerange,
// dry friction |lambda| <= frictionloss
OST_HD void osti_projectRows(ostNum* lambda, const ostRow* rows, int nrow) {
  for (int i = 0; i < nrow; i++) {
    const ostRow* r = rows + i;
    switch (r->type) {
    case OST_ROW_LIMIT:
      if (lambda[i] < 0) {
        lambda[i] = 0;
      }
      break;
    case OST_ROW_CONTACT: {
      if (lambda[i] < 0) {
        lambda[i] = 0;
      }
      // the friction rows of this contact follow it
      int nf = osti_frictionCount(rows, nrow, i);
      if (nf) {
        ostNum bound = r->mu * lambda[i], t2 = 0;
        for (int k = 1; k <= nf; k++) {
          t2 += lambda[i + k] * lambda[i + k];
        }
        ostNum t = sqrt(t2);
        if (t > bound) {
          ostNum scl = t > 0 ? bound / t : 0;
          for (int k = 1; k <= nf; k++) {
            lambda[i + k] *= scl;
          }
        }
      }
      break;
    }
    case OST_ROW_DRY:
      lambda[i] = lambda[i] < -r->mu ? -r->mu : (lambda[i] > r->mu ? r->mu : lambda[i]);
      break;
    case OST_ROW_SERVO:
      if (lambda[i] < r->lo) {
        lambda[i] = r->lo;
      }
      if (lambda[i] > r->hi) {
        lambda[i] = r->hi;
      }
      break;
    default:
      break;
    }
  }
}


// squared distance of the matching keys of rows p and r
OST_HD ostNum osti_keyDist2(const ostRow* p, const ostRow* r) {
  ostNum dx = p->key[0] - r->key[0], dy = p->key[1] - r->key[1], dz = p->key[2] - r->key[2];
  return dx * dx + dy * dy + dz * dz;
}


// new row i takes previous row best's multiplier (best marked used); the friction rows of a
// matched contact inherit the previous tangential multipliers
OST_HD void osti_takeMatch(ostNum* lambda, const ostRow* rows, int nrow, int i,
                           const ostNum* prev_lambda, const ostRow* prev, int nprev,
                           unsigned char* used, int best) {
  used[best] = 1;
  lambda[i] = prev_lambda[best];
  int nf = osti_frictionCount(rows, nrow, i);
  if (nf && nf == osti_frictionCount(prev, nprev, best)) {
    for (int k = 1; k <= nf; k++) {
      lambda[i + k] = prev_lambda[best + k];
    }
  }
}


// copy multipliers from the previous iterate's rows to the new rows:
// same type and objects; contacts of one geom pair are paired with the nearest unused previous
// contact. Unmatched rows start at zero. used is scratch (nprev).
OST_HD void osti_matchRows(ostNum* lambda, const ostRow* rows, int nrow,
                           const ostNum* prev_lambda, const ostRow* prev, int nprev,
                           unsigned char* used) {
  for (int j = 0; j < nprev; j++) {
    used[j] = 0;
  }
  for (int i = 0; i < nrow; i++) {
    lambda[i] = 0;
  }
  for (int i = 0; i < nrow; i++) {
    const ostRow* r = rows + i;
    if (r->type == OST_ROW_FRICTION) {
      continue;  // handled with its normal row
    }
    int best = -1;
    ostNum best_d2 = HUGE_VAL;
    for (int j = 0; j < nprev; j++) {
      const ostRow* p = prev + j;
      if (used[j] || p->type != r->type || p->obj[0] != r->obj[0] || p->obj[1] != r->obj[1]) {
        continue;
      }
      ostNum d2 = osti_keyDist2(p, r);
      if (d2 < best_d2) {
        best_d2 = d2;
        best = j;
      }
    }
    if (best >= 0) {
      osti_takeMatch(lambda, rows, nrow, i, prev_lambda, prev, nprev, used, best);
    }
  }
}


// osti_matchRowsSorted searches directly (osti_matchRows) up to this many previous rows
#define OST_MATCH_SORT_MIN 32


// order of rows a, b of one list by (type, obj[0], obj[1]), then index: < 0, 0 or > 0
OST_HD int osti_rowOrder(const ostRow* rows, int a, int b) {
  const ostRow *p = rows + a, *q = rows + b;
  if (p->type != q->type) return p->type < q->type ? -1 : 1;
  if (p->obj[0] != q->obj[0]) return p->obj[0] < q->obj[0] ? -1 : 1;
  if (p->obj[1] != q->obj[1]) return p->obj[1] < q->obj[1] ? -1 : 1;
  return a < b ? -1 : (a > b ? 1 : 0);
}


// osti_matchRows with the same result in O(n log n): the previous rows are sorted by (type,
// objects, index) (bottom-up merge sort into order, 2 nprev ints of scratch), and each new row
// searches only the previous rows of its own type and objects, in index order, for the nearest
// unused one (so ties go to the lowest index, as in osti_matchRows)
OST_HD void osti_matchRowsSorted(ostNum* lambda, const ostRow* rows, int nrow,
                                 const ostNum* prev_lambda, const ostRow* prev, int nprev,
                                 unsigned char* used, int* order) {
  if (nprev <= OST_MATCH_SORT_MIN) {
    // few rows: the direct search costs less than the sort (21 rows of the wheeled robot: 2.7 %
    // of `ostrich synth` went to the sort), with the same result
    osti_matchRows(lambda, rows, nrow, prev_lambda, prev, nprev, used);
    return;
  }
  int* tmp = order + nprev;
  for (int j = 0; j < nprev; j++) {
    used[j] = 0;
    order[j] = j;
  }
  for (int i = 0; i < nrow; i++) {
    lambda[i] = 0;
  }
  for (int width = 1; width < nprev; width *= 2) {
    for (int lo = 0; lo < nprev; lo += 2 * width) {
      int mid = lo + width < nprev ? lo + width : nprev;
      int hi = lo + 2 * width < nprev ? lo + 2 * width : nprev;
      int a = lo, b = mid, k = lo;
      while (a < mid && b < hi) {
        tmp[k++] = osti_rowOrder(prev, order[a], order[b]) <= 0 ? order[a++] : order[b++];
      }
      while (a < mid) tmp[k++] = order[a++];
      while (b < hi) tmp[k++] = order[b++];
    }
    for (int j = 0; j < nprev; j++) {
      order[j] = tmp[j];
    }
  }
  for (int i = 0; i < nrow; i++) {
    const ostRow* r = rows + i;
    if (r->type == OST_ROW_FRICTION) {
      continue;  // handled with its normal row
    }
    // first previous row of r's type and objects (binary search on the sorted order)
    int lo = 0, hi = nprev;
    while (lo < hi) {
      int mid = (lo + hi) / 2;
      const ostRow* p = prev + order[mid];
      int less = p->type != r->type ? p->type < r->type
                 : p->obj[0] != r->obj[0] ? p->obj[0] < r->obj[0] : p->obj[1] < r->obj[1];
      if (less) {
        lo = mid + 1;
      } else {
        hi = mid;
      }
    }
    int best = -1;
    ostNum best_d2 = HUGE_VAL;
    for (int k = lo; k < nprev; k++) {
      int j = order[k];
      const ostRow* p = prev + j;
      if (p->type != r->type || p->obj[0] != r->obj[0] || p->obj[1] != r->obj[1]) {
        break;
      }
      if (used[j]) {
        continue;
      }
      ostNum d2 = osti_keyDist2(p, r);
      if (d2 < best_d2) {
        best_d2 = d2;
        best = j;
      }
    }
    if (best >= 0) {
      osti_takeMatch(lambda, rows, nrow, i, prev_lambda, prev, nprev, used, best);
    }
  }
}


#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_CONSTRAINT_H_
