// ost_util_tree.h: the mass matrix of a kinematic tree, factored without fill (mirrors
// engine_core_smooth.c's mj_factorM / mj_solveM, on Ostrich's row-major nv x nv storage).
// M_ij is non-zero only where dof j is dof i or one of its ancestors (parent[] chain), and
// parents come before children. Factoring from the leaves up, M = L' D L with L unit lower
// triangular keeps exactly that pattern (Featherstone, Rigid Body Dynamics Algorithms, sec. 6.5:
// "LTDL" factorization), so factor and solves cost sum(depth^2) and sum(depth) instead of
// n^3/3 and n^2. L's strictly lower entries and D (on the diagonal) replace the lower triangle of
// M in place; the upper triangle is left untouched.
// Invariant: no allocation; every function writes only its output arguments.
#ifndef OSTRICH_CORE_OST_UTIL_TREE_H_
#define OSTRICH_CORE_OST_UTIL_TREE_H_

#include "ost_hd.h"
#include "ost_util_dense.h"  // OSTU_SKIPPABLE

#ifdef __cplusplus
extern "C" {
#endif

// in-place M = L' D L of an (n x n) symmetric tree-sparse matrix (parent[k] < k, -1 for roots);
// returns 0, or 1 + the dof whose pivot is not positive (M not positive definite)
OST_HD int ostu_treeFactor(ostNum* M, const int* parent, int n) {
  for (int k = n - 1; k >= 0; k--) {
    ostNum dkk = M[(size_t)k * n + k];
    if (!(dkk > 0)) {
      return k + 1;
    }
    // eliminate dof k from each ancestor i: row i (over i's own ancestors, i included) loses
    // L_ki M_kj, then M_ki becomes L_ki = M_ki / D_k
    for (int i = parent[k]; i >= 0; i = parent[i]) {
      ostNum lki = M[(size_t)k * n + i] / dkk;
      for (int j = i; j >= 0; j = parent[j]) {
        M[(size_t)i * n + j] -= lki * M[(size_t)k * n + j];
      }
      M[(size_t)k * n + i] = lki;
    }
  }
  return 0;
}


// y = L^-T b in place (x holds b on entry): the leaves' values flow to their ancestors
OST_HD void ostu_treeSolveLT(ostNum* x, const ostNum* L, const int* parent, int n) {
  for (int i = n - 1; i >= 0; i--) {
    ostNum xi = x[i];
    if (OSTU_SKIPPABLE(xi)) {
      continue;  // a row Jacobian is zero off its bodies' chains
    }
    for (int j = parent[i]; j >= 0; j = parent[j]) {
      x[j] -= L[(size_t)i * n + j] * xi;
    }
  }
}


// x = M^-1 x in place on the dofs [r0, r1) of whole trees (no dof in it has an ancestor
// outside it, and x is not read elsewhere) with the factor of ostu_treeFactor; n is L's size.
// Trees are independent, so the solve of a set of trees is that of the whole matrix there.
OST_HD void ostu_treeSolveRange(ostNum* x, const ostNum* L, const int* parent, int n, int r0,
                                int r1) {
  for (int i = r1 - 1; i >= r0; i--) {  // y = L^-T x: the leaves' values flow to ancestors
    ostNum xi = x[i];
    if (OSTU_SKIPPABLE(xi)) {
      continue;
    }
    for (int j = parent[i]; j >= 0; j = parent[j]) {
      x[j] -= L[(size_t)i * n + j] * xi;
    }
  }
  for (int i = r0; i < r1; i++) {  // z = D^-1 y
    x[i] /= L[(size_t)i * n + i];
  }
  for (int i = r0; i < r1; i++) {  // L x = z: each dof after its ancestors
    ostNum s = x[i];
    for (int j = parent[i]; j >= 0; j = parent[j]) {
      s -= L[(size_t)i * n + j] * x[j];
    }
    x[i] = s;
  }
}


// solve M x = b with the factor of ostu_treeFactor; x and b may alias
OST_HD void ostu_treeSolve(ostNum* x, const ostNum* L, const int* parent, const ostNum* b,
                           int n) {
  if (x != b) {
    for (int i = 0; i < n; i++) {
      x[i] = b[i];
    }
  }
  ostu_treeSolveRange(x, L, parent, n, 0, n);
}


// b' M^-1 b = y' D^-1 y with y = L^-T b; y is scratch of size n
OST_HD ostNum ostu_treeNormSqr(ostNum* OST_RESTRICT y, const ostNum* L, const int* parent,
                               const ostNum* b, int n) {
  for (int i = 0; i < n; i++) {
    y[i] = b[i];
  }
  ostu_treeSolveLT(y, L, parent, n);
  ostNum s2 = 0;
  for (int i = 0; i < n; i++) {
    s2 += y[i] * y[i] / L[(size_t)i * n + i];
  }
  return s2;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_UTIL_TREE_H_
