"""``ugpcl bench ear_clipping``: one large star by the host's numpy ear clipping and by mapbox-earcut, then 10^4
glyph polygons by the EarClipping kernel, by a loop over mapbox-earcut and by the host clipper."""

from __future__ import annotations

import numpy as np

from ..geometry import ear_clipping as ec
from ..geometry.ear_clipping_input import glyph_batch, star
from ..scenes.ear_clipping import MAX_BATCH_VERTICES, clip_batch
from .timing import seconds_per_call

NO_SHARE = "-"
"""The share column of every ear-clipping row: the host rows (numpy, mapbox-earcut) run on the CPU outside OpenCL,
and the EarClipping kernel's row is float64 arithmetic (FP_CONTRACT off, to match the host bit for bit) timed with
its transfers: ``ugpcl bench peak`` measures an FP32 rate only, so no limit of the device applies to it."""


def bench(runtime, sizes=None) -> list[dict]:
    """ms and polygons/s: one n-vertex star (n = size) by the host's numpy ear clipping and by mapbox-earcut (C++
    ear slicing with z-order hashing); then 10^4 glyph outlines (letters, holes bridged on the host beforehand) by the
    EarClipping kernel (one work-item per polygon, transfers included), by a Python loop over mapbox-earcut and by the
    host clipper (on the first 500). clip flop/s: "-" on every row (NO_SHARE says why)."""
    import mapbox_earcut

    sizes = sizes or [100, 1000, 10000]
    queue, rows = runtime.queue, []

    def row(workload, n, polygons, solver, seconds):
        rows.append(
            {"workload": workload, "vertices": n, "polygons": polygons, "solver": solver, "ms": seconds * 1e3,
             "polygons/s": polygons / seconds, "clip flop/s": NO_SHARE}
        )  # fmt: skip

    for n in sizes:
        ring = star(max(n // 2, 2), 1.0, 0.5)
        ends = np.array([len(ring)], np.uint32)
        host = seconds_per_call(lambda r=ring: ec.triangulate([r]), queue, max_calls=1 if n > 2000 else 1000)
        row("star", len(ring), 1, "host (numpy)", host)
        earcut = seconds_per_call(lambda r=ring, e=ends: mapbox_earcut.triangulate_float64(r, e), queue)
        row("star", len(ring), 1, "mapbox_earcut", earcut)
    glyphs = glyph_batch(10_000, MAX_BATCH_VERTICES)
    total = sum(len(g) for g in glyphs)
    points = np.concatenate(glyphs)
    offsets = np.concatenate([[0], np.cumsum([len(g) for g in glyphs])]).astype(np.int32)
    kernel = seconds_per_call(lambda: clip_batch(runtime, points, offsets), queue)  # its warm-up call builds
    row("glyphs", total, len(glyphs), "EarClipping kernel", kernel)
    ends = [np.array([len(g)], np.uint32) for g in glyphs]
    loop = lambda: [mapbox_earcut.triangulate_float64(g, e) for g, e in zip(glyphs, ends, strict=True)]  # noqa: E731
    row("glyphs", total, len(glyphs), "mapbox_earcut loop", seconds_per_call(loop, queue))
    few = glyphs[:500]
    host_loop = seconds_per_call(lambda: [ec.clip_on_host(g) for g in few], queue, max_calls=1)
    row("glyphs", sum(len(g) for g in few), len(few), "host (numpy) loop", host_loop)
    return rows
