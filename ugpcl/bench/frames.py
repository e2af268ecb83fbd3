"""``ugpcl bench frames``: what a viewer frame costs, every scene at its defaults (on a CPU device at the sizes the
viewer starts with there, the scene's ``interactive`` overrides): the simulation's step, the view's upload (the
transfer from the device and the GL upload), the draw into an offscreen 1280x720 multisampled target with the GL
queue finished, and apart from the frame the read-back a picture (``--png``, ``--video``, ``ugpcl.render``) adds."""

from __future__ import annotations

import time

from ..registry import scenes as all_scenes

SIZE = (1280, 720)
"""The frame: the previews' size."""
MIN_SECONDS = 0.5
"""Frames repeat until this long has passed (at least MIN_FRAMES)."""
MIN_FRAMES = 3
NO_SHARE = "-"
"""The share column of every row: a frame's parts are Python, OpenCL and GL together, its bytes are not counted (the
view's transfers differ per scene), and ``ugpcl bench copy`` measures the device's own copies, not PCIe or GL."""


def time_frame(sim, view, camera, target, dt, parts: dict) -> None:
    """One frame, each part timed with its queue finished, added to ``parts`` (step, upload, draw, read-back)."""
    ctx = target.ctx
    t0 = time.perf_counter()
    sim.step(dt)
    sim.runtime.queue.finish()
    t1 = time.perf_counter()
    view.upload()
    ctx.finish()
    t2 = time.perf_counter()
    target.draw(view, camera)
    ctx.finish()
    t3 = time.perf_counter()
    target.read()
    t4 = time.perf_counter()
    for key, seconds in zip(parts, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
        parts[key] += seconds


def bench(runtime, sizes=None, scenes=None) -> list[dict]:
    """ms per frame and frames/s of step + upload + draw (each part's ms beside it, measured with the OpenCL queue
    and the GL queue finished after each part), and the read-back's ms. ``scenes``: their names (default: all)."""
    from ugpcl.viewer.offscreen import context, frame
    from ugpcl.viewer.views import create_view

    ctx, rows = context(), []
    for name, scene in all_scenes().items():
        if scenes is not None and name not in scenes:
            continue
        overrides = {} if runtime.is_gpu else scene.interactive
        sim = scene.create(runtime, **overrides)
        view = create_view(scene, ctx, sim)
        camera = view.png_camera()
        camera.aspect = SIZE[0] / SIZE[1]
        target, dt = frame(SIZE), scene.simulation.default_dt
        parts = dict.fromkeys(("step", "upload", "draw", "read-back"), 0.0)
        time_frame(sim, view, camera, target, dt, dict(parts))  # warm-up: builds, first allocations
        frames, start = 0, time.perf_counter()
        while frames < MIN_FRAMES or time.perf_counter() - start < MIN_SECONDS:
            time_frame(sim, view, camera, target, dt, parts)
            frames += 1
        ms = {key: 1e3 * seconds / frames for key, seconds in parts.items()}
        frame_ms = ms["step"] + ms["upload"] + ms["draw"]
        rows.append(
            {"scene": name, "sizes": "interactive" if overrides else "defaults", "frames/s": 1e3 / frame_ms,
             "ms/frame": frame_ms, "step ms": ms["step"], "upload ms": ms["upload"], "draw ms": ms["draw"],
             "read-back ms": ms["read-back"], "frame bytes/s": NO_SHARE}
        )  # fmt: skip
    return rows
