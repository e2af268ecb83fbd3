// scan.h: the prefix sum of one value per work-item across a work-group (Hillis-Steele in __local memory), the
// building block of the block-wise scans (grid.cl's GridScanBlocks: the host scans the block totals the same way
// and adds them back).
#ifndef UGPCL_SCAN_H
#define UGPCL_SCAN_H

// The inclusive prefix sum of `own` over the work-items of the group, in local-id order (subtract `own` for the
// exclusive one; the last work-item's result is the group's total). `sums` holds get_local_size(0) values; every
// work-item of the group must call it, as it has barriers.
inline uint scan_group_inclusive(uint own, __local uint* sums) {
    const int lid = get_local_id(0), size = get_local_size(0);
    sums[lid] = own;
    barrier(CLK_LOCAL_MEM_FENCE);  // every value stored before anyone reads a neighbour's
    for (int offset = 1; offset < size; offset <<= 1) {
        const uint add = lid >= offset ? sums[lid - offset] : 0u;
        barrier(CLK_LOCAL_MEM_FENCE);  // all reads of this round done before anyone overwrites
        sums[lid] += add;
        barrier(CLK_LOCAL_MEM_FENCE);  // all writes of this round done before the next round reads
    }
    return sums[lid];
}

#endif
