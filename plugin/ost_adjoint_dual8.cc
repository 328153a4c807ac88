// ost_adjoint_dual8.cc: ost_adjoint_dual.cc with 8 directions per dual pass (ostd8_* entry
// points). Steps use 2 (ost_adjoint_dual.cc); this build is the tests' check that directions are
// computed each on its own (the same bits at any width, tests/test_adjoint_oracle.c).
#define OSTX_CHUNK 8
#include "ost_adjoint_dual.cc"
