"""Uniform-grid neighbour search shared by the chapters (kernels: clkernels/grid.cl, helpers: grid.h).

``build()`` hashes each item's position to a cell, sorts the (cell, index) keys by a counting sort (count per cell,
prefix sum, scatter, then each cell's run in item order, so the order is the same on every run) and records each
cell's range of sorted keys. A chapter's neighbour kernel then visits the 3x3x3 (2D: 3x3) cells around a
position instead of all items, through grid.h's one neighbour loop (``GRID_FOR_EACH_NEIGHBOUR_KEY``):
exact whenever ``cell_size`` >= the search radius. ``copy_in_cell_order()`` puts the items' records in key order,
so that such a kernel, run over the sorted slots, reads each cell's items from consecutive addresses.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import pyopencl as cl
import pyopencl.array as cla
import pyopencl.cltypes as cltypes

from .runtime import Runtime

LOCAL_SIZE = 64
SCAN_GROUP, SCAN_SPAN = 256, 8
"""GridScanBlocks: work-items per group and consecutive cells per work-item (GRID_SCAN_GROUP, GRID_SCAN_SPAN)."""
SCAN_BLOCK = SCAN_GROUP * SCAN_SPAN
"""Cells one work-group of GridScanBlocks scans: one launch scans a grid of up to 2048 cells."""


class ScanLevel(NamedTuple):
    """One GridScanBlocks launch: ``count`` counts (zeroed) -> exclusive and inclusive sums, per-block totals."""

    counts: cla.Array
    exclusive: cla.Array
    inclusive: cla.Array
    block_sums: cla.Array
    count: int


class UniformGrid:
    """Cells of ``cell_size`` from ``origin``, ``dims`` = (x, y, z) cells (z = 1 for 2D items)."""

    def __init__(self, runtime: Runtime, capacity: int, origin, cell_size: float, dims):
        if capacity < 1:
            raise ValueError(f"grid capacity must be >= 1, got {capacity}")
        if not cell_size > 0:
            raise ValueError(f"grid cell_size must be > 0, got {cell_size}")
        self.dims = tuple(int(d) for d in dims)
        if len(self.dims) != 3 or min(self.dims) < 1:
            raise ValueError(f"grid dims must be three integers >= 1, got {dims}")
        self.num_cells = math.prod(self.dims)
        if self.num_cells >= 2**31:
            raise ValueError(f"grid has {self.num_cells} cells; at most 2^31 - 1")
        self.runtime, self.capacity = runtime, int(capacity)
        self.origin = tuple(float(v) for v in (*origin, 0.0, 0.0)[:3])
        self.cell_size = float(cell_size)
        self.program = runtime.program("grid")
        self.hash_keys = runtime.empty(self.capacity, np.uint64)  # what the hash kernels write: item i's key at i
        self.cell_count = runtime.zeros(self.num_cells, np.int32)  # zero between builds: the scan clears it
        # each key's arrival number in its cell; zeroed: GridScatter reads none for an item left out, yet PoCL ran it
        # 20-60x slower while those slots held garbage
        self.tickets = runtime.zeros(self.capacity, np.int32)
        self.scattered = runtime.empty(self.capacity, np.uint64)  # grouped by cell, each cell in arrival order
        self.keys = runtime.empty(self.capacity, np.uint64)  # sorted: what the neighbour loops read
        self.cell_start = runtime.zeros(self.num_cells, np.int32)
        self.cell_end = runtime.zeros(self.num_cells, np.int32)
        self.scan_levels = self._scan_levels()
        self.n = 0

    @classmethod
    def covering(cls, runtime: Runtime, capacity: int, lower, upper, cell_size: float) -> UniformGrid:
        """A grid over the box [lower, upper] (2 or 3 coordinates each); items outside fall in the border cells."""
        lower, upper = np.asarray(lower, float), np.asarray(upper, float)
        dims = [max(1, math.ceil((u - lo) / cell_size)) for lo, u in zip(lower, upper, strict=True)]
        return cls(runtime, capacity, lower, cell_size, (*dims, 1, 1)[:3])

    def _scan_levels(self) -> list[ScanLevel]:
        """The levels of the prefix sum over the cells: the first scans cell_count into cell_start (exclusive) and
        cell_end (inclusive), each next one the block sums of the one before, until one block holds them all."""
        rt = self.runtime
        levels, counts, exclusive, inclusive, count = (
            [],
            self.cell_count,
            self.cell_start,
            self.cell_end,
            self.num_cells,
        )
        while True:
            blocks = -(-count // SCAN_BLOCK)
            levels.append(ScanLevel(counts, exclusive, inclusive, rt.empty(blocks, np.int32), count))
            if blocks == 1:
                return levels
            counts, count = levels[-1].block_sums, blocks
            exclusive, inclusive = rt.empty(blocks, np.int32), rt.empty(blocks, np.int32)

    # {{{ kernel arguments a chapter's neighbour kernel takes, in grid.h's order

    def geometry_args(self) -> tuple:
        """origin (float4), cell_size (float), dims (int4)."""
        return (cltypes.make_float4(*self.origin, 0.0), np.float32(self.cell_size), cltypes.make_int4(*self.dims, 0))

    def search_args(self) -> tuple:
        """keys, cell_start, cell_end buffers."""
        return (self.keys.data, self.cell_start.data, self.cell_end.data)

    # }}}

    def build(self, items, n: int, stride: int, offset: int = 0) -> None:
        """Sort items 0..n-1 of ``items`` (a float buffer: item i's position starts at float i*stride+offset)."""
        self._check_n(n)
        buffer = items.data if isinstance(items, cla.Array) else items
        geometry = self.geometry_args()
        args = (
            buffer,
            np.int32(stride),
            np.int32(offset),
            np.int32(n),
            *geometry,
            self.hash_keys,
            self.cell_count,
            self.tickets,
        )
        self.program.kernel("GridHash").over(n, LOCAL_SIZE, *args)
        self._scan_and_scatter(n)

    def sort(self, n: int) -> None:
        """Sort the n keys a chapter's own hash kernel wrote to ``hash_keys`` (item i's key at i; GRID_EMPTY_KEY for
        an item left out: it owns no cell and goes after every cell's items) and record each cell's range."""
        self._check_n(n)
        self.program.kernel("GridCountCells").over(
            n, LOCAL_SIZE, self.hash_keys, np.int32(n), self.cell_count, self.tickets
        )
        self._scan_and_scatter(n)

    def _scan_and_scatter(self, n: int) -> None:
        """From the counts on: prefix sums into the cell ranges, the keys grouped by cell, each cell in item order."""
        kernel, levels = self.program.kernel, self.scan_levels
        for level in levels:  # up: each level scans the block sums of the one below
            groups = -(-level.count // SCAN_BLOCK)
            kernel("GridScanBlocks")(groups * SCAN_GROUP, SCAN_GROUP, *level[:4], np.int32(level.count))
        for level, above in reversed(list(zip(levels, levels[1:], strict=False))):  # down: add the earlier blocks
            args = (level.exclusive, level.inclusive, above.exclusive, np.int32(level.count))
            kernel("GridAddBlockOffsets").over(level.count, LOCAL_SIZE, *args)
        args = (self.hash_keys, self.tickets, np.int32(n), self.cell_start, self.scattered)
        kernel("GridScatter").over(n, LOCAL_SIZE, *args)
        args = (self.scattered, np.int32(n), self.cell_start, self.cell_end, np.int32(self.num_cells), self.keys)
        kernel("GridSortCells").over(n, LOCAL_SIZE, *args)
        self.n = n

    def copy_in_cell_order(self, items, sorted_items, record_bytes: int) -> None:
        """Record k of ``sorted_items`` = the record of the item of sorted key k, for the n items of the last build or
        sort (records of ``record_bytes``, a multiple of 16, from item 0 at byte 0). A neighbour kernel run over the
        sorted slots then reads a cell's items from consecutive addresses (slot k is item ``grid_item(keys[k])``)."""
        if record_bytes <= 0 or record_bytes % 16:
            raise ValueError(f"grid: record_bytes must be a positive multiple of 16, got {record_bytes}")
        args = (items, np.int32(record_bytes // 16), np.int32(self.n), self.keys, sorted_items)
        self.program.kernel("GridCopyItemsInCellOrder").over(self.n, LOCAL_SIZE, *args)

    def _check_n(self, n: int) -> None:
        if not 0 <= n <= self.capacity:
            raise ValueError(f"grid: n must be in [0, {self.capacity}], got {n}")

    def sorted_keys(self) -> np.ndarray:
        """The n sorted keys (host copy, for tests and statistics)."""
        out = np.empty(self.n, np.uint64)
        if self.n:
            cl.enqueue_copy(self.runtime.queue, out, self.keys.data)
        return out

    def occupancy(self) -> dict:
        """Items per occupied cell: the numbers that show a cell size that is too large or too small."""
        counts = self.cell_end.get() - self.cell_start.get()
        used = counts[counts > 0]
        return {
            "cells": self.num_cells,
            "occupied cells": int(len(used)),
            "mean per occupied cell": float(used.mean()) if len(used) else 0.0,
            "max per cell": int(used.max()) if len(used) else 0,
        }
