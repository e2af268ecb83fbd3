// grid.cl: uniform-grid neighbour search by sorting (cell, index) keys (grid.h; host ugpcl.grid.UniformGrid).
// Not a book chapter: the books' summaries (boids 3.6, space colonization, SPH) name a grid as the way past the
// all-pairs loops. Sorting the keys with a bitonic network makes the order within a cell the item order, so every
// run visits neighbours in the same order (a counting sort's atomic scatter would not).
// Kernels, in host call order of UniformGrid.build():
//   1. GridHash             item positions (any float layout: stride/offset in floats) -> keys; padding -> EMPTY
//   2. BitonicSortStep      keys -> keys, one compare-exchange stage (j, k) of the network per launch
//   3. GridClearCells       cell_start = cell_end = 0
//   4. GridFindCellRanges   sorted keys -> cell_start, cell_end
//   GridCountNeighbours     items within a radius, found through the grid (tests, and a template for chapters)
//   GridListNeighbours      the items grid.h's neighbour loop visits around each item, in visiting order (tests)
#include "grid.h"

__kernel void GridHash(const __global float* items, int stride, int offset, int n, int padded,
                       float4 origin, float cell_size, int4 dims, __global ulong* keys) {
    const int i = get_global_id(0);
    if (i >= padded) return;
    if (i >= n) {
        keys[i] = GRID_EMPTY_KEY;
        return;
    }
    const __global float* p = items + (size_t)i * stride + offset;
    const float3 position = (float3)(p[0], p[1], dims.z > 1 ? p[2] : 0.0f);  // 2D items need only x, y
    const int cell = grid_cell_id(grid_cell_coord(position, origin.xyz, cell_size, dims), dims);
    keys[i] = ((ulong)cell << 32) | (ulong)i;
}

// One stage of the bitonic network over `padded` (a power of two) keys: k = size of the sorted runs being
// merged, j = compare distance. Each work-item owns one pair (i, i ^ j) with i < partner, so no two work-items
// touch the same key.
__kernel void BitonicSortStep(__global ulong* keys, int j, int k) {
    const int t = get_global_id(0);                     // pair number, 0 .. padded/2 - 1
    const int i = (t / j) * 2 * j + (t % j);            // lower index of the pair
    const int partner = i + j;
    const bool ascending = (i & k) == 0;
    const ulong a = keys[i], b = keys[partner];
    if ((a > b) == ascending) {
        keys[i] = b;
        keys[partner] = a;
    }
}

__kernel void GridClearCells(__global int* cell_start, __global int* cell_end, int num_cells) {
    const int c = get_global_id(0);
    if (c >= num_cells) return;
    cell_start[c] = 0;
    cell_end[c] = 0;
}

// Each sorted key that begins a run of its cell writes the run's start; each that ends one writes its end.
__kernel void GridFindCellRanges(const __global ulong* keys, int n, __global int* cell_start, __global int* cell_end) {
    const int k = get_global_id(0);
    if (k >= n || keys[k] == GRID_EMPTY_KEY) return;  // empty keys (items a hash kernel left out) sort last
    const int cell = grid_key_cell(keys[k]);
    if (k == 0 || grid_key_cell(keys[k - 1]) != cell) cell_start[cell] = k;
    if (k == n - 1 || keys[k + 1] == GRID_EMPTY_KEY || grid_key_cell(keys[k + 1]) != cell) cell_end[cell] = k + 1;
}

__kernel void GridCountNeighbours(const __global float* items, int stride, int offset, int n, float radius,
                                  float4 origin, float cell_size, int4 dims, const __global ulong* keys,
                                  const __global int* cell_start, const __global int* cell_end, __global int* count) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const __global float* p = items + (size_t)i * stride + offset;
    const float3 me = (float3)(p[0], p[1], dims.z > 1 ? p[2] : 0.0f);
    const int4 home = grid_cell_coord(me, origin.xyz, cell_size, dims);
    int found = 0;
    GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end) {
        const __global float* q = items + (size_t)grid_item(keys[k]) * stride + offset;
        const float3 other = (float3)(q[0], q[1], dims.z > 1 ? q[2] : 0.0f);
        const float3 d = me - other;
        if (dot(d, d) <= radius * radius) found++;  // counts the item itself
    }
    count[i] = found;
}

// The first `max_found` items the neighbour loop visits around item i, in the order it visits them, then -1s: the
// order grid.h promises (cells in increasing id, a cell's items in increasing index), checked by tests/test_grid.py.
__kernel void GridListNeighbours(const __global float* items, int stride, int offset, int n, float4 origin,
                                 float cell_size, int4 dims, const __global ulong* keys, const __global int* cell_start,
                                 const __global int* cell_end, int max_found, __global int* found) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const __global float* p = items + (size_t)i * stride + offset;
    const float3 me = (float3)(p[0], p[1], dims.z > 1 ? p[2] : 0.0f);
    __global int* out = found + (size_t)i * max_found;
    const int4 home = grid_cell_coord(me, origin.xyz, cell_size, dims);
    int count = 0;
    GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end) {
        if (count < max_found) out[count++] = grid_item(keys[k]);
    }
    for (; count < max_found; count++) out[count] = -1;
}
