// pool.h: Append/Consume buffers (HLSL AppendStructuredBuffer / ConsumeStructuredBuffer) on an explicit counter.
// Host side: ugpcl.buffers.Pool, whose `counter` buffer is int[2] = {count, refused appends}.
//
//   slot = pool_append(counter, capacity);  if (slot >= 0) items[slot] = x;    // HLSL: buf.Append(x)
//   slot = pool_consume(counter);           if (slot >= 0) x = items[slot];    // HLSL: x = buf.Consume()
//   pool_append_index(counter, items, capacity, i);                          // HLSL: buf.Append(i), i an int
//
// The host reads the count (the book's CopyCount) and never dispatches more consumers than there are items,
// so pool_consume's empty branch is a safety net, not a code path. Do not append and consume the same pool in
// one launch: the clamp/undo below is correct for concurrent appends or concurrent consumes, not a mix.
#ifndef UGPCL_POOL_H
#define UGPCL_POOL_H

#define POOL_COUNT 0    // counter[POOL_COUNT]: items in the pool
#define POOL_REFUSED 1  // counter[POOL_REFUSED]: appends refused because the pool was full

// Reserve a slot for one item; returns the slot, or -1 when the pool is full.
inline int pool_append(volatile __global int* counter, int capacity) {
    int slot = atomic_inc(&counter[POOL_COUNT]);  // old count = first free slot
    if (slot >= capacity) {                       // full: undo, so the count never stays above capacity
        atomic_dec(&counter[POOL_COUNT]);
        atomic_inc(&counter[POOL_REFUSED]);
        return -1;
    }
    return slot;
}

// Take one item; returns its slot, or -1 when the pool is empty.
inline int pool_consume(volatile __global int* counter) {
    int old = atomic_dec(&counter[POOL_COUNT]);  // old count; the last item sits at old - 1
    if (old <= 0) {                              // empty: undo, so the count never goes negative
        atomic_inc(&counter[POOL_COUNT]);
        return -1;
    }
    return old - 1;
}

// Append an int (an index pool, a list of indices): items[slot] = index in the slot pool_append reserved; nothing
// when the pool is full (the refusal is counted in counter[POOL_REFUSED]).
inline void pool_append_index(volatile __global int* counter, __global int* items, int capacity, int index) {
    const int slot = pool_append(counter, capacity);  // old count = where this index goes, or -1: full
    if (slot >= 0) items[slot] = index;
}

#endif
