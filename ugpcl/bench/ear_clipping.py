"""``ugpcl bench ear_clipping``: single polygons (stars of 100 to 100,000 vertices) by the host's robust pipeline,
by the EarClippingLarge kernel and by mapbox-earcut; then batches of 10^4 and 10^5 real-world-like outlines by the
robust EarClipping kernel and by a Python loop over mapbox-earcut."""

from __future__ import annotations

import time

import numpy as np

from ..geometry import ear_clipping as ec
from ..geometry.ear_clipping_input import real_world_outlines, star
from ..scenes.ear_clipping import clip_batch, ear_clip_large, triangulate_batch
from .timing import seconds_per_call

NO_SHARE = "-"
"""The share column of every ear-clipping row: the host rows (numpy, mapbox-earcut) run on the CPU outside OpenCL,
and the kernels' rows are float64 arithmetic and branches timed with their transfers: ``ugpcl bench peak`` measures
an FP32 rate only, so no limit of the device applies to them."""
DISTINCT = 1000
"""The batches are this many distinct outlines (pre-pass run once on each), each placed again at other offsets."""
LARGE_ON_GPU = 1_000
"""EarClippingLarge is one work-item: on a GPU it runs for polygons up to this size only (one thread is slow)."""


def bench(runtime, sizes=None) -> list[dict]:
    """ms and polygons/s (or outlines/s). Stars of n = size vertices (100, 1,000, 10,000, 100,000 by default): the
    host's robust pipeline (``ec.triangulate``: pre-pass and clipper, Python and numpy), EarClippingLarge (one
    work-item, transfers included) and mapbox-earcut (C++). Batches of 10^4 and 10^5 outlines
    (``real_world_outlines``: letters, footprints, ponds with islands, plots with aligned holes): the robust
    EarClipping kernel on the merged polygons (pre-pass done beforehand, its time a row of its own per distinct
    outline), and a Python loop over mapbox-earcut on the rings; at 10^4 also ``triangulate_batch`` end to end
    (pre-pass included). clip flop/s: "-" on every row (NO_SHARE says why)."""
    import mapbox_earcut

    sizes = sizes or [100, 1000, 10000, 100000]
    queue, rows = runtime.queue, []

    def row(workload, n, count, solver, seconds):
        rows.append(
            {"workload": workload, "vertices": n, "polygons": count, "solver": solver, "ms": seconds * 1e3,
             "polygons/s": count / seconds, "clip flop/s": NO_SHARE}
        )  # fmt: skip

    for n in sizes:
        ring = star(max(n // 2, 2), 1.0, 0.5)
        ends = np.array([len(ring)], np.uint32)
        once = n > 2000
        host = seconds_per_call(lambda r=ring: ec.triangulate([r]), queue, max_calls=1 if once else 1000)
        row("star", len(ring), 1, "host pipeline (robust)", host)
        if not runtime.is_gpu or n <= LARGE_ON_GPU:
            polygon = ec.merged_polygons([ring])[0]
            large = seconds_per_call(lambda p=polygon: ear_clip_large(runtime, p), queue, max_calls=2 if once else 100)
            row("star", len(ring), 1, "EarClippingLarge kernel", large)
        earcut = seconds_per_call(lambda r=ring, e=ends: mapbox_earcut.triangulate_float64(r, e), queue)
        row("star", len(ring), 1, "mapbox_earcut", earcut)

    distinct = real_world_outlines(DISTINCT)
    start = time.perf_counter()
    merged = [ec.merged_polygons(rings) for rings in distinct]
    prepass = (time.perf_counter() - start) / DISTINCT
    for count in (10_000, 100_000):
        shift = [np.array([30.0 * (k // DISTINCT), 0.0]) for k in range(count)]  # copy c of an outline, moved
        outlines = [[r + shift[k] for r in distinct[k % DISTINCT]] for k in range(count)]
        polygons = [p + shift[k] for k in range(count) for p in merged[k % DISTINCT]]
        vertices = sum(len(r) for rings in outlines for r in rings)
        sizes_ = np.array([len(p) for p in polygons])
        offsets = np.concatenate([[0], np.cumsum(sizes_)]).astype(np.int32)
        points = np.concatenate(polygons)
        kernel = seconds_per_call(lambda p=points, o=offsets: clip_batch(runtime, p, o), queue, max_calls=20)
        row("outlines", vertices, count, "EarClipping kernel (robust)", kernel)
        row("outlines", vertices, count, "host pre-pass (each outline)", prepass * count)

        def loop(outlines=outlines):
            for rings in outlines:
                ends = np.cumsum([len(r) for r in rings]).astype(np.uint32)
                mapbox_earcut.triangulate_float64(np.concatenate(rings), ends)

        row("outlines", vertices, count, "mapbox_earcut loop", seconds_per_call(loop, queue, max_calls=3))
        if count == 10_000:
            end_to_end = seconds_per_call(lambda o=outlines: triangulate_batch(runtime, o), queue, max_calls=1)
            row("outlines", vertices, count, "triangulate_batch (pre-pass + kernel)", end_to_end)
    return rows
