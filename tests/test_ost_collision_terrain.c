// test_ost_collision_terrain.c: terrain collisions (ost_collision_terrain.h) against MuJoCo 2.2.2.
// Height field: spheres, capsules, boxes and ellipsoids at random poses over the terrain of
// terrain_hfield.xml (level, and tilted and shifted, with and without margin) must give the
// contacts of mj_collision (cylinders use Ostrich's own generator, checked in closed form by
// test_cylinder_terrain): the same count and order, dist, pos and all 9 frame entries
// to 1e-6. Mesh terrain: the hfield's triangulation as a mesh gives the hfield's contacts; the OBJ
// mesh of terrain_mesh.xml (as MuJoCo loaded it, float vertices) is the hfield's surface to float
// precision and gives the same contact counts, most contacts to 1e-5 (MPR amplifies the rounding);
// the grid gives what a single cell (brute force) gives.
#include "ost_collision_terrain.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fixture.h"

#define NPROBE 6
#define NPOSE 400

// a world with the terrain hfield (pose given) and NPROBE free bodies, one probe geom each
static mjModel* loadProbes(const char* hfpose, double margin) {
  char xml[4096];  // NPROBE bodies
  snprintf(xml, sizeof(xml),
    "<mujoco><option timestep='0.002'/>"
    "<asset><hfield name='t' file='%s/terrain_sinusoid.bin' size='12 12 0.28148 0.5'/></asset>"
    "<default><geom contype='0' conaffinity='1' margin='%g'/></default>"
    "<worldbody><geom name='terrain' type='hfield' hfield='t' %s contype='1' margin='0'/>"
    "<body><freejoint/><geom type='sphere' size='0.3'/></body>"
    "<body><freejoint/><geom type='capsule' size='0.15 0.4'/></body>"
    "<body><freejoint/><geom type='box' size='0.4 0.3 0.2'/></body>"
    "<body><freejoint/><geom type='cylinder' size='0.35 0.05'/></body>"
    "<body><freejoint/><geom type='cylinder' size='0.2 0.3'/></body>"
    "<body><freejoint/><geom type='ellipsoid' size='0.3 0.2 0.15'/></body>"
    "</worldbody></mujoco>", OST_MODEL_DIR, margin, hfpose);
  return ost_fixtureLoadString(xml);
}


// geom g of d as an ostGeom
static void packGeom(ostGeom* g, const mjModel* m, const mjData* d, int i) {
  memset(g, 0, sizeof(*g));
  g->type = m->geom_type[i];
  for (int k = 0; k < 3; k++) {
    g->size[k] = m->geom_size[3*i+k];
    g->pos[k] = d->geom_xpos[3*i+k];
  }
  for (int k = 0; k < 9; k++) {
    g->mat[k] = d->geom_xmat[9*i+k];
  }
  g->rbound = m->geom_rbound[i];
}


// the model's hfield 0 as an ostHField (data converted to ostNum into buf)
static void packHField(ostHField* hf, ostNum* buf, const mjModel* m) {
  hf->nrow = m->hfield_nrow[0];
  hf->ncol = m->hfield_ncol[0];
  for (int k = 0; k < 4; k++) hf->size[k] = m->hfield_size[k];
  for (int i = 0; i < hf->nrow*hf->ncol; i++) buf[i] = m->hfield_data[i];
  hf->data = buf;
}


// terrain height of the hfield model near world (x, y), for placing probes (level field only)
static double fieldHeight(const mjModel* m, double x, double y) {
  int ncol = m->hfield_ncol[0], nrow = m->hfield_nrow[0];
  int c = (int)((x + 12) / 24 * (ncol-1) + 0.5), r = (int)((y + 12) / 24 * (nrow-1) + 0.5);
  c = c < 0 ? 0 : (c > ncol-1 ? ncol-1 : c);
  r = r < 0 ? 0 : (r > nrow-1 ? nrow-1 : r);
  return m->geom_pos[2] + m->hfield_data[r*ncol+c]*m->hfield_size[2];
}


static double urand(double lo, double hi) {
  return lo + (hi - lo) * rand() / (double)RAND_MAX;
}


// random probe poses: xy over the field, height around the surface, random orientation
static void randomPoses(const mjModel* m, mjData* d, double zspread) {
  for (int b = 0; b < NPROBE; b++) {
    double* q = d->qpos + 7*b;
    q[0] = urand(-11.5, 11.5);
    q[1] = urand(-11.5, 11.5);
    q[2] = fieldHeight(m, q[0], q[1]) + urand(-0.5, 1.5)*zspread;
    double n = 0;
    for (int k = 0; k < 4; k++) {
      q[3+k] = urand(-1, 1);
      n += q[3+k]*q[3+k];
    }
    for (int k = 0; k < 4; k++) q[3+k] /= sqrt(n);
  }
}


typedef struct {
  double dist, pos, frame;  // max abs errors
  int ncase, ncon;          // pairs compared, contacts compared
} errStat;


// compare osti_collideHField with d->contact for every probe geom; fails on a count mismatch
static void compareHField(errStat* e, const mjModel* m, const mjData* d, const ostHField* hf) {
  ostGeom ghf, g2;
  packGeom(&ghf, m, d, 0);
  for (int gi = 1; gi < m->ngeom; gi++) {
    if (m->geom_type[gi] == mjGEOM_CYLINDER) {
      continue;  // Ostrich's own generator (ost_collision_cylsurf.h), test_cylinder_terrain
    }
    ostContact con[OST_MAXCONPAIR];
    for (int i = 0; i < OST_MAXCONPAIR; i++) {
      for (int k = 0; k < 13; k++) ((ostNum*)(con + i))[k] = NAN;  // poison
    }
    packGeom(&g2, m, d, gi);
    double margin = m->geom_margin[gi] > m->geom_margin[0] ? m->geom_margin[gi] : m->geom_margin[0];
    int n = osti_collideHField(con, OST_MAXCONPAIR, hf, &ghf, &g2, margin, m->opt.mpr_tolerance,
                               m->opt.mpr_iterations);
    int j = 0;
    for (int i = 0; i < d->ncon; i++) {
      const mjContact* c = d->contact + i;
      if (c->geom2 != gi) {
        continue;
      }
      ck_assert_int_eq(c->geom1, 0);
      ck_assert_msg(j < n, "geom %d: MuJoCo has more contacts than %d", gi, n);
      e->dist = fmax(e->dist, fabs(c->dist - con[j].dist));
      for (int k = 0; k < 3; k++) e->pos = fmax(e->pos, fabs(c->pos[k] - con[j].pos[k]));
      for (int k = 0; k < 9; k++) e->frame = fmax(e->frame, fabs(c->frame[k] - con[j].frame[k]));
      j++;
    }
    ck_assert_msg(j == n, "geom %d (type %d): MuJoCo %d contacts, Ostrich %d", gi,
                  m->geom_type[gi], j, n);
    e->ncase++;
    e->ncon += n;
  }
}


// run NPOSE random poses of the probes for one hfield pose and margin
static errStat runHField(const char* hfpose, double margin, double zspread) {
  mjModel* m = loadProbes(hfpose, margin);
  mjData* d = mj_makeData(m);
  ostNum* buf = malloc(sizeof(ostNum) * m->nhfielddata);
  ostHField hf;
  packHField(&hf, buf, m);
  errStat e = {0, 0, 0, 0, 0};
  for (int p = 0; p < NPOSE; p++) {
    randomPoses(m, d, zspread);
    mj_forward(m, d);
    compareHField(&e, m, d, &hf);
  }
  free(buf);
  mj_deleteData(d);
  mj_deleteModel(m);
  return e;
}


static void checkErr(const char* what, errStat e, int nmin) {
  printf("%-34s %5d pairs %6d contacts  max err dist %.1e pos %.1e frame %.1e\n", what, e.ncase,
         e.ncon, e.dist, e.pos, e.frame);
  ck_assert_int_ge(e.ncon, nmin);
  // the same prisms as mj_collision, in double: round-off only (measured: 0 at the time of
  // writing); 1e-6 is the suite's bound stated at the top
  ck_assert_double_le(e.dist, 1e-6);
  ck_assert_double_le(e.pos, 1e-6);
  ck_assert_double_le(e.frame, 1e-6);
}


START_TEST(test_hfield_level) {
  srand(1);
  checkErr("hfield level, margin 0", runHField("pos='0 0 -0.139822'", 0, 0.3), 1000);
}
END_TEST


START_TEST(test_hfield_tilted_margin) {
  // tilted and shifted field: probes are placed over the level surface, many still touch
  srand(2);
  checkErr("hfield tilted, margin 0", runHField("pos='0.3 -0.2 -0.1' euler='0.02 -0.03 0.4'",
                                                 0, 0.3), 1000);
}
END_TEST


// margin semantics (Ostrich's, not MuJoCo's): a sphere of radius 0.1 at gap g above a flat
// field (surface z = 0.5) with margin 0.02 gets contacts of dist = g and normal +z while
// g < margin, none beyond; a height field and a terrain mesh of the same two triangles agree
START_TEST(test_hfield_margin_gap) {
  ostNum data[4] = {0.5, 0.5, 0.5, 0.5};
  ostHField hf = {2, 2, {1, 1, 1, 0.5}, data};
  ostNum vert[12] = {-1, -1, 0.5, 1, -1, 0.5, -1, 1, 0.5, 1, 1, 0.5};
  int face[6] = {2, 0, 3, 0, 3, 1};
  ostTerrain t;
  memset(&t, 0, sizeof(t));
  t.nvert = 4;
  t.nface = 2;
  t.vert = vert;
  t.face = face;
  t.base = -0.5;
  ostu_terrainGridInit(&t, 1, 1);
  int cell_adr[1], cell_num[1], cell_face[8];
  ck_assert_int_le(ostu_terrainGridSize(&t), 8);
  ostu_terrainGridBuild(cell_adr, cell_num, cell_face, &t);
  t.cell_adr = cell_adr;
  t.cell_num = cell_num;
  t.cell_face = cell_face;
  ostGeom ghf, s;
  memset(&ghf, 0, sizeof(ghf));
  memset(&s, 0, sizeof(s));
  ghf.type = OST_GEOM_HFIELD;
  ghf.mat[0] = ghf.mat[4] = ghf.mat[8] = 1;
  s.type = OST_GEOM_SPHERE;
  s.size[0] = s.rbound = 0.1;
  s.mat[0] = s.mat[4] = s.mat[8] = 1;
  const double gaps[5] = {-0.004, 0, 0.005, 0.015, 0.03};
  for (int i = 0; i < 5; i++) {
    s.pos[0] = 0.13;
    s.pos[1] = -0.21;
    s.pos[2] = 0.6 + gaps[i];
    ostContact con[OST_MAXCONPAIR], cm[OST_MAXCONPAIR];
    int n = osti_collideHField(con, OST_MAXCONPAIR, &hf, &ghf, &s, 0.02, 1e-9, 100);
    int nm = osti_collideTerrain(cm, OST_MAXCONPAIR, &t, &ghf, &s, 0.02, 1e-9, 100);
    printf("gap %+.3f: %d hfield contacts, %d mesh contacts", gaps[i], n, nm);
    if (n) printf(", dist %.9f normal %.6f %.6f %.6f", con[0].dist, con[0].frame[0],
                  con[0].frame[1], con[0].frame[2]);
    printf("\n");
    ck_assert_int_eq(n, nm);
    if (gaps[i] >= 0.02) {
      ck_assert_int_eq(n, 0);
      continue;
    }
    ck_assert_int_ge(n, 1);
    for (int k = 0; k < n; k++) {
      ck_assert_double_eq_tol(con[k].dist, gaps[i], 1e-6);
      ck_assert_double_eq_tol(con[k].frame[2], 1, 1e-6);
      ck_assert_double_eq_tol(cm[k].dist, con[k].dist, 1e-12);
    }
  }
}
END_TEST


START_TEST(test_hfield_cap) {
  // a 3 x 3 m slab pressed into the field: more than OST_MAXCONPAIR penetrating prisms
  mjModel* m = ost_fixtureLoadString(
    "<mujoco><asset><hfield name='t' file='" OST_MODEL_DIR "/terrain_sinusoid.bin' "
    "size='12 12 0.28148 0.5'/></asset><worldbody>"
    "<geom type='hfield' hfield='t' pos='0 0 -0.139822'/>"
    "<body pos='6 5 0' euler='0.05 0.02 0.3'><freejoint/>"
    "<geom type='box' size='1.5 1.5 0.1' contype='0'/></body></worldbody></mujoco>");
  mjData* d = mj_makeData(m);
  ostNum* buf = malloc(sizeof(ostNum) * m->nhfielddata);
  ostHField hf;
  packHField(&hf, buf, m);
  mj_forward(m, d);
  ck_assert_int_eq(d->ncon, mjMAXCONPAIR);
  errStat e = {0, 0, 0, 0, 0};
  compareHField(&e, m, d, &hf);
  checkErr("hfield slab, 50-contact cap", e, OST_MAXCONPAIR);
  free(buf);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


//---------------------------------- mesh terrain ------------------------------------------------

// terrain from the hfield grid in the hfield frame, faces in the hfield's order and vertex order
static void hfieldAsTerrain(ostTerrain* t, ostNum* vert, int* face, const ostHField* hf) {
  int nrow = hf->nrow, ncol = hf->ncol, nf = 0;
  ostNum dx = (2.0*hf->size[0]) / (ncol-1), dy = (2.0*hf->size[1]) / (nrow-1);
  for (int r = 0; r < nrow; r++) {
    for (int c = 0; c < ncol; c++) {
      ostNum* v = vert + 3*(r*ncol + c);
      v[0] = dx*c - hf->size[0];
      v[1] = dy*r - hf->size[1];
      v[2] = hf->data[r*ncol + c]*hf->size[2];
    }
  }
  for (int r = 0; r < nrow-1; r++) {
    for (int c = 0; c < ncol-1; c++) {
      int v00 = r*ncol + c, v01 = v00 + 1, v10 = v00 + ncol, v11 = v10 + 1;
      int* f = face + 3*nf;
      f[0] = v10; f[1] = v00; f[2] = v11;
      f[3] = v00; f[4] = v11; f[5] = v01;
      nf += 2;
    }
  }
  memset(t, 0, sizeof(*t));
  t->nvert = nrow*ncol;
  t->nface = nf;
  t->vert = vert;
  t->face = face;
  t->base = -hf->size[3];
}


// allocate and attach a grid of gnx x gny cells (<= 0: automatic)
static void attachGrid(ostTerrain* t, int gnx, int gny, int** mem) {
  ostu_terrainGridInit(t, gnx, gny);
  int n = ostu_terrainGridSize(t), ncell = t->gnx*t->gny;
  *mem = malloc(sizeof(int) * (2*ncell + n));
  ostu_terrainGridBuild(*mem, *mem + ncell, *mem + 2*ncell, t);
  t->cell_adr = *mem;
  t->cell_num = *mem + ncell;
  t->cell_face = *mem + 2*ncell;
}


// max abs difference of two contact lists of equal length
static double conDiff(const ostContact* a, const ostContact* b, int n) {
  double e = 0;
  for (int i = 0; i < n; i++) {
    e = fmax(e, fabs(a[i].dist - b[i].dist));
    for (int k = 0; k < 3; k++) e = fmax(e, fabs(a[i].pos[k] - b[i].pos[k]));
    for (int k = 0; k < 9; k++) e = fmax(e, fabs(a[i].frame[k] - b[i].frame[k]));
  }
  return e;
}


START_TEST(test_mesh_equals_hfield) {
  // hfield triangulation as a mesh, in the hfield frame; brute force: one grid cell
  mjModel* m = loadProbes("pos='0.3 -0.2 -0.1' euler='0.02 -0.03 0.4'", 0.01);
  mjData* d = mj_makeData(m);
  ostNum* buf = malloc(sizeof(ostNum) * m->nhfielddata);
  ostHField hf;
  packHField(&hf, buf, m);
  int nrow = hf.nrow, ncol = hf.ncol, *grid, *grid1;
  ostNum* vert = malloc(sizeof(ostNum) * 3*nrow*ncol);
  int* face = malloc(sizeof(int) * 6*(nrow-1)*(ncol-1));
  ostTerrain t, t1;
  hfieldAsTerrain(&t, vert, face, &hf);
  t1 = t;
  attachGrid(&t, 0, 0, &grid);
  attachGrid(&t1, 1, 1, &grid1);
  ck_assert_int_eq(t.nface, 12482);

  srand(4);
  double emax = 0, ebrute = 0, tq = 0, th = 0;
  int ncon = 0, nq = 0;
  for (int p = 0; p < NPOSE; p++) {
    randomPoses(m, d, 0.3);
    mj_kinematics(m, d);
    ostGeom gt, g2;
    packGeom(&gt, m, d, 0);
    for (int gi = 1; gi < m->ngeom; gi++) {
      ostContact ch[OST_MAXCONPAIR], cm[OST_MAXCONPAIR], cb[OST_MAXCONPAIR];
      packGeom(&g2, m, d, gi);
      double tol = m->opt.mpr_tolerance;
      int it = m->opt.mpr_iterations;
      clock_t t0 = clock();
      int nh = osti_collideHField(ch, OST_MAXCONPAIR, &hf, &gt, &g2, 0.01, tol, it);
      th += (double)(clock() - t0) / CLOCKS_PER_SEC;
      t0 = clock();
      int nm = osti_collideTerrain(cm, OST_MAXCONPAIR, &t, &gt, &g2, 0.01, tol, it);
      tq += (double)(clock() - t0) / CLOCKS_PER_SEC;
      nq++;
      int nb = osti_collideTerrain(cb, OST_MAXCONPAIR, &t1, &gt, &g2, 0.01, tol, it);
      ck_assert_int_eq(nm, nh);
      ck_assert_int_eq(nb, nm);
      emax = fmax(emax, conDiff(ch, cm, nh));
      ebrute = fmax(ebrute, conDiff(cm, cb, nm));
      ncon += nh;
    }
  }
  printf("mesh (hfield triangulation) vs hfield: %d pairs %d contacts, max err %.1e; grid vs "
         "brute force %.1e; us per query: mesh %.1f (%d faces, grid %d x %d), hfield %.1f\n", nq,
         ncon, emax, ebrute, 1e6*tq/nq, t.nface, t.gnx, t.gny, 1e6*th/nq);
  ck_assert_int_gt(ncon, 100);
  ck_assert_double_le(emax, 1e-12);
  ck_assert_double_eq(ebrute, 0);
  free(grid); free(grid1); free(vert); free(face); free(buf);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


START_TEST(test_mesh_scene_pair) {
  // terrain_mesh.xml's mesh as MuJoCo loaded it (recentred, float) mapped to the world, against
  // terrain_hfield.xml's hfield; the robot geoms of both scenes at random poses
  mjModel* mh = ost_fixtureLoadModel("terrain_hfield.xml");
  mjModel* mm = ost_fixtureLoadModel("terrain_mesh.xml");
  mjData* dh = mj_makeData(mh);
  mjData* dm = mj_makeData(mm);
  ck_assert_int_eq(mm->nmesh, 1);
  ck_assert_int_eq(mm->mesh_facenum[0], 12482);
  ck_assert_str_eq(mm->text_data + mm->text_adr[0], "terrain");
  ostNum* buf = malloc(sizeof(ostNum) * mh->nhfielddata);
  ostHField hf;
  packHField(&hf, buf, mh);

  // mesh vertices to the world frame (the terrain frame: identity), faces as stored
  mj_kinematics(mm, dm);
  int nv = mm->mesh_vertnum[0], nf = mm->mesh_facenum[0], *grid;
  ostNum* vert = malloc(sizeof(ostNum) * 3*nv);
  int* face = malloc(sizeof(int) * 3*nf);
  for (int i = 0; i < nv; i++) {
    mjtNum v[3] = {mm->mesh_vert[3*i], mm->mesh_vert[3*i+1], mm->mesh_vert[3*i+2]};
    mju_rotVecMat(vert + 3*i, v, dm->geom_xmat);
    for (int k = 0; k < 3; k++) vert[3*i+k] += dm->geom_xpos[k];
  }
  for (int i = 0; i < 3*nf; i++) face[i] = mm->mesh_face[i];
  // the same surface: face f holds hfield triangle f (T1 as the hfield orders it, T2 wound
  // counter-clockwise), vertices equal to float rounding of the mesh
  double egeo = 0;
  int ncol = hf.ncol;
  double dx = 24.0 / (ncol-1), dy = 24.0 / (hf.nrow-1);
  for (int f = 0; f < nf; f++) {
    int r = (f/2) / (ncol-1), c = (f/2) % (ncol-1);
    int rc[2][3][2] = {{{r+1, c}, {r, c}, {r+1, c+1}}, {{r, c}, {r, c+1}, {r+1, c+1}}};
    for (int i = 0; i < 3; i++) {
      int vr = rc[f%2][i][0], vc = rc[f%2][i][1];
      double h[3] = {dx*vc - 12, dy*vr - 12,
                     mh->geom_pos[2] + hf.data[vr*ncol + vc]*hf.size[2]};
      for (int k = 0; k < 3; k++) egeo = fmax(egeo, fabs(vert[3*face[3*f+i]+k] - h[k]));
    }
  }
  printf("terrain_mesh.xml vertices vs terrain_hfield.xml samples: max err %.1e\n", egeo);
  // MuJoCo stores mesh vertices as floats: 1e-7 relative on coordinates of metres
  // (measured: 1.2e-6)
  ck_assert_double_le(egeo, 5e-6);

  ostTerrain t;
  memset(&t, 0, sizeof(t));
  t.nvert = nv;
  t.nface = nf;
  t.vert = vert;
  t.face = face;
  t.base = mh->geom_pos[2] - mh->hfield_size[3];
  attachGrid(&t, 0, 0, &grid);
  ostGeom gt;
  memset(&gt, 0, sizeof(gt));
  gt.mat[0] = gt.mat[4] = gt.mat[8] = 1;

  // robot at random poses: same contacts within float rounding of the mesh vertices
  srand(5);
  double ed = 0, ep = 0, en = 0;
  int ncon = 0, npair = 0, nclose = 0;
  for (int p = 0; p < 2*NPOSE; p++) {
    double* q = dh->qpos;
    q[0] = urand(-11, 11);
    q[1] = urand(-11, 11);
    q[2] = fieldHeight(mh, q[0], q[1]) + urand(0.1, 0.5);
    double ang = urand(-0.3, 0.3);
    q[3] = cos(ang); q[4] = sin(ang)*0.6; q[5] = sin(ang)*0.8; q[6] = 0;
    for (int j = 7; j < mh->nq; j++) q[j] = urand(-3, 3);
    mj_kinematics(mh, dh);
    ostGeom ghf, g2;
    packGeom(&ghf, mh, dh, 0);
    for (int gi = 1; gi < mh->ngeom; gi++) {
      ostContact ch[OST_MAXCONPAIR], cm[OST_MAXCONPAIR];
      packGeom(&g2, mh, dh, gi);
      int nh = osti_collideHField(ch, OST_MAXCONPAIR, &hf, &ghf, &g2, 0, 1e-6, 50);
      int nm = osti_collideTerrain(cm, OST_MAXCONPAIR, &t, &gt, &g2, 0, 1e-6, 50);
      if (nm != nh) {
        // a prism grazing at float-rounding depth may come and go: accept only if shallow
        double dmin = 0;
        for (int i = 0; i < nh; i++) dmin = fmin(dmin, ch[i].dist);
        printf("pair count differs (%d vs %d), deepest %.1e\n", nh, nm, dmin);
        // float rounding of the mesh (about 1e-6 m) times a margin of 10
        ck_assert_double_gt(dmin, -1e-5);
        continue;
      }
      for (int i = 0; i < nh; i++) {
        nclose += fabs(ch[i].dist - cm[i].dist) < 1e-5;
        ed = fmax(ed, fabs(ch[i].dist - cm[i].dist));
        for (int k = 0; k < 3; k++) {
          ep = fmax(ep, fabs(ch[i].pos[k] - cm[i].pos[k]));
          en = fmax(en, fabs(ch[i].frame[k] - cm[i].frame[k]));
        }
      }
      ncon += nh;
      npair++;
    }
  }
  printf("terrain_mesh.xml vs terrain_hfield.xml: %d pairs %d contacts, max err dist %.1e pos "
         "%.1e normal %.1e; %d contacts within 1e-5\n", npair, ncon, ed, ep, en, nclose);
  // MPR's answer moves discontinuously with its input: most contacts agree to 1e-5, a few (box
  // corners, grazing prisms) pick another portal after the float rounding of the mesh
  ck_assert_int_gt(ncon, 1000);
  // regression baseline (measured: 3871 of 3879 within 1e-5 at the time of writing): kept at
  // 70 % so that MPR's portal choice may change without a whole surface being wrong
  ck_assert_int_ge(nclose, 0.7*ncon);
  free(grid); free(vert); free(face); free(buf);
  mj_deleteData(dh); mj_deleteData(dm);
  mj_deleteModel(mh); mj_deleteModel(mm);
}
END_TEST

// a wheel (r 0.35, half length 0.05, axis along y, yawed by yaw about z) at (x, y, z) against a
// 41 x 41 height field of 4 x 4 m (0.1 m cells) whose elevation is z(x) = f(x), in the world
// frame (identity pose); contacts into con, returns the count
static int wheelField(ostContact* con, double (*f)(double), double x, double y, double z,
                      double yaw, double margin) {
  static ostNum data[41 * 41];
  for (int r = 0; r < 41; r++) {
    for (int c = 0; c < 41; c++) {
      data[r * 41 + c] = f(0.1 * c - 2);  // size[2] = 1: data is the elevation
    }
  }
  ostHField hf = {41, 41, {2, 2, 1, 0.5}, data};
  ostGeom ghf, cyl;
  memset(&ghf, 0, sizeof(ghf));
  memset(&cyl, 0, sizeof(cyl));
  ghf.type = OST_GEOM_HFIELD;
  ghf.mat[0] = ghf.mat[4] = ghf.mat[8] = 1;
  cyl.type = OST_GEOM_CYLINDER;
  cyl.size[0] = 0.35;
  cyl.size[1] = 0.05;
  cyl.pos[0] = x; cyl.pos[1] = y; cyl.pos[2] = z;
  cyl.rbound = sqrt(0.35 * 0.35 + 0.05 * 0.05);
  double cs = cos(yaw), sn = sin(yaw);
  double ax[3] = {cs, sn, 0}, ay[3] = {0, 0, -1}, az[3] = {-sn, cs, 0};  // columns: axes
  for (int r = 0; r < 3; r++) {
    cyl.mat[3 * r] = ax[r]; cyl.mat[3 * r + 1] = ay[r]; cyl.mat[3 * r + 2] = az[r];
  }
  return osti_collideHField(con, OST_MAXCONPAIR, &hf, &ghf, &cyl, margin, 1e-6, 50);
}

static double flatField(double x) { (void)x; return 0.2; }
static double slopeField(double x) { return 0.5 + 0.1 * x; }
static double ridgeField(double x) { return 0.5 - 0.2 * fabs(x); }


// closed-form wheel-terrain cases (Ostrich's own generator, ost_collision_cylsurf.h): flat, on a
// slope, on a ridge (edge contacts); continuity while rolling over the ridge and yawing on it
START_TEST(test_cylinder_terrain) {
  ostContact con[OST_MAXCONPAIR];
  const double r = 0.35;

  // flat, 3 mm deep: the rims' lowest points, at y = +-0.05 around the centre
  int n = wheelField(con, flatField, 0.23, 0.07, 0.2 + r - 0.003, 0, 0);
  ck_assert_int_eq(n, 2);
  for (int i = 0; i < n; i++) {
    ck_assert_double_eq_tol(con[i].dist, -0.003, 1e-14);
    ck_assert_double_eq_tol(con[i].frame[2], 1, 1e-14);
    ck_assert_double_eq_tol(fabs(con[i].pos[1] - 0.07), 0.05, 1e-14);
  }

  // on the slope z = 0.5 + 0.1 x: distance of the axis from the plane minus r
  double k = 0.1, nz = 1 / sqrt(1 + k * k), zc = 0.5 + k * 0.33 + (r - 0.002) / nz;
  n = wheelField(con, slopeField, 0.33, 0.02, zc, 0, 0);
  ck_assert_int_eq(n, 2);
  for (int i = 0; i < n; i++) {
    ck_assert_double_eq_tol(con[i].dist, -0.002, 1e-14);
    ck_assert_double_eq_tol(con[i].frame[0], -k * nz, 1e-14);
    ck_assert_double_eq_tol(con[i].frame[2], nz, 1e-14);
  }

  // right above the ridge x = 0 (a grid line), 4 mm deep: two edge contacts, vertical normal
  n = wheelField(con, ridgeField, 0, 0.05, 0.5 + r - 0.004, 0, 0);
  ck_assert_int_eq(n, 2);
  for (int i = 0; i < n; i++) {
    ck_assert_double_eq_tol(con[i].dist, -0.004, 1e-14);
    ck_assert_double_eq_tol(con[i].frame[2], 1, 1e-14);
    ck_assert_double_eq_tol(con[i].pos[0], 0, 1e-14);
  }

  // rolling over the ridge: the deepest distance is continuous (slope at most 1 in x) and so
  // is the normal's x component
  double prev_d = 0, prev_nx = 0, step = 1e-4, worst = 0;
  for (int i = 0; i <= 3000; i++) {
    double x = -0.15 + i * step;
    double zc2 = 0.5 - 0.2 * fabs(x) + r;  // about touching
    n = wheelField(con, ridgeField, x, 0.05, zc2 - 0.001, 0, 0.05);
    ck_assert_int_ge(n, 1);
    double d = 1, nx = 0;
    for (int j = 0; j < n; j++) {
      if (con[j].dist < d) {
        d = con[j].dist;
        nx = con[j].frame[0];
      }
    }
    if (i > 0) {
      worst = fmax(worst, fabs(d - prev_d) / step);
      ck_assert_msg(fabs(nx - prev_nx) < 0.01, "normal jumps at x = %g", x);
    }
    prev_d = d;
    prev_nx = nx;
  }
  ck_assert_double_le(worst, 1 + 1e-6);

  // yawing through 0 on the ridge: two contacts throughout, distances continuous
  double prev[2] = {0, 0};
  for (int i = -100; i <= 100; i++) {
    n = wheelField(con, ridgeField, 0, 0.05, 0.5 + r - 0.004, i * 1e-6, 0);
    ck_assert_int_eq(n, 2);
    if (i > -100) {
      for (int j = 0; j < 2; j++) {
        ck_assert_double_le(fabs(con[j].dist - prev[j]), 1e-6);
      }
    }
    prev[0] = con[0].dist;
    prev[1] = con[1].dist;
  }
}
END_TEST



START_TEST(test_scenes_rest) {
  // the robot starts resting on the hfield: touching at t = 0, still level after 1 s
  mjModel* m = ost_fixtureLoadModel("terrain_hfield.xml");
  mjData* d = mj_makeData(m);
  mj_forward(m, d);
  ck_assert_int_ge(d->ncon, 1);
  for (int i = 0; i < 500; i++) mj_step(m, d);
  // stock MuJoCo's soft contact sinks somewhat: 2 mm around the 0.35 m ride height is a
  // regression baseline for "touching at t = 0 and still resting"
  ck_assert_double_eq_tol(d->qpos[2], 0.35, 2e-3);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


int main(void) {
  setvbuf(stdout, NULL, _IOLBF, 0);  // keep the measurements of a failing test
  ost_fixtureSetup();
  Suite* s = suite_create("ost_collision_terrain");
  TCase* tc = tcase_create("terrain");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_hfield_level);
  tcase_add_test(tc, test_hfield_tilted_margin);
  tcase_add_test(tc, test_hfield_margin_gap);
  tcase_add_test(tc, test_hfield_cap);
  tcase_add_test(tc, test_mesh_equals_hfield);
  tcase_add_test(tc, test_mesh_scene_pair);
  tcase_add_test(tc, test_scenes_rest);
  tcase_add_test(tc, test_cylinder_terrain);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
