// ost_check.h: the refusal list shared by the model checks (ost_check.c: what Ostrich models;
// ost_pack.c: what the native geometry provider represents), not public. A check visits every
// element of the model and adds one refusal per (element, unsupported feature); refusals with
// the same element kind and feature text are grouped into one ostRefusal with a count and the
// first OST_REFUSAL_NAMES element names, so a message names every feature once.
// Invariant: adding to a list never allocates and never fails; a full list counts what it
// cannot store in `extra`.
#ifndef OSTRICH_PLUGIN_OST_CHECK_H_
#define OSTRICH_PLUGIN_OST_CHECK_H_

#include <mujoco/mujoco.h>

#include "ostrich.h"

#define OST_REFUSAL_CAP 32        // features a check keeps before it only counts

typedef struct ostRefusalList_ {  // refusals found so far
  ostRefusal* item;               // grouped features                                   (cap)
  int         cap;                // capacity of item
  int         n;                  // features stored
  int         extra;              // refusals of features that did not fit
} ostRefusalList;

// Name of object i of a type into buf, or "#i" when unnamed; returns buf.
const char* ost_objName(const mjModel* m, int type, int i, char* buf, int sz);

// Add one refusal: element kind `what` ("" for the whole model), element name, feature text.
void ost_refuse(ostRefusalList* l, const char* what, const char* name, const char* fmt, ...)
    __attribute__((format(printf, 4, 5)));

// Every feature of m that Ostrich does not model, into l (ost_check.c).
void ost_refusalsModel(const mjModel* m, ostRefusalList* l);

// Every feature of m that the native geometry provider cannot represent, into l (ost_pack.c).
void ost_refusalsNative(const mjModel* m, ostRefusalList* l);

// Format a list as "<prefix> N features of this model: A; B; ..." into err; entries that do not
// fit become "; ... and K more". Returns OST_OK for an empty list, else OST_ERR_MODEL.
int ost_refusalMessage(const ostRefusalList* l, const char* prefix, char* err, int err_sz);

#endif  // OSTRICH_PLUGIN_OST_CHECK_H_
