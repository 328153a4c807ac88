// ost_cli_bench_humanoids.c: the models of N copies of MuJoCo's humanoid that `ostrich bench
// models --scaling` times (the driver is ost_cli_bench_models.c): a small copier of MJCF text
// that repeats the top-level bodies and the per-model sections, prefixes names, places the copies
// on a grid, and writes and loads the result in the driver's scratch directory.
// Invariant: the copy is textual and leaves every attribute it does not rename or move as the
// source has it; a copy that cannot be written or loaded is reported once and its file removed.
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "ost_cli_bench_models.h"
#include "ost_cli_util.h"

#define MODELS_MAX_BODIES  256    // top-level bodies of the --humanoid file


//---------------------------------- Copier --------------------------------------------------------
// The generated model is the --humanoid file with each top-level <body> of its <worldbody> and
// the contents of its <actuator>, <tendon>, <sensor>, <contact> and <equality> sections repeated
// N times. Copy k prefixes "hk_" to every name and every name reference (joint=, body1=,
// target=, ...); assets and default classes are shared, so class=, material= and mesh= are
// not prefixed. The other <worldbody> children (floor, lights) appear once, their references
// pointing at copy 0. Copies sit on a square grid MODELS_SPACING apart (copy 0 of N = 1 at the
// source's place); <keyframe> is dropped (its sizes no longer fit) and a last <size> element
// sets nconmax and njmax.

static const char* kRefAttrs[] = {  // attributes that hold names (entry 0: the name itself)
  "name", "joint", "joint1", "joint2", "jointinparent", "body", "body1", "body2", "geom",
  "geom1", "geom2", "site", "tendon", "tendon1", "tendon2", "target", "objname", "refname",
  "actuator", "refsite", "slidersite", "cranksite", "sidesite"};

typedef struct xmlTag_ {          // one tag: text [start, end)
  const char* start;
  const char* end;
  char name[32];
  int  kind;                      // 1 open, 0 empty (<x/>), -1 close, 2 other (<?, <!)
} xmlTag;


// the next tag at or after p; 0 if none
static int xmlNext(const char* p, xmlTag* t) {
  const char* s = strchr(p, '<');
  const char* e = s ? strchr(s, '>') : NULL;
  if (!e) {
    return 0;
  }
  t->start = s;
  t->end = e + 1;
  const char* n = s + 1 + (s[1] == '/');
  size_t len = strcspn(n, " \t\r\n/>");
  snprintf(t->name, sizeof(t->name), "%.*s", (int)len, n);
  t->kind = s[1] == '/' ? -1 : (s[1] == '?' || s[1] == '!') ? 2 : e[-1] == '/' ? 0 : 1;
  return 1;
}


// the close tag that matches an open tag ending at p
static int xmlMatch(const char* p, xmlTag* close) {
  for (int depth = 1; xmlNext(p, close); p = close->end) {
    depth += close->kind == 1 ? 1 : close->kind == -1 ? -1 : 0;
    if (depth == 0) {
      return 1;
    }
  }
  return 0;
}


// write text [s, s + n) with prefix put before every name reference, and before every name
// if names
static void genRename(FILE* f, const char* s, size_t n, const char* prefix, int names) {
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && (isalnum((unsigned char)s[j]) || s[j] == '_')) {
      j++;
    }
    int attr = j > i && (i == 0 || isspace((unsigned char)s[i - 1])) && j + 1 < n
               && s[j] == '=' && (s[j + 1] == '"' || s[j + 1] == '\'');
    for (int k = names ? 0 : 1; attr && k < (int)(sizeof(kRefAttrs) / sizeof(char*)); k++) {
      if (strlen(kRefAttrs[k]) == j - i && !strncmp(s + i, kRefAttrs[k], j - i)) {
        fprintf(f, "%.*s%s", (int)(j + 2 - i), s + i, prefix);
        i = j + 2;
        attr = 2;
        break;
      }
    }
    if (attr != 2) {
      fwrite(s + i, 1, j > i ? j - i : 1, f);
      i = j > i ? j : i + 1;
    }
  }
}


// write a top-level body's open tag t with pos moved by (dx, dy), renamed for copy prefix
static void genBodyTag(FILE* f, const xmlTag* t, double dx, double dy, const char* prefix) {
  char tag[2048];
  double x = 0, y = 0, z = 0;
  const char* pos = NULL;
  for (const char* p = t->start; (p = strstr(p, "pos=")) && p < t->end; p++) {
    if (isspace((unsigned char)p[-1])) {
      pos = p;
      break;
    }
  }
  if (pos) {
    char* e;
    x = strtod(pos + 5, &e);
    y = strtod(e, &e);
    z = strtod(e, &e);
    const char* rest = strchr(pos + 5, pos[4]) + 1;
    snprintf(tag, sizeof(tag), "%.*spos=\"%.9g %.9g %.9g\"%.*s", (int)(pos - t->start), t->start,
             x + dx, y + dy, z, (int)(t->end - rest), rest);
  } else {
    size_t head = strlen(t->name) + 1;
    snprintf(tag, sizeof(tag), "%.*s pos=\"%.9g %.9g 0\"%.*s", (int)head, t->start, dx, dy,
             (int)(t->end - t->start - head), t->start + head);
  }
  genRename(f, tag, strlen(tag), prefix, 1);
}


// write the <worldbody> element whose open tag is t and close tag c, with ncopy copies
static int genWorld(FILE* f, const xmlTag* t, const xmlTag* c, int ncopy) {
  xmlTag body[MODELS_MAX_BODIES], bodyend[MODELS_MAX_BODIES], u, v;
  int nbody = 0;
  fwrite(t->start, 1, t->end - t->start, f);
  for (const char* p = t->end; xmlNext(p, &u) && u.start < c->start; p = v.end) {
    v = u;
    if (u.kind == 1 && !xmlMatch(u.end, &v)) {
      return 1;
    }
    if (!strcmp(u.name, "body") && u.kind == 1 && nbody < MODELS_MAX_BODIES) {
      body[nbody] = u;
      bodyend[nbody++] = v;
    } else if (u.kind != 2) {
      fputs("\n    ", f);
      genRename(f, u.start, v.end - u.start, "h0_", 0);
    }
  }
  int ncol = (int)ceil(sqrt(ncopy));
  for (int k = 0; k < ncopy; k++) {
    char prefix[16];
    snprintf(prefix, sizeof(prefix), "h%d_", k);
    double dx = MODELS_SPACING * (k % ncol - 0.5 * (ncol - 1));
    double dy = MODELS_SPACING * (k / ncol - 0.5 * ((ncopy - 1) / ncol));
    for (int b = 0; b < nbody; b++) {
      fputs("\n    ", f);
      genBodyTag(f, body + b, dx, dy, prefix);
      genRename(f, body[b].end, bodyend[b].end - body[b].end, prefix, 1);
    }
  }
  fputs("\n  ", f);
  fwrite(c->start, 1, c->end - c->start, f);
  return nbody == 0 || nbody == MODELS_MAX_BODIES;
}


// write N copies of the model text src (comments removed) to path; 0 on success
static int genHumanoids(const char* src, int ncopy, int nconmax, int njmax, const char* path) {
  static const char* repeat[] = {"actuator", "tendon", "sensor", "contact", "equality"};
  FILE* f = fopen(path, "w");
  int bad = !f, depth = 0;
  xmlTag t, c;
  const char* p = src;
  while (!bad && xmlNext(p, &t)) {
    fwrite(p, 1, t.start - p, f);
    p = t.end;
    int section = -1;
    for (int i = 0; i < 5; i++) {
      section = strcmp(t.name, repeat[i]) ? section : i;
    }
    if (depth == 1 && t.kind == 1 && (section >= 0 || !strcmp(t.name, "worldbody")
                                      || !strcmp(t.name, "keyframe"))) {
      bad = !xmlMatch(t.end, &c);
      if (!bad && section >= 0) {
        fwrite(t.start, 1, t.end - t.start, f);
        for (int k = 0; k < ncopy; k++) {
          char prefix[16];
          snprintf(prefix, sizeof(prefix), "h%d_", k);
          genRename(f, t.end, c.start - t.end, prefix, 1);
        }
        fwrite(c.start, 1, c.end - c.start, f);
      } else if (!bad && !strcmp(t.name, "worldbody")) {
        bad = genWorld(f, &t, &c, ncopy);
      }
      p = bad ? p : c.end;
      continue;
    }
    if (depth == 1 && t.kind == -1 && !strcmp(t.name, "mujoco")) {
      fprintf(f, "<size nconmax=\"%d\" njmax=\"%d\"/>\n", nconmax, njmax);
    }
    fwrite(t.start, 1, t.end - t.start, f);
    depth += t.kind == 1 ? 1 : t.kind == -1 ? -1 : 0;
  }
  if (f) {
    fputs(p, f);
    bad = fclose(f) || bad;
  }
  return bad;
}


//---------------------------------- Source and model ----------------------------------------------

char* bench_models_readSource(const char* path) {
  FILE* f = fopen(path, "rb");
  char* s = NULL;
  long n = -1;
  if (f && !fseek(f, 0, SEEK_END) && (n = ftell(f)) >= 0 && !fseek(f, 0, SEEK_SET)) {
    s = (char*)malloc(n + 1);
  }
  if (s && fread(s, 1, n, f) != (size_t)n) {
    free(s);
    s = NULL;
  }
  if (f) {
    fclose(f);
  }
  if (s) {
    s[n] = 0;
    char *out = s, *c;
    for (char* in = s; *in;) {
      if (!strncmp(in, "<!--", 4) && (c = strstr(in + 4, "-->"))) {
        in = c + 3;
      } else {
        *out++ = *in++;
      }
    }
    *out = 0;
  }
  return s;
}


int bench_models_makeHumanoids(const char* src, const char* humanoid, int n, int nv1,
                               const char* dir, char* path, int path_sz, mjModel** m, mjData** d,
                               int* njmax) {
  // MuJoCo 2.2.2 sizes efc_AR as njmax^2 and efc_J as njmax x nv in one int-sized buffer
  int nconmax = 40 * n, nj = MODELS_NJMAX_COPY * n;
  while (12.0 * nj * nj + 24.0 * nj * nv1 * n > 1.5e9) {
    nj = nj * 9 / 10;
  }
  *njmax = nj;

  // write the copies, load them and check that the sizes were taken
  char err[CLI_MSG_SZ] = "";
  snprintf(path, path_sz, "%s/humanoids_%d.xml", dir, n);
  *m = genHumanoids(src, n, nconmax, nj, path) ? NULL : mj_loadXML(path, NULL, err, sizeof(err));
  *d = *m ? mj_makeData(*m) : NULL;
  if (!*d || (*m)->nconmax < nconmax || (*m)->njmax < nj) {
    cli_oneLine(err);
    cli_error("bench models: cannot make the model of %d copies of %s: %s", n, humanoid,
              err[0] ? err : *m ? "nconmax/njmax not set, or out of memory" : "cannot write");
    mj_deleteData(*d);
    mj_deleteModel(*m);
    *d = NULL;
    *m = NULL;
    remove(path);
    return 1;
  }
  return 0;
}
