#pragma once
/// FISSURE_ASSERT: programmer errors only, active in Debug builds. User data is
/// checked with fissure::Error instead (see error.h).

#include <cstdio>
#include <cstdlib>

#if defined(FISSURE_ENABLE_ASSERTS)
#define FISSURE_ASSERT(cond)                                                              \
  do {                                                                                    \
    if (!(cond)) {                                                                        \
      std::fprintf(stderr, "%s:%d: assertion failed: %s\n", __FILE__, __LINE__, #cond);   \
      std::abort();                                                                       \
    }                                                                                     \
  } while (false)
#else
#define FISSURE_ASSERT(cond) ((void)sizeof(cond))
#endif
