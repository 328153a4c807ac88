// ost_envelope.h: a sparse direct solve of an island's Schur system (core/README.md eq. 11)
//   A x = b,   A = J Mt^-1 J' + diag(c) / h,
// on the host, for islands above the dense solve's OST_DIRECT_MAX rows. A_lm is the dot product
// of two rows' half-solves y_l = D^-1/2 L^-T J_l' over the dofs their patterns share, so A is
// sparse wherever rows lie on different kinematic trees: a grid of particles joined by tendons,
// a hammock of bodies of their own, a pile of spheres. The rows are reordered by reverse
// Cuthill-McKee (George and Liu, Computer Solution of Large Sparse Positive Definite Systems,
// 1981, ch. 4), which keeps each row's non-zeros near the diagonal, A is equilibrated by its
// diagonal and factored within that envelope, where no entry outside a row's envelope ever
// fills: L L' (the skyline Cholesky of the same chapter), or L U where sliding friction makes A
// non-symmetric. The factor is kept for the next solves with the same operator.
// When (osti_schurSolveSet): always inside the geometric Newton term (ost_geometric.h), which
// solves tens of times with one operator; elsewhere only after PCR or GMRES ran out of budget
// and failed outright (OST_ENV_FALLBACK): where it merely stopped short, its truncated answer
// served the Newton loop of a contact-rich cloth better than the exact one.
// MuJoCo factors M, never A: there is no counterpart in its engine.
// Host only (OST_ROW_CACHE: it reads the half-solves osti_rowDiag kept in ostWorld.yrow): the
// GPU and the batches, whose worlds have no yrow, never take this path, so they stay bitwise
// equal to each other.
// Invariant: writes only the work's arrays, x and the world's scratch w->tmp; a solve that
// cannot be made (no room, a factor that fails, one dearer than OST_ENV_KRYLOV Krylov
// iterations, or one whose first answer misses its system: OST_DIRECT_EXACT) returns 0, leaves x
// as it was and the solve to PCR or GMRES.
#ifndef OSTRICH_CORE_OST_ENVELOPE_H_
#define OSTRICH_CORE_OST_ENVELOPE_H_

#ifndef OSTRICH_CORE_OST_SOLVER_H_INSIDE
#error "ost_envelope.h is part of ost_solver.h: include that"
#endif

// a Krylov solve that ran out of budget with a relative residual (Jacobi norm) above this, a
// hundred times worse than x = 0, failed outright and is done again by the envelope factor
// (osti_schurSolveSet). Measured over the exhausted GMRES solves of MuJoCo's hammock (60 steps)
// and cloth (250 steps): medians 75 and 0.2. Any lower bound hurt the cloth: its contacts
// outnumber its dofs, GMRES's truncated answers serve its Newton loop better than exact ones
// (17 ms per step with the bound at 100, 21 at 10, 48 at 1e-2, damped or not), while the
// hammock keeps most of the gain (339 ms per step against 947 with the geometric term's solves
// alone)
#define OST_ENV_FALLBACK 100
// most doubles an envelope factor may hold (16 MB); a larger one leaves the solve to PCR/GMRES
#define OST_ENV_CAP (1 << 21)
// the factor (sum of (envelope width)^2 / 2 flops) may cost this many Krylov iterations of the set
// (each about 4 times the sum of its rows' pattern sizes): its solves are then cheaper than
// PCR's within a few Newton directions, and the geometric term makes tens of solves with one
// operator. Measured on MuJoCo's hammock: 64 left its largest islands to GMRES (1,037 ms per
// step against 239 with 256); 1,024 chose as 256 on the hammock and grid2pin
#define OST_ENV_KRYLOV 256

// One host world's envelope work; the X-macro drives size and pointer setup (r x c entries)
#define OST_ENV_ARRAYS(X)                                                                      \
  X(int,    perm,   nrow_max, 1)      /* envelope order -> position in the set            */  \
  X(int,    order,  nrow_max, 1)      /* position in the set -> envelope order (-1: none)  */  \
  X(int,    first,  nrow_max, 1)      /* first column of each envelope row                 */  \
  X(size_t, adr,    nrow_max + 1, 1)  /* start of each envelope row in L                   */  \
  X(int,    deg,    nrow_max, 1)      /* rows a row couples to (degree in A's graph)       */  \
  X(int,    mark,   nrow_max, 1)      /* neighbour marks                                   */  \
  X(int,    nb,     nrow_max, 1)      /* one row's neighbours                              */  \
  X(int,    col_adr, nv + 1, 1)       /* start of each dof's list in col_row               */  \
  X(int,    col_row, nrow_max, ncol)  /* the set positions of the rows on each dof         */  \
  X(ostNum, Y,      nrow_max, ncol)   /* y_l on row l's pattern                            */  \
  X(ostNum, yd,     nv, 1)            /* one y_l scattered (zero off its pattern)          */  \
  X(ostNum, t,      nrow_max, 1)      /* permuted right-hand side and solution            */  \
  X(ostNum, s,      nrow_max, 1)      /* equilibration 1 / sqrt(A_ll), by envelope row     */  \
  X(ostNum, xs,     nrow_max, 1)      /* a new factor's first answer, checked before use   */  \
  X(ostNum, res,    nrow_max, 1)      /* its residual                                      */  \
  X(ostNum, L,      cap, 1)           /* the factor, row by row within the envelope        */  \
  X(int,    red_row, nrow_max, 1)     /* a reduced set's rows (osti_decoupledSolve)        */  \
  X(ostNum, red_x,  nrow_max, 1)      /* the decoupled rows' answers, zero elsewhere       */  \
  X(ostNum, red_ax, nrow_max, 1)      /* the operator on red_x                             */  \
  X(ostNum, red_b,  nrow_max, 1)      /* the reduced right-hand side                       */  \
  X(ostNum, red_y,  nrow_max, 1)      /* the reduced answer                                */

typedef struct ostEnvWork_ {      // envelope solves of one host world (ost_envelope.h)
  int    nrow_max;                // row capacity the arrays were sized for
  int    ncol;                    // columns of a stored row
  int    nv;                      // dofs
  size_t cap;                     // doubles L can hold
  ostOpKey kept;                  // the operator of the kept factor (version -1: none)
  int    lu;                      // 1: the kept factor is an LU (sliding couplings), 0: Cholesky
  int    active;                  // 1 while the geometric term's direction solves (below)
  ostOpKey bad;                   // the operator whose factor failed or was rejected: not tried
                                  // again (version -1: none)
  int    solves;                  // solves by this path (counter, never reset here)
  int    factors;                 // factors they took (counter)
  int    rejects;                 // factors rejected by their first answer (counter)
  int    decouple;                // 1: large sets' open contacts are solved alone
                                  // (osti_decoupledSolve; option decouple_open)
  int    reducing;                // 1 while osti_decoupledSolve solves its reduced set
  int    reduced;                 // sets solved reduced (counter, never reset here)
#define X(type, name, r, c) type* name;
  OST_ENV_ARRAYS(X)
#undef X
} ostEnvWork;


#if OST_ROW_CACHE
// doubles of the factor for a world of nrow_max rows: none at or below the dense solve's size
OST_HD size_t ostu_envCap(int nrow_max) {
  if (nrow_max <= OST_DIRECT_MAX) {
    return 0;
  }
  size_t full = (size_t)nrow_max * (nrow_max + 1) / 2;
  return full < OST_ENV_CAP ? full : OST_ENV_CAP;
}


// bytes of an envelope work area for a world of these sizes
OST_HD size_t ostu_envSize(int nv, int ncol, int nrow_max) {
  size_t sz = 0, cap = ostu_envCap(nrow_max);
  (void)cap;
#define X(type, name, r, c) sz += (((size_t)(r) * (c) * sizeof(type) + 63) / 64) * 64;
  OST_ENV_ARRAYS(X)
#undef X
  return sz;
}


// point e's arrays into buf (64-byte aligned, ostu_envSize bytes)
OST_HD void ostu_envInit(ostEnvWork* e, void* buf, int nv, int ncol, int nrow_max) {
  char* p = (char*)buf;
  size_t cap = ostu_envCap(nrow_max);
  e->nrow_max = nrow_max;
  e->ncol = ncol;
  e->nv = nv;
  e->cap = cap;
  e->kept = (ostOpKey){-1, NULL, 0};
  e->lu = 0;
  e->active = 0;
  e->bad = (ostOpKey){-1, NULL, 0};
  e->solves = 0;
  e->factors = 0;
  e->rejects = 0;
  e->decouple = 0;
  e->reducing = 0;
  e->reduced = 0;
#define X(type, name, r, c)                      \
  e->name = (type*)p;                            \
  p += (((size_t)(r) * (c) * sizeof(type) + 63) / 64) * 64;
  OST_ENV_ARRAYS(X)
#undef X
}


// the rows coupled to set position l (sharing a dof of its pattern), each once, into nb
// (marks with stamp l + 1); returns their number
OST_HD int osti_envNeighbours(const ostWorld* w, ostEnvWork* e, const ostRowSet* set, int l,
                              int* nb) {
  int i = OST_SET_ROW(set, l), cnt = 0;
  const int* ind = w->Jind + (size_t)i * w->ncol;
  for (int k = 0; k < w->Jnnz[i]; k++) {
    int c = ind[k];
    for (int a = e->col_adr[c]; a < e->col_adr[c + 1]; a++) {
      int m = e->col_row[a];
      if (e->mark[m] != l + 1) {
        e->mark[m] = l + 1;
        nb[cnt++] = m;
      }
    }
  }
  return cnt;
}


// the graph of A on the set (rows per dof, degrees) and its reverse Cuthill-McKee order;
// returns the envelope's size (doubles), or 0 if it exceeds the work's capacity or its factor
// would cost more than `budget` (flops, sum of (envelope width)^2 / 2): the rows on one dof
// couple to each other, so a dof that R rows share (the root of a tree they all hang from)
// costs at least R^3 / 6, checked before any ordering
OST_HD size_t osti_envOrder(const ostWorld* w, ostEnvWork* e, const ostRowSet* set,
                            double budget) {
  int n = set->n, nv = w->nv;
  int* nb = e->nb;
  for (int c = 0; c <= nv; c++) e->col_adr[c] = 0;
  for (int l = 0; l < n; l++) {
    int i = OST_SET_ROW(set, l);
    const int* ind = w->Jind + (size_t)i * w->ncol;
    for (int k = 0; k < w->Jnnz[i]; k++) e->col_adr[ind[k] + 1]++;
  }
  for (int c = 0; c < nv; c++) {
    double r = e->col_adr[c + 1];
    if (r * r * r / 6 > budget) {
      return 0;
    }
    e->col_adr[c + 1] += e->col_adr[c];
  }
  for (int l = 0; l < n; l++) {
    int i = OST_SET_ROW(set, l);
    const int* ind = w->Jind + (size_t)i * w->ncol;
    for (int k = 0; k < w->Jnnz[i]; k++) e->col_row[e->col_adr[ind[k]]++] = l;
  }
  for (int c = nv; c > 0; c--) e->col_adr[c] = e->col_adr[c - 1];  // back to the starts
  e->col_adr[0] = 0;
  for (int l = 0; l < n; l++) e->mark[l] = 0;
  for (int l = 0; l < n; l++) e->deg[l] = osti_envNeighbours(w, e, set, l, nb);

  // Cuthill-McKee: breadth first from a row of least degree, each row's unvisited neighbours
  // in increasing degree; every component in turn (perm doubles as the queue)
  for (int l = 0; l < n; l++) e->order[l] = -1, e->mark[l] = 0;
  int head = 0, tail = 0;
  while (tail < n) {
    if (head == tail) {
      int start = -1;
      for (int l = 0; l < n; l++) {
        if (e->order[l] < 0 && (start < 0 || e->deg[l] < e->deg[start])) start = l;
      }
      e->order[start] = tail;
      e->perm[tail++] = start;
    }
    int l = e->perm[head++];
    int cnt = osti_envNeighbours(w, e, set, l, nb), t0 = tail;
    for (int a = 0; a < cnt; a++) {
      int m = nb[a];
      if (e->order[m] >= 0) continue;
      int p = tail++;  // insertion by degree among this row's new neighbours
      while (p > t0 && e->deg[e->perm[p - 1]] > e->deg[m]) {
        e->perm[p] = e->perm[p - 1];
        p--;
      }
      e->perm[p] = m;
      e->order[m] = 0;  // queued (its position is set below)
    }
  }
  for (int a = 0; a < n / 2; a++) {  // reversed
    int s = e->perm[a];
    e->perm[a] = e->perm[n - 1 - a];
    e->perm[n - 1 - a] = s;
  }
  for (int a = 0; a < n; a++) e->order[e->perm[a]] = a;

  // each row's envelope: from its first coupled row in the new order to the diagonal
  for (int l = 0; l < n; l++) e->mark[l] = 0;
  size_t size = 0;
  double cost = 0;
  for (int a = 0; a < n; a++) {
    int l = e->perm[a], lo = a;
    int cnt = osti_envNeighbours(w, e, set, l, nb);
    for (int b = 0; b < cnt; b++) {
      int o = e->order[nb[b]];
      lo = o < lo ? o : lo;
    }
    e->adr[a] = size;
    size += (size_t)(a - lo + 1);
    cost += 0.5 * (double)(a - lo + 1) * (a - lo + 1);
    e->first[a] = lo;
  }
  e->adr[n] = size;
  return size <= e->cap && cost <= budget ? size : 0;
}


// S A S on the set in the envelope order (osti_envOrder made it) into the factor's storage:
// A_ab = y_l . y_m over the dofs two rows share (y_l scattered as in osti_directAssemble, so each
// entry sums the shared columns in ascending order), plus c / h on the diagonal, S = e->s. Row a
// of the lower triangle at e->L + e->adr[a] - first_a; with lu, also column a of the upper
// triangle (diagonal included) at the same place after e->adr[n] doubles, else the diagonal in L
OST_HD void osti_envAssemble(const ostWorld* w, ostEnvWork* e, const ostRowSet* set, int lu) {
  int n = set->n, ncol = w->ncol;
  ostNum* yd = e->yd;
  ostNum* U = lu ? e->L + e->adr[n] : e->L;
  for (int c = 0; c < w->nv; c++) yd[c] = 0;
  for (size_t q = 0; q < (lu ? 2 : 1) * e->adr[n]; q++) e->L[q] = 0;
  for (int l = 0; l < n; l++) e->mark[l] = 0;
  for (int a = 0; a < n; a++) {
    int l = e->perm[a], i = OST_SET_ROW(set, l);
    const int* il = w->Jind + (size_t)i * ncol;
    const ostNum* Yl = e->Y + (size_t)l * ncol;
    ostNum* La = e->L + e->adr[a] - e->first[a];
    ostNum* Ua = U + e->adr[a] - e->first[a];
    for (int k = 0; k < w->Jnnz[i]; k++) yd[il[k]] = Yl[k];
    int cnt = osti_envNeighbours(w, e, set, l, e->nb);
    for (int q = 0; q < cnt; q++) {
      int m = e->nb[q], b = e->order[m], j = OST_SET_ROW(set, m);
      if (b > a) continue;
      const int* jm = w->Jind + (size_t)j * ncol;
      const ostNum* Ym = e->Y + (size_t)m * ncol;
      ostNum s = 0;
      for (int k = 0; k < w->Jnnz[j]; k++) s += Ym[k] * yd[jm[k]];
      La[b] = Ua[b] = s * e->s[a] * e->s[b];
    }
    for (int k = 0; k < w->Jnnz[i]; k++) yd[il[k]] = 0;
    Ua[a] += w->c[i] / w->h * e->s[a] * e->s[a];
  }
}


// L L' = S A S (osti_envAssemble) by the skyline Cholesky, row by row,
//   L_ab = (A_ab - sum_k L_ak L_bk) / L_bb,   k from max(first_a, first_b) to b - 1,
//   L_aa = sqrt(A_aa - sum_k L_ak^2),          k from first_a to a - 1.
// Returns 0, or 1 if a pivot is not positive (A only semidefinite: PCR takes the set).
OST_HD int osti_envFactor(const ostWorld* w, ostEnvWork* e, const ostRowSet* set) {
  int n = set->n;
  osti_envAssemble(w, e, set, 0);
  for (int a = 0; a < n; a++) {
    ostNum* La = e->L + e->adr[a] - e->first[a];  // La[b]: entry (a, b), b in [first_a, a]
    // row a of the factor from the rows above it
    for (int b = e->first[a]; b < a; b++) {
      const ostNum* Lb = e->L + e->adr[b] - e->first[b];
      int k0 = e->first[a] > e->first[b] ? e->first[a] : e->first[b];
      ostNum s = La[b];
      for (int k = k0; k < b; k++) s -= La[k] * Lb[k];
      La[b] = s / Lb[b];
    }
    ostNum d = La[a];
    for (int k = e->first[a]; k < a; k++) d -= La[k] * La[k];
    if (!(d > 0)) {
      return 1;
    }
    La[a] = sqrt(d);
  }
  return 0;
}


// Where sliding friction makes A non-symmetric (osti_directSet adds the same couplings: a
// sliding contact's friction row along the slip holds its force at mu times the normal force)
// A = L U within the same envelope, by Doolittle's elimination without pivoting, unit L:
//   L_ab = (A_ab - sum_k L_ak U_kb) / U_bb,   U_ba = A_ba - sum_k L_bk U_ka,
// k from max(first_a, first_b) to b - 1. The rows of L sit in e->L as Cholesky's do, the columns
// of U after them (e->L + e->adr[n]). Pivoting is not needed for the rows that make A
// non-symmetric: those are fixed rows, whose diagonal c / h ~ 1e12 k_f dominates them; a pivot
// below 1e-13 of its row's diagonal still fails the factor (GMRES takes the set).
OST_HD int osti_envFactorLU(const ostWorld* w, ostEnvWork* e, const ostRowSet* set) {
  int n = set->n;
  ostNum* U = e->L + e->adr[n];
  osti_envAssemble(w, e, set, 1);
  for (int l = 0; l + 1 < n; l++) {  // the sliding couplings: entry (l + 1, l) of the set
    int i = OST_SET_ROW(set, l);
    if (!osti_slidingCoupled(w, i)) continue;
    int a = e->order[l + 1], b = e->order[l];
    ostNum v = w->c[i + 1] / w->h * w->rows[i].mu * e->s[a] * e->s[b];
    if (a > b) (e->L + e->adr[a] - e->first[a])[b] -= v;  // row a of L's storage
    else (U + e->adr[b] - e->first[b])[a] -= v;            // column b of U's
  }
  for (int a = 0; a < n; a++) {
    int f = e->first[a];
    ostNum* La = e->L + e->adr[a] - f;
    ostNum* Ua = U + e->adr[a] - f;
    ostNum diag = Ua[a];
    for (int b = f; b < a; b++) {  // row a of L
      const ostNum* Ub = U + e->adr[b] - e->first[b];
      int k0 = f > e->first[b] ? f : e->first[b];
      ostNum s = La[b];
      for (int k = k0; k < b; k++) s -= La[k] * Ub[k];
      La[b] = s / Ub[b];
    }
    for (int b = f; b <= a; b++) {  // column a of U
      const ostNum* Lb = e->L + e->adr[b] - e->first[b];
      int k0 = f > e->first[b] ? f : e->first[b];
      ostNum s = Ua[b];
      for (int k = k0; k < b; k++) s -= Lb[k] * Ua[k];
      Ua[b] = s;
    }
    if (!(fabs(Ua[a]) > 1e-13 * fabs(diag))) {
      return 1;
    }
  }
  return 0;
}


// x = A^-1 b on the set (local vectors) with the kept factor: L y = P b, then L' z = y
// (Cholesky) or U z = y (LU, lu = 1), x = P' z
OST_HD void osti_envSolve(const ostEnvWork* e, int n, int lu, ostNum* x, const ostNum* b) {
  ostNum* t = e->t;
  if (lu) {
    const ostNum* U = e->L + e->adr[n];
    for (int a = 0; a < n; a++) {
      const ostNum* La = e->L + e->adr[a] - e->first[a];
      ostNum s = e->s[a] * b[e->perm[a]];
      for (int k = e->first[a]; k < a; k++) s -= La[k] * t[k];
      t[a] = s;
    }
    for (int a = n - 1; a >= 0; a--) {
      const ostNum* Ua = U + e->adr[a] - e->first[a];
      t[a] /= Ua[a];
      ostNum ta = t[a];
      for (int k = e->first[a]; k < a; k++) t[k] -= Ua[k] * ta;
    }
    for (int a = 0; a < n; a++) x[e->perm[a]] = e->s[a] * t[a];
    return;
  }
  for (int a = 0; a < n; a++) {
    const ostNum* La = e->L + e->adr[a] - e->first[a];
    ostNum s = e->s[a] * b[e->perm[a]];
    for (int k = e->first[a]; k < a; k++) s -= La[k] * t[k];
    t[a] = s / La[a];
  }
  for (int a = n - 1; a >= 0; a--) {
    const ostNum* La = e->L + e->adr[a] - e->first[a];
    t[a] /= La[a];
    ostNum ta = t[a];
    for (int k = e->first[a]; k < a; k++) t[k] -= La[k] * ta;
  }
  for (int a = 0; a < n; a++) x[e->perm[a]] = e->s[a] * t[a];
}


// A x = b on a set of more than OST_DIRECT_MAX rows by the envelope factor, made once per
// operator (ostWorld.op_version and the set) and kept for the next solves. Returns 1, or 0
// where PCR or GMRES must solve instead: no work or row cache, a sliding coupling (A not
// symmetric), an envelope over the capacity or dearer than OST_ENV_KRYLOV Krylov iterations,
// or a factor that failed.
OST_HD int osti_envelopeSet(ostWorld* w, const ostRowSet* set, ostNum* x, const ostNum* b,
                            int factor) {
  ostEnvWork* e = w->env;
  int n = set->n;
  if (!e || !w->yrow || !w->dof_parent || e->cap == 0 || n > e->nrow_max) {
    return 0;
  }
  int lu = osti_hasSlidingCouplingSet(w, set);
  int kept = osti_opKeyIs(&e->kept, w, set) && e->lu == lu;
  if (!kept && !factor && !e->active) {
    return 0;
  }
  if (!kept && osti_opKeyIs(&e->bad, w, set)) {
    return 0;  // this operator's factor failed or was rejected already
  }
  if (!kept) {
    // one Krylov iteration: a product with J, one with J' and a tree solve, about 4 times the
    // sum of the rows' pattern sizes (flops); the factor may cost OST_ENV_KRYLOV of them
    double krylov = 0;
    for (int l = 0; l < n; l++) krylov += 4.0 * w->Jnnz[OST_SET_ROW(set, l)];
    e->kept.version = -1;
    size_t size = osti_envOrder(w, e, set, OST_ENV_KRYLOV * krylov / (lu ? 2 : 1));
    osti_opKeySet(&e->bad, w, set);  // until the factor below is made and checked
    if (size == 0 || (lu && 2 * size > e->cap)) {
      return 0;
    }
    // y_l = D^-1/2 (L^-T J_l') from the half-solves osti_rowDiag kept
    for (int l = 0; l < n; l++) {
      int i = OST_SET_ROW(set, l);
      const int* ind = w->Jind + (size_t)i * w->ncol;
      const ostNum* yr = w->yrow + (size_t)i * w->ncol;
      ostNum* Y = e->Y + (size_t)l * w->ncol;
      for (int k = 0; k < w->Jnnz[i]; k++) {
        Y[k] = yr[k] / osti_sqrtD(w, ind[k]);
      }
    }
    // symmetric equilibration S A S, S = diag(A)^-1/2 (the Jacobi scale PCR uses): fixed rows'
    // c / h ~ 1e12 k_f would otherwise dwarf the rows they couple to
    for (int a = 0; a < n; a++) {
      int i = OST_SET_ROW(set, e->perm[a]);
      e->s[a] = 1 / sqrt(w->diag[i] + w->c[i] / w->h);
    }
    if (lu ? osti_envFactorLU(w, e, set) : osti_envFactor(w, e, set)) {
      return 0;
    }
    e->factors++;
    // neither factor pivots: where A is nearly singular (contacts outnumbering the dofs they
    // hold, a sliding coupling that nearly cancels its normal's pivot) the LU's entries grow
    // without bound while every pivot passes. Measured on MuJoCo's rope lying on its floor with
    // every large solve made by this path: 22 % of the LU factors answered with relative
    // residuals of 1e2 to 1e17, where the dense LU with partial pivoting of the same systems
    // reached 1e-15 to 1e-10. So a new factor's first answer must solve its system to
    // OST_DIRECT_EXACT, or the factor is dropped and the solve left to PCR or GMRES
    osti_envSolve(e, n, lu, e->xs, b);
    if (!osti_solvesExactly(w, set, e->xs, b, e->res)) {
      e->rejects++;
      return 0;
    }
    e->bad.version = -1;
    osti_opKeySet(&e->kept, w, set);
    e->lu = lu;
    for (int l = 0; l < n; l++) x[l] = e->xs[l];
  } else {
    osti_envSolve(e, n, lu, x, b);
  }
  e->solves++;
  return 1;
}
#endif  // OST_ROW_CACHE

#endif  // OSTRICH_CORE_OST_ENVELOPE_H_
