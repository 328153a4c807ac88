// ost_rev.h: reverse-mode numbers (a tape of partial derivatives), to differentiate one scalar of
// core/ by all its inputs in one backward sweep: compile core as C++ with ostNum = ostRev through
// ost_hd.h's OST_NUM_TYPE hook, as ost_dual.h does for forward mode. An ostRev is a value v and
// the index i of its node on the current thread's tape (0: a constant, no node). Each operation
// on a variable appends one node: the indices of at most two operands and the partial
// derivatives by them. ostr_sweep then runs the chain rule backward over the nodes.
// Invariants: values are computed by the same double operations as ost_dual.h's (so they equal
// the double build's bit for bit), and the partial derivatives follow its conventions at
// nondifferentiable points (sqrt and fabs 0 at 0, fmin and fmax the argument returned, floor and
// ceil 0); comparisons and branches see v only; zero bytes are the constant 0. CPU only (one
// tape per thread, set by ostr_tapeBegin).
#ifndef OSTRICH_PLUGIN_OST_REV_H_
#define OSTRICH_PLUGIN_OST_REV_H_

#ifndef __cplusplus
#error "ost_rev.h is C++ only"
#endif

#include <float.h>
#include <math.h>
#include <stddef.h>

#include <type_traits>

#include "../core/ost_math.h"

struct ostRevTape {               // the nodes of one evaluation (structure of arrays)
  int     n;                      // nodes used; node 0 is reserved (constants)
  int     cap;                    // nodes allocated
  int     overflow;               // 1 if a node did not fit (the sweep is then invalid)
  int*    a;                      // first operand's node (0: none)             (cap)
  int*    b;                      // second operand's node (0: none)            (cap)
  double* da;                     // d node / d a                                (cap)
  double* db;                     // d node / d b                                (cap)
};

// the tape the current thread's operations append to (NULL: none; every result is a constant).
// The default TLS model: initial-exec would save a call per operation, but a library loaded by
// dlopen (Python) may then find no static TLS block left, and fail to load.
#define OST_REV_INLINE inline __attribute__((always_inline))
extern thread_local ostRevTape* ostr_tape;

// a node with operands (a, da) and (b, db); 0 when neither operand is a variable
OST_REV_INLINE int ostr_node(int a, double da, int b, double db) {
  ostRevTape* t = ostr_tape;
  if ((a == 0 && b == 0) || !t) {
    return 0;
  }
  if (t->n >= t->cap) {
    t->overflow = 1;
    return 0;
  }
  int i = t->n++;
  t->a[i] = a;
  t->da[i] = da;
  t->b[i] = b;
  t->db[i] = db;
  return i;
}

struct ostRev {
  double v;  // value
  int    i;  // node on the tape (0: a constant)

  ostRev() = default;                                   // uninitialized, as a double
  ostRev(double x) : v(x), i(0) {}                      // a constant
  explicit operator double() const { return v; }        // drops the node

  static OST_REV_INLINE ostRev make(double v, int i) {
    ostRev r;
    r.v = v;
    r.i = i;
    return r;
  }
  // f(x) given f = f(x.v) and df = f'(x.v)
  static OST_REV_INLINE ostRev chain(const ostRev& x, double f, double df) {
    return make(f, ostr_node(x.i, df, 0, 0));
  }

  OST_REV_INLINE ostRev& operator+=(const ostRev& b) { return *this = *this + b; }
  OST_REV_INLINE ostRev& operator-=(const ostRev& b) { return *this = *this - b; }
  OST_REV_INLINE ostRev& operator*=(const ostRev& b) { return *this = *this * b; }
  OST_REV_INLINE ostRev& operator/=(const ostRev& b) { return *this = *this / b; }

  //-------------------------------- arithmetic (hidden friends: found through an ostRev argument)

  friend OST_REV_INLINE ostRev operator-(const ostRev& a) { return chain(a, -a.v, -1); }
  friend OST_REV_INLINE ostRev operator+(const ostRev& a, const ostRev& b) {
    return make(a.v + b.v, b.i == 0 ? a.i : (a.i == 0 ? b.i : ostr_node(a.i, 1, b.i, 1)));
  }
  friend OST_REV_INLINE ostRev operator+(const ostRev& a, double b) { return make(a.v + b, a.i); }
  friend OST_REV_INLINE ostRev operator+(double a, const ostRev& b) { return make(a + b.v, b.i); }
  friend OST_REV_INLINE ostRev operator-(const ostRev& a, const ostRev& b) {
    return make(a.v - b.v, b.i == 0 ? a.i : ostr_node(a.i, 1, b.i, -1));
  }
  friend OST_REV_INLINE ostRev operator-(const ostRev& a, double b) { return make(a.v - b, a.i); }
  friend OST_REV_INLINE ostRev operator-(double a, const ostRev& b) { return chain(b, a - b.v, -1); }
  friend OST_REV_INLINE ostRev operator*(const ostRev& a, const ostRev& b) {
    return make(a.v * b.v, ostr_node(a.i, b.v, b.i, a.v));
  }
  friend OST_REV_INLINE ostRev operator*(const ostRev& a, double b) { return chain(a, a.v * b, b); }
  friend OST_REV_INLINE ostRev operator*(double a, const ostRev& b) { return chain(b, a * b.v, a); }
  friend OST_REV_INLINE ostRev operator/(const ostRev& a, const ostRev& b) {
    double r = a.v / b.v;
    return make(r, ostr_node(a.i, 1 / b.v, b.i, -r / b.v));
  }
  friend OST_REV_INLINE ostRev operator/(const ostRev& a, double b) { return chain(a, a.v / b, 1 / b); }
  friend OST_REV_INLINE ostRev operator/(double a, const ostRev& b) {
    double r = a / b.v;
    return chain(b, r, -r / b.v);
  }

  //-------------------------------- comparisons: values only

#define OST_REV_CMP(op)                                                                \
  friend OST_REV_INLINE bool operator op(const ostRev& a, const ostRev& b) { return a.v op b.v; } \
  friend OST_REV_INLINE bool operator op(const ostRev& a, double b) { return a.v op b; }           \
  friend OST_REV_INLINE bool operator op(double a, const ostRev& b) { return a op b.v; }
  OST_REV_CMP(<)
  OST_REV_CMP(<=)
  OST_REV_CMP(>)
  OST_REV_CMP(>=)
  OST_REV_CMP(==)
  OST_REV_CMP(!=)
#undef OST_REV_CMP

  //-------------------------------- <math.h> and core's own functions (ost_math.h)

  friend OST_REV_INLINE ostRev sqrt(const ostRev& x) {
    double s = ::sqrt(x.v);
    return chain(x, s, s > 0 ? 0.5 / s : 0);
  }
  friend OST_REV_INLINE ostRev fabs(const ostRev& x) {
    return chain(x, ::fabs(x.v), x.v > 0 ? 1 : (x.v < 0 ? -1 : 0));
  }
  friend OST_REV_INLINE ostRev sin(const ostRev& x) { return chain(x, ::sin(x.v), ::cos(x.v)); }
  friend OST_REV_INLINE ostRev cos(const ostRev& x) { return chain(x, ::cos(x.v), -::sin(x.v)); }
  friend OST_REV_INLINE ostRev ostu_sin(const ostRev& x) { return chain(x, ::ostu_sin(x.v), ::ostu_cos(x.v)); }
  friend OST_REV_INLINE ostRev ostu_cos(const ostRev& x) { return chain(x, ::ostu_cos(x.v), -::ostu_sin(x.v)); }
  friend OST_REV_INLINE ostRev exp(const ostRev& x) {
    double e = ::exp(x.v);
    return chain(x, e, e);
  }
  friend OST_REV_INLINE ostRev log(const ostRev& x) { return chain(x, ::log(x.v), 1 / x.v); }
  friend OST_REV_INLINE ostRev acos(const ostRev& x) {
    return chain(x, ::acos(x.v), -1 / ::sqrt(1 - x.v * x.v));
  }
  friend OST_REV_INLINE ostRev asin(const ostRev& x) {
    return chain(x, ::asin(x.v), 1 / ::sqrt(1 - x.v * x.v));
  }
  friend OST_REV_INLINE ostRev pow(const ostRev& x, double p) {
    return chain(x, ::pow(x.v, p), p == 0 ? 0 : p * ::pow(x.v, p - 1));
  }
  friend OST_REV_INLINE ostRev atan2(const ostRev& y, const ostRev& x) {
    double r2 = x.v * x.v + y.v * y.v;
    return make(::atan2(y.v, x.v), ostr_node(y.i, x.v / r2, x.i, -y.v / r2));
  }
  friend OST_REV_INLINE ostRev ostu_atan2(const ostRev& y, const ostRev& x) {
    ostRev r = atan2(y, x);
    r.v = ::ostu_atan2(y.v, x.v);
    return r;
  }
  friend OST_REV_INLINE ostRev fmin(const ostRev& a, const ostRev& b) {
    ostRev r = (b.v < a.v || a.v != a.v) ? b : a;
    r.v = ::fmin(a.v, b.v);
    return r;
  }
  friend OST_REV_INLINE ostRev fmax(const ostRev& a, const ostRev& b) {
    ostRev r = (b.v > a.v || a.v != a.v) ? b : a;
    r.v = ::fmax(a.v, b.v);
    return r;
  }
  friend OST_REV_INLINE ostRev floor(const ostRev& x) { return ostRev(::floor(x.v)); }
  friend OST_REV_INLINE ostRev ceil(const ostRev& x) { return ostRev(::ceil(x.v)); }
  friend OST_REV_INLINE bool isnan(const ostRev& x) { return x.v != x.v; }
  friend OST_REV_INLINE bool isfinite(const ostRev& x) { return ::fabs(x.v) <= DBL_MAX; }
};

static_assert(std::is_trivially_copyable<ostRev>::value &&
              std::is_trivially_default_constructible<ostRev>::value,
              "ostRev must behave as a plain double in memory");


// a new input variable of value v (a node with no operands), or 0 if the tape is full
inline ostRev ostr_input(double v) {
  ostRevTape* t = ostr_tape;
  ostRev r = ostRev::make(v, 0);
  if (!t || t->n >= t->cap) {
    if (t) t->overflow = 1;
    return r;
  }
  r.i = t->n++;
  t->a[r.i] = t->b[r.i] = 0;
  t->da[r.i] = t->db[r.i] = 0;
  return r;
}


// the chain rule backward over the nodes [to, from), last first: adj (tape->n; adj[y] = dL/dy
// seeded, the rest zero) receives dL/dnode for each node (node 0, the constants', is not swept)
inline void ostr_sweep(const ostRevTape* t, double* adj, int from, int to) {
  for (int i = from - 1; i >= to && i > 0; i--) {
    double g = adj[i];
    if (g == 0) {
      continue;
    }
    adj[t->a[i]] += t->da[i] * g;
    adj[t->b[i]] += t->db[i] * g;
  }
}

#endif  // OSTRICH_PLUGIN_OST_REV_H_
