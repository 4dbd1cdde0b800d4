#pragma once
// Contact sub-models are tiny and called once per contact per step: they must
// be inlined into the kernels, whatever the compiler's size heuristics say.
#if defined(__GNUC__)
#define MLCG_INLINE inline __attribute__((always_inline))
#else
#define MLCG_INLINE inline
#endif
