"""``ugpcl bench kleinian``: RenderKleinian's frame time and Mpixel-samples/s, and uniform against adaptive
supersampling at equal error (vol.4 ch.2)."""

from __future__ import annotations

import functools

import numpy as np

from ..scenes.kleinian import Params, Simulation
from .timing import seconds_per_call

REFERENCE_SAMPLES = 256
"""Samples per pixel of the reference image the anti-aliasing rows are measured against."""


ITERATION_FLOPS = 40
"""One iteration of jos_kleinian (include/kleinian.h) in float: the shear offset |v| / u * z.y (2) added and taken
away (2), kleinian_wrap (5: floor not counted), kleinian_line3 (16: exp 1, sign and abs 0), the point symmetry
(2, counted as if always taken), kleinian_trans_a (dot 3, two divisions and the translation 4) and the 2-cycle test
length(z - llz) (6: sqrt 1). Flop convention of the benches: an FMA is 2, sqrt, exp and a division 1 each,
compares 0. The per-pixel set-up and colour (about 30) are left out."""


def bench(runtime, sizes=None) -> list[dict]:
    """Frame time, Mpixel-samples/s and mean iterations (of sample 0) of RenderKleinian at t = (1.94, 0.02) (the
    book's "interesting" shape; iteration 50, the scenes' value) for W x 9W/16 frames with 1 and 20 samples; then
    anti-aliasing at equal error: RMS error against a 256-sample image, uniform vs adaptive supersampling (samples
    spent per pixel and time) at the smallest size (320 x 180 on a CPU). --size gives widths. iteration flop/s:
    ITERATION_FLOPS x the iterations of sample 0 of every pixel (standing for every sample) x samples per second."""
    widths = sizes or ([640, 1920, 3840] if runtime.is_gpu else [640])
    rows = []
    for width in widths:
        height = width * 9 // 16
        for samples in (1, 20):
            mode = 0 if samples == 1 else 1
            sim = Simulation(runtime, Params(width=width, height=height, u=1.94, v=0.02, mode=mode, samples=samples))
            image = sim.render_kleinian()  # also the warm-up: the build
            # the kernels alone: the frame stays on the device, as the viewer's would
            launch = functools.partial(sim.enqueue_frame, width, height)
            seconds = seconds_per_call(launch, runtime.queue, max_calls=50)
            rows.append(
                {
                    "frame": f"{width}x{height}",
                    "AA": "none" if samples == 1 else "uniform",
                    "samples": samples,
                    "ms/frame": seconds * 1e3,
                    "Mpixel-samples/s": width * height * samples / seconds / 1e6,
                    "mean iterations": float(image["iters"].mean()),
                    "iteration flop/s": ITERATION_FLOPS * float(image["iters"].sum()) * samples / seconds,
                }
            )
    rows += _aa_rows(runtime, widths[0] if runtime.is_gpu or sizes else 320)  # a 256-sample frame is slow on a CPU
    return rows


def _aa_rows(runtime, width: int) -> list[dict]:
    """Uniform vs adaptive supersampling in mode 1, error against the reference, per sample count."""
    height = width * 9 // 16
    sim = Simulation(runtime, Params(width=width, height=height, u=1.94, v=0.02, mode=1))
    reference = sim.render_kleinian(samples=REFERENCE_SAMPLES)["rgba"]
    rows = []
    for samples in (4, 8, 16, 32, 64):
        for adaptive in (False, True):
            image = {}

            def render(samples=samples, adaptive=adaptive, image=image):
                image.update(sim.render_kleinian(samples=samples, adaptive=adaptive))

            seconds = seconds_per_call(render, runtime.queue, min_seconds=0.5, max_calls=10)
            # adaptive: one centre sample everywhere, then `samples` where the neighbourhood is not uniform
            spent = 1 + nonuniform(image["centre_hit"]).mean() * samples if adaptive else samples
            error = float(np.sqrt(np.mean((image["rgba"][..., :3] - reference[..., :3]) ** 2)))
            rows.append(
                {
                    "frame": f"{width}x{height}",
                    "AA": "adaptive" if adaptive else "uniform",
                    "samples": samples,
                    "ms/frame": seconds * 1e3,
                    "samples/pixel": float(spent),
                    "RMS error": error,
                    "iteration flop/s": ITERATION_FLOPS * float(image["iters"].sum()) * float(spent) / seconds,
                }
            )
    return rows


def nonuniform(centre_hit: np.ndarray) -> np.ndarray:
    """Pixels whose 3x3 neighbourhood (clamped at the edges) of centre samples is not uniform: those that adaptive
    supersampling samples (the rule of RenderKleinian)."""
    padded = np.pad(centre_hit, 1, mode="edge")
    h, w = centre_hit.shape
    out = np.zeros(centre_hit.shape, bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            out |= padded[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w] != centre_hit
    return out
