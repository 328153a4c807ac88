// ost_hd.h: the host+device shared-source shim for core/.
// Mirrors MuJoCo's mjtnum.h/engine_inline.h: one definition of the scalar type and of the
// qualifiers that let every per-world function (osti_*) compile under gcc and nvcc alike.
// Invariant: nothing here allocates, prints or touches MuJoCo.
#ifndef OSTRICH_CORE_OST_HD_H_
#define OSTRICH_CORE_OST_HD_H_

#ifdef __CUDACC__
#define OST_HD __host__ __device__ static inline
#else
#define OST_HD static inline
#endif

#ifdef __cplusplus
#define OST_RESTRICT __restrict__
#define OST_STATIC_ASSERT(c, msg) static_assert(c, msg)
#else
#define OST_RESTRICT restrict
#define OST_STATIC_ASSERT(c, msg) _Static_assert(c, msg)
#endif

// scalar type of the solver (double, like mjtNum by default); C++ may substitute a class type,
// e.g. ostDual<8> from ost_dual.h for forward-mode derivatives
#ifdef OST_NUM_TYPE
typedef OST_NUM_TYPE ostNum;
#elif defined(OST_USE_FLOAT)
typedef float ostNum;
#else
typedef double ostNum;
#endif

// internal invariants: on in Debug and tests, off in Release (Lua's lua_assert)
#if defined(OST_DEBUG) && !defined(__CUDA_ARCH__)
#include <assert.h>
#define OST_ASSERT(c) assert(c)
#else
#define OST_ASSERT(c) ((void)0)
#endif

#endif  // OSTRICH_CORE_OST_HD_H_
