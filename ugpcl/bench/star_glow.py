"""``ugpcl bench star_glow``: ms per StarGlow frame for the book's per-pass launches and the fused variant, beside
the streaks as a CPU line convolution and the viewer's GL passes (vol.4 ch.4). The GL row imports the viewer: it
lives here, above the chapter, never in the scene module."""

from __future__ import annotations

import math
import time

import numpy as np

from ..scenes.star_glow import TAPS, Params, Simulation
from .timing import seconds_per_call

TEXEL_BYTES = 16
"""One float4 texel of every StarGlow image (src, bright, the streak layers, comp, dst)."""


def frame_bytes(W: int, H: int, w: int, h: int, streaks: int, iteration: int, variant: str) -> int:
    """Least memory traffic of one StarGlow frame (Simulation.star_glow), TEXEL_BYTES per texel read or written,
    taps that overlap a texel read before counted once (from cache):
      Brightness: 4 bilinear taps of src per small texel (distinct when divide >= 2), bright written: 5 w h;
      book: comp cleared (w h); per direction, each of the `iteration` Streak passes reads its input and writes its
        output (2 w h), ScreenAccumulate reads in and comp and writes comp (3 w h);
      fused: StreakAllDirections passes 1 .. iteration-1 read the input (bright once: w h; then n layers) and write
        n layers; StreakAccumulate reads its input the same way and writes comp (w h);
      Composite: src read and dst written (2 W H) and comp read (w h)."""
    small, n = w * h, streaks
    if variant == "book":
        streak_bytes = small + n * (2 * iteration * small + 3 * small)
    else:
        passes = [small if k == 0 else n * small for k in range(iteration)]  # what each pass reads
        streak_bytes = sum(read + n * small for read in passes[:-1]) + passes[-1] + small
    return TEXEL_BYTES * (5 * small + streak_bytes + 2 * W * H + small)


def bench(runtime, sizes=None) -> list[dict]:
    """ms per frame of the StarGlow passes (source fixed; brightness to composite, the queue finished after each
    frame) for the book's per-pass launches and the fused variant, at two workloads (W, H, divide, N,
    iteration) = (1920, 1080, 7, 5, 2) and (3840, 2160, 3, 8, 4); beside it the streaks alone on the CPU: the brightness
    image filtered with one direction's line kernel a^d, d < 4^iteration (cv2.filter2D where opencv is installed,
    else scipy.ndimage.convolve), timed for one direction and multiplied by N; and the GL passes (EGL) if available.
    frame bytes/s: the OpenCL variant's least traffic (frame_bytes) per second (the CPU and GL rows: -).
    sizes: ignored (the two workloads are fixed)."""
    rows = []
    for W, H, divide, n, iteration in ((1920, 1080, 7, 5, 2), (3840, 2160, 3, 8, 4)):
        common = {"width": W, "height": H, "divide": divide, "num_of_streak": n, "iteration": iteration}
        label = {"source": f"{W}x{H}", "divide": divide, "streaks": n, "iteration": iteration}
        for variant in ("book", "fused"):
            sim = Simulation(runtime, Params(**common, attenuation=0.95, threshold=1.0, variant=variant), seed=0)
            # the post effect, not the demo's ray casting: star_glow alone, as a step would run it
            seconds = seconds_per_call(sim.star_glow, runtime.queue, min_seconds=1.0, max_calls=30)
            traffic = frame_bytes(sim.W, sim.H, sim.w, sim.h, n, iteration, variant)
            rows.append(
                {**label, "path": f"OpenCL {variant}", "ms/frame": seconds * 1e3, "frame bytes/s": traffic / seconds}
            )
        bright, kernel = sim.bright.get(), streak_line_kernel(0.95, iteration, (1.0, 0.0))
        name, seconds = _line_filter_seconds(bright, kernel)
        rows.append({**label, "path": f"{name} (CPU, one direction x N)", "ms/frame": seconds * n * 1e3,
                     "frame bytes/s": "-"})  # fmt: skip
        gl = _gl_seconds(sim)
        if gl is not None:
            rows.append({**label, "path": "GL passes (EGL)", "ms/frame": gl * 1e3, "frame bytes/s": "-"})
    return rows


def _line_filter_seconds(image: np.ndarray, kernel: np.ndarray) -> tuple[str, float]:
    """(name, seconds) of one direction's streaks on the CPU: cv2.filter2D where opencv is installed (it
    correlates: the kernel flipped), else scipy.ndimage.convolve per channel; edges replicated as GL clamps."""
    try:
        import cv2
    except ImportError:
        from scipy import ndimage

        return "scipy.ndimage.convolve", _seconds(
            lambda: [ndimage.convolve(image[..., c], kernel, mode="nearest") for c in range(4)]
        )
    flipped = np.ascontiguousarray(kernel[::-1, ::-1], np.float32)
    return "cv2.filter2D", _seconds(lambda: cv2.filter2D(image, -1, flipped, borderType=cv2.BORDER_REPLICATE))


def _seconds(fn, repeats: int = 2) -> float:
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _gl_seconds(sim) -> float | None:
    """Seconds per frame of the viewer's GL passes on sim's source (None without an EGL context)."""
    try:
        from ugpcl.viewer.offscreen import context
        from ugpcl.viewer.views.star_glow import GLStarGlow

        context()
    except Exception:  # no EGL (or no GL 4.3) on this machine: the table goes without the GL row
        return None
    from ugpcl.viewer.postfx import FloatTarget, float_texture

    ctx = context()
    glow, source, out = GLStarGlow(ctx), float_texture(ctx, sim.src.get()), FloatTarget(ctx, (sim.W, sim.H))

    def run():
        glow.run(source, sim.params, out)
        ctx.finish()

    run()
    seconds = _seconds(run, repeats=5)
    for obj in (glow, source, out):
        obj.release()
    return seconds


def streak_line_kernel(attenuation: float, iteration: int, direction) -> np.ndarray:
    """The convolution kernel (rows = y, GL order) that ``iteration`` streak passes along an axis ``direction``
    equal while every weighted tap stays <= 1 (the taps are saturated): a^d at d texels along +direction,
    d < 4^iteration, for ``scipy.ndimage.convolve`` (which flips it: out(p) = sum_d a^d in(p + d dir))."""
    length = TAPS**iteration
    dx, dy = (int(round(c)) for c in direction)
    if abs(dx) + abs(dy) != 1:
        raise ValueError(f"direction must be an axis, got {direction!r}")
    kernel = np.zeros((2 * length - 1, 2 * length - 1))
    d = np.arange(length)
    kernel[length - 1 - d * dy, length - 1 - d * dx] = float(attenuation) ** d
    return kernel if dy else kernel[length - 1 : length]
