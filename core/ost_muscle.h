// ost_muscle.h: MuJoCo's muscle model (core/README.md section 1, eq. 8c). Mirrors
// engine_util_misc.c's mju_muscleGain, mju_muscleBias and mju_muscleDynamics (MuJoCo 2.2.2),
// and replaces MuJoCo's explicit Euler update of a muscle's activation by the exact solution of
// its backward-Euler equation.
//   gain  = -F FL(L) FV(V)  (the active force per unit activation; a muscle pulls)
//   bias  = -F FP(L)        (the passive force)
//   force = gain act+ + bias, at the step's start (q-, u-): an explicit force (section 1)
// with L and V the normalized length and velocity, F = force, or scale / acc0 when force < 0
// (2.2.2 evaluates it at run time from actuator_acc0; its compiler keeps gainprm as written).
// prm = (range[2], force, scale, lmin, lmax, vmax, fpmax, fvmax): gainprm and biasprm[0..8].
// Invariant: pure functions of their arguments, written once for any scalar type (ostNum may be
// a dual number: the branches compare values, the derivative is that of the branch taken).
#ifndef OSTRICH_CORE_OST_MUSCLE_H_
#define OSTRICH_CORE_OST_MUSCLE_H_

#include <math.h>

#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

// MuJoCo's mjMINVAL: the smallest denominator of the muscle curves
#define OST_MUSCLE_MINVAL 1e-15

typedef enum osttGain_ {          // actuator gain, numbered as mjtGain
  OST_GAIN_FIXED = 0,             // gainprm[0]
  OST_GAIN_AFFINE,                // (refused: plugin/ost_check.c)
  OST_GAIN_MUSCLE,                // osti_muscleGain
  OST_GAIN_USER                   // mjcb_act_gain (refused)
} osttGain;

typedef enum osttBias_ {          // actuator bias, numbered as mjtBias
  OST_BIAS_NONE = 0,              // zero
  OST_BIAS_AFFINE,                // b0 + b1 L + b2 V
  OST_BIAS_MUSCLE,                // osti_muscleBias
  OST_BIAS_USER                   // mjcb_act_bias (refused)
} osttBias;


// max(OST_MUSCLE_MINVAL, x): MuJoCo's guarded denominator
OST_HD ostNum osti_muscleDen(ostNum x) {
  return x < OST_MUSCLE_MINVAL ? (ostNum)OST_MUSCLE_MINVAL : x;
}


// the peak isometric force F: prm[2], or prm[3] / acc0 when prm[2] < 0
OST_HD ostNum osti_muscleForce(ostNum acc0, const ostNum* prm) {
  return prm[2] < 0 ? prm[3] / osti_muscleDen(acc0) : prm[2];
}


// the normalized length L = range[0] + (len - lengthrange[0]) / L0, with the optimal length
// L0 = (lengthrange[1] - lengthrange[0]) / (range[1] - range[0]); L0 into *L0 when not NULL
OST_HD ostNum osti_muscleLength(ostNum len, const ostNum* lengthrange, const ostNum* prm,
                                ostNum* L0out) {
  ostNum L0 = (lengthrange[1] - lengthrange[0]) / osti_muscleDen(prm[1] - prm[0]);
  if (L0out) {
    *L0out = L0;
  }
  return prm[0] + (len - lengthrange[0]) / osti_muscleDen(L0);
}


// the active force per unit activation (mju_muscleGain): -F FL(L) FV(V), with FL two pairs of
// half-parabolas (zero below lmin and above lmax, 1 at L = 1) and FV a parabola from 0 at
// V = -1 (shortening at vmax) to fvmax at V = fvmax - 1 (lengthening), V = vel / (L0 vmax)
OST_HD ostNum osti_muscleGain(ostNum len, ostNum vel, const ostNum* lengthrange, ostNum acc0,
                              const ostNum* prm) {
  ostNum lmin = prm[4], lmax = prm[5], vmax = prm[6], fvmax = prm[8];
  ostNum L0;
  ostNum L = osti_muscleLength(len, lengthrange, prm, &L0);
  ostNum V = vel / osti_muscleDen(L0 * vmax);

  // length curve: mid-ranges a, b split each side into two half-parabolas. As in 2.2.2, only
  // the first test checks lmin: below lmin FL continues the parabola of (a, 1] (negative)
  ostNum a = 0.5 * (lmin + 1), b = 0.5 * (1 + lmax);
  ostNum FL = 0 * L;
  if (L >= lmin && L <= a) {
    ostNum x = (L - lmin) / osti_muscleDen(a - lmin);
    FL = 0.5 * x * x;
  } else if (L <= 1) {
    ostNum x = (1 - L) / osti_muscleDen(1 - a);
    FL = 1 - 0.5 * x * x;
  } else if (L <= b) {
    ostNum x = (L - 1) / osti_muscleDen(b - 1);
    FL = 1 - 0.5 * x * x;
  } else if (L <= lmax) {
    ostNum x = (lmax - L) / osti_muscleDen(lmax - b);
    FL = 0.5 * x * x;
  }

  // velocity curve
  ostNum y = fvmax - 1;
  ostNum FV = fvmax + 0 * V;
  if (V <= -1) {
    FV = 0;
  } else if (V <= 0) {
    FV = (V + 1) * (V + 1);
  } else if (V <= y) {
    FV = fvmax - (y - V) * (y - V) / osti_muscleDen(y);
  }
  return -osti_muscleForce(acc0, prm) * FL * FV;
}


// the passive force (mju_muscleBias): -F fpmax FP(L), FP zero up to L = 1, a half-parabola to
// b = (1 + lmax) / 2 where it reaches 1/2, linear beyond
OST_HD ostNum osti_muscleBias(ostNum len, const ostNum* lengthrange, ostNum acc0,
                              const ostNum* prm) {
  ostNum lmax = prm[5], fpmax = prm[7];
  ostNum L = osti_muscleLength(len, lengthrange, prm, (ostNum*)0);
  ostNum b = 0.5 * (1 + lmax);
  ostNum F = osti_muscleForce(acc0, prm);
  if (L <= 1) {
    return 0 * F;
  }
  if (L <= b) {
    ostNum x = (L - 1) / osti_muscleDen(b - 1);
    return -F * fpmax * 0.5 * x * x;
  }
  ostNum x = (L - b) / osti_muscleDen(b - 1);
  return -F * fpmax * (0.5 + x);
}


// the larger root of A a^2 + B a + C = 0 with A >= 0, C <= 0 (so the roots have opposite signs
// or A = 0), in the form without cancellation: 2 (-C) / (B + s) when B >= 0, else (s - B) / 2A
OST_HD ostNum osti_muscleRoot(ostNum A, ostNum B, ostNum C) {
  ostNum s = sqrt(B * B - 4 * A * C);
  if (B >= 0) {
    return -2 * C / osti_muscleDen(B + s);
  }
  return (s - B) / (2 * A);
}


// act+ of a muscle after a backward-Euler step of size h (eq. 8c): the solution of
//   act+ = act- + h (c - act+) / tau(c, act+),  c = ctrl clamped to [0, 1],
//   tau = tau_act (0.5 + 1.5 a) when c > act+ (activation), tau_deact / (0.5 + 1.5 a) otherwise,
//   a = act+ clamped to [0, 1],
// i.e. act+ = act- + h mju_muscleDynamics(ctrl, act+, dynprm). act+ lies between act- and c, so
// c > act+ exactly when c > act-: the branch is known before solving. On a in [0, 1] the equation
// times tau is a quadratic in act+ (solved exactly, no iteration); on the clamped pieces
// (act- outside [0, 1]) tau is constant and the equation linear. Stable for any h / tau: act+
// moves monotonically from act- towards c and never passes it. dynprm = (tau_act, tau_deact),
// each at least OST_MUSCLE_MINVAL (MuJoCo guards tau itself: equal unless tau < 2e-15 s).
OST_HD ostNum osti_muscleActNext(const ostNum* dynprm, ostNum act, ostNum ctrl, ostNum h) {
  ostNum c = ctrl < 0 ? 0 * ctrl : (ctrl > 1 ? 0 * ctrl + 1 : ctrl);
  ostNum ta = osti_muscleDen(dynprm[0]), td = osti_muscleDen(dynprm[1]);
  if (c > act) {
    // activation; below a = 0 tau = tau_act / 2
    if (act < 0) {
      ostNum t = 0.5 * ta;
      ostNum a = (t * act + h * c) / (t + h);
      if (a <= 0) {
        return a;
      }
    }
    // (a - act-) tau_act (0.5 + 1.5 a) = h (c - a)
    return osti_muscleRoot(1.5 * ta, ta * (0.5 - 1.5 * act) + h, -(0.5 * ta * act + h * c));
  }
  if (c < act) {
    // deactivation; above a = 1 tau = tau_deact / 2
    if (act > 1) {
      ostNum t = 0.5 * td;
      ostNum a = (t * act + h * c) / (t + h);
      if (a >= 1) {
        return a;
      }
    }
    // (a - act-) tau_deact = h (c - a) (0.5 + 1.5 a)
    return osti_muscleRoot(1.5 * h, td + h * (0.5 - 1.5 * c), -(td * act + 0.5 * h * c));
  }
  return act;  // c = act-: act_dot = 0
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_MUSCLE_H_
