// grid.cl: uniform-grid neighbour search by a counting sort of (cell, index) keys (grid.h; host ugpcl.grid).
// Not a book chapter: the books' summaries (boids 3.6, space colonization, SPH) name a grid as the way past the
// all-pairs loops. A counting sort (histogram, prefix sum, scatter) costs a few passes over the items and cells where
// the bitonic network it replaces took log2(N)^2 / 2 launches. Its atomic scatter leaves each cell's items in
// arrival order, so a last pass puts every cell's run in item order: every run visits neighbours in the same order.
// Kernels, in host call order of UniformGrid.build() (cell_count is all zeros between builds):
//   1. GridHash             item positions (any float layout: stride/offset in floats) -> hash_keys (item i's at i);
//                           cell_count[cell] += 1, tickets[i] = the item's arrival number in its cell
//      GridCountCells       the same count for keys a chapter's own hash kernel wrote (UniformGrid.sort)
//   2. GridScanBlocks, GridAddBlockOffsets  cell_count -> cell_start (exclusive prefix sum), cell_end (inclusive),
//                           cell_count = 0 again: GRID_SCAN_BLOCK cells per work-group, the block totals scanned
//                           the same way one level up (the host recurses) and added back
//   3. GridScatter          hash_keys, tickets -> scattered[cell_start[cell] + ticket]: grouped by cell
//   4. GridSortCells        scattered -> keys: each key to its rank in its cell's run (the cell in item order)
//   5. GridCopyItemsInCellOrder  items -> sorted_items: item records in key order (UniformGrid.copy_in_cell_order;
//                           optional: for neighbour kernels that run one work-item per sorted slot)
//   GridCountNeighbours     items within a radius, found through the grid (tests, and a template for chapters)
//   GridListNeighbours      the items grid.h's neighbour loop visits around each item, in visiting order (tests)
// Build defines: none (GRID_SCAN_GROUP, GRID_SCAN_SPAN below shape GridScanBlocks; ugpcl/grid.py mirrors them).
// Atomics: the atomic_inc per key on its cell's count (GridHash, GridCountCells); the tickets' order varies from
// run to run, the keys' final order does not. Races: none; every other kernel writes only its own slots.
// Keys a chapter's own hash kernel leaves out (GRID_EMPTY_KEY: space colonization's inactive nodes) own no cell and
// fill the slots after the last cell's items, where a full sort of the keys would put them.
#include "grid.h"
#include "scan.h"  // scan_group_inclusive

#define GRID_SCAN_GROUP 256                                 // work-items per group of GridScanBlocks
#define GRID_SCAN_SPAN 8                                    // consecutive cells each work-item scans
#define GRID_SCAN_BLOCK (GRID_SCAN_GROUP * GRID_SCAN_SPAN)  // cells per group: one launch scans up to 2048 cells

__kernel void GridHash(const __global float* items, int stride, int offset, int n, float4 origin, float cell_size,
                       int4 dims, __global ulong* hash_keys, volatile __global int* cell_count, __global int* tickets) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const __global float* p = items + (size_t)i * stride + offset;
    const float3 position = (float3)(p[0], p[1], dims.z > 1 ? p[2] : 0.0f);  // 2D items need only x, y
    const int cell = grid_cell_id(grid_cell_coord(position, origin.xyz, cell_size, dims), dims);
    hash_keys[i] = ((ulong)cell << 32) | (ulong)i;
    tickets[i] = atomic_inc(&cell_count[cell]);
}

__kernel void GridCountCells(const __global ulong* hash_keys, int n, volatile __global int* cell_count,
                             __global int* tickets) {
    const int k = get_global_id(0);
    if (k >= n || hash_keys[k] == GRID_EMPTY_KEY) return;
    tickets[k] = atomic_inc(&cell_count[grid_key_cell(hash_keys[k])]);
}

// Prefix sums of the n `counts`, GRID_SCAN_BLOCK per work-group (GRID_SCAN_SPAN consecutive ones per work-item):
// exclusive[i] = the sum of the block's counts before i, inclusive[i] = exclusive[i] + counts[i]; counts[i] = 0
// (ready for the next build); the block's total goes to block_sums[group].
__kernel __attribute__((reqd_work_group_size(GRID_SCAN_GROUP, 1, 1)))
void GridScanBlocks(__global int* counts, __global int* exclusive, __global int* inclusive, __global int* block_sums,
                    int n) {
    __local uint sums[GRID_SCAN_GROUP];
    const int first = get_global_id(0) * GRID_SCAN_SPAN;
    int own[GRID_SCAN_SPAN], total = 0;
    for (int s = 0; s < GRID_SCAN_SPAN; s++) {
        own[s] = first + s < n ? counts[first + s] : 0;
        total += own[s];
    }
    int running = (int)scan_group_inclusive((uint)total, sums) - total;  // the group's counts before this one's
    for (int s = 0; s < GRID_SCAN_SPAN && first + s < n; s++) {
        exclusive[first + s] = running;
        running += own[s];
        inclusive[first + s] = running;
        counts[first + s] = 0;
    }
    if (get_local_id(0) == GRID_SCAN_GROUP - 1) block_sums[get_group_id(0)] = running;  // counts past n are 0
}

// Both sums of value i += the sum of all earlier blocks (block_offsets: the exclusive scan of the block totals).
__kernel void GridAddBlockOffsets(__global int* exclusive, __global int* inclusive, const __global int* block_offsets,
                                  int n) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const int add = block_offsets[i / GRID_SCAN_BLOCK];
    exclusive[i] += add;
    inclusive[i] += add;
}

__kernel void GridScatter(const __global ulong* hash_keys, const __global int* tickets, int n,
                          const __global int* cell_start, __global ulong* scattered) {
    const int k = get_global_id(0);
    if (k >= n || hash_keys[k] == GRID_EMPTY_KEY) return;
    scattered[cell_start[grid_key_cell(hash_keys[k])] + tickets[k]] = hash_keys[k];
}

// Slot p's key goes to its cell's start + the number of smaller keys in the cell's run: the run in item order, the
// same on every run. O(items of the cell) per key, which the neighbour loop (9 or 27 such cells per item) dwarfs.
// Slots past the last cell's items get the keys a hash kernel left empty.
__kernel void GridSortCells(const __global ulong* scattered, int n, const __global int* cell_start,
                            const __global int* cell_end, int num_cells, __global ulong* keys) {
    const int p = get_global_id(0);
    if (p >= n) return;
    if (p >= cell_end[num_cells - 1]) {  // the inclusive sum of the last cell: every cell's items
        keys[p] = GRID_EMPTY_KEY;
        return;
    }
    const ulong key = scattered[p];
    const int cell = grid_key_cell(key), start = cell_start[cell], end = cell_end[cell];
    int rank = 0;
    for (int q = start; q < end; q++) rank += scattered[q] < key;
    keys[start + rank] = key;
}

// Record k of sorted_items = the record of the item of key k (records of record_float4s float4s; slots of empty keys
// are left alone). A neighbour kernel that runs one work-item per sorted slot and reads its neighbours from this
// copy reads each cell's items from consecutive addresses, the same ones for every work-item of a cell, where
// keys[k] -> items[grid_item] gathers one scattered record per neighbour (on a GPU: a memory transaction per lane).
__kernel void GridCopyItemsInCellOrder(const __global float4* items, int record_float4s, int n,
                                       const __global ulong* keys, __global float4* sorted_items) {
    const int k = get_global_id(0);
    if (k >= n || keys[k] == GRID_EMPTY_KEY) return;
    const __global float4* from = items + (size_t)grid_item(keys[k]) * record_float4s;
    __global float4* to = sorted_items + (size_t)k * record_float4s;
    for (int f = 0; f < record_float4s; f++) to[f] = from[f];
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
