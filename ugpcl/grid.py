"""Uniform-grid neighbour search shared by the chapters (kernels: clkernels/grid.cl, helpers: grid.h).

``build()`` hashes each item's position to a cell, sorts (cell, index) keys with a bitonic network and records
each cell's range of sorted keys. A chapter's neighbour kernel then visits the 3x3x3 (2D: 3x3) cells around a
position instead of all items, through grid.h's one neighbour loop (``grid_neighbours`` / ``grid_next_neighbour``):
exact whenever ``cell_size`` >= the search radius.
"""

from __future__ import annotations

import math

import numpy as np
import pyopencl as cl
import pyopencl.array as cla
import pyopencl.cltypes as cltypes

from .runtime import Runtime, round_up

LOCAL_SIZE = 64


def next_power_of_two(n: int) -> int:
    return 1 << max(0, (n - 1).bit_length())


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
        self.keys = runtime.empty(next_power_of_two(self.capacity), np.uint64)
        self.cell_start = runtime.zeros(self.num_cells, np.int32)
        self.cell_end = runtime.zeros(self.num_cells, np.int32)
        self.n = 0

    @classmethod
    def covering(cls, runtime: Runtime, capacity: int, lower, upper, cell_size: float) -> UniformGrid:
        """A grid over the box [lower, upper] (2 or 3 coordinates each); items outside fall in the border cells."""
        lower, upper = np.asarray(lower, float), np.asarray(upper, float)
        dims = [max(1, math.ceil((u - lo) / cell_size)) for lo, u in zip(lower, upper, strict=True)]
        return cls(runtime, capacity, lower, cell_size, (*dims, 1, 1)[:3])

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
        if not 0 <= n <= self.capacity:
            raise ValueError(f"grid: n must be in [0, {self.capacity}], got {n}")
        buffer = items.data if isinstance(items, cla.Array) else items
        padded = next_power_of_two(max(n, 1))
        self.program.kernel("GridHash")(
            (round_up(padded, LOCAL_SIZE),),
            None,
            buffer,
            np.int32(stride),
            np.int32(offset),
            np.int32(n),
            np.int32(padded),
            *self.geometry_args(),
            self.keys.data,
        )
        self.sort(n)

    def sort(self, n: int) -> None:
        """Sort the keys of items 0..n-1 (from GridHash or a chapter's own hash kernel, which fills the slots up to the
        next power of two with GRID_EMPTY_KEY: they sort last and own no cell) and record each cell's key range."""
        padded = next_power_of_two(max(n, 1))
        sort_step = self.program.kernel("BitonicSortStep")
        k = 2
        while k <= padded:
            j = k // 2
            while j >= 1:
                sort_step((padded // 2,), None, self.keys.data, np.int32(j), np.int32(k))
                j //= 2
            k *= 2
        self.program.kernel("GridClearCells")(
            (round_up(self.num_cells, LOCAL_SIZE),),
            None,
            self.cell_start.data,
            self.cell_end.data,
            np.int32(self.num_cells),
        )
        self.n = n
        if n:
            self.program.kernel("GridFindCellRanges")(
                (round_up(n, LOCAL_SIZE),),
                None,
                self.keys.data,
                np.int32(n),
                self.cell_start.data,
                self.cell_end.data,
            )

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
