"""``ugpcl bench compute_intro``: GB/s of the texture sample's KernelFunction_A for each numthreads shape (vol.1
ch.2; docs/chapters/02-compute-intro.md)."""

from __future__ import annotations

from ..scenes.compute_intro import Params, Simulation
from .timing import seconds_per_call

LOCAL_SHAPES = ((8, 8), (16, 16), (32, 8), (64, 1), (256, 1), (1, 64))
"""numthreads shapes compared by the bench (vol.1 ch.2 section 2.4.2, "Tips for specifying the number of threads
efficiently")."""


TEXEL_BYTES = 4
"""KernelFunction_A's whole memory traffic per texel: it reads nothing and writes one RGBA8 texel (4 bytes)."""


def bench(runtime, sizes=None) -> list[dict]:
    """GB/s of KernelFunction_A filling a size x size RGBA8 texture with each numthreads shape,
    and once with a size that is not a multiple of the shape (padding + guard); write bytes/s = the same traffic
    (TEXEL_BYTES per texel) per second."""
    sizes = sizes or ([8192] if runtime.is_gpu else [2048])
    rows = []
    for size in sizes:
        for shape in LOCAL_SHAPES:
            if shape[0] * shape[1] > runtime.device.max_work_group_size:
                continue
            for width in (size, size + 1):
                sim = Simulation(runtime, Params(sample="texture", tex_width=width, tex_height=width, local_size=shape))
                seconds = seconds_per_call(sim.kernel_function_a_texture, runtime.queue)
                rows.append(
                    {
                        "size": f"{width}x{width}",
                        "numthreads": f"{shape[0]}x{shape[1]}",
                        "ms": seconds * 1e3,
                        "GB/s": width * width * TEXEL_BYTES / seconds / 1e9,
                        "write bytes/s": width * width * TEXEL_BYTES / seconds,
                    }
                )
    return rows
