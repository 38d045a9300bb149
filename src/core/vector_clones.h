// Internal to the core library: loops compiled once per SIMD width.
#pragma once

// Each function so marked is compiled three times, for AVX-512, for AVX2 and for the x86-64 baseline
// (SSE2), and the loader picks the widest the processor runs (GCC's target_clones, an ifunc): the package
// keeps building for every x86-64 machine and still uses 4 or 8 lanes where they exist. With
// -ffp-contract=off (CMakeLists) every clone rounds exactly like the others, so the results are the same
// bits on every machine.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define CLOTH_SIM_VECTOR_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define CLOTH_SIM_VECTOR_CLONES
#endif
