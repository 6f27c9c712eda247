#pragma once
// Function multi-versioning for hot loops: GCC/Clang compile one clone per
// instruction set and glibc's ifunc resolver picks the best one at load time,
// so one binary uses AVX-512 or AVX2 where present and SSE2 elsewhere.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(__SANITIZE_ADDRESS__)
#define MUCOSA_TARGET_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define MUCOSA_TARGET_CLONES
#endif
