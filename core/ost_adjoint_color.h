// ost_adjoint_color.h: fewer passes for dR/dq+ (the split passes' GEO units, core/README.md
// eq. 15c). A row's residual reads q+ only through the dofs that move its objects: a contact's
// rows the dof chains of its two geoms' bodies, a limit's and a servo's the joint's dof, a dry
// row none; the dynamics rows read it through J' lambda, so through each row's dofs. Dofs that no
// row reads together can share a direction of a dual pass (a colour): each row's derivative
// along it is the one by its only dof of that colour, the others' terms being zero (up to the
// rounding of a root subtree's com, which every contact Jacobian's terms carry and cancel).
// For a translation unit with ostNum = ostDual<OSTX_CHUNK>, after ost_adjoint_work.h.
// Invariant: writes only the work's colours, subtree sizes and marks, and Rq's columns.
#ifndef OSTRICH_CORE_OST_ADJOINT_COLOR_H_
#define OSTRICH_CORE_OST_ADJOINT_COLOR_H_

#include "ost_adjoint_work.h"

// the heads of the dof chains a row reads (-1: none) into h[2]; returns 1 if it reads h[0]
// alone (a joint's dof), 0 if the whole chains (each head and its ancestors)
OST_HD int ostx_rowHeads(const ostModel* m, const ostRow* r, int* h) {
  h[0] = h[1] = -1;
  switch (r->type) {
  case OST_ROW_CONTACT:
  case OST_ROW_FRICTION:
    for (int s = 0; s < 2; s++) {
      int b = m->geom_bodyid[r->obj[s]];
      while (b > 0 && m->body_dofnum[b] == 0) b = m->body_parentid[b];  // welded: its parent's
      h[s] = b > 0 ? m->body_dofadr[b] + m->body_dofnum[b] - 1 : -1;
    }
    return 0;
  case OST_ROW_LIMIT:
    h[0] = m->jnt_dofadr[r->obj[0]];
    return 1;
  case OST_ROW_SERVO:
    h[0] = m->jnt_dofadr[m->actuator_trnid[r->obj[0]]];
    return 1;
  default:  // dry friction: J and its bound do not move
    return 1;
  }
}


// 1 if dof l is dof h or one of its ancestors (subtree sizes of a preorder dof tree)
OST_HD int ostx_dofAbove(const ostJacWork* wk, int l, int h) {
  return h >= 0 && l <= h && h < l + wk->subtree[l];
}


// 1 if row r reads dof l
OST_HD int ostx_rowReads(const ostJacWork* wk, const ostRow* r, int l) {
  int h[2];
  if (ostx_rowHeads(wk->m, r, h)) {
    return h[0] == l;
  }
  return ostx_dofAbove(wk, l, h[0]) || ostx_dofAbove(wk, l, h[1]);
}


// colours of the dofs (wk->color) by first fit, so that no row reads two dofs of one colour;
// returns their count. Every dof its own colour where the dofs are not in preorder (each
// subtree a contiguous range after its root), which ostx_dofAbove needs.
OST_HD int ostx_colorDofs(ostJacWork* wk, int nrow) {
  const ostModel* m = wk->m;
  const ostWorld* w = &wk->w;
  int nv = m->s.nv, ncolor = 0, preorder = 1;
  int *size = wk->subtree, *mark = wk->subtree + nv, *color = wk->color;
  for (int l = 0; l < nv; l++) size[l] = 1;
  for (int l = nv - 1; l >= 0; l--) {
    int p = m->dof_parentid[l];
    preorder &= p < l;
    if (p >= 0) size[p] += size[l];
  }
  for (int l = 0; l < nv && preorder; l++) {
    int p = m->dof_parentid[l];
    preorder &= p < 0 || l < p + size[p];  // inside its parent's range
  }
  for (int l = 0; l < nv; l++) {
    color[l] = preorder ? -1 : l;
    mark[l] = -1;
  }
  if (!preorder) {
    return nv;
  }
  for (int l = 0; l < nv; l++) {
    // the colours of the dofs that a row reading l also reads
    for (int i = 0; i < nrow; i++) {
      const ostRow* r = w->rows + i;
      int h[2];
      if (r->type == OST_ROW_FRICTION || !ostx_rowReads(wk, r, l)) {
        continue;  // a friction row reads its contact's dofs
      }
      if (ostx_rowHeads(m, r, h)) {
        continue;  // l alone
      }
      for (int s = 0; s < 2; s++) {
        for (int d = h[s]; d >= 0; d = m->dof_parentid[d]) {
          if (color[d] >= 0) mark[color[d]] = l;
        }
      }
    }
    int c = 0;
    while (c < ncolor && mark[c] == l) c++;
    color[l] = c;
    ncolor = c + 1 > ncolor ? c + 1 : ncolor;
  }
  return ncolor;  // 1 where no row reads two dofs (one pass then writes every column)
}


// after a GEO pass with the colours [c0, c0 + OSTX_CHUNK) seeded: the columns of Rq (ny x nv) of
// their dofs, each row's derivative by its own dof of the pass's colour. R (the constraint rows)
// and J (the dynamics rows, -h J' lambda) carry the pass's derivatives.
OST_HD void ostx_colorColumns(const ostJacWork* wk, int nrow, int c0, double* Rq) {
  const ostWorld* w = &wk->w;
  int nv = wk->m->s.nv;
  double h = (double)w->h;
  for (int l = 0; l < nv; l++) {
    int k = wk->color[l] - c0;
    if (k < 0 || k >= OSTX_CHUNK) {
      continue;
    }
    for (int i = 0; i < nv; i++) Rq[(size_t)i * nv + l] = 0;
    for (int r = 0; r < nrow; r++) {
      int reads = ostx_rowReads(wk, w->rows + r, l);
      Rq[(size_t)(nv + r) * nv + l] = reads ? wk->R[nv + r].d[k] : 0;
      double lam = (double)wk->lambda[r];
      const ostNum* J = w->J + (size_t)r * nv;
      for (int i = 0; reads && lam != 0 && i < nv; i++) {
        Rq[(size_t)i * nv + l] += J[i].d[k] * lam;
      }
    }
    for (int i = 0; i < nv; i++) Rq[(size_t)i * nv + l] *= -h;
  }
}

#endif  // OSTRICH_CORE_OST_ADJOINT_COLOR_H_
