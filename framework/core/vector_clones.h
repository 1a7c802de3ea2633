// Hot loops compiled twice and picked once at load time: wide vectors where the CPU has them
// (AVX2 + FMA, x86-64-v3), the baseline (SSE2) otherwise. On a function whose loops the
// compiler vectorises; a lambda inside such a function is not inlined into the clones, so
// helpers are [[gnu::always_inline]] functions.
#pragma once

#if defined(__clang__)
// clang 14 (the sanitizer and fuzzer build) takes no "arch=" clone: one baseline version.
#define DSNAKE_VECTOR_CLONES
#else
#define DSNAKE_VECTOR_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#endif

// A two-vector lane shuffle with constant lane indices (0..n-1 from a, n..2n-1 from b), spelled
// for GCC (__builtin_shuffle with an index vector of type IndexVec) and clang
// (__builtin_shufflevector with the indices as arguments).
#if defined(__clang__)
#define DSNAKE_SHUFFLE2(a, b, IndexVec, ...) __builtin_shufflevector(a, b, __VA_ARGS__)
#else
#define DSNAKE_SHUFFLE2(a, b, IndexVec, ...) __builtin_shuffle(a, b, IndexVec{__VA_ARGS__})
#endif
