// ost_collision_terrain.h: terrain collisions: a height field, or a non-convex triangle mesh used
// as a height surface, against one convex geom (sphere, capsule, ellipsoid, cylinder, box, mesh).
// Mirrors mjc_ConvexHField in engine_collision_convex.c of MuJoCo 2.2.2: every terrain triangle
// near the geom becomes a triangular prism reaching down to a flat base, and MPR
// (osti_mprPenetration, ost_collision_convex.h) runs once per prism; each penetrating prism gives
// one contact. The mesh terrain (Ostrich only; MuJoCo collides a mesh as its convex hull) applies
// the same rule to arbitrary triangles, found through a uniform xy grid built on the host. A
// cylinder (a wheel) is the exception: both terrains hand their triangles to Ostrich's own
// generator (ost_collision_cylsurf.h) instead of prisms and MPR.
// Invariant: both functions write n <= min(ncon_max, OST_MAXCONPAIR) contacts in con[0..n) with
// normals from the terrain (geom1) to the geom (geom2), and a mesh whose triangles, vertex order
// and face order equal the height field's triangulation (compare/gen_terrain.py) gives the same
// contacts in the same order as the height field.
#ifndef OSTRICH_CORE_OST_COLLISION_TERRAIN_H_
#define OSTRICH_CORE_OST_COLLISION_TERRAIN_H_

#include <math.h>
#include <stddef.h>

#include "ost_collision_convex.h"
#include "ost_collision_cylsurf.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_TERRAIN_MAXCAND 256  // candidate faces sorted per pass of osti_collideTerrain

typedef struct ostHField_ {  // a height field (mjModel hfield_* of one hfield)
  int           nrow;        // samples along y (hfield_nrow)
  int           ncol;        // samples along x (hfield_ncol)
  ostNum        size[4];     // half x, half y, elevation scale, base depth (hfield_size)
  const ostNum* data;        // elevations in [0, 1], row-major, z = data[r*ncol+c]*size[2] at
                             // x = 2 size[0] c/(ncol-1) - size[0],
                             // y = 2 size[1] r/(nrow-1) - size[1]                  (nrow x ncol)
} ostHField;

typedef struct ostTerrain_ {  // a triangle mesh used as a height surface, in the frame gt
  int           nvert;        // number of vertices
  int           nface;        // number of triangles
  const ostNum* vert;         // vertices in the terrain frame, +z up                  (nvert x 3)
  const int*    face;         // vertex indices of each triangle                       (nface x 3)
  int           gnx;          // grid cells along x
  int           gny;          // grid cells along y
  ostNum        gx0;          // grid origin x: cell ix spans [gx0 + ix gdx, gx0 + (ix+1) gdx)
  ostNum        gy0;          // grid origin y
  ostNum        gdx;          // cell size along x (> 0)
  ostNum        gdy;          // cell size along y (> 0)
  const int*    cell_adr;     // first entry of cell iy*gnx+ix in cell_face            (gnx*gny)
  const int*    cell_num;     // number of faces listed for the cell                   (gnx*gny)
  const int*    cell_face;    // faces whose xy box overlaps the cell, ascending per cell
  ostNum        base;         // z of the prism bottoms in the terrain frame (below every vertex)
} ostTerrain;


//---------------------------------- frames and support ------------------------------------------

// res = mat vec (mju_rotVecMat)
OST_HD void osti_terrainRot(ostNum res[3], const ostNum mat[9], const ostNum vec[3]) {
  for (int i = 0; i < 3; i++) {
    res[i] = mat[3*i]*vec[0] + mat[3*i+1]*vec[1] + mat[3*i+2]*vec[2];
  }
}


// res = mat' vec (mju_rotVecMatT)
OST_HD void osti_terrainRotT(ostNum res[3], const ostNum mat[9], const ostNum vec[3]) {
  for (int i = 0; i < 3; i++) {
    res[i] = mat[i]*vec[0] + mat[3+i]*vec[1] + mat[6+i]*vec[2];
  }
}


// express g in the frame f: loc = g with pos = f.mat' (g.pos - f.pos), mat = f.mat' g.mat
OST_HD void osti_terrainLocal(ostGeom* loc, const ostGeom* f, const ostGeom* g) {
  *loc = *g;
  ostNum dif[3] = {g->pos[0] - f->pos[0], g->pos[1] - f->pos[1], g->pos[2] - f->pos[2]};
  osti_terrainRotT(loc->pos, f->mat, dif);
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) {
      loc->mat[3*i+j] = f->mat[i]*g->mat[j] + f->mat[3+i]*g->mat[3+j] + f->mat[6+i]*g->mat[6+j];
    }
  }
}


// axis-aligned box of g in its parent frame from support points without margin (as the AABB of
// mjc_ConvexHField): box = {xmin, xmax, ymin, ymax, zmin, zmax}
OST_HD void osti_terrainAABB(ostNum box[6], const ostGeom* g) {
  for (int k = 0; k < 3; k++) {
    ostNum dir[3] = {0, 0, 0}, p[3];
    dir[k] = 1;
    osti_support(p, g, dir, 0);
    box[2*k+1] = p[k];
    dir[k] = -1;
    osti_support(p, g, dir, 0);
    box[2*k] = p[k];
  }
}


//---------------------------------- one prism ---------------------------------------------------

// MPR between the prism (6 vertices in the terrain frame: bottom 0-2, top 3-5 above them) and loc
// (geom2 in the terrain frame) inflated by margin; on penetration write con with the normal and
// point mapped to the world through the terrain pose f, dist = margin - depth (the signed
// distance between prism and geom), frame[3:9] = 0, and return 1
OST_HD int osti_terrainPrism(ostContact* con, const ostNum prism[18], const ostGeom* loc,
                             const ostGeom* f, ostNum margin, ostNum tol, int maxiter) {
  ostGeom p;
  p.type = OST_GEOM_PRISM;
  p.nvert = 6;
  p.vert = prism;
  p.nface = 0;
  p.face = NULL;
  p.rbound = 0;
  for (int i = 0; i < 9; i++) p.mat[i] = (i % 4 == 0);
  for (int k = 0; k < 3; k++) {
    p.size[k] = 0;
    p.pos[k] = 0;  // unused: MPR centers a prism at the mean of its vertices (osti_center)
  }

  // penetration; a zero direction means no usable normal
  ostNum depth, dir[3], pos[3];
  // MPR inflates each convex geom by half its margin argument and never a prism
  if (osti_mprPenetration(&p, loc, 2 * margin, tol, maxiter, &depth, dir, pos) != 0) {
    return 0;
  }
  if (osti_cvxIsOrigin(dir)) {
    return 0;
  }

  // to the world: n = R dir, pos = R pos + p0
  con->dist = margin - depth;
  osti_terrainRot(con->frame, f->mat, dir);
  osti_terrainRot(con->pos, f->mat, pos);
  for (int i = 0; i < 3; i++) {
    con->pos[i] += f->pos[i];
    con->frame[3+i] = 0;
    con->frame[6+i] = 0;
  }
  return 1;
}


// finish n contacts as MuJoCo does after the pair function: the smooth-surface normal of g2
// (mjc_fixNormal; the terrain g1 is never a smooth type), then the completed frame
OST_HD void osti_terrainFinish(ostContact* con, int n, const ostGeom* g1, const ostGeom* g2) {
  for (int i = 0; i < n; i++) {
    osti_fixNormal(con + i, g1, g2);
    osti_makeFrame(con[i].frame);
  }
}


//---------------------------------- height field ------------------------------------------------

// height field hf with pose ghf against the convex geom g2 (mjc_ConvexHField's cells, prisms and
// MPR). Margin: Ostrich reports the signed distance, dist = margin - depth with g2 inflated by
// the margin and prisms at their true height, so look-ahead contacts have true gaps. (MuJoCo
// 2.2.2 instead raises prism tops by the margin and reports -depth; with margin 0 both agree
// bitwise.)
OST_HD int osti_collideHField(ostContact* con, int ncon_max, const ostHField* hf,
                              const ostGeom* ghf, const ostGeom* g2, ostNum margin,
                              ostNum tol, int maxiter) {
  const ostNum* size = hf->size;
  int nrow = hf->nrow, ncol = hf->ncol;
  if (ncon_max > OST_MAXCONPAIR) {
    ncon_max = OST_MAXCONPAIR;
  }

  // geom2 in the hfield frame
  ostGeom loc;
  osti_terrainLocal(&loc, ghf, g2);
  const ostNum* pos = loc.pos;
  ostNum r2 = g2->rbound;

  // bounding sphere against the hfield box [-sx, sx] x [-sy, sy] x [-base, sz]
  for (int i = 0; i < 2; i++) {
    if (size[i] < pos[i] - r2 - margin || -size[i] > pos[i] + r2 + margin) {
      return 0;
    }
  }
  if (size[2] < pos[2] - r2 - margin || -size[3] > pos[2] + r2 + margin) {
    return 0;
  }

  // geom2's box in the hfield frame against the hfield box
  ostNum box[6];
  osti_terrainAABB(box, &loc);
  if (box[0] - margin > size[0] || box[1] + margin < -size[0] ||
      box[2] - margin > size[1] || box[3] + margin < -size[1] ||
      box[4] - margin > size[2] || box[5] + margin < -size[3]) {
    return 0;
  }

  // sub-grid of columns [cmin, cmax] and rows [rmin, rmax] under the box grown by the margin
  int cmin = (int)floor((double)((box[0] - margin + size[0]) / (2*size[0]) * (ncol-1)));
  int cmax = (int)ceil((double)((box[1] + margin + size[0]) / (2*size[0]) * (ncol-1)));
  int rmin = (int)floor((double)((box[2] - margin + size[1]) / (2*size[1]) * (nrow-1)));
  int rmax = (int)ceil((double)((box[3] + margin + size[1]) / (2*size[1]) * (nrow-1)));
  cmin = cmin < 0 ? 0 : cmin;
  cmax = cmax > ncol-1 ? ncol-1 : cmax;
  rmin = rmin < 0 ? 0 : rmin;
  rmax = rmax > nrow-1 ? nrow-1 : rmax;

  // grid step: x_c = dx c - sx, y_r = dy r - sy
  ostNum dx = (2.0*size[0]) / (ncol-1);
  ostNum dy = (2.0*size[1]) / (nrow-1);

  // a cylinder: Ostrich's own contacts over the same triangles (ost_collision_cylsurf.h)
  if (g2->type == OST_GEOM_CYLINDER) {
    ostCylSurf cs;
    osti_cylSurfInit(&cs, &loc, margin);
    int n = 0;
    for (int r = rmin; r < rmax; r++) {
      for (int c = cmin; c < cmax; c++) {
        ostNum v[4][3];  // (c, r+1), (c, r), (c+1, r+1), (c+1, r)
        for (int k = 0; k < 4; k++) {
          int cc = c + k / 2, rr = r + 1 - k % 2;
          v[k][0] = dx*cc - size[0];
          v[k][1] = dy*rr - size[1];
          v[k][2] = hf->data[rr*ncol + cc]*size[2];
        }
        n = osti_cylSurfTriangle(&cs, v[0], v[1], v[2], con, n, ncon_max);
        n = osti_cylSurfTriangle(&cs, v[1], v[2], v[3], con, n, ncon_max);
      }
    }
    return osti_cylSurfFinish(&cs, ghf, con, n, ncon_max);
  }

  // strip of row r: vertices (c, r+1), (c, r), (c+1, r+1), (c+1, r), ...; every new vertex closes
  // a triangle with the two before it: {(c,r+1), (c,r), (c+1,r+1)}, {(c,r), (c+1,r+1), (c+1,r)}
  ostNum prism[18] = {0};
  int cnt = 0;
  for (int r = rmin; r < rmax && cnt < ncon_max; r++) {
    int nvert = 0;
    for (int c = cmin; c <= cmax && cnt < ncon_max; c++) {
      for (int i = 0; i < 2 && cnt < ncon_max; i++) {
        int rr = r + 1 - i;

        // shift the window; new vertex last: bottom at -base, top at elevation + margin
        for (int k = 0; k < 6; k++) {
          prism[k] = prism[k+3];
          prism[9+k] = prism[12+k];
        }
        prism[6] = prism[15] = dx*c - size[0];
        prism[7] = prism[16] = dy*rr - size[1];
        prism[8] = -size[3];
        prism[17] = hf->data[rr*ncol + c]*size[2];
        if (++nvert < 3) {
          continue;
        }

        // skip prisms whose top lies entirely below the geom (less the margin)
        if (prism[11] + margin < box[4] && prism[14] + margin < box[4]
            && prism[17] + margin < box[4]) {
          continue;
        }
        cnt += osti_terrainPrism(con + cnt, prism, &loc, ghf, margin, tol, maxiter);
      }
    }
  }

  osti_terrainFinish(con, cnt, ghf, g2);
  return cnt;
}


//---------------------------------- mesh terrain ------------------------------------------------

// grid cell range [c[0], c[1]] x [c[2], c[3]] of the xy box b = {xmin, xmax, ymin, ymax}, clamped
OST_HD void osti_terrainCells(int c[4], const ostTerrain* t, const ostNum b[4]) {
  c[0] = (int)floor((double)((b[0] - t->gx0) / t->gdx));
  c[1] = (int)floor((double)((b[1] - t->gx0) / t->gdx));
  c[2] = (int)floor((double)((b[2] - t->gy0) / t->gdy));
  c[3] = (int)floor((double)((b[3] - t->gy0) / t->gdy));
  c[0] = c[0] < 0 ? 0 : (c[0] > t->gnx-1 ? t->gnx-1 : c[0]);
  c[1] = c[1] < 0 ? 0 : (c[1] > t->gnx-1 ? t->gnx-1 : c[1]);
  c[2] = c[2] < 0 ? 0 : (c[2] > t->gny-1 ? t->gny-1 : c[2]);
  c[3] = c[3] < 0 ? 0 : (c[3] > t->gny-1 ? t->gny-1 : c[3]);
}


// xy box {xmin, xmax, ymin, ymax} of face f
OST_HD void osti_terrainFaceBox(ostNum b[4], const ostTerrain* t, int f) {
  const int* v = t->face + 3*f;
  for (int k = 0; k < 2; k++) {
    ostNum p0 = t->vert[3*v[0]+k], p1 = t->vert[3*v[1]+k], p2 = t->vert[3*v[2]+k];
    ostNum lo = p0 < p1 ? p0 : p1, hi = p0 > p1 ? p0 : p1;
    b[2*k] = lo < p2 ? lo : p2;
    b[2*k+1] = hi > p2 ? hi : p2;
  }
}


// mesh terrain t with pose gt against the convex geom g2: every face whose xy box overlaps g2's
// box in the terrain frame, in ascending face order, as a prism from its vertices (tops raised
// by margin) down to t->base, then MPR as osti_collideHField; candidates are taken from the grid
// in passes of at most OST_TERRAIN_MAXCAND faces, so any number of faces is handled in order
OST_HD int osti_collideTerrain(ostContact* con, int ncon_max, const ostTerrain* t,
                               const ostGeom* gt, const ostGeom* g2, ostNum margin,
                               ostNum tol, int maxiter) {
  if (ncon_max > OST_MAXCONPAIR) {
    ncon_max = OST_MAXCONPAIR;
  }

  // geom2 and its box in the terrain frame; nothing to do outside the grid or below the base
  ostGeom loc;
  osti_terrainLocal(&loc, gt, g2);
  ostNum box[6];
  osti_terrainAABB(box, &loc);
  for (int k = 0; k < 2; k++) {  // faces within the margin sideways are candidates too
    box[2*k] -= margin;
    box[2*k+1] += margin;
  }
  if (box[1] < t->gx0 || box[0] > t->gx0 + t->gnx*t->gdx ||
      box[3] < t->gy0 || box[2] > t->gy0 + t->gny*t->gdy || box[5] + margin < t->base) {
    return 0;
  }
  int qc[4];
  osti_terrainCells(qc, t, box);

  // passes: collect the smallest candidate faces above 'last' into cand (sorted), test them
  // (a cylinder: Ostrich's own contacts over the faces, ost_collision_cylsurf.h)
  int cand[OST_TERRAIN_MAXCAND];
  int cnt = 0, last = -1, more = 1, cylinder = g2->type == OST_GEOM_CYLINDER;
  ostCylSurf cs;
  osti_cylSurfInit(&cs, &loc, margin);
  while (more && cnt < ncon_max) {
    int ncand = 0;
    more = 0;
    for (int iy = qc[2]; iy <= qc[3]; iy++) {
      for (int ix = qc[0]; ix <= qc[1]; ix++) {
        int cell = iy*t->gnx + ix;
        for (int j = 0; j < t->cell_num[cell]; j++) {
          int f = t->cell_face[t->cell_adr[cell] + j];
          if (f <= last) {
            continue;
          }

          // face box must overlap the geom box; count a face once, in its first query cell
          ostNum fb[4];
          int fc[4];
          osti_terrainFaceBox(fb, t, f);
          if (fb[1] < box[0] || fb[0] > box[1] || fb[3] < box[2] || fb[2] > box[3]) {
            continue;
          }
          osti_terrainCells(fc, t, fb);
          if (ix != (fc[0] > qc[0] ? fc[0] : qc[0]) || iy != (fc[2] > qc[2] ? fc[2] : qc[2])) {
            continue;
          }

          // insert into the sorted bounded list; what falls off waits for the next pass
          if (ncand == OST_TERRAIN_MAXCAND) {
            more = 1;
            if (f > cand[ncand-1]) {
              continue;
            }
            ncand--;
          }
          int k = ncand++;
          while (k > 0 && cand[k-1] > f) {
            cand[k] = cand[k-1];
            k--;
          }
          cand[k] = f;
        }
      }
    }

    // one prism per candidate: bottom (x, y, base), top (x, y, z)
    for (int j = 0; j < ncand && cnt < ncon_max; j++) {
      const int* v = t->face + 3*cand[j];
      ostNum prism[18];
      for (int i = 0; i < 3; i++) {
        const ostNum* p = t->vert + 3*v[i];
        prism[3*i] = prism[9+3*i] = p[0];
        prism[3*i+1] = prism[10+3*i] = p[1];
        prism[3*i+2] = t->base;
        prism[11+3*i] = p[2];
      }
      if (prism[11] + margin < box[4] && prism[14] + margin < box[4]
          && prism[17] + margin < box[4]) {
        continue;
      }
      if (cylinder) {
        cnt = osti_cylSurfTriangle(&cs, prism + 9, prism + 12, prism + 15, con, cnt, ncon_max);
      } else {
        cnt += osti_terrainPrism(con + cnt, prism, &loc, gt, margin, tol, maxiter);
      }
    }
    if (ncand) {
      last = cand[ncand-1];
    }
  }
  if (cylinder) {
    return osti_cylSurfFinish(&cs, gt, con, cnt, ncon_max);
  }
  osti_terrainFinish(con, cnt, gt, g2);
  return cnt;
}


//---------------------------------- host: grid construction -------------------------------------

// grid geometry over the xy box of the vertices, gnx x gny cells (<= 0: about 4 faces per cell)
static inline void ostu_terrainGridInit(ostTerrain* t, int gnx, int gny) {
  ostNum lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
  for (int v = 0; v < t->nvert; v++) {
    for (int k = 0; k < 2; k++) {
      ostNum p = t->vert[3*v+k];
      lo[k] = p < lo[k] ? p : lo[k];
      hi[k] = p > hi[k] ? p : hi[k];
    }
  }
  if (gnx <= 0 || gny <= 0) {
    gnx = gny = 1;
    while (2*gnx*gny < t->nface / 2) {
      gnx++;
      gny++;
    }
  }
  t->gnx = gnx;
  t->gny = gny;
  t->gx0 = lo[0];
  t->gy0 = lo[1];
  t->gdx = (hi[0] > lo[0] ? hi[0] - lo[0] : 1) / gnx * (1 + 1e-9);  // last vertex inside
  t->gdy = (hi[1] > lo[1] ? hi[1] - lo[1] : 1) / gny * (1 + 1e-9);
}


// number of entries of cell_face for the grid set by ostu_terrainGridInit
static inline int ostu_terrainGridSize(const ostTerrain* t) {
  int n = 0;
  for (int f = 0; f < t->nface; f++) {
    ostNum fb[4];
    int fc[4];
    osti_terrainFaceBox(fb, t, f);
    osti_terrainCells(fc, t, fb);
    n += (fc[1] - fc[0] + 1) * (fc[3] - fc[2] + 1);
  }
  return n;
}


// fill cell_adr, cell_num (gnx*gny) and cell_face (ostu_terrainGridSize entries), faces ascending
// within each cell; the caller then points t->cell_adr, cell_num, cell_face at them
static inline void ostu_terrainGridBuild(int* cell_adr, int* cell_num, int* cell_face,
                                         const ostTerrain* t) {
  int ncell = t->gnx * t->gny;
  for (int i = 0; i < ncell; i++) {
    cell_num[i] = 0;
  }

  // count per cell, prefix sums, then fill in face order (counting sort keeps faces ascending)
  for (int pass = 0; pass < 2; pass++) {
    for (int f = 0; f < t->nface; f++) {
      ostNum fb[4];
      int fc[4];
      osti_terrainFaceBox(fb, t, f);
      osti_terrainCells(fc, t, fb);
      for (int iy = fc[2]; iy <= fc[3]; iy++) {
        for (int ix = fc[0]; ix <= fc[1]; ix++) {
          int cell = iy*t->gnx + ix;
          if (pass == 0) {
            cell_num[cell]++;
          } else {
            cell_face[cell_adr[cell] + cell_num[cell]++] = f;
          }
        }
      }
    }
    if (pass == 0) {
      int adr = 0;
      for (int i = 0; i < ncell; i++) {
        cell_adr[i] = adr;
        adr += cell_num[i];
        cell_num[i] = 0;
      }
    }
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_TERRAIN_H_
