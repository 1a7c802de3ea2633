// Hot loops compiled twice and picked once at load time: wide vectors where the CPU has them
// (AVX2 + FMA, x86-64-v3), the baseline (SSE2) otherwise. On a function whose loops the
// compiler vectorises; a lambda inside such a function is not inlined into the clones, so
// helpers are [[gnu::always_inline]] functions.
#pragma once

#define DSNAKE_VECTOR_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
