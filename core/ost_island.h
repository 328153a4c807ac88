// ost_island.h: constraint islands of a Newton iterate (core/README.md section 1, "Islands";
// MuJoCo 3's engine_island.c has the same notion). Two degrees of freedom are in one island when
// they are in one kinematic tree or a row (contact, limit, equality, servo) couples them. The
// Newton system is block diagonal over islands, so each island gets its own Schur solve, its own
// line search step, its own best iterate and its own convergence: an island that reached tol is
// held fixed while the others iterate, and a step is converged when every island is. Islands are
// recomputed at every iterate (contacts come and go); the state an island keeps across iterates
// (its best merit) is kept per dof, so islands that merge or split carry it over.
// Invariant: writes only the world's island arrays; a world without a tree factor or without
// row patterns has no islands (nisland = 0: one system, as before islands).
#ifndef OSTRICH_CORE_OST_ISLAND_H_
#define OSTRICH_CORE_OST_ISLAND_H_

#include <math.h>

#include "ost_hd.h"
#include "ost_solver.h"

#ifdef __cplusplus
extern "C" {
#endif

// per-island scalars in w->isl_num (6 per island)
#define OST_ISL_MERIT(w, I) ((w)->isl_num[6 * (I)])      // merit of the last evaluation (m/s)
#define OST_ISL_BASE(w, I) ((w)->isl_num[6 * (I) + 1])   // merit at the line search's base
#define OST_ISL_ALPHA(w, I) ((w)->isl_num[6 * (I) + 2])  // step of the current trial
#define OST_ISL_LOW(w, I) ((w)->isl_num[6 * (I) + 3])    // lowest trial merit
#define OST_ISL_ALOW(w, I) ((w)->isl_num[6 * (I) + 4])   // its step
#define OST_ISL_ALAST(w, I) ((w)->isl_num[6 * (I) + 5])  // step of the island's last trial


// representative of dof j's component (path halving)
OST_HD int osti_ufFind(int* uf, int j) {
  while (uf[j] != j) {
    uf[j] = uf[uf[j]];
    j = uf[j];
  }
  return j;
}


// the island of row i under dof labels lab: that of its first pattern dof (a row with no dof
// joins island 0)
OST_HD int osti_rowIsland(const ostWorld* w, const int* lab, int i) {
  return w->Jnnz[i] > 0 ? lab[w->Jind[(size_t)i * w->ncol]] : 0;
}


// islands of the current rows: dof_island, row_island, and the rows and trees of each island
// (isl_row / isl_row_adr, isl_tree / isl_tree_adr), islands numbered by their smallest dof
OST_HD void osti_islands(ostWorld* w) {
  int nv = w->nv;
  const int* parent = w->dof_parent;
  if (!parent || !w->Jnnz || !w->dof_island || nv == 0) {
    w->nisland = 0;
    return;
  }
  // trees: each dof starts at its root; a root's tree ends where the next root starts
  int* uf = w->uf;
  for (int j = 0; j < nv; j++) {
    uf[j] = parent[j] < 0 ? j : uf[parent[j]];
  }
  for (int j = nv - 1, end = nv; j >= 0; j--) {
    if (parent[j] < 0) {
      w->tree_end[j] = end;
      end = j;
    }
  }
  // rows join the trees of their pattern; a component's representative is its smallest root
  for (int i = 0; i < w->nrow; i++) {
    const int* ind = w->Jind + (size_t)i * w->ncol;
    if (w->Jnnz[i] == 0) {
      continue;
    }
    int a = osti_ufFind(uf, ind[0]);
    for (int k = 1; k < w->Jnnz[i]; k++) {
      int b = osti_ufFind(uf, ind[k]);
      if (a != b) {
        int lo = a < b ? a : b, hi = a < b ? b : a;
        uf[hi] = lo;
        a = lo;
      }
    }
  }
  // labels in order of the representatives (each is labelled before the dofs it represents)
  int n = 0;
  for (int j = 0; j < nv; j++) {
    int r = osti_ufFind(uf, j);
    w->dof_island[j] = r == j ? n++ : w->dof_island[r];
  }
  w->nisland = n;
  // rows and trees grouped by island, ascending within each (counting sort)
  for (int I = 0; I <= n; I++) {
    w->isl_row_adr[I] = 0;
    w->isl_tree_adr[I] = 0;
  }
  for (int i = 0; i < w->nrow; i++) {
    w->row_island[i] = osti_rowIsland(w, w->dof_island, i);
    w->isl_row_adr[w->row_island[i] + 1]++;
  }
  for (int j = 0; j < nv; j++) {
    if (parent[j] < 0) {
      w->isl_tree_adr[w->dof_island[j] + 1]++;
    }
  }
  for (int I = 0; I < n; I++) {
    w->isl_row_adr[I + 1] += w->isl_row_adr[I];
    w->isl_tree_adr[I + 1] += w->isl_tree_adr[I];
  }
  int* fill = w->uf;  // the union-find is done: reuse it as fill counters
  for (int I = 0; I < n; I++) {
    fill[I] = w->isl_row_adr[I];
  }
  for (int i = 0; i < w->nrow; i++) {
    w->isl_row[fill[w->row_island[i]]++] = i;
  }
  for (int I = 0; I < n; I++) {
    fill[I] = w->isl_tree_adr[I];
  }
  for (int j = 0; j < nv; j++) {
    if (parent[j] < 0) {
      w->isl_tree[fill[w->dof_island[j]]++] = j;
    }
  }
}


// each island's merit (m/s) under dof labels lab (nisl islands) into OST_ISL_MERIT: its dofs'
// dynamics residuals and its rows' terms, summed in osti_evaluate's order
OST_HD void osti_islandMerits(ostWorld* w, const int* lab, int nisl) {
  for (int I = 0; I < nisl; I++) {
    OST_ISL_MERIT(w, I) = 0;
  }
  for (int j = 0; j < w->nv; j++) {
    OST_ISL_MERIT(w, lab[j]) += w->Minv_rdyn[j] * w->Minv_rdyn[j];
  }
  for (int i = 0; i < w->nrow; i++) {
    int I = osti_rowIsland(w, lab, i);
    OST_ISL_MERIT(w, I) += w->merit_row[2 * i];
    OST_ISL_MERIT(w, I) += w->merit_row[2 * i + 1];
  }
  for (int I = 0; I < nisl; I++) {
    OST_ISL_MERIT(w, I) = sqrt(OST_ISL_MERIT(w, I));
  }
}


// start of a Newton loop: no island has a best iterate yet
OST_HD void osti_islandsStart(ostWorld* w) {
  for (int j = 0; j < w->nv; j++) {
    w->best_dof[j] = HUGE_VAL;
    w->bestk_dof[j] = -1;
  }
  w->nrow_best = 0;
}


// after iterate k was evaluated and its islands found: islands whose merit improved on their
// best (from k_min on) keep this iterate (u on their dofs, their rows and multipliers); each
// island is done when its merit is at most tol. Returns 1 if every island is done.
OST_HD int osti_islandsUpdate(ostWorld* w, int k, int k_min, ostNum tol) {
  int n = w->nisland, all_done = 1;
  osti_islandMerits(w, w->dof_island, n);

  // an island's best so far: the worst best of its dofs (islands merge and split)
  for (int I = 0; I < n; I++) {
    OST_ISL_BASE(w, I) = -HUGE_VAL;  // used here as the island's best so far
  }
  for (int j = 0; j < w->nv; j++) {
    int I = w->dof_island[j];
    OST_ISL_BASE(w, I) = w->best_dof[j] > OST_ISL_BASE(w, I) ? w->best_dof[j] : OST_ISL_BASE(w, I);
  }
  for (int I = 0; I < n; I++) {
    w->isl_acc[I] = k >= k_min && OST_ISL_MERIT(w, I) < OST_ISL_BASE(w, I);  // improved
    w->isl_done[I] = k >= k_min && OST_ISL_MERIT(w, I) <= tol;
    all_done &= w->isl_done[I];
  }
  for (int j = 0; j < w->nv; j++) {
    int I = w->dof_island[j];
    if (w->isl_acc[I]) {
      w->qvel_best[j] = w->qvel[j];
      w->best_dof[j] = OST_ISL_MERIT(w, I);
      w->bestk_dof[j] = k;
    }
  }
  // best rows: drop those of improved islands, append their current rows (row order kept)
  int m = 0;
  for (int i = 0; i < w->nrow_best; i++) {
    if (!w->isl_acc[w->dof_island[w->anchor_best[i]]]) {
      w->rows_best[m] = w->rows_best[i];
      w->lambda_best[m] = w->lambda_best[i];
      w->anchor_best[m++] = w->anchor_best[i];
    }
  }
  for (int i = 0; i < w->nrow; i++) {
    if (w->isl_acc[w->row_island[i]] && m < w->nrow_max) {
      w->rows_best[m] = w->rows[i];
      w->lambda_best[m] = w->lambda[i];
      w->anchor_best[m++] = w->Jnnz[i] > 0 ? w->Jind[(size_t)i * w->ncol] : 0;
    }
  }
  w->nrow_best = m;
  return all_done;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_ISLAND_H_
