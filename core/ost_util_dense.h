// ost_util_dense.h: small dense linear algebra for one world (mirrors engine_util_blas.c and
// engine_util_solve.c). Matrices are row-major; the Cholesky factor L is lower triangular and
// stored in place of the matrix (upper triangle left untouched).
// Invariant: no allocation; every function writes only its output arguments.
#ifndef OSTRICH_CORE_OST_UTIL_DENSE_H_
#define OSTRICH_CORE_OST_UTIL_DENSE_H_

#include <math.h>

#include "ost_hd.h"

// 1 if a zero factor's term may be skipped: never for dual numbers (core/ost_dual.h), whose
// zero value may still carry derivatives
// OSTU_NONZERO(x): 1 unless x is known to be exactly zero (always 1 for dual numbers)
#ifdef OST_NUM_TYPE
#define OSTU_SKIPPABLE(x) 0
#define OSTU_NONZERO(x) 1
#else
#define OSTU_SKIPPABLE(x) ((x) == 0)
#define OSTU_NONZERO(x) ((x) != 0)
#endif

#ifdef __cplusplus
extern "C" {
#endif

// dot product of two vectors
OST_HD ostNum ostu_dot(const ostNum* a, const ostNum* b, int n) {
  ostNum s = 0;
  for (int i = 0; i < n; i++) {
    s += a[i] * b[i];
  }
  return s;
}


// res = A * x, A is (nr x nc)
OST_HD void ostu_mulMatVec(ostNum* OST_RESTRICT res, const ostNum* A, const ostNum* x,
                           int nr, int nc) {
  for (int i = 0; i < nr; i++) {
    res[i] = ostu_dot(A + i * nc, x, nc);
  }
}


// res = A' * x, A is (nr x nc)
OST_HD void ostu_mulMatTVec(ostNum* OST_RESTRICT res, const ostNum* A, const ostNum* x,
                            int nr, int nc) {
  for (int j = 0; j < nc; j++) {
    res[j] = 0;
  }
  for (int i = 0; i < nr; i++) {
    ostNum xi = x[i];
    if (!OSTU_SKIPPABLE(xi)) {
      const ostNum* a = A + i * nc;
      for (int j = 0; j < nc; j++) {
        res[j] += a[j] * xi;
      }
    }
  }
}


// in-place Cholesky A = L L' of a symmetric (n x n) matrix; returns 0 or 1 + failing column
OST_HD int ostu_cholFactor(ostNum* A, int n) {
  for (int j = 0; j < n; j++) {
    ostNum djj = A[j * n + j];
    for (int k = 0; k < j; k++) {
      djj -= A[j * n + k] * A[j * n + k];
    }
    if (!(djj > 0)) {
      return j + 1;
    }
    ostNum ljj = sqrt(djj);
    A[j * n + j] = ljj;
    // column j below the diagonal, four rows at a time: four independent sums in flight instead
    // of one latency-bound chain (each sum still runs over k in ascending order: the same bits)
    const ostNum* Aj = A + j * n;
    int i = j + 1;
    for (; i + 3 < n; i += 4) {
      ostNum* A0 = A + i * n;
      ostNum* A1 = A0 + n;
      ostNum* A2 = A1 + n;
      ostNum* A3 = A2 + n;
      ostNum s0 = A0[j], s1 = A1[j], s2 = A2[j], s3 = A3[j];
      for (int k = 0; k < j; k++) {
        ostNum a = Aj[k];
        s0 -= A0[k] * a;
        s1 -= A1[k] * a;
        s2 -= A2[k] * a;
        s3 -= A3[k] * a;
      }
      A0[j] = s0 / ljj;
      A1[j] = s1 / ljj;
      A2[j] = s2 / ljj;
      A3[j] = s3 / ljj;
    }
    for (; i < n; i++) {
      ostNum s = A[i * n + j];
      for (int k = 0; k < j; k++) {
        s -= A[i * n + k] * Aj[k];
      }
      A[i * n + j] = s / ljj;
    }
  }
  return 0;
}


// solve L L' x = b with the factor from ostu_cholFactor; x and b may alias
OST_HD void ostu_cholSolve(ostNum* x, const ostNum* L, const ostNum* b, int n) {
  // forward substitution: L y = b
  for (int i = 0; i < n; i++) {
    ostNum s = b[i];
    for (int k = 0; k < i; k++) {
      s -= L[i * n + k] * x[k];
    }
    x[i] = s / L[i * n + i];
  }
  // back substitution: L' x = y
  for (int i = n - 1; i >= 0; i--) {
    ostNum s = x[i];
    for (int k = i + 1; k < n; k++) {
      s -= L[k * n + i] * x[k];
    }
    x[i] = s / L[i * n + i];
  }
}


// squared norm of L^-1 b (= b' (L L')^-1 b); y is scratch of size n
OST_HD ostNum ostu_cholNormSqr(ostNum* OST_RESTRICT y, const ostNum* L, const ostNum* b, int n) {
  ostNum s2 = 0;
  for (int i = 0; i < n; i++) {
    ostNum s = b[i];
    for (int k = 0; k < i; k++) {
      s -= L[i * n + k] * y[k];
    }
    y[i] = s / L[i * n + i];
    s2 += y[i] * y[i];
  }
  return s2;
}


// in-place LU factorization P A = L U of a general (n x n) matrix with partial pivoting
// (L unit lower, U upper, both stored in A); piv[i] is the row swapped with i. Returns 0, or
// 1 + the column whose pivot is zero (mju_factorLU's role; the adjoint's Jacobians are not
// symmetric). The LU functions take double whatever ostNum is: the adjoint's matrices are
// plain numbers even in a dual-number translation unit.
OST_HD int ostu_luFactor(double* A, int* piv, int n) {
  for (int j = 0; j < n; j++) {
    int p = j;
    double best = fabs(A[j * n + j]);
    for (int i = j + 1; i < n; i++) {
      if (fabs(A[i * n + j]) > best) {
        best = fabs(A[i * n + j]);
        p = i;
      }
    }
    piv[j] = p;
    if (!(best > 0)) {
      return j + 1;
    }
    if (p != j) {
      for (int k = 0; k < n; k++) {
        double t = A[j * n + k];
        A[j * n + k] = A[p * n + k];
        A[p * n + k] = t;
      }
    }
    for (int i = j + 1; i < n; i++) {
      double l = A[i * n + j] / A[j * n + j];
      A[i * n + j] = l;
      for (int k = j + 1; k < n; k++) {
        A[i * n + k] -= l * A[j * n + k];
      }
    }
  }
  return 0;
}


// solve A' x = b with the factor of ostu_luFactor (U' L' P x = b); x and b may alias
OST_HD void ostu_luSolveT(double* x, const double* LU, const int* piv, const double* b, int n) {
  for (int i = 0; i < n; i++) {
    x[i] = b[i];
  }
  // U' y = b (forward), then L' z = y (backward), then x = P' z
  for (int i = 0; i < n; i++) {
    double s = x[i];
    for (int k = 0; k < i; k++) {
      s -= LU[k * n + i] * x[k];
    }
    x[i] = s / LU[i * n + i];
  }
  for (int i = n - 1; i >= 0; i--) {
    double s = x[i];
    for (int k = i + 1; k < n; k++) {
      s -= LU[k * n + i] * x[k];
    }
    x[i] = s;
  }
  for (int i = n - 1; i >= 0; i--) {
    if (piv[i] != i) {
      double t = x[i];
      x[i] = x[piv[i]];
      x[piv[i]] = t;
    }
  }
}


// solve A x = b with the factor of ostu_luFactor; x and b may alias
OST_HD void ostu_luSolve(double* x, const double* LU, const int* piv, const double* b, int n) {
  for (int i = 0; i < n; i++) {
    x[i] = b[i];
  }
  for (int i = 0; i < n; i++) {
    if (piv[i] != i) {
      double t = x[i];
      x[i] = x[piv[i]];
      x[piv[i]] = t;
    }
  }
  for (int i = 0; i < n; i++) {
    double s = x[i];
    for (int k = 0; k < i; k++) {
      s -= LU[i * n + k] * x[k];
    }
    x[i] = s;
  }
  for (int i = n - 1; i >= 0; i--) {
    double s = x[i];
    for (int k = i + 1; k < n; k++) {
      s -= LU[i * n + k] * x[k];
    }
    x[i] = s / LU[i * n + i];
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_UTIL_DENSE_H_
