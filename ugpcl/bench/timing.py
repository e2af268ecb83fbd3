"""The one timing helper of every bench (``ugpcl bench``): wall-clock seconds per step or per call with the queue
drained, never used in tests; and the workload counts benches share (pairs within a grid's neighbour cells)."""

from __future__ import annotations

import time


def seconds_per_step(sim, min_seconds: float = 1.0, max_steps: int = 200, dt: float | None = None) -> float:
    """Seconds per ``sim.step(dt)``: one warm-up step (kernel builds, first transfers), then repeat until
    ``min_seconds`` have passed or ``max_steps`` ran, finishing the queue after each step."""
    queue = sim.runtime.queue
    sim.step(dt)
    queue.finish()
    steps, start = 0, time.perf_counter()
    while steps < max_steps and (steps == 0 or time.perf_counter() - start < min_seconds):
        sim.step(dt)
        queue.finish()
        steps += 1
    return (time.perf_counter() - start) / steps


def seconds_per_call(fn, queue, min_seconds: float = 0.5, max_calls: int = 1000, batch: int = 1) -> float:
    """Seconds per ``fn()`` for kernels that are not a whole step (one warm-up call, not timed).

    ``batch`` = how many calls run back to back before the queue is finished: 1 (default) times a call that
    waits for its result, as a step's one-off kernel; K > 1 times a call inside a loop, as a Jacobi sweep of a
    solve or a substep of a frame, where the host enqueues the next launch while the device runs the last and
    one finish ends the loop (the finish's cost is shared by the K calls). Batches repeat until ``min_seconds``
    have passed or ``max_calls`` calls ran (at least one batch); the result is the mean over every timed call."""
    if batch < 1:
        raise ValueError(f"batch must be >= 1, got {batch}")
    fn()
    queue.finish()
    calls, start = 0, time.perf_counter()
    while calls == 0 or (calls + batch <= max_calls and time.perf_counter() - start < min_seconds):
        for _ in range(batch):
            fn()
        queue.finish()
        calls += batch
    return (time.perf_counter() - start) / calls


def grid_pairs_2d(points, origin, cell_size: float, dims) -> tuple:
    """The ordered pairs (i, j), i != j, that a 2D uniform-grid kernel visits (j in the 3x3 cells around i's cell,
    cells clamped as grid.h's grid_cell_coord), as two index arrays: a host count of a grid kernel's pair work for
    the flop columns of a bench (with cell_size >= the radius they hold every pair within it)."""
    import numpy as np

    nx, ny = int(dims[0]), int(dims[1])
    xy = np.asarray(points, np.float64)[:, :2]
    c = np.floor((xy - np.asarray(origin, np.float64)[:2]) / cell_size)
    c = np.clip(np.nan_to_num(c), 0, [nx - 1, ny - 1]).astype(np.int64)
    cell = c[:, 1] * nx + c[:, 0]
    order = np.argsort(cell, kind="stable")
    counts = np.bincount(cell, minlength=nx * ny)
    start = np.cumsum(counts) - counts
    pairs_i, pairs_j = [], []
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            cx, cy = c[:, 0] + dx, c[:, 1] + dy
            inside = (cx >= 0) & (cx < nx) & (cy >= 0) & (cy < ny)
            items, neighbour = np.nonzero(inside)[0], cy[inside] * nx + cx[inside]
            n = counts[neighbour]
            first = np.repeat(start[neighbour], n)
            rank = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)  # 0 .. n - 1 within each neighbour cell
            pairs_i.append(np.repeat(items, n))
            pairs_j.append(order[first + rank])
    i, j = np.concatenate(pairs_i), np.concatenate(pairs_j)
    keep = i != j
    return i[keep], j[keep]
