// random.cl: random.h's Philox-4x32-10 on its own (ugpcl.random; tests/test_random.py). Not a book chapter: the
// counter-based generator the chapters that need reproducible random numbers draw from (random.h says why).
// Kernels:
//   1. PhiloxFill  counters[i] under key -> bits[i] = philox4x32_10(counters[i], key),
//                  uniforms[i] = philox_uniform4(counters[i], key), for i < n
// Build defines: none.
#include "random.h"  // philox4x32_10, philox_uniform4

__kernel void PhiloxFill(const __global uint4* counters, int n, uint2 key, __global uint4* bits,
                         __global float4* uniforms) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const uint4 counter = counters[i];
    bits[i] = philox4x32_10(counter, key);
    uniforms[i] = philox_uniform4(counter, key);
}
