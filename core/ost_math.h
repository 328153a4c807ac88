// ost_math.h: sin, cos and atan2 written out in core, so that the CPU (glibc) and the GPU (CUDA's
// libdevice) compute the same bits: the two libraries round transcendental functions
// differently (by an ulp), and a batch rollout turns one ulp into visible differences within a
// few contact events. Everything here uses only +, -, *, / and sqrt, which both round exactly
// (IEEE 754, no fused multiply-add: cuda/ is compiled with -fmad=false, x86-64 gcc has none by
// default). Accuracy against glibc: sin and cos within 2 ulp for |x| <= 1e5, atan2 within 4 ulp
// (tests/test_ost_math.c).
//   ostu_sin, ostu_cos  Cody-Waite reduction by pi/2 (three-part constant) to |r| <= pi/4, then
//                       the Taylor series to x^19 / x^18 (remainder below 1e-19)
//   ostu_atan2          octant reduction to 0 <= t <= 1, then atan t = pi/4 + atan((t-1)/(t+1))
//                       above tan(pi/8), and the Taylor series to t^45
// Invariant: pure functions of doubles; the same expression order on host and device.
#ifndef OSTRICH_CORE_OST_MATH_H_
#define OSTRICH_CORE_OST_MATH_H_

#include <math.h>

// ost_hd.h's OST_HD, repeated: ost_dual.h includes this file before a dual TU has defined
// OST_NUM_TYPE, which ost_hd.h would then fix as double
#ifdef __CUDACC__
#define OST_MATH_HD __host__ __device__ static inline
#else
#define OST_MATH_HD static inline
#endif

#ifdef __cplusplus
extern "C" {
#endif

#define OST_PI 3.14159265358979323846

// sin(r) and cos(r) for |r| <= pi/4 by their Taylor series (Horner in r^2)
OST_MATH_HD double ostu_sinKernel(double r) {
  double z = r * r;
  if (z == 0) {
    return r;  // keeps the sign of zero
  }
  double p = 1.0 / 121645100408832000.0;        // 1/19!
  p = 1.0 / 355687428096000.0 - z * p;          // 1/17!
  p = 1.0 / 1307674368000.0 - z * p;            // 1/15!
  p = 1.0 / 6227020800.0 - z * p;               // 1/13!
  p = 1.0 / 39916800.0 - z * p;                 // 1/11!
  p = 1.0 / 362880.0 - z * p;                   // 1/9!
  p = 1.0 / 5040.0 - z * p;                     // 1/7!
  p = 1.0 / 120.0 - z * p;                      // 1/5!
  p = 1.0 / 6.0 - z * p;                        // 1/3!
  return r - r * z * p;
}

OST_MATH_HD double ostu_cosKernel(double r) {
  double z = r * r;
  double p = 1.0 / 6402373705728000.0;          // 1/18!
  p = 1.0 / 20922789888000.0 - z * p;           // 1/16!
  p = 1.0 / 87178291200.0 - z * p;              // 1/14!
  p = 1.0 / 479001600.0 - z * p;                // 1/12!
  p = 1.0 / 3628800.0 - z * p;                  // 1/10!
  p = 1.0 / 40320.0 - z * p;                    // 1/8!
  p = 1.0 / 720.0 - z * p;                      // 1/6!
  p = 1.0 / 24.0 - z * p;                       // 1/4!
  p = 0.5 - z * p;                              // 1/2!
  return 1 - z * p;
}


// x = k pi/2 + r with |r| <= pi/4 (about): returns r, *k gets k mod 4. pi/2 in three parts of
// 33 significant bits each, so that k * part is exact for |k| < 2^20
OST_MATH_HD double ostu_reduceHalfPi(double x, int* k) {
  const double p1 = 1.57079632673412561417e+00;  // first 33 bits of pi/2
  const double p2 = 6.07710050630396597660e-11;  // next 33 bits
  const double p3 = 2.02226624879595063154e-21;  // the rest
  double n = floor(x * (2 / OST_PI) + 0.5);
  *k = (int)(n - 4 * floor(n * 0.25));
  return ((x - n * p1) - n * p2) - n * p3;
}


// sin x
OST_MATH_HD double ostu_sin(double x) {
  if (!(fabs(x) < 1e9)) {
    return isfinite(x) ? sin(x) : x - x;  // out of the exact reduction's range (not in physics)
  }
  int k;
  double r = ostu_reduceHalfPi(x, &k);
  switch (k) {
  case 0: return ostu_sinKernel(r);
  case 1: return ostu_cosKernel(r);
  case 2: return -ostu_sinKernel(r);
  default: return -ostu_cosKernel(r);
  }
}


// cos x
OST_MATH_HD double ostu_cos(double x) {
  if (!(fabs(x) < 1e9)) {
    return isfinite(x) ? cos(x) : x - x;
  }
  int k;
  double r = ostu_reduceHalfPi(x, &k);
  switch (k) {
  case 0: return ostu_cosKernel(r);
  case 1: return -ostu_sinKernel(r);
  case 2: return -ostu_cosKernel(r);
  default: return ostu_sinKernel(r);
  }
}


// atan t for 0 <= t <= 1: above tan(pi/8), atan t = pi/4 + atan((t - 1) / (t + 1)), which
// leaves |t| <= tan(pi/8) = 0.4142; then the Taylor series to t^45 (remainder below 2e-19)
OST_MATH_HD double ostu_atanUnit(double t) {
  double base = 0;
  if (t > 0.41421356237309503) {
    base = OST_PI / 4;
    t = (t - 1) / (t + 1);
  }
  double z = t * t, p = 1.0 / 45;
  for (int n = 43; n >= 1; n -= 2) {
    p = 1.0 / n - z * p;
  }
  return base + t * p;
}


// atan2(y, x) in (-pi, pi], with atan2's signs and its values at zeros
OST_MATH_HD double ostu_atan2(double y, double x) {
  if (isnan(x) || isnan(y)) {
    return x + y;
  }
  if (isinf(x) || isinf(y)) {
    return atan2(y, x);  // the limits, exact in every library
  }
  double ax = fabs(x), ay = fabs(y), a;
  if (ax == 0 && ay == 0) {
    a = signbit(x) ? OST_PI : 0;
  } else if (ay <= ax) {
    a = ostu_atanUnit(ay / ax);
    if (signbit(x)) a = OST_PI - a;
  } else {
    a = OST_PI / 2 - ostu_atanUnit(ax / ay);
    if (signbit(x)) a = OST_PI - a;
  }
  return signbit(y) ? -a : a;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_MATH_H_
