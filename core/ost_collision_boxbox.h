// ost_collision_boxbox.h: analytic box : box collision, and the 3x3 helpers of the box pairs.
// Mirrors mjc_BoxBox of engine_collision_box.c in MuJoCo 2.2.2: a separating-axis test over the
// 6 face normals and the 9 edge-edge directions picks the least-penetrating feature pair, then
// the contact points of that face (or edge) are clipped against the other box, in the frame of
// the face turned to +z. Two versions: osti_collideBoxBoxMujoco keeps MuJoCo's quirks, as the
// oracle of the tests (face contacts report half the height as dist, face points that can lie
// outside the reference face, and an edge path that reuses a squared gap as a determinant after
// its first accepted face corner); osti_collideBoxBox, which both geometry providers use, clips
// the incident face to the reference face, reports the whole height as dist, breaks near-ties
// between features in favour of faces, and merges coincident points (osti_collideBoxBoxMode).
// MuJoCo's half height changes at half the rate J u predicts, so a Newton step removed only half
// of a box-on-box violation (linear convergence at rate 1/2), and its face choice and point set
// changed between Newton iterates on a box resting on a box.
// Invariant: at most 24 (face) or OST_MAXCONPAIR (edge) contacts, all within the margin,
// normals from g1 to g2, frames completed as MuJoCo's driver completes them.
#ifndef OSTRICH_CORE_OST_COLLISION_BOXBOX_H_
#define OSTRICH_CORE_OST_COLLISION_BOXBOX_H_

#include <math.h>

#include "ost_collision_primitive.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

// res = R v (row-major R)
OST_HD void osti_boxMulMatVec(ostNum res[3], const ostNum R[9], const ostNum v[3]) {
  ostNum r0 = R[0]*v[0] + R[1]*v[1] + R[2]*v[2];
  ostNum r1 = R[3]*v[0] + R[4]*v[1] + R[5]*v[2];
  ostNum r2 = R[6]*v[0] + R[7]*v[1] + R[8]*v[2];
  res[0] = r0; res[1] = r1; res[2] = r2;
}


// res = R' v (row-major R)
OST_HD void osti_boxMulMatTVec(ostNum res[3], const ostNum R[9], const ostNum v[3]) {
  ostNum r0 = R[0]*v[0] + R[3]*v[1] + R[6]*v[2];
  ostNum r1 = R[1]*v[0] + R[4]*v[1] + R[7]*v[2];
  ostNum r2 = R[2]*v[0] + R[5]*v[1] + R[8]*v[2];
  res[0] = r0; res[1] = r1; res[2] = r2;
}


//---------------------------------- box : box ----------------------------------------------------

// res = A B (3x3, row-major; res must not alias)
OST_HD void osti_boxMulMat(ostNum res[9], const ostNum A[9], const ostNum B[9]) {
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) {
      res[3*i+j] = A[3*i]*B[j] + A[3*i+1]*B[3+j] + A[3*i+2]*B[6+j];
    }
  }
}


// res = A B' (3x3, row-major; res must not alias)
OST_HD void osti_boxMulMatT(ostNum res[9], const ostNum A[9], const ostNum B[9]) {
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) {
      res[3*i+j] = A[3*i]*B[3*j] + A[3*i+1]*B[3*j+1] + A[3*i+2]*B[3*j+2];
    }
  }
}


// the signed permutation F that turns box face f (axis f%3, side + for f < 3, - else) to +z:
// F (outward normal of face f) = (0,0,1); rows as in the table below
OST_HD void osti_boxFaceTurn(ostNum F[9], int f) {
  const signed char table[6][9] = {
    {0, 0, -1,  0, 1, 0,  1, 0, 0},    // +x
    {1, 0, 0,   0, 0, -1, 0, 1, 0},    // +y
    {1, 0, 0,   0, 1, 0,  0, 0, 1},    // +z
    {0, 0, 1,   0, 1, 0,  -1, 0, 0},   // -x
    {1, 0, 0,   0, 0, 1,  0, -1, 0},   // -y
    {-1, 0, 0,  0, 1, 0,  0, 0, -1}};  // -z
  for (int i = 0; i < 9; i++) {
    F[i] = table[f][i];
  }
}


// the 2D segment o + t d (0 <= t <= 1, d = dir) against the lines x_q = +-ext[q] of the
// rectangle |x| <= ext[0], |y| <= ext[1]: writes the crossings inside the rectangle as
// t[k], l[k] (the line's coordinate) and c[k] (the other coordinate); returns their number
OST_HD int osti_boxSegmentRect(ostNum t[4], ostNum l[4], ostNum c[4], int q[4],
                               const ostNum o[3], const ostNum dir[3], const ostNum ext[3]) {
  int cnt = 0;
  for (int qq = 0; qq < 2; qq++) {
    if (fabs(dir[qq]) <= OST_MINVAL) {
      continue;
    }
    for (int side = -1; side <= 1; side += 2) {
      ostNum line = ext[qq] * side;
      ostNum tt = (line - o[qq]) * (1 / dir[qq]);
      if (tt < 0 || tt > 1) {
        continue;
      }
      ostNum other = o[1-qq] + dir[1-qq] * tt;
      if (fabs(other) > ext[1-qq]) {
        continue;
      }
      t[cnt] = tt;
      l[cnt] = line;
      c[cnt] = other;
      q[cnt] = qq;
      cnt++;
    }
  }
  return cnt;
}


// box : box, face contact: box A's face turned to +z by F; B is the other box.
// In A's turned frame (origin at the face's center, face = rectangle ext[0] x ext[1] at z = 0):
// pB = B's center, rB = B's axes (columns), sB = B's half sizes. Points: B's bottom edges
// crossing the face's rim, the face's corners under B's bottom face, B's bottom corners over
// the face. Returns the number of points and writes them (x, y, z = height over the face).
OST_HD int osti_boxFacePoints(ostNum pts[][3], const ostNum pB[3], const ostNum rB[9],
                              const ostNum sB[3], const ostNum ext[3]) {
  ostNum corner[6][3] = {{0}};
  int n = 0;

  // lowest corner of B: + half size along axes pointing down, and its horizontal-ish edges
  int low = 0;
  for (int i = 0; i < 3; i++) {
    corner[0][i] = pB[i];
    if (rB[6+i] < 0) {
      low |= 1 << i;
    }
  }
  for (int i = 0; i < 3; i++) {
    ostNum sgn = (low & (1 << i)) ? 1 : -1;
    for (int k = 0; k < 3; k++) {
      corner[0][k] += rB[3*k+i] * (sB[i] * sgn);
    }
  }
  int m = 1;
  for (int i = 0; i < 3; i++) {
    if (fabs(rB[6+i]) < 0.5) {
      ostNum scl = sB[i] * ((low & (1 << i)) ? -2 : 2);
      for (int k = 0; k < 3; k++) {
        corner[m][k] = rB[3*k+i] * scl;
      }
      m++;
    }
  }
  // corner[1], corner[2]: edge vectors; corner[3..5]: the other corners of the bottom face
  for (int k = 0; k < 3; k++) {
    corner[3][k] = corner[0][k] + corner[1][k];
    corner[4][k] = corner[0][k] + corner[2][k];
    corner[5][k] = corner[3][k] + corner[2][k];
  }

  // bottom edges (origin, direction) crossing the rim of the face
  int nline = 0;
  ostNum lo[4][3], ld[4][3];
  const int lorig[4] = {0, 0, 3, 4}, ldir[4] = {1, 2, 2, 1};
  if (m > 1) {
    nline = m > 2 ? 4 : 1;
  }
  for (int i = 0; i < nline; i++) {
    for (int k = 0; k < 3; k++) {
      lo[i][k] = corner[lorig[i]][k];
      ld[i][k] = corner[ldir[i]][k];
    }
    ostNum t[4], l[4], c[4];
    int q[4];
    int nc = osti_boxSegmentRect(t, l, c, q, lo[i], ld[i], ext);
    for (int j = 0; j < nc; j++) {
      osti_primAxpy(pts[n], lo[i], t[j], ld[i]);
      n++;
    }
  }

  // corners of the face inside B's bottom face, at the height of that face:
  //   (x, y) - corner0 = u e1 + v e2,  0 < u, v < 1
  ostNum a = corner[1][0], b = corner[2][0], c = corner[1][1], d = corner[2][1];
  ostNum det = a*d - b*c;
  if (m > 2) {
    for (int i = 0; i < 4; i++) {
      ostNum fx = (i / 2) ? ext[0] : -ext[0], fy = (i % 2) ? ext[1] : -ext[1];
      ostNum x = fx - corner[0][0], y = fy - corner[0][1];
      ostNum u = (x*d - y*b) * (1 / det), v = (y*a - x*c) * (1 / det);
      if (u <= 0 || v <= 0 || u >= 1 || v >= 1) {
        continue;
      }
      pts[n][0] = fx;
      pts[n][1] = fy;
      pts[n][2] = corner[0][2] + u*corner[1][2] + v*corner[2][2];
      n++;
    }
  }

  // B's bottom corners strictly over the face (the lowest one always)
  for (int i = 0; i < (1 << (m - 1)); i++) {
    const ostNum* cp = corner[i == 0 ? 0 : i + 2];
    if (i && (cp[0] <= -ext[0] || cp[0] >= ext[0] || cp[1] <= -ext[1] || cp[1] >= ext[1])) {
      continue;
    }
    pts[n][0] = cp[0];
    pts[n][1] = cp[1];
    pts[n][2] = cp[2];
    n++;
  }
  return n;
}


// box : box, edge contact between axis i of box 1 and axis j of box 2 (separating direction
// nrm = e_i x b_j in box 1's frame, inward = box 2 lies on its negative side); face = the face of
// box 1 the edges are projected on, edge2 = box 2's edge (corner bits); s1 = box 1's size
// Writes points (box 1's turned frame, z from the face) and their depths; returns their number.
OST_HD int osti_boxEdgePoints(ostNum pts[][3], ostNum depth[], const ostNum p[3],
                              const ostNum rnorm[3], const ostNum r[9], const ostNum size2[3],
                              const ostNum ext[3], int j, int ax1, int ax2, int edge2,
                              int inward, ostNum margin) {
  // box 2's face through the edge: corners P0..P3 (P0,P1 and P2,P3 along axis j)
  ostNum P[4][3], pu[4][3], axi[3][3], rt[9];
  for (int a = 0; a < 3; a++) {
    for (int b = 0; b < 3; b++) {
      rt[3*a+b] = r[3*b+a];
    }
  }
  for (int h = 0; h < 2; h++) {
    ostNum s1 = (edge2 & (1 << ax1)) ? 1 : -1;
    ostNum s2 = (edge2 & (1 << ax2)) ? 1 : -1;
    if (h) {
      s1 = -s1;
    }
    for (int k = 0; k < 3; k++) {
      P[2*h][k] = p[k];
    }
    osti_primAxpy(P[2*h], P[2*h], size2[ax1] * s1, rt + 3*ax1);
    osti_primAxpy(P[2*h], P[2*h], size2[ax2] * s2, rt + 3*ax2);
    for (int k = 0; k < 3; k++) {
      P[2*h+1][k] = P[2*h][k];
    }
    osti_primAxpy(P[2*h], P[2*h], size2[j], rt + 3*j);
    osti_primAxpy(P[2*h+1], P[2*h+1], -size2[j], rt + 3*j);
  }
  for (int k = 0; k < 3; k++) {
    axi[0][k] = P[0][k];
    axi[1][k] = P[1][k] - P[0][k];
    axi[2][k] = P[2][k] - P[0][k];
  }
  if (fabs(rnorm[2]) < OST_MINVAL) {
    return 0;
  }
  ostNum innorm = (1 / rnorm[2]) * (inward ? -1 : 1);

  // project the corners along the normal onto the face plane z = 0
  ostNum pp[4][2];
  for (int i = 0; i < 4; i++) {
    ostNum t = -P[i][2] * (1 / rnorm[2]);
    for (int k = 0; k < 3; k++) {
      pu[i][k] = P[i][k];
    }
    osti_primAxpy(P[i], P[i], t, rnorm);
    pp[i][0] = P[i][0];
    pp[i][1] = P[i][1];
  }
  ostNum e0[3], e1[3], e2[3];
  for (int k = 0; k < 3; k++) {
    e0[k] = P[0][k];
    e1[k] = P[1][k] - P[0][k];
    e2[k] = P[2][k] - P[0][k];
  }

  // edges of the projected face crossing the face's rim; the 3D point on box 2's face and the
  // rim point give the midpoint, their normal gap the depth
  int n = 0;
  for (int i = 0; i < 4; i++) {
    ostNum o[3], d[3], uo[3], ud[3];
    for (int k = 0; k < 3; k++) {
      o[k] = e0[k] + (i == 2 ? e1[k] : (i == 3 ? e2[k] : 0));
      d[k] = (i == 0 || i == 3) ? e1[k] : e2[k];
      uo[k] = axi[0][k] + (i == 2 ? axi[1][k] : (i == 3 ? axi[2][k] : 0));
      ud[k] = (i == 0 || i == 3) ? axi[1][k] : axi[2][k];
    }
    ostNum t[4], l[4], c[4];
    int q[4];
    int nc = osti_boxSegmentRect(t, l, c, q, o, d, ext);
    for (int h = 0; h < nc && n < OST_MAXCONPAIR; h++) {
      if ((uo[2] + ud[2]*t[h]) * innorm > margin) {
        continue;
      }
      for (int k = 0; k < 3; k++) {
        pts[n][k] = uo[k]*0.5 + ud[k]*(0.5*t[h]);
      }
      pts[n][q[h]] += 0.5 * l[h];
      pts[n][1-q[h]] += 0.5 * c[h];
      depth[n] = pts[n][2] * innorm * 2;
      n++;
    }
  }
  int nl = n;

  // corners of box 1's face inside the projected face (or near it when no edge crossed): the
  // point of box 2's face above them, midway; the determinant is replaced by the last accepted
  // squared gap after each accepted corner, as MuJoCo 2.2.2 does
  ostNum a = e1[0], b = e2[0], c = e1[1], d = e2[1];
  ostNum den = a*d - b*c;
  ostNum margin2 = margin * margin;
  for (int i = 0; i < 4 && n < OST_MAXCONPAIR; i++) {
    ostNum fx = (i / 2) ? ext[0] : -ext[0], fy = (i % 2) ? ext[1] : -ext[1];
    ostNum x = fx - e0[0], y = fy - e0[1];
    ostNum u = (x*d - y*b) * (1 / den), v = (y*a - x*c) * (1 / den);
    int uout = (u < 0 || u > 1), vout = (v < 0 || v > 1);
    if (nl == 0 ? (uout && vout) : (uout || vout)) {
      continue;
    }
    u = u < 0 ? 0 : (u > 1 ? 1 : u);
    v = v < 0 ? 0 : (v > 1 ? 1 : v);
    ostNum on2[3], gap[3];
    for (int k = 0; k < 3; k++) {
      on2[k] = pu[0][k] * (1 - u - v);
    }
    osti_primAxpy(on2, on2, u, pu[1]);
    osti_primAxpy(on2, on2, v, pu[2]);
    ostNum fc[3] = {fx, fy, 0};
    for (int k = 0; k < 3; k++) {
      gap[k] = fc[k] - on2[k];
    }
    ostNum g2 = osti_primDot(gap, gap);
    den = g2;
    if (on2[2] > 0 && g2 > margin2) {
      continue;
    }
    for (int k = 0; k < 3; k++) {
      pts[n][k] = (fc[k] + on2[k]) * 0.5;
    }
    depth[n] = sqrt(g2) * (on2[2] < 0 ? -1 : 1);
    n++;
  }
  int nf = n;

  // corners of box 2's face whose projection falls on box 1's face (or near it when nothing else
  // was found): midway between the corner and its nearest point on the face
  for (int i = 0; i < 4 && n < OST_MAXCONPAIR; i++) {
    ostNum x = pp[i][0], y = pp[i][1];
    int xout = (x < -ext[0] || x > ext[0]), yout = (y < -ext[1] || y > ext[1]);
    if (nl == 0) {
      if (nf != 0 && xout && yout) {
        continue;
      }
    } else if (xout || yout) {
      continue;
    }
    ostNum g2 = 0;
    for (int k = 0; k < 2; k++) {
      if (pp[i][k] < -ext[k]) {
        g2 += (pp[i][k] + ext[k]) * (pp[i][k] + ext[k]);
      } else if (pp[i][k] > ext[k]) {
        g2 += (pp[i][k] - ext[k]) * (pp[i][k] - ext[k]);
      }
    }
    g2 += pu[i][2] * innorm * pu[i][2] * innorm;
    if (pu[i][2] > 0 && g2 > margin2) {
      continue;
    }
    ostNum mid[3] = {pp[i][0] * 0.5, pp[i][1] * 0.5, 0};
    for (int k = 0; k < 2; k++) {
      if (pp[i][k] < -ext[k]) {
        mid[k] = -ext[k] * 0.5;
      } else if (pp[i][k] > ext[k]) {
        mid[k] = ext[k] * 0.5;
      }
    }
    osti_primAxpy(pts[n], mid, 0.5, pu[i]);
    depth[n] = sqrt(g2) * (pu[i][2] < 0 ? -1 : 1);
    n++;
  }
  return n;
}


// the contact points of a face contact, Ostrich's: the incident face of box B (its face most
// opposed to the reference face's normal +z) clipped to the reference face's rectangle
// |x| <= ext[0], |y| <= ext[1] (Sutherland-Hodgman), in the reference face's frame (z: the
// height over it). pB: B's centre, rB: B's axes as columns, sB: its half sizes. Every point lies
// on both faces' regions and moves continuously with the poses while the incident face stays the
// same; at most 8 points.
OST_HD int osti_boxClipFace(ostNum pts[][3], const ostNum pB[3], const ostNum rB[9],
                            const ostNum sB[3], const ostNum ext[3]) {
  // incident face: the axis k with the largest |z| component, on the side facing down
  int k = 0;
  for (int i = 1; i < 3; i++) {
    if (fabs(rB[6+i]) > fabs(rB[6+k])) k = i;
  }
  int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  ostNum side = rB[6+k] > 0 ? -sB[k] : sB[k];
  ostNum poly[2][8][3];
  const ostNum su[4] = {1, -1, -1, 1}, sv[4] = {1, 1, -1, -1};
  for (int v = 0; v < 4; v++) {
    for (int i = 0; i < 3; i++) {
      poly[0][v][i] = pB[i] + side * rB[3*i+k] + su[v] * sB[k1] * rB[3*i+k1]
                      + sv[v] * sB[k2] * rB[3*i+k2];
    }
  }
  // clip by the four half planes s x_c <= ext[c]
  int n = 4, cur = 0;
  for (int e = 0; e < 4 && n > 0; e++) {
    int c = e / 2;
    ostNum sg = (e % 2) ? -1 : 1;
    int m = 0;
    for (int v = 0; v < n; v++) {
      const ostNum* a = poly[cur][v];
      const ostNum* b = poly[cur][(v + 1) % n];
      ostNum da = sg * a[c] - ext[c], db = sg * b[c] - ext[c];
      if (da <= 0) {
        for (int i = 0; i < 3; i++) poly[1-cur][m][i] = a[i];
        m++;
      }
      if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
        ostNum t = da / (da - db);
        for (int i = 0; i < 3; i++) poly[1-cur][m][i] = a[i] + t * (b[i] - a[i]);
        m++;
      }
    }
    n = m;
    cur = 1 - cur;
  }
  for (int v = 0; v < n; v++) {
    for (int i = 0; i < 3; i++) pts[v][i] = poly[cur][v][i];
  }
  return n;
}


// box : box (separating axis test over 3 + 3 face normals and 9 edge-edge directions, then the
// contact points of the least-penetrating feature pair). mujoco = 1: MuJoCo 2.2.2's results
// (a face contact's dist is half its height; its points from MuJoCo's face routine; the smallest
// overlap wins, an edge by a relative 1e-12). mujoco = 0, Ostrich's: a face contact's points are
// the incident face clipped to the reference face (osti_boxClipFace), its dist their height;
// box 2's face wins over box 1's, and an edge over a face, only by OST_BOXBOX_TIE x the boxes'
// size (as Box2D and ODE prefer faces): two faces that overlap equally (a box resting on a box,
// whose overlaps differ by the noise of the tilts) keep one reference face and its points,
// where the choice flipped from one Newton iterate to the next
#define OST_BOXBOX_TIE 1e-3
OST_HD int osti_collideBoxBoxMode(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                  ostNum margin, int mujoco) {
  const ostNum *s1 = g1->size, *s2 = g2->size;
  ostNum dif[3], pos21[3], pos12[3], rot[9], rotabs[9], plen1[3], plen2[3];

  // relative poses: pos21 = R1'(p2 - p1), pos12 = R2'(p1 - p2), rot = R1'R2 (rot_ij = a_i.b_j)
  for (int k = 0; k < 3; k++) {
    dif[k] = g2->pos[k] - g1->pos[k];
  }
  osti_boxMulMatTVec(pos21, g1->mat, dif);
  for (int k = 0; k < 3; k++) {
    dif[k] = g1->pos[k] - g2->pos[k];
  }
  osti_boxMulMatTVec(pos12, g2->mat, dif);
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) {
      rot[3*i+j] = g1->mat[i]*g2->mat[j] + g1->mat[3+i]*g2->mat[3+j] + g1->mat[6+i]*g2->mat[6+j];
    }
  }
  for (int i = 0; i < 9; i++) {
    rotabs[i] = fabs(rot[i]);
  }

  // extents of each box along the other's axes: plen2 = |rot| s2, plen1 = |rot|' s1
  osti_boxMulMatVec(plen2, rotabs, s2);
  osti_boxMulMatTVec(plen1, rotabs, s1);

  // face axes: overlap c = s + plen - |center offset|; keep the smallest (code 0..11)
  ostNum depth_scale = mujoco ? 0.5 : 1;
  ostNum size = s1[0] + s1[1] + s1[2] + s2[0] + s2[1] + s2[2];
  ostNum tie = mujoco ? 0 : OST_BOXBOX_TIE * size;
  ostNum pen = margin;
  for (int i = 0; i < 3; i++) {
    pen += s1[i] * 3 + s2[i] * 3;
  }
  int code = -1;
  for (int i = 0; i < 3; i++) {
    ostNum c1 = -fabs(pos21[i]) + s1[i] + plen2[i];
    ostNum c2 = -fabs(pos12[i]) + s2[i] + plen1[i];
    if (c1 < -margin || c2 < -margin) {
      return 0;
    }
    if (c1 < pen) {
      pen = c1;
      code = i + 3 * (pos21[i] < 0);
    }
    if (c2 < pen - tie) {
      pen = c2;
      code = i + 3 * (pos12[i] < 0) + 6;
    }
  }

  // edge axes a_i x b_j (box 1's frame), normalized; they win only by a relative 1e-12
  ostNum clnorm[3] = {0, 0, 0};
  int cle1 = 0, cle2 = 0, inward = 0;
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) {
      const ostNum bj[3] = {rot[j], rot[3+j], rot[6+j]};
      ostNum ax[3] = {0, 0, 0};
      if (i == 0) {
        ax[1] = -bj[2]; ax[2] = bj[1];
      } else if (i == 1) {
        ax[0] = bj[2]; ax[2] = -bj[0];
      } else {
        ax[0] = -bj[1]; ax[1] = bj[0];
      }
      ostNum len = sqrt(osti_primDot(ax, ax));
      if (len < OST_MINVAL) {
        continue;
      }
      ostNum inv = 1 / len;
      ax[0] *= inv; ax[1] *= inv; ax[2] *= inv;
      ostNum off = osti_primDot(pos21, ax);

      // overlap: projected half widths of both boxes minus the offset; b_k.ax = +-rot_i,l / len
      ostNum c3 = 0;
      for (int k = 0; k < 3; k++) {
        if (k != i) {
          c3 += s1[k] * fabs(ax[k]);
        }
      }
      for (int k = 0; k < 3; k++) {
        if (k != j) {
          c3 += s2[k] * rotabs[3*i + 3 - k - j] / len;
        }
      }
      c3 -= fabs(off);
      if (c3 < -margin) {
        return 0;
      }
      if (c3 < pen * (1 - 1e-12) - tie) {
        pen = c3;
        // the nearest edges: box 1's corner bits towards box 2, box 2's towards box 1
        cle1 = 0;
        for (int k = 0; k < 3; k++) {
          if (k != i && ((ax[k] > 0) ^ (off < 0))) {
            cle1 += 1 << k;
          }
        }
        cle2 = 0;
        for (int k = 0; k < 3; k++) {
          if (k != j && ((rot[3*i + 3 - k - j] > 0) ^ (off < 0) ^ ((k - j + 3) % 3 == 1))) {
            cle2 += 1 << k;
          }
        }
        code = 12 + 3*i + j;
        clnorm[0] = ax[0]; clnorm[1] = ax[1]; clnorm[2] = ax[2];
        inward = off < 0;
      }
    }
  }
  if (code == -1) {
    return 0;
  }

  ostNum F[9], r[9], p[3], t[3], ext[3], pts[OST_MAXCONPAIR][3], depth[OST_MAXCONPAIR];
  ostNum W[9], nrm[3];
  int n = 0;

  // face contact: the face (code % 6) of box (code / 6) against the other box
  if (code < 12) {
    int face = code % 6, onbox2 = code / 6;
    osti_boxFaceTurn(F, face);
    if (onbox2) {
      osti_boxMulMatT(r, F, rot);
      osti_boxMulMatVec(p, F, pos12);
      osti_boxMulMatVec(t, F, s2);
    } else {
      osti_boxMulMat(r, F, rot);
      osti_boxMulMatVec(p, F, pos21);
      osti_boxMulMatVec(t, F, s1);
    }
    for (int k = 0; k < 3; k++) {
      ext[k] = fabs(t[k]);
    }
    p[2] -= ext[2];
    int m = mujoco ? osti_boxFacePoints(pts, p, r, onbox2 ? s1 : s2, ext)
                   : osti_boxClipFace(pts, p, r, onbox2 ? s1 : s2, ext);

    // keep the points within the margin; pos midway between the face and the point
    for (int i = 0; i < m; i++) {
      if (pts[i][2] > margin) {
        continue;
      }
      for (int k = 0; k < 3; k++) {
        pts[n][k] = pts[i][k];
      }
      depth[n] = pts[n][2] * depth_scale;
      pts[n][2] *= 0.5;
      n++;
    }

    // back to the world: W = R F', normal = -+ W's z column
    osti_boxMulMatT(W, onbox2 ? g2->mat : g1->mat, F);
    const ostNum* org = onbox2 ? g2->pos : g1->pos;
    ostNum sgn = onbox2 ? -1 : 1;
    nrm[0] = sgn * W[2]; nrm[1] = sgn * W[5]; nrm[2] = sgn * W[8];
    for (int i = 0; i < n; i++) {
      pts[i][2] += ext[2];
      ostNum wp[3];
      osti_boxMulMatVec(wp, W, pts[i]);
      osti_primAxpy(wp, wp, 1, org);
      osti_primSetContact(con + i, depth[i], wp, nrm, 0);
    }
    return n;
  }

  // edge contact: box 1's axis i against box 2's axis j
  code -= 12;
  int i = code / 3, j = code % 3;
  const int other1[3][2] = {{1, 2}, {0, 2}, {1, 0}};
  int ax1 = other1[j][0], ax2 = other1[j][1];
  int pax1 = other1[i][0], pax2 = other1[i][1];
  if (rotabs[3*i + ax1] < rotabs[3*i + ax2]) {
    ax1 = ax2;
    ax2 = 3 - j - ax1;
  }
  if (rotabs[3*pax1 + j] < rotabs[3*pax2 + j]) {
    pax1 = pax2;
    pax2 = 3 - i - pax1;
  }
  int face = (cle1 & (1 << pax2)) ? pax2 : pax2 + 3;
  osti_boxFaceTurn(F, face);
  ostNum rnorm[3];
  osti_boxMulMatVec(p, F, pos21);
  osti_boxMulMatVec(rnorm, F, clnorm);
  osti_boxMulMat(r, F, rot);
  osti_boxMulMatTVec(t, F, s1);
  for (int k = 0; k < 3; k++) {
    ext[k] = fabs(t[k]);
  }
  p[2] -= ext[2];
  n = osti_boxEdgePoints(pts, depth, p, rnorm, r, s2, ext, j, ax1, ax2, cle2, inward, margin);
  if (!mujoco) {
    // no point of either box lies deeper than the overlap pen along the contact axis, but the
    // points of an edge contact are clipped against a face of box 1 and measured there: where
    // the boxes cross at an angle they came out centimetres deep for boxes millimetres apart
    // (two fingers of the Allegro hand 6.8 mm apart: a point at -22 mm, and Newton cycled).
    // Such a point is given the deepest distance the axis allows
    for (int h = 0; h < n; h++) {
      depth[h] = depth[h] < -pen ? -pen : depth[h];
    }
  }

  // back to the world: W = R1 F'
  osti_boxMulMatT(W, g1->mat, F);
  osti_boxMulMatVec(nrm, W, rnorm);
  if (inward) {
    nrm[0] = -nrm[0]; nrm[1] = -nrm[1]; nrm[2] = -nrm[2];
  }
  for (int h = 0; h < n; h++) {
    pts[h][2] += ext[2];
    ostNum wp[3];
    osti_boxMulMatVec(wp, W, pts[h]);
    osti_primAxpy(wp, wp, 1, g1->pos);
    osti_primSetContact(con + h, depth[h], wp, nrm, 0);
  }
  return n;
}


// box : box for both geometry providers: face contacts report their signed distance, and
// points closer than OST_BOXBOX_MERGE x the boxes' size are one contact (the deeper distance).
// Boxes with aligned edges (equal boxes stacked) put a corner of one face on an edge of the
// other: the clipping then reports that point once or twice depending on rounding, which
// changed the contact count from one Newton iterate to the next.
#define OST_BOXBOX_MERGE 1e-6
OST_HD int osti_collideBoxBox(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                              ostNum margin) {
  int n = osti_collideBoxBoxMode(con, g1, g2, margin, 0), kept = 0;
  ostNum tol = OST_BOXBOX_MERGE * (g1->size[0] + g1->size[1] + g1->size[2] + g2->size[0]
                                   + g2->size[1] + g2->size[2]);
  for (int i = 0; i < n; i++) {
    int dup = -1;
    for (int j = 0; j < kept && dup < 0; j++) {
      ostNum d[3] = {con[i].pos[0] - con[j].pos[0], con[i].pos[1] - con[j].pos[1],
                     con[i].pos[2] - con[j].pos[2]};
      if (osti_primDot(d, d) < tol * tol) {
        dup = j;
      }
    }
    if (dup >= 0) {
      if (con[i].dist < con[dup].dist) {
        con[dup].dist = con[i].dist;
      }
      continue;
    }
    con[kept++] = con[i];
  }
  return kept;
}


// box : box as MuJoCo 2.2.2 computes it (face contacts report half their height): the tests'
// oracle of the shared algorithm
OST_HD int osti_collideBoxBoxMujoco(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                    ostNum margin) {
  return osti_collideBoxBoxMode(con, g1, g2, margin, 1);
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_BOXBOX_H_
