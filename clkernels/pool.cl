// pool.cl: the Append/Consume pool of pool.h exercised on its own (ugpcl.buffers.Pool; tests/test_pool.py).
// Kernels:
//   1. AppendMultiples  i in [0, n) with i % every == 0 -> pool   (many work-items appending at once)
//   2. ConsumeInto      pool -> out[i] for i in [0, n)            (out[i] = -1 when the pool was empty)
#include "pool.h"

__kernel void AppendMultiples(volatile __global int* counter, __global int* items, int capacity, int n, int every) {
    int i = get_global_id(0);
    if (i >= n || i % every != 0) return;
    pool_append_index(counter, items, capacity, i);
}

__kernel void ConsumeInto(volatile __global int* counter, const __global int* items, __global int* out, int n) {
    int i = get_global_id(0);
    if (i >= n) return;
    int slot = pool_consume(counter);
    out[i] = slot >= 0 ? items[slot] : -1;
}
