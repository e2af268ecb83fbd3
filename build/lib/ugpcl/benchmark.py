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


def seconds_per_call(fn, queue, min_seconds: float = 0.5, max_calls: int = 1000) -> float:
    """Seconds per ``fn()`` for kernels that are not a whole step (one warm-up call)."""
    fn()
    queue.finish()
    calls, start = 0, time.perf_counter()
    while calls < max_calls and (calls == 0 or time.perf_counter() - start < min_seconds):
        fn()
        queue.finish()
        calls += 1
    return (time.perf_counter() - start) / calls
