"""Buffers every chapter shares: ``Pool`` (Append/Consume), ``PingPong`` (read/write pair) and struct checks.

HLSL's AppendStructuredBuffer/ConsumeStructuredBuffer have a hidden counter; here the counter is explicit.
A ``Pool`` is an item buffer plus a two-int counter buffer ``[count, refused]``; kernels use
``clkernels/include/pool.h`` (``pool_append`` = ``atomic_inc``, ``pool_consume`` = ``atomic_dec``).
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pyopencl.array as cla

from .runtime import Runtime

COUNT, REFUSED = 0, 1  # slots of a pool's counter buffer (pool.h: POOL_COUNT, POOL_REFUSED)


def ordered_floats(bits: np.ndarray) -> np.ndarray:
    """The floats behind ordered ints (clkernels/include/ordered.h: ``ordered_int``, its own inverse), float32."""
    bits = np.asarray(bits, np.int32)
    return np.where(bits >= 0, bits, bits ^ np.int32(0x7FFFFFFF)).view(np.float32)


class Pool:
    """Append/Consume buffer of ``capacity`` items of ``dtype`` with an atomic counter.

    ``count()`` is the book's ``ComputeBuffer.CopyCount``; the host reads it before every consuming
    dispatch and never launches more consumers than there are items. Appends past capacity are refused
    in the kernel (the counter is clamped) and counted in ``refused()``.
    """

    def __init__(self, runtime: Runtime, capacity: int, dtype=np.int32, name: str = "pool"):
        if capacity < 1:
            raise ValueError(f"{name}: capacity must be >= 1, got {capacity}")
        self.runtime, self.capacity, self.dtype, self.name = runtime, int(capacity), np.dtype(dtype), name
        self.items = runtime.zeros(self.capacity, self.dtype)
        self.counter = runtime.zeros(2, np.int32)

    def counts(self) -> tuple[int, int]:
        """(count, refused) in one device read."""
        counter = self.counter.get()
        return int(counter[COUNT]), int(counter[REFUSED])

    def count(self) -> int:
        """Items in the pool (CopyCount)."""
        return self.counts()[0]

    def refused(self) -> int:
        """Appends refused because the pool was full, since the last ``set_count``/``fill``."""
        return self.counts()[1]

    def set_count(self, n: int) -> None:
        """SetCounterValue: the next append writes slot n; also clears the refused count."""
        if not 0 <= n <= self.capacity:
            raise ValueError(f"{self.name}: count must be in [0, {self.capacity}], got {n}")
        self.counter.set(np.array([n, 0], np.int32))

    def fill(self, items) -> None:
        """Put ``items`` in slots 0..len-1 and set the count to their number (the book's init kernels)."""
        items = np.asarray(items, self.dtype)
        if len(items) > self.capacity:
            raise ValueError(f"{self.name}: {len(items)} items do not fit capacity {self.capacity}")
        if len(items):
            cl.enqueue_copy(self.runtime.queue, self.items.data, np.ascontiguousarray(items))
        self.set_count(len(items))

    def read(self) -> np.ndarray:
        """The pooled items, slots 0..count-1 (their order depends on atomic order: compare as sets)."""
        count = self.count()
        out = np.empty(count, self.dtype)
        if count:  # only the live slots cross to the host
            cl.enqueue_copy(self.runtime.queue, out, self.items.data)
        return out


class PingPong:
    """Two buffers (or images) for kernels that read neighbours they also write: read ``.read``, write
    ``.write``, then ``swap()``, as the book swaps its read/write buffers after each pass."""

    def __init__(self, read, write):
        self.read, self.write = read, write

    def swap(self) -> None:
        self.read, self.write = self.write, self.read

    @classmethod
    def zeros(cls, runtime: Runtime, shape, dtype) -> PingPong:
        return cls(runtime.zeros(shape, dtype), runtime.zeros(shape, dtype))


def device_sizeof(runtime: Runtime, type_name: str, header: str) -> int:
    """``sizeof(type_name)`` as the device compiles it with ``#include "header"``: tests assert numpy mirrors."""
    source = (
        f'#include "{header}"\n__kernel void ugpcl_sizeof(__global int* out) {{ out[0] = (int)sizeof({type_name}); }}'
    )
    out = cla.zeros(runtime.queue, 1, np.int32)
    runtime.program_from_source(source, "sizeof.cl").kernel("ugpcl_sizeof")((1,), None, out)
    return int(out.get()[0])


def put(array: cla.Array, value, name: str) -> None:
    """Copy a saved array (``ugpcl run --resume``) onto the device array it came from, checking its shape."""
    value = np.asarray(value)
    if value.shape != array.shape:
        raise ValueError(f"saved {name} has shape {value.shape}; this scene's parameters make {array.shape}")
    array.set(np.ascontiguousarray(value, array.dtype))
