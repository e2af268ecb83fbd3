"""Timing for ``ugpcl bench``: wall-clock seconds per step with the queue drained, never used in tests."""

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


def bench_launch(runtime, sizes=None) -> list[dict]:
    """Host cost of one kernel launch (LaunchProbe: 3 buffers, 4 scalars, 256 work-items), per way of launching:
    PyOpenCL's plain call `kernel(queue, gsize, lsize, *args)` (sets every argument every time), a bare
    `enqueue_nd_range_kernel` with the arguments set once, and ugpcl's launch path (runtime.Kernel: buffers set once,
    scalars from their bytes). host us/launch: time to enqueue; us/launch: with the device's work, the
    queue finished at the end of each batch."""
    import numpy as np
    import pyopencl as cl

    n, batch = 256, 2000
    queue = runtime.queue
    a, b, out = (runtime.zeros(n, np.float32) for _ in range(3))
    wrapper = runtime.program("launch").kernel("LaunchProbe")
    plain = cl.Kernel(wrapper.cl.program, "LaunchProbe")  # a second cl.Kernel: its arguments are its own
    fixed = (a.data, b.data, out.data, np.int32(n), np.float32(2.0))

    def plain_call(i):
        plain(queue, (n,), None, *fixed, np.float32(i), np.int32(0))

    def bare_enqueue(i):
        cl.enqueue_nd_range_kernel(queue, plain, (n,), None)

    def launch_path(i):
        wrapper((n,), None, *fixed, np.float32(i), np.int32(0))

    rows = []
    for name, launch in (("plain call", plain_call), ("bare enqueue", bare_enqueue), ("launch path", launch_path)):
        if launch is bare_enqueue:
            plain.set_args(*fixed, np.float32(0.0), np.int32(0))
        host, total = [], []
        for _ in range(5):  # the best of five batches: the least disturbed by the rest of the machine
            queue.finish()
            start = time.perf_counter()
            for i in range(batch):
                launch(i)
            enqueued = time.perf_counter()
            queue.finish()
            host.append((enqueued - start) / batch)
            total.append((time.perf_counter() - start) / batch)
        rows.append({"launch": name, "host us/launch": min(host) * 1e6, "us/launch": min(total) * 1e6})
    bare = rows[1]["host us/launch"]
    for row in rows:
        row["x bare"] = row["host us/launch"] / bare
    return rows
