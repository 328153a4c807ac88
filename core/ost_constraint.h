// ost_constraint.h: constraint rows of one Ostrich step (DESIGN.md section 1; paper eq. 3-7).
// Mirrors engine_core_constraint.c: the row description, the Fischer-Burmeister (FB) function,
// the projection of multipliers onto their admissible
// sets, and the matching of multipliers across Newton iterates whose contact sets differ.
//
// Row layout contract: a contact contributes one OST_ROW_CONTACT (normal) row, immediately
// followed by its two OST_ROW_FRICTION rows when it has friction (condim 3). A friction row
// stores the index of its normal row in `normal`. Units: every row's residual is a velocity.
#ifndef OSTRICH_CORE_OST_CONSTRAINT_H_
#define OSTRICH_CORE_OST_CONSTRAINT_H_

#include <math.h>

#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum osttRow_ {           // kind of constraint row
  OST_ROW_EQUALITY = 0,           // bilateral c(q) + E*lambda = 0 (connect, weld, joint)
  OST_ROW_LIMIT,                  // unilateral joint limit, FB(gap, lambda) = 0
  OST_ROW_CONTACT,                // unilateral contact normal, FB(gap, lambda) = 0
  OST_ROW_FRICTION,               // tangential: J_f u + W lambda_f = 0
  OST_ROW_SERVO                   // implicit actuator: alpha*(lambda - force(q, u)) = 0
} osttRow;

typedef struct ostRow_ {          // one constraint row                        (nrow x 1)
  int    type;                    // osttRow
  int    obj[2];                  // matching key: geom ids (contact), else (object id, sub-row)
  int    normal;                  // friction rows: index of the normal row; else -1
  ostNum key[3];                  // contact position (matching key); zero otherwise
  ostNum pos;                     // unilateral: gap (m); equality: violation; servo: force at u=0
  ostNum mu;                      // contact: friction coefficient; servo: velocity gain b2 <= 0
  ostNum alpha;                   // servo: compliance 1/(kd + h kp); equality: compliance E
  ostNum lo;                      // servo: lower force limit (-HUGE_VAL if none)
  ostNum hi;                      // servo: upper force limit (+HUGE_VAL if none)
} ostRow;

OST_STATIC_ASSERT(sizeof(ostRow) == 4 * sizeof(int) + 8 * sizeof(ostNum),
                  "ostRow crosses the gcc/nvcc boundary: keep it unpadded");


// smoothed Fischer-Burmeister function phi(a,b) = a + b - sqrt(a^2 + b^2 + eps^2) and its
// partial derivatives; phi = 0 iff a >= 0, b >= 0, a*b = eps^2/2 (paper eq. 4)
OST_HD ostNum osti_fb(ostNum a, ostNum b, ostNum eps, ostNum* fa, ostNum* fb) {
  ostNum s = sqrt(a * a + b * b + eps * eps);
  *fa = 1 - a / s;
  *fb = 1 - b / s;
  return a + b - s;
}


// project the multipliers onto their admissible sets (paper section III-B safeguards):
// lambda_n >= 0, |lambda_f| <= mu lambda_n (cone clamp), servo forces within forcerange
OST_HD void osti_projectRows(ostNum* lambda, const ostRow* rows, int nrow) {
  for (int i = 0; i < nrow; i++) {
    const ostRow* r = rows + i;
    switch (r->type) {
    case OST_ROW_LIMIT:
      if (lambda[i] < 0) {
        lambda[i] = 0;
      }
      break;
    case OST_ROW_CONTACT:
      if (lambda[i] < 0) {
        lambda[i] = 0;
      }
      // the friction rows of this contact follow it
      if (i + 2 < nrow && rows[i + 1].type == OST_ROW_FRICTION && rows[i + 1].normal == i) {
        ostNum bound = r->mu * lambda[i];
        ostNum t = sqrt(lambda[i + 1] * lambda[i + 1] + lambda[i + 2] * lambda[i + 2]);
        if (t > bound) {
          ostNum scl = t > 0 ? bound / t : 0;
          lambda[i + 1] *= scl;
          lambda[i + 2] *= scl;
        }
      }
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
      ostNum dx = p->key[0] - r->key[0], dy = p->key[1] - r->key[1], dz = p->key[2] - r->key[2];
      ostNum d2 = dx * dx + dy * dy + dz * dz;
      if (d2 < best_d2) {
        best_d2 = d2;
        best = j;
      }
    }
    if (best < 0) {
      continue;
    }
    used[best] = 1;
    lambda[i] = prev_lambda[best];
    // friction rows of a matched contact inherit the previous tangential multipliers
    if (r->type == OST_ROW_CONTACT && i + 2 < nrow && rows[i + 1].type == OST_ROW_FRICTION
        && best + 2 < nprev && prev[best + 1].type == OST_ROW_FRICTION) {
      lambda[i + 1] = prev_lambda[best + 1];
      lambda[i + 2] = prev_lambda[best + 2];
    }
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_CONSTRAINT_H_
