"""``ugpcl bench frames``: what a viewer frame costs: the simulation's step, the view's upload (the transfer from the
device and the GL upload), the draw into an offscreen multisampled target (1280x720 unless the scene's ``at_scale``
says otherwise) with the GL queue finished, and apart from the frame the read-back a picture (``--png``, ``--video``,
``ugpcl.render``) adds. The flagship scenes at scale (``Scene.at_scale``: a million boids, 256^3 grids, or their
``cpu`` sizes on a CPU device); with ``--all`` also every scene at its defaults (on a CPU device at the sizes the
viewer starts with there, the scene's ``interactive`` overrides)."""

from __future__ import annotations

import time

from ..registry import scenes as all_scenes

SIZE = (1280, 720)
"""The frame: the previews' size."""
MIN_SECONDS = 0.5
"""Frames repeat until this long has passed (at least MIN_FRAMES)."""
MIN_FRAMES = 3


def time_frame(sim, view, camera, target, dt, parts: dict) -> None:
    """One frame, each part timed with its queue finished, added to ``parts`` (step, upload, draw, read-back)."""
    ctx = target.ctx
    t0 = time.perf_counter()
    sim.step(dt)
    sim.runtime.queue.finish()
    t1 = time.perf_counter()
    before = sim.runtime.read_back_bytes
    view.upload()
    ctx.finish()
    t2 = time.perf_counter()
    parts["bytes"] += sim.runtime.read_back_bytes - before
    target.draw(view, camera)
    ctx.finish()
    t3 = time.perf_counter()
    target.read()
    t4 = time.perf_counter()
    for key, seconds in zip(("step", "upload", "draw", "read-back"), (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
        parts[key] += seconds


def workloads(runtime, every: bool, names=None) -> list[tuple]:
    """(scene, sizes label, overrides, frame size) of each row: the flagship scenes at scale (``Scene.at_scale``, its
    ``cpu`` sizes on a CPU device), then with ``every`` every scene at its defaults (on a CPU device at the sizes the
    viewer starts with there, ``Scene.interactive``). ``names``: only these scenes."""
    chosen = {name: scene for name, scene in all_scenes().items() if names is None or name in names}
    rows = []
    for scene in chosen.values():
        if scene.at_scale is not None:
            scale = scene.at_scale
            if runtime.is_gpu:
                rows.append((scene, "at scale", scale.gpu, scale.frame))
            else:
                rows.append((scene, "at scale (cpu)", scale.cpu, SIZE))
    if every or names is not None:
        for scene in chosen.values():
            sized = {} if runtime.is_gpu else scene.interactive
            rows.append((scene, "interactive" if sized else "defaults", sized, SIZE))
    return rows


def bench(runtime, sizes=None, scenes=None, every: bool = False) -> list[dict]:
    """ms per frame and frames/s of step + upload + draw (each part's ms beside it, measured with the OpenCL queue
    and the GL queue finished after each part), and the read-back's ms: the flagship scenes at scale (a million
    boids, 256^3 grids; smaller on a CPU device), with ``--all`` every scene at its defaults too. ``scenes``: only
    these (both their rows)."""
    from ugpcl.viewer.offscreen import context, frame
    from ugpcl.viewer.views import create_view

    ctx, rows = context(), []
    for scene, label, overrides, size in workloads(runtime, every, scenes):
        sim = scene.create(runtime, **overrides)
        view = create_view(scene, ctx, sim)
        camera = view.png_camera()
        camera.aspect = size[0] / size[1]
        target, dt = frame(size), scene.simulation.default_dt
        parts = dict.fromkeys(("step", "upload", "draw", "read-back", "bytes"), 0.0)
        time_frame(sim, view, camera, target, dt, dict(parts))  # warm-up: builds, first allocations
        frames, start = 0, time.perf_counter()
        while frames < MIN_FRAMES or time.perf_counter() - start < MIN_SECONDS:
            time_frame(sim, view, camera, target, dt, parts)
            frames += 1
        ms = {key: 1e3 * seconds / frames for key, seconds in parts.items() if key != "bytes"}
        frame_ms = ms["step"] + ms["upload"] + ms["draw"]
        read_back = parts["bytes"] / frames  # what the upload read through Runtime.read_back (other reads: not counted)
        rows.append(
            {"scene": scene.name, "sizes": label, "frame": "x".join(map(str, size)), "frames/s": 1e3 / frame_ms,
             "ms/frame": frame_ms, "step ms": ms["step"], "upload ms": ms["upload"], "draw ms": ms["draw"],
             "read-back ms": ms["read-back"], "upload MB": read_back / 1e6,
             "upload host bytes/s": read_back / (ms["upload"] / 1e3) if read_back else "-"}
        )  # fmt: skip
        del view, sim  # free the device memory of a large scene before the next is made
    return rows
