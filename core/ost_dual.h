// ost_dual.h: forward-mode dual numbers, to differentiate core/ by compiling it as C++ with
// ostNum = ostDual<N> through ost_hd.h's OST_NUM_TYPE hook:
//   #include "ost_dual.h"
//   #define OST_NUM_TYPE ostDual<8>
//   #include "ost_kinematics.h"  // any core headers
// An ostDual<N> carries a value v and N directional derivatives d[k] (vector mode: one pass
// gives the derivatives along N seeded directions, see ostx_seed). It mirrors the part of
// double's interface that core/ uses: arithmetic, comparisons and <math.h>'s functions, the
// latter as overloads that core's generic calls (sqrt(x), fabs(x), ...) find by
// argument-dependent lookup. Once ost_model.h is in (it includes this file again), it also gives
// ostModelDouble, the layout twin of the double build's ostModel, and its conversion to the dual
// ostModel, so that a model packed by libostrich (double) can be used in a dual TU.
// Invariants: every value v is computed by the same double operation as in the double build, so
// values equal the double build's bit for bit; comparisons and branches see v only; the type is
// trivially copyable and trivially default-constructible (memset, memcpy and arrays in structs
// work as for double; zero bytes are 0 with zero derivatives). Converting to double drops the
// derivatives: it is explicit and meant for indices and branches only.
// Nondifferentiable points: sqrt and fabs have derivative 0 at 0, fmin and fmax take the
// derivative of the argument they return (the first one on ties), floor and ceil have
// derivative 0.
#ifndef OSTRICH_CORE_OST_DUAL_H_
#define OSTRICH_CORE_OST_DUAL_H_

#ifndef __cplusplus
#error "ost_dual.h is C++ only"
#endif

#include <float.h>
#include <math.h>
#include <stddef.h>

#include <type_traits>

#include "ost_math.h"

#ifdef __CUDACC__
#define OST_DUAL_HD __host__ __device__ inline
#else
#define OST_DUAL_HD inline
#endif

// value v and N directional derivatives d
template <int N>
struct ostDual {
  double v;     // value
  double d[N];  // derivatives along the seeded directions

  ostDual() = default;                                 // uninitialized, as a double
  OST_DUAL_HD ostDual(double x) : v(x), d() {}         // a constant: derivatives zero
  OST_DUAL_HD explicit operator double() const { return v; }  // drops the derivatives

  OST_DUAL_HD ostDual& operator+=(const ostDual& b) {
    v += b.v;
    for (int k = 0; k < N; k++) d[k] += b.d[k];
    return *this;
  }
  OST_DUAL_HD ostDual& operator-=(const ostDual& b) {
    v -= b.v;
    for (int k = 0; k < N; k++) d[k] -= b.d[k];
    return *this;
  }
  OST_DUAL_HD ostDual& operator*=(const ostDual& b) {
    // derivatives first: they read the old v (b may be *this)
    for (int k = 0; k < N; k++) d[k] = d[k] * b.v + v * b.d[k];
    v *= b.v;
    return *this;
  }
  OST_DUAL_HD ostDual& operator/=(const ostDual& b) { return *this = *this / b; }

  // f(x) given f = f(x.v) and df = f'(x.v): the chain rule
  static OST_DUAL_HD ostDual chain(const ostDual& x, double f, double df) {
    ostDual r;
    r.v = f;
    for (int k = 0; k < N; k++) r.d[k] = df * x.d[k];
    return r;
  }

  //-------------------------------- arithmetic (hidden friends: found through a dual argument)

  friend OST_DUAL_HD ostDual operator-(const ostDual& a) { return chain(a, -a.v, -1); }
  friend OST_DUAL_HD ostDual operator+(ostDual a, const ostDual& b) { return a += b; }
  friend OST_DUAL_HD ostDual operator+(const ostDual& a, double b) { return chain(a, a.v + b, 1); }
  friend OST_DUAL_HD ostDual operator+(double a, const ostDual& b) { return chain(b, a + b.v, 1); }
  friend OST_DUAL_HD ostDual operator-(ostDual a, const ostDual& b) { return a -= b; }
  friend OST_DUAL_HD ostDual operator-(const ostDual& a, double b) { return chain(a, a.v - b, 1); }
  friend OST_DUAL_HD ostDual operator-(double a, const ostDual& b) { return chain(b, a - b.v, -1); }
  friend OST_DUAL_HD ostDual operator*(ostDual a, const ostDual& b) { return a *= b; }
  friend OST_DUAL_HD ostDual operator*(const ostDual& a, double b) { return chain(a, a.v * b, b); }
  friend OST_DUAL_HD ostDual operator*(double a, const ostDual& b) { return chain(b, a * b.v, a); }
  friend OST_DUAL_HD ostDual operator/(const ostDual& a, const ostDual& b) {
    // (a/b)' = (a' - (a/b) b') / b
    ostDual r;
    r.v = a.v / b.v;
    for (int k = 0; k < N; k++) r.d[k] = (a.d[k] - r.v * b.d[k]) / b.v;
    return r;
  }
  friend OST_DUAL_HD ostDual operator/(const ostDual& a, double b) {
    return chain(a, a.v / b, 1 / b);
  }
  friend OST_DUAL_HD ostDual operator/(double a, const ostDual& b) {
    double r = a / b.v;
    return chain(b, r, -r / b.v);
  }

  //-------------------------------- comparisons: values only

#define OST_DUAL_CMP(op)                                                                         \
  friend OST_DUAL_HD bool operator op(const ostDual& a, const ostDual& b) { return a.v op b.v; } \
  friend OST_DUAL_HD bool operator op(const ostDual& a, double b) { return a.v op b; }           \
  friend OST_DUAL_HD bool operator op(double a, const ostDual& b) { return a op b.v; }
  OST_DUAL_CMP(<)
  OST_DUAL_CMP(<=)
  OST_DUAL_CMP(>)
  OST_DUAL_CMP(>=)
  OST_DUAL_CMP(==)
  OST_DUAL_CMP(!=)
#undef OST_DUAL_CMP

  //-------------------------------- <math.h>: mixed arguments convert to ostDual

  friend OST_DUAL_HD ostDual sqrt(const ostDual& x) {
    double s = ::sqrt(x.v);
    return chain(x, s, s > 0 ? 0.5 / s : 0);  // derivative 0 at 0 (convention)
  }
  friend OST_DUAL_HD ostDual fabs(const ostDual& x) {
    return chain(x, ::fabs(x.v), x.v > 0 ? 1 : (x.v < 0 ? -1 : 0));  // 0 at 0 (convention)
  }
  friend OST_DUAL_HD ostDual sin(const ostDual& x) { return chain(x, ::sin(x.v), ::cos(x.v)); }
  // core's own sin, cos and atan2 (ost_math.h): values from the same double functions
  friend OST_DUAL_HD ostDual ostu_sin(const ostDual& x) {
    return chain(x, ::ostu_sin(x.v), ::ostu_cos(x.v));
  }
  friend OST_DUAL_HD ostDual ostu_cos(const ostDual& x) {
    return chain(x, ::ostu_cos(x.v), -::ostu_sin(x.v));
  }
  friend OST_DUAL_HD ostDual cos(const ostDual& x) { return chain(x, ::cos(x.v), -::sin(x.v)); }
  friend OST_DUAL_HD ostDual exp(const ostDual& x) {
    double e = ::exp(x.v);
    return chain(x, e, e);
  }
  friend OST_DUAL_HD ostDual log(const ostDual& x) { return chain(x, ::log(x.v), 1 / x.v); }
  friend OST_DUAL_HD ostDual acos(const ostDual& x) {
    return chain(x, ::acos(x.v), -1 / ::sqrt(1 - x.v * x.v));
  }
  friend OST_DUAL_HD ostDual asin(const ostDual& x) {
    return chain(x, ::asin(x.v), 1 / ::sqrt(1 - x.v * x.v));
  }
  friend OST_DUAL_HD ostDual pow(const ostDual& x, double p) {
    return chain(x, ::pow(x.v, p), p == 0 ? 0 : p * ::pow(x.v, p - 1));
  }
  friend OST_DUAL_HD ostDual atan2(const ostDual& y, const ostDual& x) {
    // d atan2(y, x) = (x dy - y dx) / (x^2 + y^2)
    ostDual r;
    double r2 = x.v * x.v + y.v * y.v;
    r.v = ::atan2(y.v, x.v);
    for (int k = 0; k < N; k++) r.d[k] = (x.v * y.d[k] - y.v * x.d[k]) / r2;
    return r;
  }
  friend OST_DUAL_HD ostDual ostu_atan2(const ostDual& y, const ostDual& x) {
    ostDual r = atan2(y, x);
    r.v = ::ostu_atan2(y.v, x.v);
    return r;
  }
  friend OST_DUAL_HD ostDual fmin(const ostDual& a, const ostDual& b) {
    // the derivatives of the argument returned (NaN loses, as in fmin), the value from fmin
    ostDual r = (b.v < a.v || a.v != a.v) ? b : a;
    r.v = ::fmin(a.v, b.v);
    return r;
  }
  friend OST_DUAL_HD ostDual fmax(const ostDual& a, const ostDual& b) {
    ostDual r = (b.v > a.v || a.v != a.v) ? b : a;
    r.v = ::fmax(a.v, b.v);
    return r;
  }
  friend OST_DUAL_HD ostDual floor(const ostDual& x) { return ostDual(::floor(x.v)); }
  friend OST_DUAL_HD ostDual ceil(const ostDual& x) { return ostDual(::ceil(x.v)); }
  friend OST_DUAL_HD bool isnan(const ostDual& x) { return x.v != x.v; }
  friend OST_DUAL_HD bool isfinite(const ostDual& x) { return ::fabs(x.v) <= DBL_MAX; }
};

static_assert(std::is_trivially_copyable<ostDual<1>>::value &&
              std::is_trivially_default_constructible<ostDual<1>>::value,
              "ostDual must behave as a plain double in memory");
static_assert(sizeof(ostDual<8>) == 9 * sizeof(double), "ostDual must be unpadded");


// the variable v seeded along direction k (derivative 1 there, 0 along the others)
template <int N>
OST_DUAL_HD ostDual<N> ostx_seed(double v, int k) {
  ostDual<N> x(v);
  x.d[k] = 1;
  return x;
}


// value and derivative along direction k
template <int N>
OST_DUAL_HD double ostx_val(const ostDual<N>& x) { return x.v; }
template <int N>
OST_DUAL_HD double ostx_der(const ostDual<N>& x, int k) { return x.d[k]; }


// core/ost_constraint.h's ostRow as the double build lays it out (rows exchanged with C code)
struct ostRowDouble {
  int    type;
  int    obj[2];
  int    normal;
  double key[3];
  double pos;
  double mu;
  double alpha;
  double lo;
  double hi;
};
static_assert(sizeof(ostRowDouble) == 4 * sizeof(int) + 8 * sizeof(double),
              "ostRowDouble must be unpadded, as the double ostRow");

#endif  // OSTRICH_CORE_OST_DUAL_H_


// the double model's layout twin; needs ost_model.h (which includes this file again at its end)
#if defined(OSTRICH_CORE_OST_MODEL_H_) && !defined(OSTRICH_CORE_OST_DUAL_MODEL_)
#define OSTRICH_CORE_OST_DUAL_MODEL_

// OST_MODEL_ARRAYS's element types with ostNum read as double (pasted: ostx_dbl_##type)
typedef int ostx_dbl_int;
typedef double ostx_dbl_ostNum;

struct ostModelDouble {           // ostModel as the double build (libostrich) lays it out
  ostSizes s;
  double   gravity[3];
  double   mpr_tolerance;
  int      mpr_iterations;
  int      disableflags;
#define X(type, name, r, c) ostx_dbl_##type* name;
  OST_MODEL_ARRAYS(X)
#undef X
};

#define X(type, name, r, c) +1
enum { OSTX_MODEL_NARRAYS = 0 OST_MODEL_ARRAYS(X) };
#undef X
static_assert(sizeof(ostModelDouble) == sizeof(ostSizes) + 4 * sizeof(double) + 2 * sizeof(int)
                                        + OSTX_MODEL_NARRAYS * sizeof(void*),
              "ostModelDouble must be unpadded, as the double ostModel");


// n elements of src into dst, converted (double to a dual: derivatives zero)
template <typename T, typename U>
inline void ostx_copyArray(T* dst, const U* src, size_t n) {
  for (size_t i = 0; i < n; i++) {
    dst[i] = T(src[i]);
  }
}


// bytes of the block of the dual model of sizes s (ostu_modelSize with this TU's ostNum). Static,
// as everything here that names ostModel: translation units with different ostDual<N> (the CPU's
// and the GPU's) must not share one definition at link time.
static inline size_t ostx_dualModelSize(ostSizes s) {
  return ostu_modelSize(s);
}


// the dual model dst of the double model src, its arrays in block (ostx_dualModelSize(src->s)
// bytes, 64-byte aligned): every value copied, every derivative zero
static inline void ostx_dualModel(ostModel* dst, void* block, const ostModelDouble* src) {
  ostSizes s = src->s;
  dst->s = s;
  for (int i = 0; i < 3; i++) {
    dst->gravity[i] = src->gravity[i];
  }
  dst->mpr_tolerance = src->mpr_tolerance;
  dst->mpr_iterations = src->mpr_iterations;
  dst->disableflags = src->disableflags;
  ostu_modelInit(dst, block);
#define X(type, name, r, c) ostx_copyArray(dst->name, src->name, (size_t)(r) * (c));
  OST_MODEL_ARRAYS(X)
#undef X
}

#endif  // OSTRICH_CORE_OST_DUAL_MODEL_
