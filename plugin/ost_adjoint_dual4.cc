// ost_adjoint_dual4.cc: ost_adjoint_dual.cc with 4 directions per dual pass (ostd4_* entry
// points), for models of nv <= 4; ost_adjoint_dual.cc's ostd_* entry points choose it.
#define OSTX_CHUNK 4
#include "ost_adjoint_dual.cc"
